/* HARDSPHERE_GPU collision engine: the CUDA backend and resident step for a build without
   CUDA, see collision_backend_cuda.h and resident_step_cuda.h.  Asking for one throws, so
   callers fall back to the CPU backend. */
#include "collision_backend_cuda.h"
#include "resident_step_cuda.h"

#include "gpu_error.h"

namespace HSGPU {
namespace Collide {

  std::unique_ptr<CollisionBackend> make_cuda_backend(int)
  {
    throw GPU::Error("built without CUDA");
  }

  std::unique_ptr<ResidentStep> make_cuda_resident_step(int)
  {
    throw GPU::Error("built without CUDA");
  }

  bool cuda_backend_available()
  {
    return false;
  }

}    // namespace Collide
}    // namespace HSGPU
