/* HARDSPHERE_GPU collision engine: the CUDA backend, see collision_backend_cuda.h.

   Per call: the edge adjacency (CSR, edges in increasing index per body, as the CPU builds
   it) is made on the host; bodies, edges, adjacency, groups and the restitution table go to
   the device; one warp per group runs resolve_group_warp (group_loop_warp.cuh) with the
   best-event array in global memory; per-group tallies and the bodies come back, and the
   tallies are handed to the caller in group order (added to its tally, or stored one per
   group in WindowWork::group_tally), as the CPU backend does.

   Compiled with --fmad=false and without fast math (collide.cmake): together with the host's
   -ffp-contract=off this makes every core function give the host's bits (test_core_device
   checks them one by one). */
#include "collision_backend_cuda.h"

#include "group_loop_warp.cuh"
#include "cuda_check.cuh"
#include "device_info.cuh"

#include <algorithm>
#include <stdexcept>
#include <vector>

namespace HSGPU {
namespace Collide {

  namespace {

    using GPU::cuda_check;
    using GPU::DeviceBuffer;

    constexpr int GROUP_BLOCK = 128;

    // Launch contract: 1-D grid of blocks of whole warps, 32 ngroups threads or more.  Warp
    // g < ngroups resolves group g (members gmembers[gstart[g] .. gstart[g + 1])) up to t_end
    // when g <= last_group, with at most `budget` events (`capped_budget` for
    // g == capped_group), and writes its events' tally, summed in event order from zero, to
    // tallies[g]; groups after last_group are left as they are and their tallies unwritten.
    // Everything in device memory: graph.bodies (changed in place), graph.edges,
    // graph.adj_start, graph.adj, graph.best (one Event per body, scratch), gstart[ngroups +
    // 1], gmembers, tallies[ngroups], p.epair ((p.ntypes + 1)^2 values).  The groups must be
    // closed under the edges (see collision_group_loop.h): warps then share no data, and the
    // lanes of one warp order their accesses with __syncwarp() (group_loop_warp.cuh).
    __global__ void resolve_groups_kernel(GroupGraph graph, const int *__restrict__ gstart,
                                          const int *__restrict__ gmembers, int ngroups,
                                          int last_group, double t_end,
                                          const __grid_constant__ Params p, long budget,
                                          int capped_group, long capped_budget,
                                          Tally *__restrict__ tallies)
    {
      const int g = (int) (((long) blockIdx.x * blockDim.x + threadIdx.x) >> 5);
      if (g >= ngroups || g > last_group) return;    // whole warps leave together
      const int lo = gstart[g], hi = gstart[g + 1];
      Tally t;
      if (hi > lo)
        resolve_group_warp(graph, p, gmembers + lo, hi - lo, t_end,
                           g == capped_group ? capped_budget : budget, t);
      if ((threadIdx.x & 31) == 0) tallies[g] = t;
    }

    class CudaBackend : public CollisionBackend {
     public:
      explicit CudaBackend(int dev) : device(dev)
      {
        const cudaError_t err = cudaSetDevice(device);
        // A failed call is also left as the thread's "last error", which the next kernel
        // launch check (cudaGetLastError) would report as its own: clear it first.
        if (err != cudaSuccess) cudaGetLastError();
        cuda_check(err, "cudaSetDevice");
        cuda_check(cudaStreamCreateWithFlags(&stream, cudaStreamNonBlocking), "cudaStreamCreate");
      }

      ~CudaBackend() override
      {
        cudaSetDevice(device);
        for (DeviceBuffer *b : {&d_bodies, &d_edges, &d_adj_start, &d_adj, &d_best, &d_gstart,
                                &d_gmembers, &d_tallies, &d_epair})
          b->release();
        if (stream) cudaStreamDestroy(stream);
      }

      CudaBackend(const CudaBackend &) = delete;
      CudaBackend &operator=(const CudaBackend &) = delete;

