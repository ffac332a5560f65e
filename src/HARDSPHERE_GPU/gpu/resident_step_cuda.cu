/* HARDSPHERE_GPU collision engine: the device-resident step, see engine/resident_step.h and
   resident_step_cuda.h; its kernels are in resident_kernels.cuh, this file drives them.

   One step, with the bodies on the device from the upload to the download:

     upload    run(): bodies and step bounds; run_atoms(): the caller's eight per-atom arrays,
               page-locked where they lie (cudaHostRegister, kept between steps), the step
               budget's maxima (the host's step_budget()), and the bodies built from them on
               the device (through a tile in shared memory)
     scan:     largest r + bound, fastest drift, wall overlaps     (one thread per body, block
               reductions, one atomic per block)
     search:   the grid of cells (from the scan's largest reach, on the device), cell of every
               start point, CUB radix sort by cell, cell ranges and the start points in cell
               order, candidate pairs counted (one thread per body, the 13 cells on one side
               of it and the later bodies of its own: each pair once; the first 16 of a body
               kept), CUB scan, written from what the count kept (a body with more searches
               again) into room for a quarter more than the last step's, pair overlaps; CSR
               adjacency of the candidates
     windows:  for each window length tried (window_chooser.h): window start points and bounds,
               edges joined (a flag per candidate), connected components by a lock-free
               union-find whose roots are the components' smallest indices, group sizes and the
               largest (read by the host); for the window taken: groups numbered in root
               order (a CUB scan), members placed, bodies snapshot, groups partitioned by size
               (CUB): one thread per group of one or two bodies runs collision_group_loop.h's
               exact loop (on a second stream, beside the larger groups), one warp per larger
               group group_loop_warp.cuh's (the larger groups' first best events computed
               before, one thread per body), per-group tallies
               reduced (CUB, a fixed order), excursions, pairs not joined that could have
               touched joined (if any: bodies back to the snapshot, components again, resolved
               again)
     serial:   (order serial, instead of the windows) serial_loop.cuh's loop, one globally
               earliest event per iteration, iterations launched ahead in a CUDA graph
     end:      excursions to dt, the step's check (bodies beyond their step bound, each
               one's neighbours shared by the lanes of a warp: any pair with a neighbour that
               was not a candidate and could have touched declines the step); only the bodies that had events go back, compacted in body order (run:
               whole Bodies; run_atoms: end-of-step x, v and tlast, written into the caller's
               arrays, or, where more than 1/32 of the atoms changed and the arrays are
               page-locked, written by the device straight into them, which the driver maps
               into its address space (HSGPU_RESIDENT_DIRECT=0: into the device copies, and x
               and v copied back whole); every atom's tlast shifted to the step end and copied
               back whole)

   The host waits for the device where it needs a number to go on, and reads every scalar it
   needs then (Scalars, one download): once for the scan, the search and the first window
   length the chooser tries (set up ahead: the chooser's first_end()); once per resolve pass,
   for its check, which brings the next window's first try (set up ahead likewise, into the
   other of two sets of window bounds and joined flags) or, after the step's last window,
   the step's end (a repair undoes either with the bodies); once per further window length
   tried; once per repair, for its components; once for the results.  Work enqueued ahead
   and found unneeded (a step that declines, a repair) is thrown away or done again from the
   snapshot: no result bit depends on it, and the chooser sees the same windows.  Where the
   candidates did not fit their room, the search writes them again (another wait); after a
   step that declined for a small box, the next waits for its grid before searching.

   Every body and event computation is core/'s, compiled with --fmad=false (collide.cmake), so
   the events, and every bit of the bodies, are the step driver's.  Components are sets, the
   order of members and edges within a group does not change which event is earliest (no two
   events have equal keys), and groups are numbered by their smallest member as the driver
   numbers them; only the tallies' floating-point sums are added in another order.

   Debugging aids: HSGPU_RESIDENT_VERIFY=1 copies every window's groups to the host and reports
   bodies placed twice or not at all and joined edges between groups on stderr;
   HSGPU_RESIDENT_PROFILE=1 times the phases above (waiting for the stream after each; work
   enqueued ahead counts in the phase that reads it: the first window tried in the search, a
   later window's first try in the check before it, the step's end in the last window's
   check) and prints the means per step on stderr at the end; HSGPU_RESIDENT_PROFILE=2 times
   the same phases by CUDA events without waiting, and the device's idle time while the host
   waits for it and enqueues the next work;
   HSGPU_RESIDENT_SCATTER=1 always sends the changed atoms back compacted (tests run both ways);
   HSGPU_RESIDENT_DIRECT=0 copies x and v back whole instead of the device's writes into them;
   HSGPU_RESIDENT_EDGE_TIMES=0 has the warps find each best event from its edges' pair times
   again instead of keeping those times;
   HSGPU_RESIDENT_TARGET, _SMALL, _KF and _FLOOR override the window target, the largest group
   resolved by one thread, and the window bounds' factor and floor fraction, and
   HSGPU_RESIDENT_SIDE=0 runs the small groups after the larger ones on one stream, and
   HSGPU_RESIDENT_STASH=k keeps k < 16 candidates per body from the count pass (tuning and
   testing aids; no result bit depends on them). */
#include "resident_step_cuda.h"

#include "group_loop_warp.cuh"
#include "serial_loop.cuh"
#include "cuda_check.cuh"
#include "engine/window_chooser.h"

#include <cub/device/device_radix_sort.cuh>
#include <cub/device/device_reduce.cuh>
#include <cub/block/block_reduce.cuh>
#include <cub/device/device_scan.cuh>
#include <cub/device/device_partition.cuh>
#include <thrust/iterator/counting_iterator.h>

#include <algorithm>
#include <climits>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <vector>
#include <cmath>
#include <cstddef>
#include <cstring>

#include "resident_kernels.cuh"

namespace HSGPU {
namespace Collide {

  namespace {

    using GPU::cuda_check;
    using GPU::DeviceBuffer;
    using GPU::PinnedBuffer;
    using GPU::copy_xvf_to_device;
    using GPU::HostRangeLock;
    using GPU::copy_statics_to_device;
    using GPU::copy_state_from_device;

    using Clock = std::chrono::steady_clock;

    /// The number in environment variable `name` (the tuning aids), else `fallback`.
    double env_number(const char *name, double fallback)
    {
      const char *v = std::getenv(name);
      return v ? std::atof(v) : fallback;
    }

    double seconds_since(Clock::time_point t)
    {
      return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
    }

    class CudaResidentStep : public ResidentStep {
     public:
      explicit CudaResidentStep(int dev) : device(dev)
      {
        const cudaError_t err = cudaSetDevice(device);
        if (err != cudaSuccess) cudaGetLastError();
        cuda_check(err, "cudaSetDevice");
        cuda_check(cudaStreamCreateWithFlags(&stream, cudaStreamNonBlocking), "cudaStreamCreate");
        cuda_check(cudaMallocHost(&host_scalars, sizeof(Scalars)), "cudaMallocHost(scalars)");
        cuda_check(cudaEventCreate(&ev_up0), "cudaEventCreate");
        cuda_check(cudaEventCreate(&ev_up1), "cudaEventCreate");
        cuda_check(cudaStreamCreateWithFlags(&side, cudaStreamNonBlocking), "cudaStreamCreate");
        cuda_check(cudaEventCreateWithFlags(&ev_fork, cudaEventDisableTiming), "cudaEventCreate");
        cuda_check(cudaEventCreateWithFlags(&ev_join, cudaEventDisableTiming), "cudaEventCreate");
      }

      ~CudaResidentStep() override
      {
        cudaSetDevice(device);
        for (DeviceBuffer *b :
             {&d_bodies, &d_snap,   &d_bound,  &d_scalars, &d_key,      &d_val,  &d_key2,
              &d_val2,   &d_cstart, &d_count,  &d_offset,  &d_edges,    &d_deg,  &d_adj_start,
              &d_fill,   &d_adj,    &d_joined, &d_wbound,  &d_parent,   &d_root, &d_size,
              &d_isroot, &d_gid,    &d_goff,   &d_gstart,  &d_gmembers, &d_best, &d_sums,
              &d_lexc,   &d_temp,   &d_near,   &d_neartag, &d_order,    &d_rspin, &d_stash,
              &d_wbound2, &d_joined2})
          b->release();
        if (host_scalars) cudaFreeHost(host_scalars);
        for (PinnedBuffer *b :
             {&host_changed, &host_index, &host_results, &host_rspin, &host_control})
          b->release();
        d_control.release();
        d_part.release();
        d_boost.release();
        d_etime.release();
        d_budget.release();
        host_budget.release();
        if (serial_exec) cudaGraphExecDestroy(serial_exec);
        for (DeviceBuffer *b : {&d_ax, &d_av, &d_af, &d_arad, &d_amass, &d_atlast, &d_atype,
                                &d_aid, &d_aomega, &d_kx, &d_kv, &d_oid, &d_slot, &d_rx, &d_rv,
                                &d_rt, &d_rr, &d_rm, &d_rty, &d_most})
          b->release();
        host_most.release();
        for (HostRangeLock &l : locked) l.release();
        if (ev_up0) cudaEventDestroy(ev_up0);
        if (ev_up1) cudaEventDestroy(ev_up1);
        if (ev_fork) cudaEventDestroy(ev_fork);
        if (ev_join) cudaEventDestroy(ev_join);
        if (side) cudaStreamDestroy(side);
        if (stream) cudaStreamDestroy(stream);
        if (prof.on || prof.line.on) prof.print();
      }

      CudaResidentStep(const CudaResidentStep &) = delete;
      CudaResidentStep &operator=(const CudaResidentStep &) = delete;

      void run(Body *bodies, const double *bound, int n, const ResidentBox &box, const Params &p,
               const WindowSettings &s, Tally &tally, ResidentReport &report) override;
      void run_atoms(const ResidentAtoms &a, const ResidentBox &box, const Params &p,
                     const WindowSettings &s, Tally &tally, ResidentReport &report) override;
      void deliver_atoms() override
      {
        if (!later.pending) return;
        cuda_check(cudaSetDevice(device), "cudaSetDevice");
        write_back(later);
        later = Later();
      }

     private:
      // run_atoms()'s results on their way to the caller's arrays (write_back()), kept for
      // deliver_atoms() where the caller deferred them (ResidentAtoms::defer_writes).
      struct Later {
        bool pending = false;
        ResidentAtoms a{};
        int changed = 0;
        bool spin = false, keep_motion = false;
      } later;
      void write_back(const Later &w);

