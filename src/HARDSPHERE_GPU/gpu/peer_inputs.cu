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
    HostRangeLock locked[3];    // the host arrays of put()
    bool locking = true;        // false once the driver refused: pageable copies from then on

    void close()
    {
      for (double *&b : buf) {
        if (b) cudaIpcCloseMemHandle(b);
        b = nullptr;
      }
      (void) cudaGetLastError();
      handles.clear();
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
    for (HostRangeLock &l : impl->locked) l.release();
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
    copy_xvf_to_device(impl->buf, first, count, x, v, f, impl->locked, impl->locking, impl->stream,
                       "cudaMemcpy(atoms to the gathering device)");
  }

  void PeerInputs::forget_host_arrays()
  {
    cudaSetDevice(impl->device);
    for (HostRangeLock &l : impl->locked) l.release();
  }

}    // namespace GPU
}    // namespace HSGPU
