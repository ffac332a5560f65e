/* HARDSPHERE_GPU: GravityEngine on CUDA, see gravity_engine.h.  Host code only: the kernels
   are reached through gravity_kernels.cuh. */
#include "gravity_engine.h"

#include "cuda_check.cuh"
#include "gravity_kernels.cuh"

#include <cuda_runtime.h>

#include <algorithm>
#include <limits>
#include <cstring>
#include <vector>

namespace HSGPU {
namespace GPU {

  namespace {
    constexpr int SORT_INTERVAL = 16;

  }    // namespace

  struct GravityEngine::Impl {
    int device = 0;
    int num_sms = 1;
    std::string name;
    cudaStream_t stream = nullptr;
    cudaEvent_t start = nullptr, stop = nullptr;
    DeviceBuffer x, m, src, tidx, scratch, f, e, v;
    DeviceBuffer keys, tsorted, slot, sort_temp;    // Mixed: targets in Z-curve order
    // The Z-curve order is redone when the targets change and otherwise every
    // SORT_INTERVAL calls: atoms move little in between, so blocks stay compact.
    bool sorted = false;
    int calls_since_sort = 0;
    long nsrc = 0, ntgt = 0;
    double max_mass = 0.0;
    std::vector<int> host_tidx;
    bool targets_identity = false;    // target i is source i, for all i < ntgt
    long tmin = 0, tmax = -1;         // the least and largest target index
    // Mixed: the targets in Z-curve order (targets) and their result slots, sorted again
    // when they changed or every SORT_INTERVAL calls.  Called after the start event, so the
    // kernel time includes the sort on the calls that redo it.
    void order_targets(const GravityArgs &a, const int *&targets, const int *&out_slot);
    bool last_once = false;
    float kernel_ms = 0.0f;
    // begin_own() ... finish_rest(): the other sources are uploaded on copy_stream while
    // the own sums run, `copied` orders them before the other sums.
    cudaStream_t copy_stream = nullptr;
    cudaEvent_t copied = nullptr;
    struct Split {
      bool open = false;
      Precision p = Precision::Single;
      GravityArgs a{};
      GravityShape shape{};    // block and ilp; splits: all ranges together
      long first = 0, n_own = 0;
      int splits_low = 0, splits_own = 0, splits_high = 0;
      bool masses_pending = false;    // the other sources' masses still to upload
      const int *targets = nullptr, *slot = nullptr;
    } split;
    double own_max_mass = 0.0;
    cudaEvent_t own_up = nullptr;    // the own sources are on the device (share_sources())
    // The other ranks' positions and masses, opened by CUDA IPC (open_peers()), per rank.
    std::vector<std::vector<char>> peer_handles;
    std::vector<void *> peer_x, peer_m;
    int peer_me = -1;    // this rank among them
    void close_peers();
    void upload_range(DeviceBuffer &b, const double *h, long begin, long end, int per,
                      cudaStream_t st, const char *what);
  };

  void GravityEngine::Impl::close_peers()
  {
    for (void *&p : peer_x)
      if (p) cudaIpcCloseMemHandle(p);
    for (void *&p : peer_m)
      if (p) cudaIpcCloseMemHandle(p);
    (void) cudaGetLastError();
    peer_x.clear();
    peer_m.clear();
    peer_handles.clear();
  }

  void GravityEngine::Impl::upload_range(DeviceBuffer &b, const double *h, long begin, long end,
                                         int per, cudaStream_t st, const char *what)
  {
    if (end <= begin) return;
    cuda_check(cudaMemcpyAsync((double *) b.ptr + per * begin, h + per * begin,
                               per * (end - begin) * sizeof(double), cudaMemcpyHostToDevice, st),
               what);
  }

  void GravityEngine::Impl::order_targets(const GravityArgs &a, const int *&targets,
                                          const int *&out_slot)
  {
    const long nt = ntgt;
    if (!sorted || calls_since_sort >= SORT_INTERVAL) {
      const size_t temp = sort_temp_bytes(nt);
      keys.reserve(2 * nt * sizeof(unsigned), "cudaMalloc(sort keys)");
      tsorted.reserve(nt * sizeof(int), "cudaMalloc(sorted targets)");
      slot.reserve(nt * sizeof(int), "cudaMalloc(target slots)");
      sort_temp.reserve(temp, "cudaMalloc(sort space)");
      sorted = true;
      calls_since_sort = 0;
      cuda_check(sort_targets((const double *) x.ptr, (const int *) tidx.ptr, nt, a,
                              (unsigned *) keys.ptr, (int *) tsorted.ptr, (int *) slot.ptr,
                              sort_temp.ptr, temp, stream),
                 "target sort");
    }
    ++calls_since_sort;
    targets = (const int *) tsorted.ptr;
    out_slot = (const int *) slot.ptr;
  }

