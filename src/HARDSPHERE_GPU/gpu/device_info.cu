/* HARDSPHERE_GPU: CUDA device queries, see device_info.cuh */
#include "device_info.cuh"

#include <cuda_runtime.h>

#include <cstdio>

namespace HSGPU {
namespace GPU {

  bool compiled_with_cuda()
  {
    return true;
  }

  int device_count()
  {
    int n = 0;
    if (cudaGetDeviceCount(&n) != cudaSuccess) {
      (void) cudaGetLastError();    // no driver or no device: clear the sticky error
      return 0;
    }
    return n;
  }

  std::string device_description(int id)
  {
    cudaDeviceProp prop;
    const cudaError_t err = cudaGetDeviceProperties(&prop, id);
    if (err != cudaSuccess) return std::string("CUDA error: ") + cudaGetErrorString(err);
    char buf[512];
    std::snprintf(buf, sizeof(buf), "%s (sm_%d%d, %d SMs, %zu MiB)", prop.name, prop.major,
                  prop.minor, prop.multiProcessorCount, prop.totalGlobalMem >> 20);
    return buf;
  }

}    // namespace GPU
}    // namespace HSGPU
