/* HARDSPHERE_GPU: PeerInputs on CUDA (see peer_inputs.h).  Host code. */
#include "peer_inputs.h"

#include "cuda_check.cuh"

#include <cstring>

namespace HSGPU {
namespace GPU {

  struct PeerInputs::Impl {
    int device = 0;
    cudaStream_t stream = nullptr;
    std::vector<char> handles;    // of the buffers open now
    double *buf[3] = {nullptr, nullptr, nullptr};
    const void *locked[3] = {nullptr, nullptr, nullptr};
    size_t locked_bytes[3] = {0, 0, 0};
    bool locking = true;    // false once the driver refused: pageable copies from then on

    void close()
    {
      for (double *&b : buf) {
        if (b) cudaIpcCloseMemHandle(b);
        b = nullptr;
      }
      (void) cudaGetLastError();
      handles.clear();
    }

    void unlock(int k)
    {
      if (locked[k]) cudaHostUnregister(const_cast<void *>(locked[k]));
      (void) cudaGetLastError();
      locked[k] = nullptr;
      locked_bytes[k] = 0;
    }

    void lock(int k, const void *p, size_t bytes)
    {
      if (locked[k] == p && locked_bytes[k] == bytes) return;
      unlock(k);
      if (!locking || !p || bytes == 0) return;
      if (cudaHostRegister(const_cast<void *>(p), bytes, cudaHostRegisterDefault) != cudaSuccess) {
        (void) cudaGetLastError();
        locking = false;
        return;
      }
      locked[k] = p;
      locked_bytes[k] = bytes;
    }
  };

  PeerInputs::PeerInputs(int device) : impl(new Impl())
  {
    impl->device = device;
    try {
      cuda_check(cudaSetDevice(device), "cudaSetDevice");
      cuda_check(cudaStreamCreateWithFlags(&impl->stream, cudaStreamNonBlocking),
                 "cudaStreamCreate");
    } catch (...) {
      delete impl;
      throw;
    }
  }

  PeerInputs::~PeerInputs()
  {
    cudaSetDevice(impl->device);
    impl->close();
    for (int k = 0; k < 3; ++k) impl->unlock(k);
    if (impl->stream) cudaStreamDestroy(impl->stream);
    (void) cudaGetLastError();
    delete impl;
  }

  void PeerInputs::open(const std::vector<char> &handles)
  {
    if (handles.size() != 3 * sizeof(cudaIpcMemHandle_t))
      throw Error("PeerInputs: not three CUDA IPC handles");
    if (handles == impl->handles) return;
    cuda_check(cudaSetDevice(impl->device), "cudaSetDevice");
    impl->close();
    cudaIpcMemHandle_t h[3];
    std::memcpy(h, handles.data(), sizeof(h));
    for (int k = 0; k < 3; ++k) {
      void *p = nullptr;
      cuda_check(cudaIpcOpenMemHandle(&p, h[k], cudaIpcMemLazyEnablePeerAccess),
                 "cudaIpcOpenMemHandle");
      impl->buf[k] = static_cast<double *>(p);
    }
    impl->handles = handles;
  }

  void PeerInputs::put(long first, long count, const double *x, const double *v, const double *f)
  {
    if (count <= 0) return;
    if (!impl->buf[0]) throw Error("PeerInputs: no buffers open");
    cuda_check(cudaSetDevice(impl->device), "cudaSetDevice");
    const double *src[3] = {x, v, f};
    const size_t bytes = (size_t) 3 * count * sizeof(double);
    for (int k = 0; k < 3; ++k) {
      impl->lock(k, src[k], bytes);
      cuda_check(
          cudaMemcpyAsync(impl->buf[k] + 3 * first, src[k], bytes, cudaMemcpyDefault, impl->stream),
          "cudaMemcpy(atoms to the gathering device)");
    }
    cuda_check(cudaStreamSynchronize(impl->stream), "cudaMemcpy(atoms to the gathering device)");
  }

  void PeerInputs::forget_host_arrays()
  {
    cudaSetDevice(impl->device);
    for (int k = 0; k < 3; ++k) impl->unlock(k);
  }

}    // namespace GPU
}    // namespace HSGPU