      int device;
      cudaStream_t stream = nullptr;
      Scalars *host_scalars = nullptr;
      cudaEvent_t ev_up0 = nullptr, ev_up1 = nullptr;    // run_atoms(): around the uploads
      // resolve_groups(): the groups of one or two bodies on a second stream, beside the
      // larger groups' warps (forked from and joined back to `stream` by two events).
      cudaStream_t side = nullptr;
      cudaEvent_t ev_fork = nullptr, ev_join = nullptr;
      // Pinned: what comes back, run()'s bodies that had events with their indices, or
      // run_atoms()'s results (and their angular velocities, rough spheres).
      PinnedBuffer host_changed, host_index, host_results, host_rspin, host_control;
      DeviceBuffer d_control, d_part;    // order serial: the loop's state, block minima
      DeviceBuffer d_boost;              // run_atoms(): step bounds raised by a failed check
      DeviceBuffer d_budget;             // run_atoms(): the step budget's maxima (bits)
      PinnedBuffer host_budget;
      bool step_missed = false;                 // the last step declined on a missed contact
      cudaGraphExec_t serial_exec = nullptr;    // order serial: the iterations, and what
      std::vector<char> serial_key;             // arguments they were captured with
      DeviceBuffer d_ax, d_av, d_af, d_arad, d_amass, d_atlast, d_atype, d_aid;
      DeviceBuffer d_aomega;    // run_atoms(): the angular velocities (rough spheres only)
      DeviceBuffer d_etime;     // resolve_groups(): pair event times of the larger groups' edges
      static constexpr int NLOCKED = 8;
      HostRangeLock locked[NLOCKED];    // run_atoms()'s arrays, page-locked where they lie
      bool locking = true;       // false once the driver refused: pageable copies from then on
      // run_atoms()'s arrays from FIRST_KEPT on (tlast, radius, rmass, type, id) as the last
      // step that was done left them on the device, and where they lie on the host: the next
      // step keeps them where the caller says they are unchanged (ResidentAtoms::same_atoms).
      static constexpr int FIRST_KEPT = 3;
      bool kept = false;
      const void *kept_host[NLOCKED] = {};
      size_t kept_bytes[NLOCKED] = {};
      // d_ax and d_av hold x and v as the last done run_atoms() with KeptMotion::keep left
      // them (ResidentStep::motion_done()); d_kx, d_kv: the kept copies set aside on a check
      // (traded with d_ax, d_av).
      DeviceBuffer d_kx, d_kv;

     public:
      bool share_inputs(long count, int id_bytes, bool spin, std::vector<char> &handles) override
      {
        state_kept = false;
        handles.clear();
        cuda_check(cudaSetDevice(device), "cudaSetDevice");
        // The sizes run_atoms() reserves (its up()): no buffer moves between the two.
        const size_t n3 = (size_t) 3 * count * sizeof(double) + 8,
                     n1 = (size_t) count * sizeof(double) + 8;
        const struct {
          DeviceBuffer *b;
          size_t bytes;
        } bufs[NLOCKED] = {{&d_ax, n3},     {&d_av, n3},     {&d_af, n3},
                           {&d_atlast, n1}, {&d_arad, n1},   {&d_amass, n1},
                           {&d_atype, (size_t) count * sizeof(int) + 8},
                           {&d_aid, (size_t) count * id_bytes + 8}};
        const void *ptr[NLOCKED + 1] = {};
        for (int k = 0; k < NLOCKED; ++k) {
          const void *was = bufs[k].b->ptr;
          bufs[k].b->reserve(bufs[k].bytes, "cudaMalloc(atoms)");
          if (bufs[k].b->ptr != was) kept = ids_kept = false;    // the device copies are gone
          ptr[k] = bufs[k].b->ptr;
        }
        if (spin) {
          d_aomega.reserve(n3, "cudaMalloc(atoms)");
          ptr[NLOCKED] = d_aomega.ptr;
        }
        // The same buffers as last time: the same handles (none exported again).
        if (!shared_handles.empty() && std::equal(ptr, ptr + NLOCKED + 1, shared_ptr)) {
          handles = shared_handles;
          return true;
        }
        shared_handles.clear();
        cudaIpcMemHandle_t h[NLOCKED + 1];
        const int nh = spin ? NLOCKED + 1 : NLOCKED;
        for (int k = 0; k < nh; ++k)
          if (cudaIpcGetMemHandle(&h[k], const_cast<void *>(ptr[k])) != cudaSuccess) {
            (void) cudaGetLastError();
            return false;
          }
        handles.assign(reinterpret_cast<const char *>(h), reinterpret_cast<const char *>(h + nh));
        shared_handles = handles;
        std::copy(ptr, ptr + NLOCKED + 1, shared_ptr);
        return true;
      }

      void put_spin(long first, long count, const double *omega) override
      {
        if (count <= 0) return;
        cuda_check(cudaSetDevice(device), "cudaSetDevice");
        cuda_check(cudaMemcpyAsync(d_aomega.as<double>() + 3 * first, omega,
                                   3 * count * sizeof(double), cudaMemcpyDefault, stream),
                   "cudaMemcpy(atoms)");
        cuda_check(cudaStreamSynchronize(stream), "cudaMemcpy(atoms)");
      }

      void put_inputs(long first, long count, const double *x, const double *v,
                      const double *f, long room) override
      {
        state_kept = false;
        if (count <= 0) return;
        cuda_check(cudaSetDevice(device), "cudaSetDevice");
        double *const dst[3] = {d_ax.as<double>(), d_av.as<double>(), d_af.as<double>()};
        // This rank's own arrays, page-locked in place in run_atoms()'s x, v, f slots.
        copy_xvf_to_device(dst, first, count, x, v, f, locked, locking, stream, "cudaMemcpy(atoms)",
                           room);
      }

      bool share_results(bool spin, std::vector<char> &handles) override
      {
        handles.clear();
        cuda_check(cudaSetDevice(device), "cudaSetDevice");
        cudaIpcMemHandle_t h[3];
        DeviceBuffer *b[3] = {&d_sums, &d_atlast, &d_rspin};
        const int nh = spin ? 3 : 2;
        for (int k = 0; k < nh; ++k)
          if (!b[k]->ptr || cudaIpcGetMemHandle(&h[k], b[k]->ptr) != cudaSuccess) {
            (void) cudaGetLastError();
            return false;
          }
        handles.assign(reinterpret_cast<const char *>(h), reinterpret_cast<const char *>(h + nh));
        return true;
      }

      void put_ids(long first, long count, const void *id, int id_bytes) override
      {
        if (count <= 0) return;
        state_kept = false;
        cuda_check(cudaSetDevice(device), "cudaSetDevice");
        void *const dst[5] = {nullptr, nullptr, nullptr, nullptr, d_aid.ptr};
        copy_statics_to_device(dst, first, count, nullptr, nullptr, nullptr, nullptr, id, id_bytes,
                               stream, "cudaMemcpy(atoms)");
      }

      bool get_atoms(long first, long count, double *x, double *v, double *tlast) override
      {
        if (!state_kept) return false;
        cuda_check(cudaSetDevice(device), "cudaSetDevice");
        const double *const src[3] = {d_ax.as<double>(), d_av.as<double>(),
                                      d_atlast.as<double>()};
        copy_state_from_device(src, first, count, x, v, tlast, stream, "cudaMemcpy(atoms back)");
        return true;
      }

      void put_statics(long first, long count, const double *tlast, const double *radius,
                       const double *rmass, const int *type, const void *id,
                       int id_bytes) override
      {
        state_kept = false;
        ids_kept = false;
        if (count <= 0) return;
        cuda_check(cudaSetDevice(device), "cudaSetDevice");
        void *const dst[5] = {d_atlast.ptr, d_arad.ptr, d_amass.ptr, d_atype.ptr, d_aid.ptr};
        copy_statics_to_device(dst, first, count, tlast, radius, rmass, type, id, id_bytes, stream,
                               "cudaMemcpy(atoms)");
      }

      void forget_host_arrays() override
      {
        state_kept = false;
        ids_kept = false;
        cudaSetDevice(device);
        for (HostRangeLock &l : locked) l.release();
        kept = false;
        motion_forget();
        later = Later();
      }

     private:
      WindowChooser chooser;
      int n = 0, ne = 0;
      double tol = 0.0;    // overlap tolerance of the step
      Grid grid;           // the search's cells, as the device found them (Scalars::grid)
      // The candidate search runs ahead of the host (search()): room for edge_room edges, sized
      // from the last step's count; the kernels over the edges run on edge_threads threads,
      // edge_room until the host has read the count, then the count (ne).
      long edge_room = 0;
      long edge_threads = 0;
      DeviceBuffer d_bodies, d_snap, d_bound, d_scalars, d_key, d_val, d_key2, d_val2, d_cstart,
          d_count, d_offset, d_edges, d_deg, d_adj_start, d_fill, d_adj, d_joined, d_wbound,
          d_parent, d_root, d_size, d_isroot, d_gid, d_goff, d_gstart, d_gmembers, d_best, d_sums,
          d_lexc, d_temp, d_near, d_neartag, d_order, d_stash;
      DeviceBuffer d_rspin;    // run_atoms(): the results' angular velocities (rough spheres)
      // The last run_atoms() left its end state in d_ax, d_av and d_atlast for get_atoms().
      bool state_kept = false;
      // share_inputs(): the buffers whose handles it gave last, and those handles.
      const void *shared_ptr[NLOCKED + 1] = {};
      std::vector<char> shared_handles;
      // ResidentAtoms::reordered: the end state's IDs in its order (ids_kept: d_oid holds the
      // last done step's oid_n IDs, and d_ax, ... its end state), the IDs' slots, scratch.
      bool ids_kept = false;
      int oid_n = 0, oid_bytes = 0;
      DeviceBuffer d_oid, d_slot, d_rx, d_rv, d_rt, d_rr, d_rm, d_rty, d_most;
      PinnedBuffer host_most;
      bool reorder(const ResidentAtoms &a);
      template <class IdT>
      bool reorder_by();
      // Window bounds and joined flags come in two sets, window k's in set k % 2, so that the
      // next window's first try can be set up while this one's check may still repair it.
      DeviceBuffer d_wbound2, d_joined2;
      double *wbound(int set) const { return (set ? d_wbound2 : d_wbound).as<double>(); }
      unsigned char *joined(int set) const
      {
        return (set ? d_joined2 : d_joined).as<unsigned char>();
      }

      Scalars *scalars() const { return d_scalars.as<Scalars>(); }
      int *nedges() const { return &scalars()->nedges; }
      // The cells' ranges: cstart and cend, most_cells(n) each, in one buffer.
      int *cstart() const { return d_cstart.as<int>(); }
      int *cend() const { return d_cstart.as<int>() + most_cells(n); }

      /// HSGPU_RESIDENT_PROFILE: 0 unset, 2 where it is "2", else 1.
      static int profile_mode()
      {
        static const int mode = [] {
          const char *e = std::getenv("HSGPU_RESIDENT_PROFILE");
          return !e ? 0 : std::strcmp(e, "2") == 0 ? 2 : 1;
        }();
        return mode;
      }