  GravityEngine::GravityEngine(int device) : impl(new Impl)
  {
    impl->device = device;
    try {
      cuda_check(cudaSetDevice(device), "cudaSetDevice");
      cudaDeviceProp prop;
      cuda_check(cudaGetDeviceProperties(&prop, device), "cudaGetDeviceProperties");
      impl->num_sms = prop.multiProcessorCount;
      impl->name = prop.name;
      cuda_check(cudaStreamCreateWithFlags(&impl->stream, cudaStreamNonBlocking),
                 "cudaStreamCreate");
      cuda_check(cudaEventCreate(&impl->start), "cudaEventCreate");
      cuda_check(cudaEventCreate(&impl->stop), "cudaEventCreate");
    } catch (...) {
      delete impl;
      throw;
    }
  }

  GravityEngine::~GravityEngine()
  {
    cudaSetDevice(impl->device);
    for (DeviceBuffer *b :
         {&impl->x, &impl->m, &impl->src, &impl->tidx, &impl->scratch, &impl->f, &impl->e, &impl->v,
          &impl->keys, &impl->tsorted, &impl->slot, &impl->sort_temp})
      b->release();
    impl->close_peers();
    if (impl->own_up) cudaEventDestroy(impl->own_up);
    if (impl->copied) cudaEventDestroy(impl->copied);
    if (impl->copy_stream) cudaStreamDestroy(impl->copy_stream);
    if (impl->start) cudaEventDestroy(impl->start);
    if (impl->stop) cudaEventDestroy(impl->stop);
    if (impl->stream) cudaStreamDestroy(impl->stream);
    delete impl;
  }

  int GravityEngine::device() const
  {
    return impl->device;
  }
  std::string GravityEngine::device_name() const
  {
    return impl->name;
  }
  int GravityEngine::num_sms() const
  {
    return impl->num_sms;
  }
  float GravityEngine::last_kernel_ms() const
  {
    return impl->kernel_ms;
  }
  bool GravityEngine::last_pairs_once() const
  {
    return impl->last_once;
  }

  void GravityEngine::set_sources(long n, const double *x, const double *m, bool masses_changed)
  {
    cuda_check(cudaSetDevice(impl->device), "cudaSetDevice");
    const bool grown = (n != impl->nsrc);
    impl->x.reserve(3 * n * sizeof(double) + 1, "cudaMalloc(positions)");
    impl->m.reserve(n * sizeof(double) + 1, "cudaMalloc(masses)");
    cuda_check(cudaMemcpyAsync(impl->x.ptr, x, 3 * n * sizeof(double), cudaMemcpyHostToDevice,
                               impl->stream),
               "cudaMemcpy(positions)");
    if (grown || masses_changed) {
      cuda_check(
          cudaMemcpyAsync(impl->m.ptr, m, n * sizeof(double), cudaMemcpyHostToDevice, impl->stream),
          "cudaMemcpy(masses)");
      impl->max_mass = 0.0;
      for (long i = 0; i < n; ++i) impl->max_mass = std::max(impl->max_mass, m[i]);
    }
    impl->nsrc = n;
  }

  void GravityEngine::set_targets(long ntgt, const long *index)
  {
    cuda_check(cudaSetDevice(impl->device), "cudaSetDevice");
    bool same = (ntgt == impl->ntgt);
    for (long i = 0; same && i < ntgt; ++i) same = (impl->host_tidx[i] == (int) index[i]);
    if (same) return;
    impl->host_tidx.resize(ntgt);
    impl->targets_identity = true;
    impl->tmin = ntgt > 0 ? index[0] : 0;
    impl->tmax = ntgt > 0 ? index[0] : -1;
    for (long i = 0; i < ntgt; ++i) {
      impl->host_tidx[i] = (int) index[i];
      impl->targets_identity &= (index[i] == i);
      impl->tmin = std::min(impl->tmin, index[i]);
      impl->tmax = std::max(impl->tmax, index[i]);
    }
    impl->tidx.reserve(ntgt * sizeof(int) + 1, "cudaMalloc(targets)");
    cuda_check(cudaMemcpyAsync(impl->tidx.ptr, impl->host_tidx.data(), ntgt * sizeof(int),
                               cudaMemcpyHostToDevice, impl->stream),
               "cudaMemcpy(targets)");
    // The stream keeps the copy ordered before the next kernel; host_tidx must stay valid
    // until then, which it does (it only changes in the next set_targets call, after a sync).
    cuda_check(cudaStreamSynchronize(impl->stream), "cudaStreamSynchronize(targets)");
    impl->ntgt = ntgt;
    impl->sorted = false;
  }

