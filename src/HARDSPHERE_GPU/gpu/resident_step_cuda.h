/* HARDSPHERE_GPU collision engine: the device-resident step of the CUDA backend (see
   engine/resident_step.h for the contract).

   Plain C++: no CUDA types.  Built from resident_step_cuda.cu with CUDA, from
   collision_backend_none.cpp without (make_cuda_resident_step then throws). */
#ifndef HSGPU_GPU_RESIDENT_STEP_CUDA_H
#define HSGPU_GPU_RESIDENT_STEP_CUDA_H

#include "engine/resident_step.h"

#include <memory>

namespace HSGPU {
namespace Collide {

  /// A resident step on CUDA device `device`.  Throws HSGPU::GPU::Error (gpu/gpu_error.h)
  /// when the device cannot be used or the package was built without CUDA.
  std::unique_ptr<ResidentStep> make_cuda_resident_step(int device);

}    // namespace Collide
}    // namespace HSGPU

#endif