      std::string name() const override { return "cuda"; }

      long resolve(const WindowWork &w, const Params &p, Tally &tally) override;

     private:
      int device;
      cudaStream_t stream = nullptr;
      DeviceBuffer d_bodies, d_edges, d_adj_start, d_adj, d_best, d_gstart, d_gmembers, d_tallies,
          d_epair;
      std::vector<int> adj_start, adj, fill;
      std::vector<Tally> tallies;

      /// Uploads the window, resolves its groups (twice where the cap stops it, see
      /// collision_backend_cuda.h), downloads the bodies and the tallies of the groups that
      /// ran into `tallies`.  Returns the last group that ran.
      int run_groups(const WindowWork &w, const Params &p, long events_before);

      void upload_bodies(const WindowWork &w)
      {
        cuda_check(cudaMemcpyAsync(d_bodies.ptr, w.bodies, w.nbodies * sizeof(Body),
                                   cudaMemcpyHostToDevice, stream),
                   "cudaMemcpy(bodies)");
      }

      void launch(const WindowWork &w, const Params &dp, int last_group, long budget,
                  int capped_group, long capped_budget)
      {
        const GroupGraph graph{d_bodies.as<Body>(), d_edges.as<Edge>(), d_adj_start.as<int>(),
                               d_adj.as<int>(), d_best.as<Event>()};
        const int nblocks = (int) ((32L * w.ngroups + GROUP_BLOCK - 1) / GROUP_BLOCK);
        // The check after the launch must see this launch's error only, not one that an
        // earlier failed call (reported through its return value) left behind.
        (void) cudaGetLastError();
        resolve_groups_kernel<<<nblocks, GROUP_BLOCK, 0, stream>>>(
            graph, d_gstart.as<int>(), d_gmembers.as<int>(), w.ngroups, last_group, w.t_end, dp,
            budget, capped_group, capped_budget, d_tallies.as<Tally>());
        cuda_check(cudaGetLastError(), "resolve_groups_kernel launch");
        cuda_check(cudaMemcpyAsync(tallies.data(), d_tallies.ptr, w.ngroups * sizeof(Tally),
                                   cudaMemcpyDeviceToHost, stream),
                   "cudaMemcpy(group tallies)");
        cuda_check(cudaStreamSynchronize(stream), "resolve_groups_kernel");
      }
    };

    long CudaBackend::resolve(const WindowWork &w, const Params &p, Tally &tally)
    {
      const int n = w.nbodies, ng = w.ngroups;
      if (w.body_virial)
        throw std::logic_error("the CUDA collision backend does not tally per-atom virials");
      if (ng <= 0) return 0;
      tallies.assign(ng, Tally());
      // As the CPU backend: once the cap has stopped a step, no group runs (last = -1).
      int last = -1;
      if (!tally.capped && n > 0) last = run_groups(w, p, tally.events);
      return hand_over_tallies(w.group_start, ng, tallies.data(), last, w.group_tally, tally);
    }