  void GravityEngine::compute(Precision p, const GravityArgs &a, double *f, double *e, double *v,
                              GravityShape shape)
  {
    cuda_check(cudaSetDevice(impl->device), "cudaSetDevice");
    const long n = impl->nsrc, nt = impl->ntgt;
    impl->last_once = a.pairs_once > 0 && pairs_once_supported(p, a) && impl->targets_identity &&
                      nt == n && (a.pairs_once > 1 || pairs_once_pays(p, n));
    if (impl->last_once) {
      launch_pairs_once(p, a, shape.splits > 0 ? shape.ilp : 0);
    } else {
      if (shape.splits <= 0) shape = choose_shape(p, a, nt, n, impl->num_sms);
      impl->src.reserve(source_bytes(p) * n + 1, "cudaMalloc(sources)");
      impl->scratch.reserve(scratch_bytes(p, shape, nt, a.energy_virial) + 1,
                            "cudaMalloc(scratch)");
      impl->f.reserve(3 * nt * sizeof(double) + 1, "cudaMalloc(forces)");
      if (a.energy_virial) {
        impl->e.reserve(nt * sizeof(double) + 1, "cudaMalloc(energies)");
        impl->v.reserve(6 * nt * sizeof(double) + 1, "cudaMalloc(virials)");
      }
      cuda_check(pack_sources(p, (const double *) impl->x.ptr, (const double *) impl->m.ptr, n, a,
                              impl->src.ptr, impl->stream),
                 "pack_sources kernel");
      cuda_check(cudaEventRecord(impl->start, impl->stream), "cudaEventRecord");
      const int *targets = (const int *) impl->tidx.ptr;
      const int *slot = nullptr;
      if (p == Precision::Mixed && nt > 0) impl->order_targets(a, targets, slot);
      cuda_check(compute_gravity(p, shape, impl->src.ptr, n, targets, slot, nt,
                                 (const double *) impl->m.ptr, impl->max_mass, a, impl->scratch.ptr,
                                 (double *) impl->f.ptr, (double *) impl->e.ptr,
                                 (double *) impl->v.ptr, impl->stream),
                 "gravity kernel");
    }
    fetch_results(a.energy_virial, f, e, v);
  }

  // Records the stop event, downloads the results of the last sums and waits for them.
  void GravityEngine::fetch_results(bool energy_virial, double *f, double *e, double *v)
  {
    const long nt = impl->ntgt;
    cuda_check(cudaEventRecord(impl->stop, impl->stream), "cudaEventRecord");
    cuda_check(cudaMemcpyAsync(f, impl->f.ptr, 3 * nt * sizeof(double), cudaMemcpyDeviceToHost,
                               impl->stream),
               "cudaMemcpy(forces)");
    if (energy_virial) {
      cuda_check(cudaMemcpyAsync(e, impl->e.ptr, nt * sizeof(double), cudaMemcpyDeviceToHost,
                                 impl->stream),
                 "cudaMemcpy(energies)");
      cuda_check(cudaMemcpyAsync(v, impl->v.ptr, 6 * nt * sizeof(double), cudaMemcpyDeviceToHost,
                                 impl->stream),
                 "cudaMemcpy(virials)");
    }
    cuda_check(cudaStreamSynchronize(impl->stream), "gravity kernel (synchronize)");
    cuda_check(cudaEventElapsedTime(&impl->kernel_ms, impl->start, impl->stop),
               "cudaEventElapsedTime");
  }