      /* Debugging and tuning aid (HSGPU_RESIDENT_PROFILE=1): the stream is waited for at the
         end of every phase of a step and the seconds are summed per phase; the sums per step
         go to stderr when the object is destroyed.  Off, mark() costs nothing. */
      struct Profile {
        enum {
          upload,
          scan,
          search,
          choose,
          snapshot,
          groups,
          resolve,
          check,
          end,
          download,
          count
        };
        /* HSGPU_RESIDENT_PROFILE=2: the step as it runs, timed by CUDA events on its stream (no
           waits added): the device's time per phase, and its idle time from each wait of the
           host (a download of the scalars) to the first work the host enqueues after it (a
           round trip: the copy, the wake-up, the host's own work and the next launch).  The
           first step of the object is left out; so are steps that return early (declines). */
        struct Timeline {
          enum Tag { phase_end, wait_begin, wait_end, start };
          bool on = profile_mode() == 2;
          std::vector<cudaEvent_t> ev;
          std::vector<std::pair<int, int>> tag;    // (Tag, phase)
          size_t used = 0;
          double sec[count] = {};
          double idle = 0.0, span = 0.0, wall = 0.0;
          long waits = 0, steps = 0, events = 0;
          Clock::time_point t0;
          ~Timeline()
          {
            for (cudaEvent_t e : ev) cudaEventDestroy(e);
          }
          void record(cudaStream_t s, int t, int phase)
          {
            if (t == start) {
              used = 0;
              t0 = Clock::now();
            }
            if (used == ev.size()) {
              ev.emplace_back();
              tag.emplace_back();
              cuda_check(cudaEventCreate(&ev.back()), "cudaEventCreate");
            }
            tag[used] = {t, phase};
            cuda_check(cudaEventRecord(ev[used++], s), "cudaEventRecord");
          }
          /// After the step's last wait: the events of the step summed (where `counted`).
          void end_step(bool counted)
          {
            if (!on || used < 2) return;
            cuda_check(cudaEventSynchronize(ev[used - 1]), "cudaEventSynchronize");
            if (!counted) return;
            float ms = 0.0f;
            double pending = 0.0;
            for (size_t i = 1; i < used; ++i) {
              cuda_check(cudaEventElapsedTime(&ms, ev[i - 1], ev[i]), "cudaEventElapsedTime");
              if (tag[i - 1].first == wait_begin && tag[i].first == wait_end) {
                idle += 1e-3 * ms;
                ++waits;
                continue;
              }
              pending += 1e-3 * ms;
              if (tag[i].first == phase_end) {
                sec[tag[i].second] += pending;
                pending = 0.0;
              }
            }
            sec[download] += pending;
            cuda_check(cudaEventElapsedTime(&ms, ev[0], ev[used - 1]), "cudaEventElapsedTime");
            span += 1e-3 * ms;
            wall += std::chrono::duration<double>(Clock::now() - t0).count();
            events += (long) used;
            ++steps;
          }
          void print(const char *const *name) const
          {
            if (!on || steps == 0) return;
            const double k = 1e3 / steps;
            std::fprintf(stderr,
                         "resident timeline: %ld steps after the first, host %.4g ms per step, "
                         "device span %.4g ms, of it idle %.4g ms in %.3g waits per step for the "
                         "host (%.1f events per step); device time per phase",
                         steps, k * wall, k * span, k * idle, (double) waits / steps,
                         (double) events / steps);
            for (int p = 0; p < count; ++p) std::fprintf(stderr, "; %s %.4g", name[p], k * sec[p]);
            std::fprintf(stderr, " ms\n");
          }
        };

        bool on = profile_mode() == 1;    // waits after every phase
        Timeline line;    // HSGPU_RESIDENT_PROFILE=2: times by events, no waits
        double sec[count] = {};
        long steps = 0, tries = 0, passes = 0, whole = 0, direct = 0;
        int locked = 0;
        bool warm = false;    // the first step (allocations, page-locking) is not counted
        void end_step()
        {
          line.end_step(warm);
          if (warm) return;
          warm = true;
          for (double &x : sec) x = 0.0;
          steps = tries = passes = whole = direct = 0;
        }
        Clock::time_point last;
        void print() const
        {
          static const char *name[count] = {"upload",   "scan",    "search",  "choose windows",
                                            "snapshot", "groups",  "resolve", "check",
                                            "step end", "download"};
          line.print(name);
          if (steps == 0 || !on) return;
          double total = 0.0;
          for (double x : sec) total += x;
          std::fprintf(stderr, "resident profile: %ld steps after the first, %.4g ms per step",
                       steps, 1e3 * total / steps);
          for (int k = 0; k < count; ++k)
            std::fprintf(stderr, "; %s %.4g", name[k], 1e3 * sec[k] / steps);
          std::fprintf(stderr,
                       " ms; %.3g windows tried and %.3g resolve passes per step; %d arrays "
                       "page-locked, %ld steps copied x, v and tlast back whole, %ld wrote the "
                       "changed atoms into them directly\n",
                       (double) tries / steps, (double) passes / steps, locked, whole, direct);
        }
      } prof;

      void mark(int phase)
      {
        if (prof.line.on) prof.line.record(stream, Profile::Timeline::phase_end, phase);
        if (!prof.on) return;
        cuda_check(cudaStreamSynchronize(stream), "profile");
        const Clock::time_point now = Clock::now();
        prof.sec[phase] += std::chrono::duration<double>(now - prof.last).count();
        prof.last = now;
      }

      /// Scalars to the host (waits for the stream).
      const Scalars &download_scalars()
      {
        cuda_check(cudaMemcpyAsync(host_scalars, d_scalars.ptr, sizeof(Scalars),
                                   cudaMemcpyDeviceToHost, stream),
                   "cudaMemcpy(scalars)");
        wait("resident step");
        return *host_scalars;
      }

      /// Waits for the stream (the profile's timeline counts the device's idle time after it).
      void wait(const char *what)
      {
        if (prof.line.on) prof.line.record(stream, Profile::Timeline::wait_begin, 0);
        cuda_check(cudaStreamSynchronize(stream), what);
        if (prof.line.on) prof.line.record(stream, Profile::Timeline::wait_end, 0);
      }

      /// Enqueues a copy of the first `bytes` of src into dst (grown as needed).
      void fetch(const DeviceBuffer &src, PinnedBuffer &dst, size_t bytes, const char *what)
      {
        dst.reserve(bytes + 8, what);
        cuda_check(cudaMemcpyAsync(dst.ptr, src.ptr, bytes, cudaMemcpyDeviceToHost, stream), what);
      }

      void launched(const char *what) { cuda_check(cudaGetLastError(), what); }

      /// Exclusive sum of n + 1 ints (in[n] must be 0) into out, with CUB.
      void exclusive_sum(const int *in, int *out, int count)
      {
        size_t bytes = 0;
        cuda_check(cub::DeviceScan::ExclusiveSum(nullptr, bytes, in, out, count, stream),
                   "cub::DeviceScan");
        d_temp.reserve(bytes + 16, "cudaMalloc(scan scratch)");
        cuda_check(cub::DeviceScan::ExclusiveSum(d_temp.ptr, bytes, in, out, count, stream),
                   "cub::DeviceScan");
      }

      double *d_epair = nullptr;          // the restitution table, after the scalars
      double *d_fpair = nullptr;          // rough spheres: the friction table, after it
      Clock::time_point windows_start;    // when the last step's windows began

      void prepare(const Params &p);
      bool resolve_step(const ResidentBox &box, const Params &p, const WindowSettings &s,
                        Tally &total, ResidentReport &report, Clock::time_point t_start);
      bool resolve_serial(const Params &dp, Tally &total, WindowStats &stats);
      void count_changed();
      void search_cells(const ResidentBox &box);
      void search_pairs();
      bool small_box_last = false;    // the last step declined for a box of too few cells
      void fill_edges();
      void verify_groups(int ngroups, const char *where, int set);
      void try_window(double t0, double t1, double kf, double floor_fraction, int set);
      void components(int set);
      void step_end(double dt);
      void groups(int ngroups);
      void resolve_groups(const GroupGraph &graph, int ngroups, double t_end, const Params &dp,
                          long budget);
      int resident_blocks = 0;    // resolve_kernel's blocks that fit on the device at once
    };

    /* The candidate search, enqueued only: nothing here waits for the device.  search_cells()
       finds the grid from the scan's largest reach on the device (cell_kernel) and every
       start point's cell; search_pairs() the candidate pairs and their adjacency.  The host
       reads the grid, the number of candidates and the declines (a periodic length of fewer
       than three cells, a pair that overlaps) with the next download.  The pairs are written
       while they fit in edge_room (fill_edges()); where they did not, the caller makes room
       and fills them in again. */
    void CudaResidentStep::search_cells(const ResidentBox &box)
    {
      Grid g;
      for (int d = 0; d < 3; ++d) {
        g.lo[d] = box.lo[d];
        g.prd[d] = box.prd[d];
        g.periodic[d] = box.periodic[d];
        g.width[d] = 0.0;
        g.n[d] = 0;
      }
      const long cells = most_cells(n);    // the device's grid has no more
      d_key.reserve(n * sizeof(int), "cudaMalloc(cells)");
      d_val.reserve(n * sizeof(int), "cudaMalloc(cells)");
      d_key2.reserve(n * sizeof(int), "cudaMalloc(cells)");
      d_val2.reserve(n * sizeof(int), "cudaMalloc(cells)");
      d_cstart.reserve(2 * cells * sizeof(int), "cudaMalloc(cell ranges)");
      d_count.reserve((n + 1) * sizeof(int), "cudaMalloc(pair counts)");
      d_offset.reserve((n + 1) * sizeof(int), "cudaMalloc(pair counts)");
      cell_kernel<<<nblocks(n), BLOCK, 0, stream>>>(d_bodies.as<Body>(), n, g, scalars(),
                                                    d_key.as<int>(), d_val.as<int>());
      launched("cell_kernel");
    }

    void CudaResidentStep::search_pairs()
    {
      const long cells = most_cells(n);
      // Keys below `cells`: the sort by all their bits puts the bodies in the order that a
      // sort by the bits of the grid's own count does (a stable sort, the upper bits zero).
      int end_bit = 1;
      while (end_bit < 31 && (1L << end_bit) < cells) ++end_bit;
      size_t bytes = 0;
      cuda_check(cub::DeviceRadixSort::SortPairs(nullptr, bytes, d_key.as<int>(), d_key2.as<int>(),
                                                 d_val.as<int>(), d_val2.as<int>(), n, 0, end_bit,
                                                 stream),
                 "cub::DeviceRadixSort");
      d_temp.reserve(bytes + 16, "cudaMalloc(sort scratch)");
      cuda_check(cub::DeviceRadixSort::SortPairs(d_temp.ptr, bytes, d_key.as<int>(),
                                                 d_key2.as<int>(), d_val.as<int>(),
                                                 d_val2.as<int>(), n, 0, end_bit, stream),
                 "cub::DeviceRadixSort");
      // Only the grid's own cells emptied (a memset of the most there can be would write up to
      // 16 bytes per body).
      zero_cells_kernel<<<std::min(nblocks(cells), 2048), BLOCK, 0, stream>>>(scalars(), cstart(),
                                                                             cend());
      launched("zero_cells_kernel");
      d_near.reserve(n * sizeof(NearPoint), "cudaMalloc(search points)");
      d_neartag.reserve(n * sizeof(NearTag), "cudaMalloc(search points)");
      cell_range_kernel<<<nblocks(n), BLOCK, 0, stream>>>(
          d_key2.as<int>(), d_val2.as<int>(), d_bodies.as<Body>(), d_bound.as<double>(), n,
          cstart(), cend(), d_near.as<NearPoint>(), d_neartag.as<NearTag>());
      launched("cell_range_kernel");
      // The count pass also finds overlaps.
      d_stash.reserve((size_t) STASH * n * sizeof(int), "cudaMalloc(candidate stash)");
      pair_count_kernel<<<nblocks(n), BLOCK, 0, stream>>>(
          d_near.as<NearPoint>(), d_neartag.as<NearTag>(), n, d_key2.as<int>(), d_val2.as<int>(),
          cstart(), cend(), d_count.as<int>(), d_stash.as<int>(), stash_keep(), tol, scalars());
      launched("pair_count_kernel");
      exclusive_sum(d_count.as<int>(), d_offset.as<int>(), n + 1);
      fill_edges();
    }

