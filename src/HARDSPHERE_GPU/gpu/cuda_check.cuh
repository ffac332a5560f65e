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

  /// A caller's host range page-locked in place (cudaHostRegister), so that copies from it
  /// move at the pinned rate.  keep() holds [q, q + n): a range that moved or changed length is
  /// released and the new one locked.  Where the driver refuses (memory limits, an overlap with
  /// another locked range) `locking` turns false and the copies stay pageable: slower, the same
  /// bytes.  Released by its owner.
  struct HostRangeLock {
    void *p = nullptr;
    size_t bytes = 0;

    void keep(const void *q, size_t n, bool &locking)
    {
      if (p == q && bytes == n) return;
      release();
      if (!locking || !q || n == 0) return;
      if (cudaHostRegister(const_cast<void *>(q), n, cudaHostRegisterDefault) != cudaSuccess) {
        (void) cudaGetLastError();
        locking = false;
        return;
      }
      p = const_cast<void *>(q);
      bytes = n;
    }

    void release()
    {
      if (p) cudaHostUnregister(p);
      (void) cudaGetLastError();
      p = nullptr;
      bytes = 0;
    }
  };

  /// Copies count atoms' x, v and f (3 doubles each) from the host into atoms [first, first +
  /// count) of the device arrays dst[0 .. 2] (this process's, or another's opened by CUDA IPC)
  /// on `stream`, each source range page-locked in place by locks[0 .. 2], and waits.
  inline void copy_xvf_to_device(double *const dst[3], long first, long count, const double *x,
                                 const double *v, const double *f, HostRangeLock locks[3],
                                 bool &locking, cudaStream_t stream, const char *what)
  {
    if (count <= 0) return;
    const double *src[3] = {x, v, f};
    const size_t bytes = (size_t) 3 * count * sizeof(double);
    for (int k = 0; k < 3; ++k) {
      locks[k].keep(src[k], bytes, locking);
      cuda_check(cudaMemcpyAsync(dst[k] + 3 * first, src[k], bytes, cudaMemcpyDefault, stream),
                 what);
    }
    cuda_check(cudaStreamSynchronize(stream), what);
  }

}    // namespace GPU
}    // namespace HSGPU

#endif
