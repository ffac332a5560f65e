/* HARDSPHERE_GPU: core_device_check.h for a build without CUDA: the runner throws. */
#include "core_device_check.h"

#include "gpu_error.h"

namespace HSGPU {
namespace GPU {

  void run_core_cases_on_device(int, const CoreCase *, int, const double *, int, CoreResult *)
  {
    throw Error("HARDSPHERE_GPU was built without CUDA");
  }

}    // namespace GPU
}    // namespace HSGPU