    /* The candidate pairs that fit in edge_room into d_edges (their offsets from
       search_pairs()) and the adjacency (CSR) of those written; enqueued only. */
    void CudaResidentStep::fill_edges()
    {
      const int room = (int) edge_room;
      d_edges.reserve((size_t) room * sizeof(Edge) + 1, "cudaMalloc(candidate pairs)");
      pair_fill_kernel<<<nblocks(n), BLOCK, 0, stream>>>(
          d_near.as<NearPoint>(), d_neartag.as<NearTag>(), n, d_key2.as<int>(), d_val2.as<int>(),
          cstart(), cend(), d_stash.as<int>(), stash_keep(), d_offset.as<int>(),
          d_edges.as<Edge>(), room, scalars());
      launched("pair_fill_kernel");

      // Adjacency (CSR) of the candidates.
      d_deg.reserve((n + 1) * sizeof(int), "cudaMalloc(adjacency)");
      d_adj_start.reserve((n + 1) * sizeof(int), "cudaMalloc(adjacency)");
      d_fill.reserve((n + 1) * sizeof(int), "cudaMalloc(adjacency)");
      d_adj.reserve((size_t) 2 * room * sizeof(int) + 1, "cudaMalloc(adjacency)");
      cuda_check(cudaMemsetAsync(d_deg.ptr, 0, (n + 1) * sizeof(int), stream), "cudaMemset");
      if (room > 0) {
        degree_kernel<<<nblocks(room), BLOCK, 0, stream>>>(d_edges.as<Edge>(), nedges(),
                                                           d_deg.as<int>());
        launched("degree_kernel");
      }
      exclusive_sum(d_deg.as<int>(), d_adj_start.as<int>(), n + 1);
      cuda_check(cudaMemcpyAsync(d_fill.ptr, d_adj_start.ptr, (n + 1) * sizeof(int),
                                 cudaMemcpyDeviceToDevice, stream),
                 "cudaMemcpy(adjacency)");
      if (room > 0) {
        adjacency_kernel<<<nblocks(room), BLOCK, 0, stream>>>(d_edges.as<Edge>(), nedges(),
                                                              d_fill.as<int>(), d_adj.as<int>());
        launched("adjacency_kernel");
      }
      d_joined.reserve((size_t) room + 1, "cudaMalloc(joined flags)");
      d_joined2.reserve((size_t) room + 1, "cudaMalloc(joined flags)");
    }

    /* The window [t0, t1) set up, enqueued only: start points, bounds (floor_fraction x the
       scan's fastest speed) and joined edges (into the buffers of `set`), components(set). */
    void CudaResidentStep::try_window(double t0, double t1, double kf, double floor_fraction,
                                      int set)
    {
      window_start_kernel<<<nblocks(n, TILE), TILE, 0, stream>>>(
          d_bodies.as<Body>(), n, t0, t1 - t0, kf, floor_fraction, &scalars()->vmax2, wbound(set));
      launched("window_start_kernel");
      if (edge_threads > 0) {
        join_kernel<<<nblocks(edge_threads), BLOCK, 0, stream>>>(
            d_bodies.as<Body>(), d_edges.as<Edge>(), nedges(), wbound(set), joined(set));
        launched("join_kernel");
      }
      components(set);
    }

    /* Components of the joined edges, enqueued only: parent[] holds every body's root (its
       component's smallest index), size[] the sizes at the roots; the largest component and
       the number of components go to the scalars (Scalars::largest, ngroups); joined flags
       of `set`. */
    void CudaResidentStep::components(int set)
    {
      uf_init_kernel<<<nblocks(n), BLOCK, 0, stream>>>(d_parent.as<int>(), d_size.as<int>(),
                                                       d_fill.as<int>(), n, scalars());
      launched("uf_init_kernel");
      if (edge_threads > 0) {
        uf_unite_kernel<<<nblocks(edge_threads), BLOCK, 0, stream>>>(
            d_edges.as<Edge>(), nedges(), joined(set), d_parent.as<int>());
        launched("uf_unite_kernel");
      }
      uf_roots_kernel<<<nblocks(n), BLOCK, 0, stream>>>(d_parent.as<int>(), d_root.as<int>(),
                                                        d_size.as<int>(), n);
      launched("uf_roots_kernel");
      roots_kernel<<<nblocks(n), BLOCK, 0, stream>>>(d_root.as<int>(), d_size.as<int>(), n,
                                                     d_isroot.as<int2>(), scalars());
      launched("roots_kernel");
    }

    /* The groups of the last components(): numbered in root order, members placed. */
    void CudaResidentStep::groups(int ngroups)
    {
      // Group numbers and offsets in one scan of (root flag, size) pairs.
      size_t bytes = 0;
      const int2 none = make_int2(0, 0);
      cuda_check(cub::DeviceScan::ExclusiveScan(nullptr, bytes, d_isroot.as<int2>(),
                                                d_goff.as<int2>(), Int2Add(), none, n + 1, stream),
                 "cub::DeviceScan");
      d_temp.reserve(bytes + 16, "cudaMalloc(scan scratch)");
      cuda_check(cub::DeviceScan::ExclusiveScan(d_temp.ptr, bytes, d_isroot.as<int2>(),
                                                d_goff.as<int2>(), Int2Add(), none, n + 1, stream),
                 "cub::DeviceScan");
      members_kernel<<<nblocks(n), BLOCK, 0, stream>>>(
          d_root.as<int>(), d_goff.as<int2>(), n, ngroups, d_gstart.as<int>(), d_fill.as<int>(),
          d_gmembers.as<int>(), scalars());
      launched("members_kernel");
    }

    /* The groups of the last groups() resolved up to t_end: those of two or more bodies by
       warps (as many as fit on the device, each taking the next group), the single bodies by
       threads; their tallies into d_sums, in the order of d_order (a partition of the groups,
       the larger ones first). */
    void CudaResidentStep::resolve_groups(const GroupGraph &graph, int ngroups, double t_end,
                                          const Params &dp, long budget)
    {
      d_order.reserve((size_t) ngroups * sizeof(int) + 8, "cudaMalloc(group order)");
      size_t bytes = 0;
      const thrust::counting_iterator<int> ids(0);
      // Tuning aid: HSGPU_RESIDENT_SMALL=n, the largest group resolved by one thread.
      static const int small = (int) env_number("HSGPU_RESIDENT_SMALL", SMALL_GROUP);
      const IsLarge multi{d_gstart.as<int>(), small};
      cuda_check(cub::DevicePartition::If(nullptr, bytes, ids, d_order.as<int>(),
                                          &scalars()->nmulti, ngroups, multi, stream),
                 "cub::DevicePartition");
      d_temp.reserve(bytes + 16, "cudaMalloc(partition scratch)");
      cuda_check(cub::DevicePartition::If(d_temp.ptr, bytes, ids, d_order.as<int>(),
                                          &scalars()->nmulti, ngroups, multi, stream),
                 "cub::DevicePartition");
      if (resident_blocks == 0) {
        int per_sm = 0, sms = 0;
        cuda_check(
            cudaOccupancyMaxActiveBlocksPerMultiprocessor(&per_sm, resolve_kernel, GROUP_BLOCK, 0),
            "cudaOccupancyMaxActiveBlocksPerMultiprocessor");
        cuda_check(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, device),
                   "cudaDeviceGetAttribute");
        resident_blocks = std::max(1, per_sm * sms);
      }
      const int warp_blocks = std::min(resident_blocks, nblocks(32L * ngroups, GROUP_BLOCK));
      // The two kernels touch disjoint groups (bodies, best events, tallies): the small groups
      // run on the side stream while the larger groups' warps finish their longest loops.
      static const bool use_side = env_number("HSGPU_RESIDENT_SIDE", 1.0) != 0.0;
      cudaStream_t two = use_side ? side : stream;
      cuda_check(cudaEventRecord(ev_fork, stream), "cudaEventRecord");
      cuda_check(cudaStreamWaitEvent(side, ev_fork, 0), "cudaStreamWaitEvent");
      // The larger groups' edge times, kept by their warps (HSGPU_RESIDENT_EDGE_TIMES=0, a
      // tuning aid: each best event from its edges' pair times found again).
      static const bool edge_times = env_number("HSGPU_RESIDENT_EDGE_TIMES", 1.0) != 0.0;
      double *et = nullptr;
      if (edge_times && ne > 0) {
        d_etime.reserve((size_t) ne * sizeof(double) + 8, "cudaMalloc(edge times)");
        et = d_etime.as<double>();
        edge_times_kernel<<<nblocks(ne), BLOCK, 0, stream>>>(
            graph, d_root.as<int>(), d_size.as<int>(), scalars(), small, dp, et);
        launched("edge_times_kernel");
      }
      first_bests_kernel<<<nblocks(n), BLOCK, 0, stream>>>(graph, d_root.as<int>(),
                                                          d_size.as<int>(), n, small, dp, et);
      launched("first_bests_kernel");
      resolve_kernel<<<warp_blocks, GROUP_BLOCK, 0, stream>>>(
          graph, d_gstart.as<int>(), d_gmembers.as<int>(), d_order.as<int>(), t_end, dp, budget,
          scalars(), d_sums.as<WinSum>(), et);
      launched("resolve_kernel");
      resolve_single_kernel<<<std::min(nblocks(ngroups), 16 * resident_blocks), BLOCK, 0, two>>>(
          graph, d_gstart.as<int>(), d_gmembers.as<int>(), d_order.as<int>(), ngroups, t_end, dp,
          budget, scalars(), d_sums.as<WinSum>());
      launched("resolve_single_kernel");
      cuda_check(cudaEventRecord(ev_join, side), "cudaEventRecord");
      cuda_check(cudaStreamWaitEvent(stream, ev_join, 0), "cudaStreamWaitEvent");
    }

    /* Debugging aid (HSGPU_RESIDENT_VERIFY=1): the groups on the host, checked against the
       joined edges. */
    void CudaResidentStep::verify_groups(int ngroups, const char *where, int set)
    {
      std::vector<int> parent(n), gstart(ngroups + 1), gmembers(n);
      std::vector<unsigned char> joined(ne);
      std::vector<Edge> edges(ne);
      cuda_check(cudaStreamSynchronize(stream), "verify");
      cudaMemcpy(parent.data(), d_root.ptr, n * sizeof(int), cudaMemcpyDeviceToHost);
      cudaMemcpy(gstart.data(), d_gstart.ptr, (ngroups + 1) * sizeof(int), cudaMemcpyDeviceToHost);
      cudaMemcpy(gmembers.data(), d_gmembers.ptr, n * sizeof(int), cudaMemcpyDeviceToHost);
      cudaMemcpy(joined.data(), this->joined(set), ne, cudaMemcpyDeviceToHost);
      cudaMemcpy(edges.data(), d_edges.ptr, ne * sizeof(Edge), cudaMemcpyDeviceToHost);
      std::vector<int> group_of(n, -1);
      int bad = 0;
      for (int g = 0; g < ngroups; ++g)
        for (int m = gstart[g]; m < gstart[g + 1]; ++m) {
          if (group_of[gmembers[m]] >= 0) ++bad;
          group_of[gmembers[m]] = g;
        }
      for (int b = 0; b < n; ++b)
        if (group_of[b] < 0) ++bad;
      int cross = 0;
      for (int q = 0; q < ne; ++q)
        if (joined[q] && group_of[edges[q].i] != group_of[edges[q].j]) ++cross;
      if (bad || cross || gstart[ngroups] != n)
        std::fprintf(stderr,
                     "resident verify (%s): %d misplaced bodies, %d joined edges across groups, "
                     "end %d of %d\n",
                     where, bad, cross, gstart[ngroups], n);
    }

