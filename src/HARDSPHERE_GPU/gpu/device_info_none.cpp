/* HARDSPHERE_GPU: device queries for a build without CUDA, see device_info.cuh */
#include "device_info.cuh"

namespace HSGPU {
namespace GPU {

  bool compiled_with_cuda()
  {
    return false;
  }
  int device_count()
  {
    return 0;
  }
  std::string device_description(int)
  {
    return "built without CUDA";
  }

}    // namespace GPU
}    // namespace HSGPU
