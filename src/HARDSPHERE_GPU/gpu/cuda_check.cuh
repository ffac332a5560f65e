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

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

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

    /// Trades memory with another buffer (no copy).
    void swap(DeviceBuffer &o)
    {
      std::swap(ptr, o.ptr);
      std::swap(bytes, o.bytes);
    }
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

  /// The pages [first, last) that the process's HostRangeLocks hold (the driver locks whole
  /// pages and refuses a range that shares one with a locked range).
  inline std::vector<std::pair<uintptr_t, uintptr_t>> &locked_pages()
  {
    static std::vector<std::pair<uintptr_t, uintptr_t>> held;
    return held;
  }

  /// The whole pages that [q, q + n) touches.
  inline std::pair<uintptr_t, uintptr_t> page_span(const void *q, size_t n)
  {
    static const uintptr_t page = [] {
      const long s = sysconf(_SC_PAGESIZE);
      return (uintptr_t) (s > 0 ? s : 4096);
    }();
    const uintptr_t a = reinterpret_cast<uintptr_t>(q);
    return {a / page * page, (a + n + page - 1) / page * page};
  }

  /// A caller's host range page-locked in place (cudaHostRegister), so that copies from it
  /// move at the pinned rate.  keep() holds [q, q + n): a locked range that covers it stays;
  /// else it is released and [q, q + max(n, room)) locked (room: what the caller's array holds,
  /// so that a later, longer range in the same array needs no new lock: registering costs
  /// about as much as copying).  A range that shares a page with one another HostRangeLock
  /// holds (small arrays side by side on the heap) is not registered (the driver would refuse
  /// it): its copies stay pageable, as do all later ones where the driver refuses a range
  /// (memory limits, a range locked by other code): `locking` turns false.  Slower, the same
  /// bytes.  Released by its owner.
  struct HostRangeLock {
    void *p = nullptr;
    size_t bytes = 0;

    void keep(const void *q, size_t n, bool &locking, size_t room = 0)
    {
      const char *c = static_cast<const char *>(q), *lo = static_cast<const char *>(p);
      if (p && c >= lo && c + n <= lo + bytes) return;
      release();
      if (!locking || !q || n == 0) return;
      const size_t want = room > n ? room : n;
      const auto span = page_span(q, want);
      for (const auto &h : locked_pages())
        if (span.first < h.second && h.first < span.second) return;
      if (cudaHostRegister(const_cast<void *>(q), want, cudaHostRegisterDefault) != cudaSuccess) {
        (void) cudaGetLastError();
        locking = false;
        return;
      }
      p = const_cast<void *>(q);
      bytes = want;
      locked_pages().push_back(span);
    }

    /// The device's address of `host`, inside the range held (which the driver maps into the
    /// device's address space); null where nothing is held or the driver gives none.
    template <class T> T *device_address(T *host) const
    {
      void *base = nullptr;
      if (!p || cudaHostGetDevicePointer(&base, p, 0) != cudaSuccess) {
        (void) cudaGetLastError();
        return nullptr;
      }
      return reinterpret_cast<T *>(static_cast<char *>(base) +
                                   (reinterpret_cast<char *>(host) - static_cast<char *>(p)));
    }

    void release()
    {
      if (p) {
        cudaHostUnregister(p);
        auto &held = locked_pages();
        const auto span = page_span(p, bytes);
        for (size_t k = 0; k < held.size(); ++k)
          if (held[k] == span) {
            held.erase(held.begin() + (long) k);
            break;
          }
      }
      (void) cudaGetLastError();
      p = nullptr;
      bytes = 0;
    }
  };

  /// Copies count atoms' x, v and f (3 doubles each) from the host into atoms [first, first +
  /// count) of the device arrays dst[0 .. 2] (this process's, or another's opened by CUDA IPC)
  /// on `stream`, each source array page-locked in place by locks[0 .. 2] for `room` atoms
  /// (what the arrays hold, at least count), and waits.  A null source is not copied (f where
  /// there are no forces).
  inline void copy_xvf_to_device(double *const dst[3], long first, long count, const double *x,
                                 const double *v, const double *f, HostRangeLock locks[3],
                                 bool &locking, cudaStream_t stream, const char *what,
                                 long room = 0)
  {
    if (count <= 0) return;
    const double *src[3] = {x, v, f};
    const size_t bytes = (size_t) 3 * count * sizeof(double);
    const size_t held = (size_t) 3 * (room > count ? room : count) * sizeof(double);
    for (int k = 0; k < 3; ++k) {
      if (!src[k]) continue;
      locks[k].keep(src[k], bytes, locking, held);
      cuda_check(cudaMemcpyAsync(dst[k] + 3 * first, src[k], bytes, cudaMemcpyDefault, stream),
                 what);
    }
    cuda_check(cudaStreamSynchronize(stream), what);
  }

  /// The other way: atoms [first, first + count) of the device arrays src[0 .. 2] (x, v: 3
  /// doubles each; tlast: one) into the host arrays x, v, tlast on `stream`, and waits.
  inline void copy_state_from_device(const double *const src[3], long first, long count,
                                     double *x, double *v, double *tlast, cudaStream_t stream,
                                     const char *what)
  {
    if (count <= 0) return;
    double *dst[3] = {x, v, tlast};
    for (int k = 0; k < 3; ++k) {
      const int per = k < 2 ? 3 : 1;
      cuda_check(cudaMemcpyAsync(dst[k], src[k] + per * first, per * count * sizeof(double),
                                 cudaMemcpyDefault, stream),
                 what);
    }
    cuda_check(cudaStreamSynchronize(stream), what);
  }

  /// Copies count atoms' times of last collision, radii, masses (doubles), types (ints) and
  /// IDs (id_bytes each) from the host into atoms [first, first + count) of the device arrays
  /// dst[0 .. 4] on `stream` (pageable: they move only after atoms moved in the arrays), and
  /// waits.  A null source is not copied (the IDs alone: ResidentAtoms::reordered).
  inline void copy_statics_to_device(void *const dst[5], long first, long count,
                                     const double *tlast, const double *radius,
                                     const double *rmass, const int *type, const void *id,
                                     int id_bytes, cudaStream_t stream, const char *what)
  {
    if (count <= 0) return;
    const void *src[5] = {tlast, radius, rmass, type, id};
    const size_t per[5] = {sizeof(double), sizeof(double), sizeof(double), sizeof(int),
                           (size_t) id_bytes};
    for (int k = 0; k < 5; ++k)
      if (src[k])
        cuda_check(cudaMemcpyAsync(static_cast<char *>(dst[k]) + per[k] * first, src[k],
                                   per[k] * count, cudaMemcpyDefault, stream),
                   what);
    cuda_check(cudaStreamSynchronize(stream), what);
  }

}    // namespace GPU
}    // namespace HSGPU

#endif
