/* HARDSPHERE_GPU collision engine: the CUDA backend (see engine/collision_backend.h).

   Each call uploads the window's bodies, edges and groups, runs one device thread per group
   through the exact per-group loop of collision_group_loop.h and downloads the bodies and the
   per-group tallies; the host hands the tallies over in group order (added to the caller's,
   or stored per group in WindowWork::group_tally).  The result is the CPU
   backend's, bit for bit (the kernels are compiled without FMA contraction and fast math).

   maxevents: the CPU backend counts every group's events against one cap, groups in order,
   and stops everything at the first group that would exceed it.  The device runs all groups
   at once, each capped at what is left before the window; when the host then finds that a
   group would have exceeded the cap in the CPU's order, it runs the window again from the
   uploaded bodies with that group capped at what the CPU would have left it and the later
   groups not run.  So a capped window, too, gives the CPU's bodies and tally.

   Plain C++: no CUDA types.  Built from collision_backend_cuda.cu with CUDA, from
   collision_backend_none.cpp without (make_cuda_backend then throws). */
#ifndef HSGPU_GPU_COLLISION_BACKEND_CUDA_H
#define HSGPU_GPU_COLLISION_BACKEND_CUDA_H

#include "engine/collision_backend.h"

#include <memory>

namespace HSGPU {
namespace Collide {

  /// A backend on CUDA device `device`.  Throws HSGPU::GPU::Error (gpu/gpu_error.h) when the
  /// device cannot be used or the package was built without CUDA.
  std::unique_ptr<CollisionBackend> make_cuda_backend(int device);

  /// True when the package was built with CUDA and at least one device is usable.
  bool cuda_backend_available();

}    // namespace Collide
}    // namespace HSGPU

#endif
