/* HARDSPHERE_GPU driver interface: which CUDA devices this process can use.
   Plain C++: no CUDA, LAMMPS or MPI types, so LAMMPS styles and tests may include it.
   Built from device_info.cu with nvcc, or from device_info_none.cpp without CUDA. */
#ifndef HSGPU_GPU_DEVICE_INFO_CUH
#define HSGPU_GPU_DEVICE_INFO_CUH

#include <string>

namespace HSGPU {
namespace GPU {

  /// True when the package was compiled with its CUDA kernels.
  bool compiled_with_cuda();

  /// Number of usable CUDA devices (0 without CUDA, a driver, or a device).
  int device_count();

  /// "NAME (sm_XY, N SMs, M MiB)" for device `id`, or the CUDA error text.
  std::string device_description(int id);

}    // namespace GPU
}    // namespace HSGPU

#endif