  void GravityEngine::begin_own(Precision p, const GravityArgs &a, long n, long first, long n_own,
                                const double *x_own, const double *m_own, bool masses_changed)
  {
    cuda_check(cudaSetDevice(impl->device), "cudaSetDevice");
    Impl &I = *impl;
    const long nt = I.ntgt;
    if (first < 0 || n_own < 0 || first + n_own > n)
      throw Error("gravity engine: the own sources lie outside the system");
    if (nt > 0 && (I.tmin < first || I.tmax >= first + n_own))
      throw Error("gravity engine: a target is not among the rank's own sources");
    if (!I.copy_stream) {
      cuda_check(cudaStreamCreateWithFlags(&I.copy_stream, cudaStreamNonBlocking),
                 "cudaStreamCreate");
      cuda_check(cudaEventCreateWithFlags(&I.copied, cudaEventDisableTiming), "cudaEventCreate");
      cuda_check(cudaEventCreateWithFlags(&I.own_up, cudaEventDisableTiming), "cudaEventCreate");
    }
    const bool masses = masses_changed || n != I.nsrc;
    I.nsrc = n;
    Impl::Split &S = I.split;
    S.open = true;
    S.p = p;
    S.a = a;
    S.first = first;
    S.n_own = n_own;
    S.masses_pending = masses;
    // One (block, ilp) for every range, chosen by the system size as compute() does; each
    // range gets the splits that fill the device by itself.
    GravityShape s = choose_shape(p, a, nt, n, I.num_sms);    // a compiled (block, ilp)
    S.splits_own = n_own > 0 ? auto_splits(s, nt, n_own, I.num_sms) : 0;
    S.splits_low = first > 0 ? auto_splits(s, nt, first, I.num_sms) : 0;
    S.splits_high = n > first + n_own ? auto_splits(s, nt, n - first - n_own, I.num_sms) : 0;
    s.splits = S.splits_low + S.splits_own + S.splits_high;
    S.shape = s;
    I.x.reserve(3 * n * sizeof(double) + 1, "cudaMalloc(positions)");
    I.m.reserve(n * sizeof(double) + 1, "cudaMalloc(masses)");
    I.src.reserve(source_bytes(p) * n + 1, "cudaMalloc(sources)");
    I.scratch.reserve(scratch_bytes(p, s, nt, a.energy_virial) + 1, "cudaMalloc(scratch)");
    I.f.reserve(3 * nt * sizeof(double) + 1, "cudaMalloc(forces)");
    if (a.energy_virial) {
      I.e.reserve(nt * sizeof(double) + 1, "cudaMalloc(energies)");
      I.v.reserve(6 * nt * sizeof(double) + 1, "cudaMalloc(virials)");
    }
    cuda_check(cudaMemcpyAsync((double *) I.x.ptr + 3 * first, x_own, 3 * n_own * sizeof(double),
                               cudaMemcpyHostToDevice, I.stream),
               "cudaMemcpy(own positions)");
    if (masses) {
      cuda_check(cudaMemcpyAsync((double *) I.m.ptr + first, m_own, n_own * sizeof(double),
                                 cudaMemcpyHostToDevice, I.stream),
                 "cudaMemcpy(own masses)");
      I.own_max_mass = 0.0;
      for (long i = 0; i < n_own; ++i) I.own_max_mass = std::max(I.own_max_mass, m_own[i]);
    }
    cuda_check(cudaEventRecord(I.own_up, I.stream), "cudaEventRecord");
    const size_t sb = source_bytes(p);
    cuda_check(pack_sources(p, (const double *) I.x.ptr + 3 * first,
                            (const double *) I.m.ptr + first, n_own, a,
                            (char *) I.src.ptr + sb * first, I.stream),
               "pack_sources kernel");
    cuda_check(cudaEventRecord(I.start, I.stream), "cudaEventRecord");
    S.targets = (const int *) I.tidx.ptr;
    S.slot = nullptr;
    if (p == Precision::Mixed && nt > 0) I.order_targets(a, S.targets, S.slot);
    GravityShape own = s;
    own.splits = S.splits_own;
    // Only the own range holds targets, so only it may need the self-pair test.
    cuda_check(compute_partials(p, own, I.src.ptr,
                                SourceRange{first, first + n_own, S.splits_low, s.splits},
                                S.targets, nt, a, needs_self_test(p, a, I.own_max_mass),
                                I.scratch.ptr, I.stream),
               "gravity kernel (own sources)");
    I.last_once = false;
  }