    int CudaBackend::run_groups(const WindowWork &w, const Params &p, long events_before)
    {
      cuda_check(cudaSetDevice(device), "cudaSetDevice");
      const int n = w.nbodies, ng = w.ngroups;
      const int nmembers = w.group_start[ng];

      // Adjacency of the window's edges, edges in increasing index for every body.
      edge_adjacency(n, w.edges, w.nedges, adj_start, adj, fill);

      // +1: never a zero-byte allocation.
      const size_t ne = (size_t) (p.ntypes + 1) * (p.ntypes + 1);
      d_bodies.reserve(n * sizeof(Body), "cudaMalloc(bodies)");
      d_best.reserve(n * sizeof(Event), "cudaMalloc(best events)");
      d_edges.reserve(w.nedges * sizeof(Edge) + 1, "cudaMalloc(edges)");
      d_adj_start.reserve((n + 1) * sizeof(int), "cudaMalloc(adjacency)");
      d_adj.reserve(adj.size() * sizeof(int) + 1, "cudaMalloc(adjacency)");
      d_gstart.reserve((ng + 1) * sizeof(int), "cudaMalloc(groups)");
      d_gmembers.reserve(nmembers * sizeof(int) + 1, "cudaMalloc(group members)");
      d_tallies.reserve(ng * sizeof(Tally), "cudaMalloc(group tallies)");
      // The restitution table, then (rough spheres) the friction table: 2 values per pair.
      const size_t nf = p.friction ? 2 * ne : 0;
      d_epair.reserve((ne + nf) * sizeof(double), "cudaMalloc(restitution table)");
      upload_bodies(w);
      cuda_check(cudaMemcpyAsync(d_edges.ptr, w.edges, w.nedges * sizeof(Edge),
                                 cudaMemcpyHostToDevice, stream),
                 "cudaMemcpy(edges)");
      cuda_check(cudaMemcpyAsync(d_adj_start.ptr, adj_start.data(), (n + 1) * sizeof(int),
                                 cudaMemcpyHostToDevice, stream),
                 "cudaMemcpy(adjacency)");
      cuda_check(cudaMemcpyAsync(d_adj.ptr, adj.data(), adj.size() * sizeof(int),
                                 cudaMemcpyHostToDevice, stream),
                 "cudaMemcpy(adjacency)");
      cuda_check(cudaMemcpyAsync(d_gstart.ptr, w.group_start, (ng + 1) * sizeof(int),
                                 cudaMemcpyHostToDevice, stream),
                 "cudaMemcpy(groups)");
      cuda_check(cudaMemcpyAsync(d_gmembers.ptr, w.group_members, nmembers * sizeof(int),
                                 cudaMemcpyHostToDevice, stream),
                 "cudaMemcpy(group members)");
      cuda_check(cudaMemcpyAsync(d_epair.ptr, p.epair, ne * sizeof(double), cudaMemcpyHostToDevice,
                                 stream),
                 "cudaMemcpy(restitution table)");
      if (nf)
        cuda_check(cudaMemcpyAsync(d_epair.as<double>() + ne, p.fpair, nf * sizeof(double),
                                   cudaMemcpyHostToDevice, stream),
                   "cudaMemcpy(friction table)");
      // The kernel's parameters, with the tables on the device.
      Params dp = p;
      dp.epair = d_epair.as<double>();
      dp.fpair = nf ? d_epair.as<double>() + ne : nullptr;

      // Every group at once, each allowed what the cap leaves before this window.
      const long budget = p.maxevents - events_before;
      launch(w, dp, ng - 1, budget, -1, 0);

      // Where the CPU's one cap over the groups in order would have stopped, if anywhere.
      long stop_budget = 0;
      const int stop = cap_stop_group(w.group_start, ng, tallies.data(), p.maxevents, events_before,
                                      stop_budget);
      int last = ng - 1;
      if (stop >= 0) {
        // Again from the window's start: the groups before `stop` give the same bits, `stop`
        // is capped where the CPU caps it, later groups do not run.
        upload_bodies(w);
        launch(w, dp, stop, budget, stop, stop_budget);
        last = stop;
      }
      cuda_check(
          cudaMemcpyAsync(w.bodies, d_bodies.ptr, n * sizeof(Body), cudaMemcpyDeviceToHost, stream),
          "cudaMemcpy(bodies back)");
      cuda_check(cudaStreamSynchronize(stream), "cudaMemcpy(bodies back)");
      return last;
    }

  }    // namespace

  std::unique_ptr<CollisionBackend> make_cuda_backend(int device)
  {
    return std::unique_ptr<CollisionBackend>(new CudaBackend(device));
  }

  bool cuda_backend_available()
  {
    return GPU::device_count() > 0;
  }

}    // namespace Collide
}    // namespace HSGPU