    /* Buffers for n bodies, the restitution table on the device. */
    void CudaResidentStep::prepare(const Params &p)
    {
      const size_t ntypes2 = (size_t) (p.ntypes + 1) * (p.ntypes + 1);
      d_bodies.reserve(n * sizeof(Body), "cudaMalloc(bodies)");
      d_snap.reserve(n * sizeof(Body), "cudaMalloc(bodies)");
      d_best.reserve(n * sizeof(Event), "cudaMalloc(best events)");
      d_sums.reserve(n * sizeof(WinSum), "cudaMalloc(group tallies)");
      const size_t ntables = p.friction ? 3 * ntypes2 : ntypes2;    // + mu, beta0 per pair
      d_scalars.reserve(sizeof(Scalars) + ntables * sizeof(double), "cudaMalloc(scalars)");
      for (DeviceBuffer *b : {&d_bound, &d_wbound, &d_wbound2, &d_lexc})
        b->reserve(n * sizeof(double), "cudaMalloc(bounds)");
      for (DeviceBuffer *b : {&d_parent, &d_root, &d_size, &d_gid, &d_gstart, &d_gmembers})
        b->reserve((n + 1) * sizeof(int), "cudaMalloc(groups)");
      // (root flag, size) pairs and their scan (roots_kernel, groups()).
      for (DeviceBuffer *b : {&d_isroot, &d_goff})
        b->reserve((n + 1) * sizeof(int2), "cudaMalloc(groups)");
      // The restitution table lives after the scalars.
      d_epair = reinterpret_cast<double *>(d_scalars.as<char>() + sizeof(Scalars));
      cuda_check(cudaMemcpyAsync(d_epair, p.epair, ntypes2 * sizeof(double), cudaMemcpyHostToDevice,
                                 stream),
                 "cudaMemcpy(restitution table)");
      d_fpair = nullptr;
      if (p.friction) {
        d_fpair = d_epair + ntypes2;
        cuda_check(cudaMemcpyAsync(d_fpair, p.fpair, 2 * ntypes2 * sizeof(double),
                                   cudaMemcpyHostToDevice, stream),
                   "cudaMemcpy(friction table)");
      }
    }

    /* The step of the n bodies in d_bodies with their step bounds in d_bound: search, windows,
       the step's check.  Returns false where it declines (report.outcome says why); else the
       bodies are at the step end on the device and `total` holds the events. */
    bool CudaResidentStep::resolve_step(const ResidentBox &box, const Params &p,
                                        const WindowSettings &s, Tally &total,
                                        ResidentReport &report, Clock::time_point t_start)
    {
      cuda_check(cudaMemsetAsync(d_scalars.ptr, 0, sizeof(Scalars), stream), "cudaMemset");
      Params dp = p;
      dp.epair = d_epair;
      dp.fpair = d_fpair;
      step_missed = false;
      const WindowChooser chooser_at_start = chooser;
      const double dt = p.dt;
      // Tuning aids: HSGPU_RESIDENT_KF and HSGPU_RESIDENT_FLOOR set the window bounds' factor
      // and floor fraction (WindowSettings).
      static const double kf_env = env_number("HSGPU_RESIDENT_KF", 0.0);
      static const double floor_env = env_number("HSGPU_RESIDENT_FLOOR", 0.0);
      // The device's default floor is half the fastest speed (the host driver's a quarter): a
      // repair here resolves the whole window again, and with the wider bounds fewer are
      // needed (measured on an H100: 0.5 against 0.25 is 15-20% faster at N = 65536 and 1e6;
      // 0.4, 0.6 and 0.75 in between).  The windows never change a result bit.  The fastest
      // speed is the scan's, on the device (window_start_kernel).
      const double bound_factor = kf_env > 0.0 ? kf_env : s.bound_factor;
      const double floor_fraction = floor_env > 0.0 ? floor_env : floor_fraction_or(s, 0.5);
      // Tuning aid: HSGPU_RESIDENT_TARGET=n sets the largest group the windows aim at.
      static const long target_env = (long) env_number("HSGPU_RESIDENT_TARGET", 0.0);
      // The device's own default (the windows never change a result bit): largest groups of
      // max(256, n / 1024) bodies, smaller than the host's max(256, n / 128), as the device
      // resolves many more groups at once (measured: 256 ... 1024 within 1% at N = 1e6, 7%
      // faster than the host's default).
      const long target = target_env > 0       ? target_env
                          : s.target_group > 0 ? s.target_group
                                               : std::max(256L, (long) n / 1024);
      // Tuning aid: HSGPU_RESIDENT_GROW=g, how much longer than the last window the next one
      // starts.
      static const double grow_env = env_number("HSGPU_RESIDENT_GROW", 2.0);
      chooser.set_growth(grow_env);
      chooser.start_step(dt);

      /* One wait for the scan, the search and the first window the chooser will try: the
         grid is worked out on the device, the edges written into room for a quarter more
         than the last step had, and the window set up ahead (the chooser's first_end()).
         The declines are then read in the order of their checks. */
      scan_bodies_kernel<<<nblocks(n, TILE), TILE, 0, stream>>>(
          d_bodies.as<Body>(), d_bound.as<double>(), n, p.walls, tol, scalars());
      launched("scan_bodies_kernel");
      mark(Profile::scan);
      auto decline_early = [&](ResidentOutcome o) {
        chooser = chooser_at_start;
        report.outcome = o;
        small_box_last = o == ResidentOutcome::small_box;
        return false;
      };
      search_cells(box);
      if (small_box_last) {
        // The last step's box held too few cells (a thin periodic slab: it may every step):
        // this one waits for its grid before it searches.
        const Scalars &g = download_scalars();
        if (g.overlap) return decline_early(ResidentOutcome::overlap);    // a wall
        if (g.small_box) return decline_early(ResidentOutcome::small_box);
      }
      if (edge_room <= 0) edge_room = 2L * n + 1024;    // the first step: a guess
      search_pairs();
      edge_threads = edge_room;
      double t_first = serial ? dt : chooser.first_end(0.0, 0, dt, s);
      if (!serial) try_window(0.0, t_first, bound_factor, floor_fraction, 0);
      Scalars sc = download_scalars();
      if (sc.overlap) return decline_early(ResidentOutcome::overlap);    // a wall
      if (sc.small_box) return decline_early(ResidentOutcome::small_box);
      if (sc.pair_overlap) return decline_early(ResidentOutcome::overlap);
      if (sc.candidates > edge_room) {
        // More than the room: the edges again with enough (the same ones), and the window.
        edge_room = (long) sc.candidates + sc.candidates / 4 + 1024;
        fill_edges();
        edge_threads = edge_room;
        if (!serial) try_window(0.0, t_first, bound_factor, floor_fraction, 0);
        sc = download_scalars();
      }
      small_box_last = false;
      ne = sc.candidates;
      edge_threads = ne;
      report.candidates = ne;
      grid = sc.grid;
      // The next step's room: a quarter more than this one's pairs.
      edge_room = (long) ne + ne / 4 + 1024;
      // A window set up ahead, the chooser's first try for window first_k, try_window(t0,
      // t_first): its largest group and groups.  The first window's was set up above; each
      // later one's is set up with the check of the window before it.
      bool first_ready = !serial;
      int first_k = 0;
      long first_largest = sc.largest;
      int first_ngroups = sc.ngroups;
      mark(Profile::search);
      report.t_search = seconds_since(t_start);
      windows_start = Clock::now();
      const auto t_windows = windows_start;

      WindowStats &stats = report.stats;
      double t0 = 0.0;
      int k = 0;
      auto decline = [&](ResidentOutcome o) {
        chooser = chooser_at_start;
        report.outcome = o;
        report.t_resolve = seconds_since(t_windows);
      };
      if (serial) {
        if (!resolve_serial(dp, total, stats)) {
          decline(ResidentOutcome::capped);
          return false;
        }
        mark(Profile::resolve);
      }
      // The step's end (end_kernel, count_changed()) is enqueued with the last window's check,
      // the next window's first try with the check of any other, and read in the same
      // download; a repair after it takes the bodies back to the snapshot (and recomputes the
      // components from this window's joined flags, the other set's are the next window's),
      // and the end or the next window's try is enqueued again with the next check.
      bool ended = false;
      while (!serial && t0 < dt) {
        long largest;
        int ngroups = 0;
        const int set = k % 2;    // this window's bounds and joined flags
        auto try_end = [&](double t1) -> long {
          ++prof.tries;
          if (first_ready && first_k == k && t1 == t_first) {    // set up ahead
            first_ready = false;
            ngroups = first_ngroups;
            return first_largest;
          }
          first_ready = false;    // the device now holds another window
          try_window(t0, t1, bound_factor, floor_fraction, set);
          const Scalars &c = download_scalars();
          ngroups = c.ngroups;
          return c.largest;
        };
        const double t1 = chooser.next(t0, k, dt, s, target, try_end, largest);
        first_ready = false;
        const GroupGraph graph{d_bodies.as<Body>(), d_edges.as<Edge>(), d_adj_start.as<int>(),
                               d_adj.as<int>(),     d_best.as<Event>(), joined(set)};
        mark(Profile::choose);
        cuda_check(cudaMemcpyAsync(d_snap.ptr, d_bodies.ptr, n * sizeof(Body),
                                   cudaMemcpyDeviceToDevice, stream),
                   "cudaMemcpy(snapshot)");
        mark(Profile::snapshot);
        const long budget = p.maxevents - total.events;
        const bool last = !(t1 < dt);    // the loop's end
        // The next window's first try (the chooser's state is the next window's now).
        const double t_next = last ? dt : chooser.first_end(t1, k + 1, dt, s);
        WinSum win;
        static const bool verify = std::getenv("HSGPU_RESIDENT_VERIFY") != nullptr;
        while (true) {
          groups(ngroups);
          if (verify) verify_groups(ngroups, "window", set);
          mark(Profile::groups);
          resolve_groups(graph, ngroups, t1, dp, budget);
          ++prof.passes;
          mark(Profile::resolve);
          size_t bytes = 0;
          const WinSum zero_sum{};
          cuda_check(cub::DeviceReduce::Reduce(nullptr, bytes, d_sums.as<WinSum>(), &scalars()->win,
                                               ngroups, WinSumAdd(), zero_sum, stream),
                     "cub::DeviceReduce");
          d_temp.reserve(bytes + 16, "cudaMalloc(reduce scratch)");
          cuda_check(cub::DeviceReduce::Reduce(d_temp.ptr, bytes, d_sums.as<WinSum>(),
                                               &scalars()->win, ngroups, WinSumAdd(), zero_sum,
                                               stream),
                     "cub::DeviceReduce");
          excursion_kernel<<<nblocks(n, TILE), TILE, 0, stream>>>(d_bodies.as<Body>(), n, t1,
                                                                  d_lexc.as<double>(), scalars());
          launched("excursion_kernel");
          if (ne > 0) {
            missed_kernel<<<nblocks(ne), BLOCK, 0, stream>>>(
                d_bodies.as<Body>(), d_edges.as<Edge>(), wbound(set), d_lexc.as<double>(),
                joined(set), scalars());
            launched("missed_kernel");
          }
          // Ahead of the check, undone by a repair: the step's end, or the next window's first
          // try (into the other set of bounds and flags).
          if (last)
            step_end(dt);
          else
            try_window(t1, t_next, bound_factor, floor_fraction, 1 - set);
          const Scalars &r = download_scalars();
          mark(Profile::check);
          win = r.win;
          if (win.capped || win.events > budget) {
            decline(ResidentOutcome::capped);
            return false;
          }
          if (r.missed == 0) {
            ended = last;
            if (!last) {    // the next window's first try came back with the check
              first_ready = true;
              first_k = k + 1;
              t_first = t_next;
              first_largest = r.largest;
              first_ngroups = r.ngroups;
            }
            break;
          }
          // Joined pairs that could have touched: the window again from its start.
          stats.repairs += r.missed;
          cuda_check(cudaMemcpyAsync(d_bodies.ptr, d_snap.ptr, n * sizeof(Body),
                                     cudaMemcpyDeviceToDevice, stream),
                     "cudaMemcpy(snapshot back)");
          components(set);
          const Scalars &c = download_scalars();
          largest = std::max(largest, (long) c.largest);
          ngroups = c.ngroups;
          mark(Profile::check);
        }
        Tally wt;
        wt.pair = win.pair;
        wt.wall = win.wall;
        wt.rest = win.rest;
        wt.events = win.events;
        wt.ke_lost = win.ke_lost;
        for (int c = 0; c < 6; ++c) wt.virial[c] = win.virial[c];
        total.add(wt);
        stats.largest_group = std::max(stats.largest_group, largest);
        stats.groups += win.groups;
        ++k;
        t0 = t1;
      }
      if (!serial) stats.windows = k;
      mark(Profile::end);

      if (!ended) {    // order serial (or a loop that ended without its last window's check)
        step_end(dt);
        download_scalars();
      }
      // count_changed()'s number (Scalars::changed) came back with the step's check.
      const EndSums es = host_scalars->end;
      std::memcpy(&report.vend2, &es.vend2, sizeof(double));
      if (es.excursion > 0) {
        double maxexc, rmax;
        std::memcpy(&maxexc, &es.maxexc, sizeof(double));
        std::memcpy(&rmax, &sc.rmax, sizeof(double));
        // Past the reach the caller's ghosts cover: the caller stops the run.
        if (maxexc > box.reach) {
          decline(ResidentOutcome::excursion);
          return false;
        }
        step_check_kernel<<<nblocks(n), BLOCK, 0, stream>>>(
            d_near.as<NearPoint>(), d_neartag.as<NearTag>(), d_bound.as<double>(),
            d_lexc.as<double>(), n, grid, d_key2.as<int>(), d_val2.as<int>(), cstart(), cend(),
            maxexc, rmax, tol, scalars());
        launched("step_check_kernel");
        if (download_scalars().end.missed_step) {
          decline(ResidentOutcome::excursion);
          step_missed = true;
          return false;
        }
      }
      mark(Profile::end);
      ++prof.steps;
      return true;
    }