  void GravityEngine::finish_rest(const double *x, const double *m, double *f, double *e,
                                  double *v)
  {
    cuda_check(cudaSetDevice(impl->device), "cudaSetDevice");
    Impl &I = *impl;
    Impl::Split &S = I.split;
    if (!S.open) throw Error("gravity engine: finish_rest() without begin_own()");
    S.open = false;
    const long n = I.nsrc, hi = S.first + S.n_own;
    // The other sources go up on their own stream while the own sums run.
    I.upload_range(I.x, x, 0, S.first, 3, I.copy_stream, "cudaMemcpy(positions)");
    I.upload_range(I.x, x, hi, n, 3, I.copy_stream, "cudaMemcpy(positions)");
    if (S.masses_pending) {
      I.upload_range(I.m, m, 0, S.first, 1, I.copy_stream, "cudaMemcpy(masses)");
      I.upload_range(I.m, m, hi, n, 1, I.copy_stream, "cudaMemcpy(masses)");
      // compute() after these calls tests the self pair by the largest mass of all.
      I.max_mass = I.own_max_mass;
      for (long i = 0; i < S.first; ++i) I.max_mass = std::max(I.max_mass, m[i]);
      for (long i = hi; i < n; ++i) I.max_mass = std::max(I.max_mass, m[i]);
    }
    sum_rest(f, e, v);
  }

  bool GravityEngine::share_sources(std::vector<char> &handles)
  {
    handles.clear();
    cuda_check(cudaSetDevice(impl->device), "cudaSetDevice");
    Impl &I = *impl;
    if (!I.split.open || !I.x.ptr || !I.m.ptr) return false;
    cuda_check(cudaEventSynchronize(I.own_up), "gravity engine (own sources up)");
    cudaIpcMemHandle_t h[2];
    if (cudaIpcGetMemHandle(&h[0], I.x.ptr) != cudaSuccess ||
        cudaIpcGetMemHandle(&h[1], I.m.ptr) != cudaSuccess) {
      (void) cudaGetLastError();
      return false;
    }
    handles.assign(reinterpret_cast<const char *>(h), reinterpret_cast<const char *>(h) + sizeof(h));
    return true;
  }

  void GravityEngine::open_peers(const std::vector<char> &all, int me)
  {
    cuda_check(cudaSetDevice(impl->device), "cudaSetDevice");
    Impl &I = *impl;
    const size_t per = 2 * sizeof(cudaIpcMemHandle_t);
    if (all.size() % per != 0 || me < 0 || (size_t) me >= all.size() / per)
      throw Error("gravity engine: not two CUDA IPC handles per rank");
    const size_t np = all.size() / per;
    I.peer_me = me;
    if (I.peer_handles.size() != np) {
      I.close_peers();
      I.peer_handles.resize(np);
      I.peer_x.assign(np, nullptr);
      I.peer_m.assign(np, nullptr);
    }
    for (size_t q = 0; q < np; ++q) {
      if ((int) q == me) continue;
      std::vector<char> h(all.begin() + q * per, all.begin() + (q + 1) * per);
      if (h == I.peer_handles[q]) continue;
      for (void **p : {&I.peer_x[q], &I.peer_m[q]}) {
        if (*p) cudaIpcCloseMemHandle(*p);
        *p = nullptr;
      }
      I.peer_handles[q].clear();
      cudaIpcMemHandle_t hh[2];
      std::memcpy(hh, h.data(), sizeof(hh));
      cuda_check(cudaIpcOpenMemHandle(&I.peer_x[q], hh[0], cudaIpcMemLazyEnablePeerAccess),
                 "cudaIpcOpenMemHandle(positions of another rank)");
      cuda_check(cudaIpcOpenMemHandle(&I.peer_m[q], hh[1], cudaIpcMemLazyEnablePeerAccess),
                 "cudaIpcOpenMemHandle(masses of another rank)");
      I.peer_handles[q] = h;
    }
  }

