/* HARDSPHERE_GPU collision engine: the backend seam.

   The step driver (window_driver.h) cuts a step into time windows and, in each window, splits
   the bodies into groups that cannot influence each other before the window ends (connected
   components of the window's edge graph).  A backend carries out the events of those groups:
   every group on its own, its events in time order (ties broken as in core/event_order.h), up
   to the window's end.  Backends: the CPU one (cpu_backend.cpp) and the CUDA one
   (gpu/collision_backend_cuda.cu; gpu/collision_backend_none.cpp where CUDA is absent).

   Contract shared by every backend, so that all of them give the same bits:
   - the physics is core/collision_step.h's, compiled without contraction into FMA;
   - a group's events are those of core/event_order.h's order restricted to the group and to
     t < t_end, computed from the bodies' own states only;
   - the tally of each group is summed in event order into a fresh Tally, and the groups'
     tallies are added to the caller's in group order (or handed back one per group);
   - p.maxevents caps the events of all groups of the call together, counted in group order
     from the caller's tally.events.

   This header includes nothing from LAMMPS, MPI or CUDA. */
#ifndef HSGPU_ENGINE_COLLISION_BACKEND_H
#define HSGPU_ENGINE_COLLISION_BACKEND_H

#include "core/trajectory.h"

#include <memory>
#include <string>

namespace HSGPU {
namespace Collide {

  /// The work of one time window: groups of bodies to resolve up to t_end.
  struct WindowWork {
    Body *bodies;    // the bodies, changed in place
    int nbodies;
    const Edge *edges;    // the window's edges; both ends in [0, nbodies), i has the lower ID
    int nedges;
    const int *group_start;      // group g's members: group_members[group_start[g] ..
    const int *group_members;    //   group_start[g + 1]), in increasing body index
    int ngroups;
    double t_end;    // events at t >= t_end are left to the next window
    /// Optional (nullptr: not used): group g's tally is stored in group_tally[g] instead of
    /// being added to the caller's, which then only gets `capped`.
    Tally *group_tally = nullptr;
    /// Optional (nullptr: not used): 6 doubles per body, to which every event adds the
    /// bodies' per-atom virial (core/collision_step.h).  Only the CPU backend supports it;
    /// the others refuse work that sets it.
    double *body_virial = nullptr;
  };

  class CollisionBackend {
   public:
    virtual ~CollisionBackend() = default;
    virtual std::string name() const = 0;
    /// Carries out the events of every group of w with t < w.t_end, in time order within each
    /// group, and adds them to tally (p.maxevents caps tally.events).  Returns the largest
    /// number of events one group needed.
    virtual long resolve(const WindowWork &w, const Params &p, Tally &tally) = 0;
  };

  /// The CPU backend (one event queue per group).
  std::unique_ptr<CollisionBackend> make_cpu_backend();

}    // namespace Collide
}    // namespace HSGPU

#endif