    /* The step's end, enqueued only: end_kernel (excursions to dt, the step's check sums into
       Scalars::end, zeroed here) and count_changed(). */
    void CudaResidentStep::step_end(double dt)
    {
      cuda_check(cudaMemsetAsync(&scalars()->end, 0, sizeof(EndSums), stream), "cudaMemset");
      end_kernel<<<nblocks(n, TILE), TILE, 0, stream>>>(
          d_bodies.as<Body>(), n, dt, d_bound.as<double>(), d_lexc.as<double>(), scalars());
      launched("end_kernel");
      count_changed();
    }

    /* Order serial (serial_loop.cuh): the step's events one globally earliest at a time, the
       iterations launched ahead in a CUDA graph of SERIAL_ITERATIONS each, the stream waited
       for between graphs.  Returns false where maxevents stops the step. */
    bool CudaResidentStep::resolve_serial(const Params &dp, Tally &total, WindowStats &stats)
    {
      using namespace SerialLoop;
      constexpr int SERIAL_ITERATIONS = 64;
      const double dt = dp.dt;
      // One window, the step: start points and window excursions as the host's serial order.
      window_start_kernel<<<nblocks(n, TILE), TILE, 0, stream>>>(
          d_bodies.as<Body>(), n, 0.0, dt, 1.0, 0.0, nullptr, d_wbound.as<double>());
      launched("window_start_kernel");
      const GroupGraph graph{d_bodies.as<Body>(), d_edges.as<Edge>(), d_adj_start.as<int>(),
                             d_adj.as<int>(),     d_best.as<Event>(), nullptr};
      init_kernel<<<nblocks(n), BLOCK, 0, stream>>>(graph, dp, n);
      launched("serial init_kernel");
      const int nparts = nblocks(n, SerialLoop::BLOCK);
      d_part.reserve((size_t) nparts * sizeof(WarpLoop::Candidate), "cudaMalloc(serial minima)");
      d_control.reserve(sizeof(Control), "cudaMalloc(serial control)");
      cuda_check(cudaMemsetAsync(d_control.ptr, 0, sizeof(Control), stream), "cudaMemset");
      Control *ctl = d_control.as<Control>();
      WarpLoop::Candidate *part = d_part.as<WarpLoop::Candidate>();
      // The graph is captured again only where its kernels' arguments changed.
      std::vector<char> key;
      auto add_key = [&key](const void *a, size_t bytes) {
        key.insert(key.end(), (const char *) a, (const char *) a + bytes);
      };
      add_key(&graph, sizeof(graph));
      add_key(&dp, sizeof(dp));
      add_key(&n, sizeof(n));
      add_key(&ctl, sizeof(ctl));
      add_key(&part, sizeof(part));
      if (!serial_exec || key != serial_key) {
        if (serial_exec) cudaGraphExecDestroy(serial_exec);
        serial_exec = nullptr;
        serial_key.clear();
        cudaGraph_t g = nullptr;
        cuda_check(cudaStreamBeginCapture(stream, cudaStreamCaptureModeThreadLocal),
                   "cudaStreamBeginCapture");
        for (int it = 0; it < SERIAL_ITERATIONS; ++it) {
          min_kernel<<<nparts, SerialLoop::BLOCK, 0, stream>>>(d_best.as<Event>(), n, ctl, part);
          event_kernel<<<1, 32, 0, stream>>>(graph, dp, part, nparts, dt, dp.maxevents, ctl);
        }
        cuda_check(cudaStreamEndCapture(stream, &g), "cudaStreamEndCapture");
        const cudaError_t made = cudaGraphInstantiate(&serial_exec, g, 0);
        cudaGraphDestroy(g);
        if (made != cudaSuccess) serial_exec = nullptr;
        cuda_check(made, "cudaGraphInstantiate");
        serial_key = key;
      }
      Control c;
      do {
        cuda_check(cudaGraphLaunch(serial_exec, stream), "cudaGraphLaunch");
        fetch(d_control, host_control, sizeof(Control), "cudaMemcpy(serial control)");
        cuda_check(cudaStreamSynchronize(stream), "order serial");
        c = *host_control.as<Control>();
      } while (!c.done);
      if (c.tally.capped) return false;
      total.add(c.tally);
      stats.windows = 1;
      stats.groups = 1;
      stats.largest_group = n;
      return true;
    }

    /* The bodies that had events, numbered in body order: d_offset[b] is body b's slot among
       them (an exclusive sum of changed_kernel's flags).  Enqueued only: their number comes
       back in the scalars (Scalars::changed) with the next download. */
    void CudaResidentStep::count_changed()
    {
      changed_kernel<<<nblocks(n), BLOCK, 0, stream>>>(d_bodies.as<Body>(), n, d_count.as<int>());
      launched("changed_kernel");
      exclusive_sum(d_count.as<int>(), d_offset.as<int>(), n + 1);
      cuda_check(cudaMemcpyAsync(&scalars()->changed, d_offset.as<int>() + n, sizeof(int),
                                 cudaMemcpyDeviceToDevice, stream),
                 "cudaMemcpy(changed)");
    }

    void CudaResidentStep::run(Body *bodies, const double *bound, int nbodies,
                               const ResidentBox &box, const Params &p, const WindowSettings &s,
                               Tally &tally, ResidentReport &report)
    {
      const auto t_start = std::chrono::steady_clock::now();
      report = ResidentReport();
      n = nbodies;
      if (n <= 0) return;
      tol = box.overlap_tol;
      cuda_check(cudaSetDevice(device), "cudaSetDevice");
      (void) cudaGetLastError();

      prepare(p);
      cuda_check(
          cudaMemcpyAsync(d_bodies.ptr, bodies, n * sizeof(Body), cudaMemcpyHostToDevice, stream),
          "cudaMemcpy(bodies)");
      cuda_check(
          cudaMemcpyAsync(d_bound.ptr, bound, n * sizeof(double), cudaMemcpyHostToDevice, stream),
          "cudaMemcpy(bounds)");
      cuda_check(cudaStreamSynchronize(stream), "cudaMemcpy(bodies)");
      report.t_upload = seconds_since(t_start);
      prof.last = t_start;
      mark(Profile::upload);
      Tally total;
      if (!resolve_step(box, p, s, total, report, t_start)) return;
      const auto t_windows = windows_start;
      // Only the bodies that had events come back (the others' drift lines did not change).
      const auto t_down = std::chrono::steady_clock::now();
      const int changed = host_scalars->changed;    // count_changed()'s
      compact_kernel<<<nblocks(n), BLOCK, 0, stream>>>(d_bodies.as<Body>(), n, d_offset.as<int>(),
                                                       d_snap.as<Body>(), d_gid.as<int>());
      launched("compact_kernel");
      fetch(d_snap, host_changed, changed * sizeof(Body), "cudaMemcpy(bodies back)");
      fetch(d_gid, host_index, changed * sizeof(int), "cudaMemcpy(bodies back)");
      cuda_check(cudaStreamSynchronize(stream), "cudaMemcpy(bodies back)");
      const Body *back = host_changed.as<Body>();
      const int *index = host_index.as<int>();
      for (int k = 0; k < changed; ++k) bodies[index[k]] = back[k];
      report.changed = changed;
      report.t_download = seconds_since(t_down);
      mark(Profile::download);
      prof.end_step();
      tally.add(total);
      report.t_resolve = seconds_since(t_windows);
    }

