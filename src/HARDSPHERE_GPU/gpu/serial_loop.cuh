/* HARDSPHERE_GPU collision engine: the seed paper's loop on the device (`order serial` with
   `gpu yes`), one globally earliest event at a time.

   Every body keeps its earliest candidate event best[b] (collision_group_loop.h's
   group_best_event over all the step's candidate pairs).  One iteration is two kernels:

     serial_min_kernel:   every block's earliest best event (cub::BlockReduce), one per block;
     serial_event_kernel: one warp takes the earliest of those; if it lies before t_end and
                          the budget allows, lane 0 carries it out and the warp recomputes the
                          best events of its bodies and their neighbours (group_loop_warp.cuh's
                          carry_out); else it sets ctl->done.

   Both kernels return at once when ctl->done is set, so that the host can launch iterations
   ahead in a CUDA graph and look at ctl->done only now and then.  The events are those of
   the CPU's serial loop (core/event_order.h), carried out in the same order by the same
   functions, and the tally is summed in that order: the step's result is the CPU's bit for
   bit.

   Device code; included by resident_step_cuda.cu only. */
#ifndef HSGPU_GPU_SERIAL_LOOP_CUH
#define HSGPU_GPU_SERIAL_LOOP_CUH

#include "group_loop_warp.cuh"

#include <cub/block/block_reduce.cuh>

namespace HSGPU {
namespace Collide {
  namespace SerialLoop {

    constexpr int BLOCK = 256;

    /// The loop's state on the device.
    struct Control {
      int done;       // no event left before t_end, or the budget ran out
      Tally tally;    // the events carried out, in order
    };

    // Launch: one thread per body (n), any block size.  best[b] = body b's earliest event over
    // all its candidate pairs and the walls.
    __global__ void init_kernel(GroupGraph g, const __grid_constant__ Params p, int n)
    {
      const int b = blockIdx.x * blockDim.x + threadIdx.x;
      if (b >= n) return;
      g.best[b] = group_best_event(g, p, b);
    }

    // Launch: blocks of BLOCK threads over the bodies (n).  part[block] = the block's
    // earliest candidate (WarpLoop::before), nothing when ctl->done.  Reads n Events.
    __global__ void min_kernel(const Event *__restrict__ best, int n,
                               const Control *__restrict__ ctl, WarpLoop::Candidate *part)
    {
      if (ctl->done) return;
      using Reduce = cub::BlockReduce<WarpLoop::Candidate, BLOCK>;
      __shared__ typename Reduce::TempStorage scratch;
      const int b = blockIdx.x * BLOCK + threadIdx.x;
      WarpLoop::Candidate c{0.0, 0, 0, -1};
      if (b < n) c = WarpLoop::candidate_of(best[b], b);
      const WarpLoop::Candidate m = Reduce(scratch).Reduce(c, WarpLoop::Earliest());
      if (threadIdx.x == 0) part[blockIdx.x] = m;
    }

    // Launch: one block of 32 threads.  The earliest of part[0 .. nparts): carried out when
    // before t_end and fewer than budget events were carried out (ctl->tally.capped set when
    // the budget stops one that is due); ctl->done set when no event is carried out.
    __global__ void event_kernel(GroupGraph g, const __grid_constant__ Params p,
                                 const WarpLoop::Candidate *part, int nparts, double t_end,
                                 long budget, Control *ctl)
    {
      if (ctl->done) return;
      const int lane = threadIdx.x & 31;
      WarpLoop::Candidate c{0.0, 0, 0, -1};
      for (int k = lane; k < nparts; k += 32)
        if (WarpLoop::before(part[k], c)) c = part[k];
      c = WarpLoop::warp_earliest(c);
      if (c.b < 0 || !(c.t < t_end) || ctl->tally.events >= budget) {
        __syncwarp();
        if (lane == 0) {
          if (c.b >= 0 && c.t < t_end) ctl->tally.capped = 1;
          ctl->done = 1;
        }
        return;
      }
      const Event ev = g.best[c.b];
      __syncwarp();
      Tally t;
      if (lane == 0) t = ctl->tally;
      WarpLoop::carry_out(g, p, ev, lane, t);
      if (lane == 0) ctl->tally = t;
    }

  }    // namespace SerialLoop
}    // namespace Collide
}    // namespace HSGPU

#endif