  void GravityEngine::finish_from_peers(const std::vector<long> &first,
                                        const std::vector<long> &count, double *f, double *e,
                                        double *v)
  {
    cuda_check(cudaSetDevice(impl->device), "cudaSetDevice");
    Impl &I = *impl;
    Impl::Split &S = I.split;
    if (!S.open) throw Error("gravity engine: finish_from_peers() without begin_own()");
    if (first.size() != I.peer_x.size() || count.size() != first.size())
      throw Error("gravity engine: the ranks' sources do not match the buffers opened");
    for (size_t q = 0; q < first.size(); ++q) {
      if ((int) q == I.peer_me || count[q] == 0) continue;    // this rank's own, or none
      if (!I.peer_x[q]) throw Error("gravity engine: another rank's buffers are not open");
      const size_t off3 = 3 * first[q] * sizeof(double), off1 = first[q] * sizeof(double);
      cuda_check(cudaMemcpyAsync((char *) I.x.ptr + off3, (const char *) I.peer_x[q] + off3,
                                 3 * count[q] * sizeof(double), cudaMemcpyDefault, I.copy_stream),
                 "cudaMemcpy(positions from another rank's device)");
      if (S.masses_pending)
        cuda_check(cudaMemcpyAsync((char *) I.m.ptr + off1, (const char *) I.peer_m[q] + off1,
                                   count[q] * sizeof(double), cudaMemcpyDefault, I.copy_stream),
                   "cudaMemcpy(masses from another rank's device)");
    }
    // The other ranks' masses are not on this host: compute() tests every self pair after.
    if (S.masses_pending) I.max_mass = std::numeric_limits<double>::infinity();
    S.open = false;
    sum_rest(f, e, v);
  }

  // The sums over the sources outside the own range once copy_stream has put them on the
  // device, the finalize, and the results back.
  void GravityEngine::sum_rest(double *f, double *e, double *v)
  {
    Impl &I = *impl;
    Impl::Split &S = I.split;
    const long n = I.nsrc, nt = I.ntgt, hi = S.first + S.n_own;
    cuda_check(cudaEventRecord(I.copied, I.copy_stream), "cudaEventRecord");
    cuda_check(cudaStreamWaitEvent(I.stream, I.copied, 0), "cudaStreamWaitEvent");
    const size_t sb = source_bytes(S.p);
    const struct {
      long begin, end;
      int split0, splits;
    } rest[2] = {{0, S.first, 0, S.splits_low}, {hi, n, S.splits_low + S.splits_own, S.splits_high}};
    for (const auto &r : rest) {
      if (r.end <= r.begin) continue;
      cuda_check(pack_sources(S.p, (const double *) I.x.ptr + 3 * r.begin,
                              (const double *) I.m.ptr + r.begin, r.end - r.begin, S.a,
                              (char *) I.src.ptr + sb * r.begin, I.stream),
                 "pack_sources kernel");
      GravityShape part = S.shape;
      part.splits = r.splits;
      cuda_check(compute_partials(S.p, part, I.src.ptr,
                                  SourceRange{r.begin, r.end, r.split0, S.shape.splits}, S.targets,
                                  nt, S.a, false, I.scratch.ptr, I.stream),
                 "gravity kernel (other sources)");
    }
    cuda_check(sum_partials(S.p, I.scratch.ptr, S.shape.splits, nt, nt, S.targets, S.slot,
                            (const double *) I.m.ptr, S.a.G, S.a.energy_virial, (double *) I.f.ptr,
                            (double *) I.e.ptr, (double *) I.v.ptr, I.stream),
               "gravity kernel (sums)");
    fetch_results(S.a.energy_virial, f, e, v);
  }

  // Reserves, records the start event and launches the pairs-once kernels for all sources;
  // compute() then fetches the forces as for the one-sided kernels.
  void GravityEngine::launch_pairs_once(Precision p, const GravityArgs &a, int ilp)
  {
    const long n = impl->nsrc;
    const PairsOnceLayout L = pairs_once_layout(p, n, ilp);
    impl->src.reserve(pairs_once_source_bytes(p, L), "cudaMalloc(sources)");
    impl->scratch.reserve(pairs_once_scratch_bytes(p, L), "cudaMalloc(scratch)");
    impl->f.reserve(3 * n * sizeof(double) + 1, "cudaMalloc(forces)");
    cuda_check(cudaEventRecord(impl->start, impl->stream), "cudaEventRecord");
    // Mixed: blocks of bodies that are close in space (the targets are all bodies, in order).
    const int *order = nullptr, *slot = nullptr;
    if (p == Precision::Mixed) impl->order_targets(a, order, slot);
    cuda_check(compute_gravity_pairs_once(
                   p, L, (const double *) impl->x.ptr, (const double *) impl->m.ptr, n, order, slot,
                   a, impl->src.ptr, impl->scratch.ptr, (double *) impl->f.ptr, impl->stream),
               "gravity kernel (pairs once)");
  }

}    // namespace GPU
}    // namespace HSGPU