    /* The results of run_atoms() into the caller's arrays (its tail, or deliver_atoms() where
       they were deferred): every atom's tlast, and the changed atoms' x and v (and omega). */
    void CudaResidentStep::write_back(const Later &w)
    {
      const ResidentAtoms &a = w.a;
      const int changed = w.changed;
      const bool spin = w.spin, keep_motion = w.keep_motion;
      const size_t n3 = (size_t) 3 * n * sizeof(double), n1 = (size_t) n * sizeof(double);
      double *d_rsp = spin ? d_rspin.as<double>() : nullptr;
      double *d_spin = spin ? d_aomega.as<double>() : nullptr;
      // Every atom's time of last collision comes back whole (8 bytes per atom), by the copy
      // engine on the side stream while the changed atoms go back on this one.
      cuda_check(cudaEventRecord(ev_fork, stream), "cudaEventRecord");
      cuda_check(cudaStreamWaitEvent(side, ev_fork, 0), "cudaStreamWaitEvent");
      cuda_check(cudaMemcpyAsync(a.tlast, d_atlast.ptr, n1, cudaMemcpyDeviceToHost, side),
                 "cudaMemcpy(tlast)");
      cuda_check(cudaEventRecord(ev_join, side), "cudaEventRecord");
      // Many atoms changed and the arrays are page-locked: writing the changed atoms into the
      // device copies of x, v and tlast and copying those back whole costs less than the
      // host's scattered writes (which touch most cache lines of the arrays anyway).  The
      // other atoms get their own bytes back.
      static const bool scatter = std::getenv("HSGPU_RESIDENT_SCATTER") != nullptr;
      const bool whole = !a.results && !scatter && changed > n / 32 && locked[0].p && locked[1].p;
      // Or the device writes the changed atoms straight into the page-locked arrays (mapped
      // into its address space): only their bytes cross the link (HSGPU_RESIDENT_DIRECT=0: the
      // whole copies).
      static const bool direct = env_number("HSGPU_RESIDENT_DIRECT", 1.0) != 0.0;
      double *hx = whole && !spin && direct ? locked[0].device_address(a.x) : nullptr;
      double *hv = hx ? locked[1].device_address(a.v) : nullptr;
      if (hx && hv) {
        ++prof.direct;
        if (changed > 0) {
          atom_write_direct_kernel<<<nblocks(6L * changed), BLOCK, 0, stream>>>(
              d_sums.as<AtomResult>(), changed, hx, hv,
              keep_motion ? d_ax.as<double>() : nullptr, keep_motion ? d_av.as<double>() : nullptr);
          launched("atom_write_direct_kernel");
        }
      } else if (whole) {
        ++prof.whole;
        if (changed > 0) {
          atom_write_kernel<<<nblocks(changed), BLOCK, 0, stream>>>(
              d_sums.as<AtomResult>(), d_rsp, changed, d_ax.as<double>(), d_av.as<double>(),
              d_spin);
          launched("atom_write_kernel");
        }
        cuda_check(cudaMemcpyAsync(a.x, d_ax.ptr, n3, cudaMemcpyDeviceToHost, stream),
                   "cudaMemcpy(x)");
        cuda_check(cudaMemcpyAsync(a.v, d_av.ptr, n3, cudaMemcpyDeviceToHost, stream),
                   "cudaMemcpy(v)");
        if (spin)
          cuda_check(cudaMemcpyAsync(a.omega, d_aomega.ptr, n3, cudaMemcpyDeviceToHost, stream),
                     "cudaMemcpy(omega)");
      }
      if (!whole && keep_motion && changed > 0) {
        // The host writes the changed atoms; the kept copies get them here.
        atom_write_kernel<<<nblocks(changed), BLOCK, 0, stream>>>(
            d_sums.as<AtomResult>(), nullptr, changed, d_ax.as<double>(), d_av.as<double>(),
            nullptr);
        launched("atom_write_kernel");
      }
      cuda_check(cudaStreamWaitEvent(stream, ev_join, 0), "cudaStreamWaitEvent");
      if (whole) {
        wait("cudaMemcpy(atoms back)");    // (or the direct writes)
      } else {
        // Room for a quarter of the atoms at once, so that the buffer rarely grows.
        host_results.reserve(std::max((size_t) changed, (size_t) n / 4) * sizeof(AtomResult),
                             "cudaMallocHost(atom results)");
        fetch(d_sums, host_results, changed * sizeof(AtomResult), "cudaMemcpy(atom results)");
        if (spin) {
          host_rspin.reserve(std::max((size_t) changed, (size_t) n / 4) * 3 * sizeof(double),
                             "cudaMallocHost(atom results)");
          fetch(d_rspin, host_rspin, (size_t) changed * 3 * sizeof(double),
                "cudaMemcpy(atom results)");
        }
        wait("cudaMemcpy(atom results)");
        const double *w = host_rspin.as<double>();
        if (a.results) {
          // The caller takes the results as they are.
          const AtomResult *r = host_results.as<AtomResult>();
          a.results->assign(r, r + changed);
          if (spin && a.result_spin) a.result_spin->assign(w, w + 3 * (size_t) changed);
        }
        for (int k = 0; k < changed && !a.results; ++k) {
          const AtomResult &r = host_results.as<AtomResult>()[k];
          for (int d = 0; d < 3; ++d) {
            a.x[3 * r.index + d] = r.x[d];
            a.v[3 * r.index + d] = r.v[d];
          }
          if (spin)
            for (int d = 0; d < 3; ++d) a.omega[3 * r.index + d] = w[3 * k + d];
        }
      }
    }

