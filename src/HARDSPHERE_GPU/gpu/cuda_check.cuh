/* HARDSPHERE_GPU: host-side CUDA plumbing shared by the GPU drivers (gravity_engine.cpp,
   collision_backend_cuda.cu, core_device_check.cu).

   - cuda_check(status, what) throws HSGPU::GPU::Error("what: cudaErrorName: message") for any
     status other than cudaSuccess;
   - DeviceBuffer is raw device memory that only grows: reserve(n) keeps the allocation (and
     its address) while n fits and otherwise reallocates with 25 % headroom, dropping the old
     contents.  It does not free itself: its owner calls release() (after selecting the
     buffer's device), so that buffers can live in structs whose destruction order the owner
     controls.  PinnedBuffer is the same for page-locked host memory (fast downloads).

   Host code; needs cuda_runtime.h, so only CUDA translation units and the CUDA drivers'
   .cpp files include it, never a header that LAMMPS styles or plain tests see. */
#ifndef HSGPU_GPU_CUDA_CHECK_CUH
#define HSGPU_GPU_CUDA_CHECK_CUH

#include "gpu_error.h"

#include <cuda_runtime.h>

#include <cstddef>
#include <string>

namespace HSGPU {
namespace GPU {

  inline void cuda_check(cudaError_t err, const char *what)
  {
    if (err != cudaSuccess)
      throw Error(std::string(what) + ": " + cudaGetErrorName(err) + ": " +
                  cudaGetErrorString(err));
  }

  struct DeviceBuffer {
    void *ptr = nullptr;
    size_t bytes = 0;

    DeviceBuffer() = default;
    DeviceBuffer(const DeviceBuffer &) = delete;
    DeviceBuffer &operator=(const DeviceBuffer &) = delete;

    /// At least `need` bytes; `what` names the buffer in the error message.
    void reserve(size_t need, const char *what)
    {
      if (need <= bytes) return;
      if (ptr) cuda_check(cudaFree(ptr), what);
      ptr = nullptr;
      bytes = 0;
      const size_t want = need + need / 4;
      cuda_check(cudaMalloc(&ptr, want), what);
      bytes = want;
    }

    void release()
    {
      if (ptr) cudaFree(ptr);
      ptr = nullptr;
      bytes = 0;
    }

    template <class T> T *as() const { return static_cast<T *>(ptr); }
  };

  /// Pinned (page-locked) host memory with DeviceBuffer's rules: grows only, 25 % headroom,
  /// contents dropped on growth, released by its owner.
  struct PinnedBuffer {
    void *ptr = nullptr;
    size_t bytes = 0;

    PinnedBuffer() = default;
    PinnedBuffer(const PinnedBuffer &) = delete;
    PinnedBuffer &operator=(const PinnedBuffer &) = delete;

    void reserve(size_t need, const char *what)
    {
      if (need <= bytes) return;
      if (ptr) cuda_check(cudaFreeHost(ptr), what);
      ptr = nullptr;
      bytes = 0;
      const size_t want = need + need / 4;
      cuda_check(cudaMallocHost(&ptr, want), what);
      bytes = want;
    }

    void release()
    {
      if (ptr) cudaFreeHost(ptr);
      ptr = nullptr;
      bytes = 0;
    }

    template <class T> T *as() const { return static_cast<T *>(ptr); }
  };

}    // namespace GPU
}    // namespace HSGPU

#endif
