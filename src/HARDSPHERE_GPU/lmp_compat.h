/* -*- c++ -*- ------------------------------------------------------------------
   HARDSPHERE_GPU: the LAMMPS API differences the package's styles meet, in one place.

   HSGPU_LAMMPS_VERSION (e.g. 20250204, 20210929) is defined by CMake for every target that
   links hsgpu::lammps.  Neighbor requests became Neighbor::add_request() and
   Comm::forward_comm_fix() became an overload of Comm::forward_comm() in early 2022.
------------------------------------------------------------------------------------- */
#ifndef LMP_HSGPU_COMPAT_H
#define LMP_HSGPU_COMPAT_H

#include "comm.h"
#include "fix.h"
#include "neigh_request.h"
#include "neighbor.h"

#ifndef HSGPU_LAMMPS_VERSION
#error "HSGPU_LAMMPS_VERSION is not defined: link the target with hsgpu::lammps"
#endif

namespace LAMMPS_NS {
namespace HsgpuCompat {

  /// A perpetual full neighbor list for `fix` (its instance_me passed as `instance`) that
  /// holds every pair within `cutoff` plus the neighbor skin.
  inline void request_full_list(Neighbor *neighbor, Fix *fix, int instance, double cutoff)
  {
#if HSGPU_LAMMPS_VERSION >= 20220324
    // The skin is added to a perpetual list's custom cutoff by Neighbor.
    (void) instance;
    neighbor->add_request(fix, NeighConst::REQ_FULL)->set_cutoff(cutoff);
#else
    const int irequest = neighbor->request(fix, instance);
    NeighRequest *rq = neighbor->requests[irequest];
    rq->pair = 0;
    rq->fix = 1;
    rq->half = 0;
    rq->full = 1;
    rq->cut = 1;
    rq->cutoff = cutoff + neighbor->skin;    // used as given
#endif
  }

  /// Forward communication of a fix's per-atom data (Fix::pack/unpack_forward_comm).
  inline void forward_comm(Comm *comm, Fix *fix)
  {
#if HSGPU_LAMMPS_VERSION >= 20220324
    comm->forward_comm(fix);
#else
    comm->forward_comm_fix(fix);
#endif
  }

  /// Reverse communication of a fix's per-atom data (Fix::pack/unpack_reverse_comm).
  inline void reverse_comm(Comm *comm, Fix *fix)
  {
#if HSGPU_LAMMPS_VERSION >= 20220324
    comm->reverse_comm(fix);
#else
    comm->reverse_comm_fix(fix);
#endif
  }

}    // namespace HsgpuCompat
}    // namespace LAMMPS_NS

#endif