    void CudaResidentStep::run_atoms(const ResidentAtoms &a, const ResidentBox &box,
                                     const Params &p, const WindowSettings &s, Tally &tally,
                                     ResidentReport &report)
    {
      const auto t_start = Clock::now();
      if (prof.line.on) prof.line.record(stream, Profile::Timeline::start, 0);
      report = ResidentReport();
      later = Later();    // an undelivered step's results are dropped
      n = a.n;
      if (n <= 0) return;
      tol = box.overlap_tol;
      cuda_check(cudaSetDevice(device), "cudaSetDevice");
      (void) cudaGetLastError();
      prepare(p);
      auto up = [&](DeviceBuffer &d, const void *h, size_t bytes) {
        d.reserve(bytes + 8, "cudaMalloc(atoms)");
        cuda_check(cudaMemcpyAsync(d.ptr, h, bytes, cudaMemcpyHostToDevice, stream),
                   "cudaMemcpy(atoms)");
      };
      const size_t n3 = (size_t) 3 * n * sizeof(double), n1 = (size_t) n * sizeof(double);
      // The arrays are page-locked where they lie, so that they move at the pinned rate.
      const size_t ni = (size_t) n * sizeof(int), nid = (size_t) n * a.id_bytes;
      const struct {
        DeviceBuffer &d;
        const void *h;
        size_t bytes;
      } arrays[NLOCKED] = {{d_ax, a.x, n3},         {d_av, a.v, n3},        {d_af, a.f, n3},
                           {d_atlast, a.tlast, n1}, {d_arad, a.radius, n1}, {d_amass, a.rmass, n1},
                           {d_atype, a.type, ni},   {d_aid, a.id, nid}};
      prof.locked = 0;
      // tlast, radius, rmass, type and id stay on the device between steps where the caller
      // vouches for them and they lie where they lay (no exchange, sort or host step since).
      bool keep = a.same_atoms && kept;
      for (int k = FIRST_KEPT; k < NLOCKED; ++k)
        keep = keep && kept_host[k] == arrays[k].h && kept_bytes[k] == arrays[k].bytes;
      kept = false;    // until this step is done
      // x and v: copied up, or the copies kept from the last step moved as LAMMPS's
      // integrator moved the caller's since (ResidentAtoms::motion).
      const KeptMotion &m = a.motion;
      const bool own = !a.results && !a.inputs_shared && !(p.friction && a.omega);
      // The step's end state stays in d_ax, d_av (the results written in): kept copies for
      // the next step (own arrays), or for get_atoms() (listed results).
      const bool keep_motion = m.keep && !(p.friction && a.omega);
      state_kept = false;
      report.motion = motion_begin(a, own);
      const bool moved = report.motion == MotionUse::predict;
      const bool check = report.motion == MotionUse::check;
      // advance: x and v come up (or lie in the shared buffers) and are moved here.
      const bool advance = report.motion == MotionUse::advance;
      // A step run ahead never reads the caller's x and v (LAMMPS may be integrating them):
      // without copies to move it does nothing, and the caller sees report.motion.
      if (a.defer_writes && !moved) return;
      if (check) {
        // The kept copies aside (the buffers traded, nothing copied), before x and v come up.
        d_kx.swap(d_ax);
        d_kv.swap(d_av);
      }
      cuda_check(cudaEventRecord(ev_up0, stream), "cudaEventRecord");
      for (int k = 0; k < NLOCKED; ++k) {
        if (k == 2 && a.zero_forces) {    // no forces: zeros, not copied
          // (Where the buffers are shared, share_inputs() sized them: no new allocation.)
          if (!a.inputs_shared) arrays[k].d.reserve(arrays[k].bytes + 8, "cudaMalloc(atoms)");
          cuda_check(cudaMemsetAsync(arrays[k].d.ptr, 0, arrays[k].bytes, stream), "cudaMemset");
          continue;
        }
        if (a.inputs_shared && k < FIRST_KEPT) continue;    // x, v, f: in place already
        if (a.statics_shared && k >= FIRST_KEPT) continue;  // the rest: in place already
        locked[k].keep(arrays[k].h, arrays[k].bytes, locking);
        if (locked[k].p) ++prof.locked;
        if (keep && k >= FIRST_KEPT) continue;
        if (moved && k < 2) continue;    // x, v: the kept copies, moved below
        up(arrays[k].d, arrays[k].h, arrays[k].bytes);
        report.bytes_up += (long) arrays[k].bytes;
      }
      // Rough spheres: the angular velocities, every step (other fixes may change them).
      const bool spin = p.friction && a.omega;
      if (spin && a.spin_shared) {
        d_aomega.reserve(n3 + 8, "cudaMalloc(atoms)");    // there already (share_inputs())
      } else if (spin) {
        up(d_aomega, a.omega, n3);
        report.bytes_up += (long) n3;
      }
      double *d_spin = spin ? d_aomega.as<double>() : nullptr;
      cuda_check(cudaEventRecord(ev_up1, stream), "cudaEventRecord");
      // The step budget (the host's step_budget() on the device) in [0, 3), and a check's
      // counts in [4, 8), read back by finish().
      constexpr int NBUDGET = 8, MISS = 4;
      d_budget.reserve(NBUDGET * sizeof(unsigned long long), "cudaMalloc(budget)");
      host_budget.reserve(NBUDGET * sizeof(unsigned long long), "cudaMallocHost(budget)");
      cuda_check(cudaMemsetAsync(d_budget.ptr, 0, NBUDGET * sizeof(unsigned long long), stream),
                 "cudaMemset");
      // The last step's IDs and end state are valid until this step moves anything.
      const bool ids_were = ids_kept;
      ids_kept = false;
      if (a.reordered && !(ids_were && reorder(a))) {
        // An ID the last step did not have (or no kept state): nothing done, nothing kept
        // (kept, state_kept and ids_kept are all false by now).
        report.motion = MotionUse::copy;
        cuda_check(cudaStreamSynchronize(stream), "resident step");
        return;
      }
      if (moved || advance) {
        verlet_kernel<<<nblocks(n), BLOCK, 0, stream>>>(d_ax.as<double>(), d_av.as<double>(),
                                                        d_af.as<double>(), d_amass.as<double>(),
                                                        n, m.move, m.fused);
        launched("verlet_kernel");
      } else if (check) {
        verlet_check_kernel<<<nblocks(n), BLOCK, 0, stream>>>(
            d_kx.as<double>(), d_kv.as<double>(), d_ax.as<double>(), d_av.as<double>(),
            d_af.as<double>(), d_amass.as<double>(), n, m.move,
            d_budget.as<unsigned long long>() + MISS);
        launched("verlet_check_kernel");
      }
      budget_kernel<<<nblocks(n), BLOCK, 0, stream>>>(d_av.as<double>(), d_af.as<double>(),
                                                      d_amass.as<double>(), d_arad.as<double>(), n,
                                                      a.ftm2v, d_budget.as<unsigned long long>());
      launched("budget_kernel");
      fetch(d_budget, host_budget, NBUDGET * sizeof(unsigned long long), "cudaMemcpy(budget)");
      // No wait here: the first read of the scalars waits for the uploads too.  Every way out
      // below ends with the stream idle; finish() then reads the budget and the upload time.
      auto finish = [&]() {
        cuda_check(cudaStreamSynchronize(stream), "resident step");
        float ms = 0.0f;
        cuda_check(cudaEventElapsedTime(&ms, ev_up0, ev_up1), "cudaEventElapsedTime");
        report.t_upload = 1e-3 * ms;
        const unsigned long long *bits = host_budget.as<unsigned long long>();
        std::memcpy(&report.vmax2, &bits[0], sizeof(double));
        std::memcpy(&report.amax, &bits[1], sizeof(double));
        std::memcpy(&report.rmax, &bits[2], sizeof(double));
        for (int k = 0; k < 4 && check; ++k)
          report.motion_miss[k] = (long long) bits[MISS + k];
      };
      prof.last = t_start;
      mark(Profile::upload);
      // A step whose check fails (a contact that no candidate covered) is done again here,
      // from the same start, with the bounds of the bodies that moved too far raised: exact
      // whatever the candidates, so the same result as the host's redo.
      constexpr int MOST_REDOS = 3;
      d_boost.reserve(n1 + 8, "cudaMalloc(bound boosts)");
      cuda_check(cudaMemsetAsync(d_boost.ptr, 0, n1, stream), "cudaMemset");
      Tally total;
      for (int attempt = 0;; ++attempt) {
        if (a.id_bytes == 8)
          build_kernel<long long><<<nblocks(n, BUILD_BLOCK), BUILD_BLOCK, 0, stream>>>(
              d_ax.as<double>(), d_av.as<double>(), d_af.as<double>(), d_arad.as<double>(),
              d_amass.as<double>(), d_atlast.as<double>(), d_atype.as<int>(), d_aid.as<long long>(),
              d_spin, d_boost.as<double>(), n, p.dt, a.ftm2v, a.bound_floor,
              d_budget.as<unsigned long long>(), a.reach, d_bodies.as<Body>(),
              d_bound.as<double>());
        else
          build_kernel<int><<<nblocks(n, BUILD_BLOCK), BUILD_BLOCK, 0, stream>>>(
              d_ax.as<double>(), d_av.as<double>(), d_af.as<double>(), d_arad.as<double>(),
              d_amass.as<double>(), d_atlast.as<double>(), d_atype.as<int>(), d_aid.as<int>(),
              d_spin, d_boost.as<double>(), n, p.dt, a.ftm2v, a.bound_floor,
              d_budget.as<unsigned long long>(), a.reach, d_bodies.as<Body>(),
              d_bound.as<double>());
        launched("build_kernel");
        total = Tally();
        report.stats = WindowStats();
        if (resolve_step(box, p, s, total, report, t_start)) break;
        if (!(report.outcome == ResidentOutcome::excursion && step_missed) ||
            attempt + 1 >= MOST_REDOS) {
          finish();
          return;
        }
        raise_kernel<<<nblocks(n), BLOCK, 0, stream>>>(d_lexc.as<double>(), d_bound.as<double>(), n,
                                                       d_boost.as<double>());
        launched("raise_kernel");
        report.outcome = ResidentOutcome::done;
        ++report.redone;
      }
      // Only the atoms that had events come back.
      const auto t_down = Clock::now();
      // In body order, so that the host writes the atoms' arrays front to back.
      d_sums.reserve((size_t) n * sizeof(AtomResult), "cudaMalloc(atom results)");
      if (spin) d_rspin.reserve(n3, "cudaMalloc(atom results)");
      double *d_rsp = spin ? d_rspin.as<double>() : nullptr;
      const int changed = host_scalars->changed;    // count_changed()'s
      atom_results_kernel<<<nblocks(n), BLOCK, 0, stream>>>(
          d_bodies.as<Body>(), n, p.dt, d_offset.as<int>(), d_sums.as<AtomResult>(), d_rsp);
      launched("atom_results_kernel");
      tlast_end_kernel<<<nblocks(n, TILE), TILE, 0, stream>>>(d_bodies.as<Body>(), n, p.dt, a.never,
                                                              d_atlast.as<double>());
      launched("tlast_end_kernel");
      report.changed = changed;
      // The results into the caller's arrays, now or (defer_writes) at deliver_atoms().
      later = Later();
      later.a = a;
      later.changed = changed;
      later.spin = spin;
      later.keep_motion = keep_motion;
      if (a.defer_writes && !a.results && !spin)
        later.pending = true;
      else
        write_back(later);
      report.t_download = seconds_since(t_down);
      mark(Profile::download);
      prof.end_step();
      tally.add(total);
      report.t_resolve = seconds_since(windows_start);
      finish();
      // The device's tlast now equals the caller's (copied back above), the rest as uploaded.
      for (int k = FIRST_KEPT; k < NLOCKED; ++k) {
        kept_host[k] = arrays[k].h;
        kept_bytes[k] = arrays[k].bytes;
      }
      kept = true;
      // d_ax, d_av: x and v as the caller's arrays now hold them (the whole copies and the
      // direct writes carry the changed atoms into them, the kernel above where the host
      // writes them).
      motion_done(a, keep_motion && own);
      state_kept = keep_motion && a.results;
      // The end state's IDs, for the next step's atoms found by ID.
      if (state_kept && a.inputs_shared) {
        const size_t nid = (size_t) n * a.id_bytes;
        d_oid.reserve(nid + 8, "cudaMalloc(atom IDs)");
        cuda_check(cudaMemcpyAsync(d_oid.ptr, d_aid.ptr, nid, cudaMemcpyDeviceToDevice, stream),
                   "cudaMemcpy(atom IDs)");
        cuda_check(cudaStreamSynchronize(stream), "cudaMemcpy(atom IDs)");
        ids_kept = true;
        oid_n = n;
        oid_bytes = a.id_bytes;
      }
    }

    /* ResidentAtoms::reordered: the kept end state of the last step (d_ax, d_av, d_atlast,
       d_arad, d_amass, d_atype in the order of the IDs in d_oid) put into the order of the IDs
       the ranks wrote into d_aid.  False where it cannot (no kept state, another atom count
       or ID width, an ID not among the old ones); then the buffers may hold anything.  The
       state is gathered into scratch and copied back, not traded: the other ranks hold IPC
       handles to these buffers, which would have to be opened again. */
    bool CudaResidentStep::reorder(const ResidentAtoms &a)
    {
      if (oid_n != n || oid_bytes != a.id_bytes) return false;
      return a.id_bytes == 8 ? reorder_by<long long>() : reorder_by<int>();
    }

    /* reorder() with the IDs as IdT (LAMMPS's tagint: 4 or 8 bytes). */
    template <class IdT>
    bool CudaResidentStep::reorder_by()
    {
      const size_t n3 = (size_t) 3 * n * sizeof(double), n1 = (size_t) n * sizeof(double);
      d_most.reserve(2 * sizeof(unsigned long long), "cudaMalloc(reorder)");
      host_most.reserve(2 * sizeof(unsigned long long), "cudaMallocHost(reorder)");
      cuda_check(cudaMemsetAsync(d_most.ptr, 0, 2 * sizeof(unsigned long long), stream),
                 "cudaMemset");
      unsigned long long *most = d_most.as<unsigned long long>();
      id_max_kernel<IdT><<<nblocks(n), BLOCK, 0, stream>>>(d_oid.as<IdT>(), n, most);
      launched("id_max_kernel");
      fetch(d_most, host_most, sizeof(unsigned long long), "cudaMemcpy(reorder)");
      wait("cudaMemcpy(reorder)");
      const long long top = (long long) host_most.as<unsigned long long>()[0];
      if (top <= 0 || top > (long long) INT_MAX - 2) return false;
      d_slot.reserve((size_t) (top + 1) * sizeof(int), "cudaMalloc(reorder)");
      for (DeviceBuffer *b : {&d_rx, &d_rv}) b->reserve(n3 + 8, "cudaMalloc(reorder)");
      for (DeviceBuffer *b : {&d_rt, &d_rr, &d_rm}) b->reserve(n1 + 8, "cudaMalloc(reorder)");
      d_rty.reserve((size_t) n * sizeof(int) + 8, "cudaMalloc(reorder)");
      unsigned long long *missing = most + 1;
      id_slot_kernel<IdT><<<nblocks(n), BLOCK, 0, stream>>>(d_oid.as<IdT>(), n, d_slot.as<int>());
      reorder_kernel<IdT><<<nblocks(n), BLOCK, 0, stream>>>(
          d_aid.as<IdT>(), d_oid.as<IdT>(), d_slot.as<int>(), top, n, d_ax.as<double>(),
          d_av.as<double>(), d_atlast.as<double>(), d_arad.as<double>(), d_amass.as<double>(),
          d_atype.as<int>(), d_rx.as<double>(), d_rv.as<double>(), d_rt.as<double>(),
          d_rr.as<double>(), d_rm.as<double>(), d_rty.as<int>(), missing);
      launched("reorder_kernel");
      fetch(d_most, host_most, 2 * sizeof(unsigned long long), "cudaMemcpy(reorder)");
      wait("cudaMemcpy(reorder)");
      if (host_most.as<unsigned long long>()[1] != 0) return false;
      const struct {
        DeviceBuffer &to, &from;
        size_t bytes;
      } back[6] = {{d_ax, d_rx, n3},     {d_av, d_rv, n3},     {d_atlast, d_rt, n1},
                   {d_arad, d_rr, n1},   {d_amass, d_rm, n1},  {d_atype, d_rty, (size_t) n * sizeof(int)}};
      for (const auto &b : back)
        cuda_check(cudaMemcpyAsync(b.to.ptr, b.from.ptr, b.bytes, cudaMemcpyDeviceToDevice, stream),
                   "cudaMemcpy(reorder)");
      return true;
    }

  }    // namespace

  std::unique_ptr<ResidentStep> make_cuda_resident_step(int device)
  {
    return std::unique_ptr<ResidentStep>(new CudaResidentStep(device));
  }

}    // namespace Collide
}    // namespace HSGPU
