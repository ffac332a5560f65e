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
    // x, v, f, tlast, radius, rmass, type, id and (rough spheres) omega:
    // ResidentStep::share_inputs()'s order.
    static constexpr int NBUF = 9;
    void *buf[NBUF] = {};
    HostRangeLock locked[3];    // the host arrays of put()
    bool locking = true;        // false once the driver refused: pageable copies from then on

    std::vector<char> rhandles;    // of the result buffers open now
    void *rbuf[3] = {};

    // Closes the opened buffers b[0 .. n) and forgets their handles h.
    static void close_buffers(void **b, int n, std::vector<char> &h)
    {
      for (int k = 0; k < n; ++k) {
        if (b[k]) cudaIpcCloseMemHandle(b[k]);
        b[k] = nullptr;
      }
      (void) cudaGetLastError();
      h.clear();
    }
    void close() { close_buffers(buf, NBUF, handles); }
    void close_results() { close_buffers(rbuf, 3, rhandles); }
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
    impl->close_results();
    for (HostRangeLock &l : impl->locked) l.release();
    if (impl->stream) cudaStreamDestroy(impl->stream);
    (void) cudaGetLastError();
    delete impl;
  }

  void PeerInputs::open(const std::vector<char> &handles)
  {
    constexpr int NBUF = Impl::NBUF;
    const int nh = (int) (handles.size() / sizeof(cudaIpcMemHandle_t));
    if (handles.size() % sizeof(cudaIpcMemHandle_t) != 0 || nh < NBUF - 1 || nh > NBUF)
      throw Error("PeerInputs: not eight or nine CUDA IPC handles");
    if (handles == impl->handles) return;
    cuda_check(cudaSetDevice(impl->device), "cudaSetDevice");
    impl->close();
    cudaIpcMemHandle_t h[NBUF];
    std::memcpy(h, handles.data(), handles.size());
    for (int k = 0; k < nh; ++k) {
      void *p = nullptr;
      cuda_check(cudaIpcOpenMemHandle(&p, h[k], cudaIpcMemLazyEnablePeerAccess),
                 "cudaIpcOpenMemHandle");
      impl->buf[k] = p;
    }
    impl->handles = handles;
  }

  void PeerInputs::put(long first, long count, const double *x, const double *v, const double *f,
                       long room)
  {
    if (count <= 0) return;
    if (!impl->buf[0]) throw Error("PeerInputs: no buffers open");
    cuda_check(cudaSetDevice(impl->device), "cudaSetDevice");
    double *const dst[3] = {static_cast<double *>(impl->buf[0]), static_cast<double *>(impl->buf[1]),
                            static_cast<double *>(impl->buf[2])};
    copy_xvf_to_device(dst, first, count, x, v, f, impl->locked, impl->locking, impl->stream,
                       "cudaMemcpy(atoms to the gathering device)", room);
  }

  void PeerInputs::open_results(const std::vector<char> &handles)
  {
    const int nh = (int) (handles.size() / sizeof(cudaIpcMemHandle_t));
    if (handles.size() % sizeof(cudaIpcMemHandle_t) != 0 || nh < 2 || nh > 3)
      throw Error("PeerInputs: not two or three CUDA IPC handles of results");
    if (handles == impl->rhandles) return;
    cuda_check(cudaSetDevice(impl->device), "cudaSetDevice");
    impl->close_results();
    cudaIpcMemHandle_t h[3];
    std::memcpy(h, handles.data(), handles.size());
    for (int k = 0; k < nh; ++k)
      cuda_check(cudaIpcOpenMemHandle(&impl->rbuf[k], h[k], cudaIpcMemLazyEnablePeerAccess),
                 "cudaIpcOpenMemHandle(results)");
    impl->rhandles = handles;
  }

  void PeerInputs::get_result(int k, size_t offset, size_t bytes, void *out)
  {
    if (bytes == 0) return;
    if (k < 0 || k > 2 || !impl->rbuf[k]) throw Error("PeerInputs: no result buffers open");
    cuda_check(cudaSetDevice(impl->device), "cudaSetDevice");
    cuda_check(cudaMemcpyAsync(out, static_cast<const char *>(impl->rbuf[k]) + offset, bytes,
                               cudaMemcpyDefault, impl->stream),
               "cudaMemcpy(results from the gathering device)");
    cuda_check(cudaStreamSynchronize(impl->stream), "cudaMemcpy(results from the gathering device)");
  }

  void PeerInputs::put_spin(long first, long count, const double *omega)
  {
    if (count <= 0) return;
    if (!impl->buf[8]) throw Error("PeerInputs: no buffer of angular velocities open");
    cuda_check(cudaSetDevice(impl->device), "cudaSetDevice");
    cuda_check(cudaMemcpyAsync(static_cast<double *>(impl->buf[8]) + 3 * first, omega,
                               3 * count * sizeof(double), cudaMemcpyDefault, impl->stream),
               "cudaMemcpy(atoms to the gathering device)");
    cuda_check(cudaStreamSynchronize(impl->stream), "cudaMemcpy(atoms to the gathering device)");
  }

  void PeerInputs::put_statics(long first, long count, const double *tlast, const double *radius,
                               const double *rmass, const int *type, const void *id, int id_bytes)
  {
    if (count <= 0) return;
    if (!impl->buf[3]) throw Error("PeerInputs: no buffers open");
    cuda_check(cudaSetDevice(impl->device), "cudaSetDevice");
    copy_statics_to_device(impl->buf + 3, first, count, tlast, radius, rmass, type, id, id_bytes,
                           impl->stream, "cudaMemcpy(atoms to the gathering device)");
  }

  void PeerInputs::put_ids(long first, long count, const void *id, int id_bytes)
  {
    if (count <= 0) return;
    if (!impl->buf[7]) throw Error("PeerInputs: no buffers open");
    cuda_check(cudaSetDevice(impl->device), "cudaSetDevice");
    copy_statics_to_device(impl->buf + 3, first, count, nullptr, nullptr, nullptr, nullptr, id,
                           id_bytes, impl->stream, "cudaMemcpy(atoms to the gathering device)");
  }

  void PeerInputs::get_atoms(long first, long count, double *x, double *v, double *tlast)
  {
    if (count <= 0) return;
    if (!impl->buf[0] || !impl->buf[3]) throw Error("PeerInputs: no buffers open");
    cuda_check(cudaSetDevice(impl->device), "cudaSetDevice");
    const double *const src[3] = {static_cast<const double *>(impl->buf[0]),
                                  static_cast<const double *>(impl->buf[1]),
                                  static_cast<const double *>(impl->buf[3])};
    copy_state_from_device(src, first, count, x, v, tlast, impl->stream,
                           "cudaMemcpy(atoms from the gathering device)");
  }

  void PeerInputs::forget_host_arrays()
  {
    cudaSetDevice(impl->device);
    for (HostRangeLock &l : impl->locked) l.release();
  }

}    // namespace GPU
}    // namespace HSGPU
