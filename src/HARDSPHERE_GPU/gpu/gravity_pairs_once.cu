/* HARDSPHERE_GPU: the pairs-once all-pairs gravity kernel (Newton's third law), see
   gravity_kernels.cuh.

   The n bodies, padded to npad with massless bodies far away, form nb blocks of `group`
   slices; a slice is PO_THREADS * ILP bodies (4 warps, ILP bodies per lane).  One thread block
   takes one task:
     - a pair of blocks (I, J), I < J: every pair of a body of I and a body of J is evaluated
       once and pulls both bodies;
     - a block with itself (I = J), evaluated one-sided (each pair twice, no reaction sums);
       these nb tasks are about 2 / (nb + 1) of the work.
   Inside a task, for each slice of J and each slice of I, every lane holds ILP bodies of I
   (positions, masses and sums in registers) and walks the slice of J in chunks of 32 bodies.
   A chunk's bodies sit one per lane and are rotated through the warp's 32 lanes by shuffles,
   carrying the reaction sums they collect, so after 32 steps each lane has met all 32.  At a
   given chunk step the 4 warps hold distinct chunks; each adds its chunk's reaction sums into
   shared memory, and a barrier ends the step, so the order of every sum is fixed.

   Output: partial sums part[(L * npad + b) * 3 + c] (accelerations over G, as the one-sided
   kernels' splits): body b of block K gets its sum over the bodies of block L at partner
   slot L, from task (K, L) or (L, K).  Every entry is written by exactly one task and
   sum_partials adds the nb partners in order: deterministic, no atomics.

   Mixed precision: the bodies come in Z-curve order (the engine's sort), so a block holds
   bodies close in space; each task converts positions to fp32 relative to the first body of
   its block I (in double), pair arithmetic is fp32, and the fp32 sums over each slice of J
   (and over each chunk, for the reaction sums) are added into fp64 partial sums.

   Launch: grid nb (nb + 1) / 2 blocks of PO_THREADS threads; shared memory 3 * slice values
   of the partial-sum type (the reaction sums of one slice of J).
   Per pair, single precision, forces only: 3 FADD (d), 3 FFMA (r^2 + eps^2), 1 MUFU (rsqrt),
   2 FMUL (1/r^3), 2 FMUL (m_j/r^3, m_i/r^3), 6 FFMA (both sums) = 17 issued instructions for
   two interactions, plus 7 SHFL per lane and rotation step shared by the ILP pairs of the
   step: (17 ILP + 7) / (2 ILP) = 8.9 instructions per interaction at ILP 8 against 13.25 in
   the one-sided loop.  Double precision: the same with the corrected reciprocal square root
   of pair_math.cuh and 14 SHFL per step.  Global memory traffic: each slice is read once per
   slice pair from L2, the partial sums written once (3 nb npad values). */

#include "gravity_kernels.cuh"
#include "pair_math.cuh"

#include <algorithm>
#include <cmath>

namespace HSGPU {
namespace GPU {

  namespace {

    constexpr int PO_WARPS = 4;
    constexpr int PO_THREADS = 32 * PO_WARPS;
    constexpr int PO_MAX_BLOCKS = 128;
    // Scratch budget: fewer, larger blocks when nb npad partial sums would exceed it.
    constexpr double PO_SCRATCH_BUDGET = 4.0 * 1024 * 1024 * 1024;
    // Pad bodies: massless, at this coordinate (relative to the box's lower corner, where
    // every real body lies at >= 0): far enough that their pairs with real bodies add
    // exactly zero (r^2 overflows to infinity in fp32; in fp64 the zero mass does it).
    constexpr double PO_PAD_COORD = -1.0e30;

    // The precision's types (pair_math.cuh); Mixed converts positions to R relative to the
    // origin of the task's block I, in double.
    template <int PREC> using PoTypes = PrecTypes<PREC>;

    // Task t -> blocks (I, J): tasks 0 .. nb-1 are the blocks with themselves, then the pairs
    // I < J row by row.  At most nb - 1 loop trips.
    __device__ inline void task_blocks(int t, int nb, int &I, int &J)
    {
      if (t < nb) {
        I = J = t;
        return;
      }
      t -= nb;
      I = 0;
      while (t >= nb - 1 - I) {
        t -= nb - 1 - I;
        ++I;
      }
      J = I + 1 + t;
    }

    template <class R> __device__ inline R rotate(R v, int from)
    {
      return __shfl_sync(0xffffffffu, v, from);
    }

    // A coordinate in the kernel's arithmetic: Mixed relative to the origin o, in double.
    template <bool MIXED, class R, class S> __device__ inline R rel(S x, double o)
    {
      if constexpr (MIXED)
        return (R) (x - o);
      else
        return (R) x;
    }

    template <int PREC, int ILP>
    __global__ void __launch_bounds__(PO_THREADS)
        pairs_once_kernel(const typename PoTypes<PREC>::Src *__restrict__ src, int nb, int group,
                          long npad, typename PoTypes<PREC>::R eps2,
                          typename PoTypes<PREC>::Part *__restrict__ part)
    {
      using R = typename PoTypes<PREC>::R;
      using Part = typename PoTypes<PREC>::Part;
      using Src = typename PoTypes<PREC>::Src;
      constexpr bool MIXED = (PREC == 1);
      constexpr int SLICE = PO_THREADS * ILP;
      constexpr int CHUNKS = SLICE / 32;
      __shared__ Part reac[3 * SLICE];

      const int lane = threadIdx.x & 31, warp = threadIdx.x >> 5;
      const int next = (lane + 1) & 31;
      int I, J;
      task_blocks(blockIdx.x, nb, I, J);
      const bool diag = (I == J);
      const long bsize = (long) group * SLICE;
      // Mixed: positions relative to the first body of block I (a real body: every block
      // starts below n), so that nearby pairs keep their digits.
      double o[3] = {0.0, 0.0, 0.0};
      if constexpr (MIXED) {
        const Src s = src[I * bsize];
        o[0] = s.x;
        o[1] = s.y;
        o[2] = s.z;
      }

      for (int gj = 0; gj < group; ++gj) {
        const long jb = J * bsize + (long) gj * SLICE;
        if (!diag) {
          for (int q = threadIdx.x; q < 3 * SLICE; q += PO_THREADS) reac[q] = (Part) 0;
          __syncthreads();
        }
        for (int gi = 0; gi < group; ++gi) {
          const long ib = I * bsize + (long) gi * SLICE + warp * 32 * ILP + lane;
          R xi[ILP], yi[ILP], zi[ILP], mi[ILP], ax[ILP], ay[ILP], az[ILP];
#pragma unroll
          for (int q = 0; q < ILP; ++q) {
            const Src s = src[ib + 32 * q];
            xi[q] = rel<MIXED, R>(s.x, o[0]);
            yi[q] = rel<MIXED, R>(s.y, o[1]);
            zi[q] = rel<MIXED, R>(s.z, o[2]);
            mi[q] = (R) s.w;
            if (MIXED || gj == 0) {
              ax[q] = ay[q] = az[q] = (R) 0;
            } else {    // this task's own partner slot, written at gj - 1 by this thread
              const Part *p = part + 3 * (J * npad + ib + 32 * q);
              ax[q] = p[0];
              ay[q] = p[1];
              az[q] = p[2];
            }
          }

          for (int t = 0; t < CHUNKS; ++t) {
            const int c = (t + warp * ILP) % CHUNKS;    // distinct for the 4 warps
            const Src s = src[jb + 32 * c + lane];
            R xj = rel<MIXED, R>(s.x, o[0]), yj = rel<MIXED, R>(s.y, o[1]);
            R zj = rel<MIXED, R>(s.z, o[2]);
            R mj = (R) s.w;
            if (diag) {
              // One-sided; a lane meets its own body at step 0 of its own chunk.
              const bool own = (gi == gj) && (c / ILP == warp);
              for (int k = 0; k < 32; ++k) {
#pragma unroll
                for (int q = 0; q < ILP; ++q) {
                  const R dx = xj - xi[q], dy = yj - yi[q], dz = zj - zi[q];
                  R r2 = fma_p(dx, dx, fma_p(dy, dy, fma_p(dz, dz, eps2)));
                  R m = mj;
                  if (own && k == 0 && c % ILP == q) {
                    r2 = (R) 1;
                    m = (R) 0;
                  }
                  const R s3 = m * inv_cube(r2);
                  ax[q] = fma_p(s3, dx, ax[q]);
                  ay[q] = fma_p(s3, dy, ay[q]);
                  az[q] = fma_p(s3, dz, az[q]);
                }
                xj = rotate(xj, next);
                yj = rotate(yj, next);
                zj = rotate(zj, next);
                mj = rotate(mj, next);
              }
            } else {
              R fx = (R) 0, fy = (R) 0, fz = (R) 0;
#pragma unroll 2
              for (int k = 0; k < 32; ++k) {
#pragma unroll
                for (int q = 0; q < ILP; ++q) {
                  const R dx = xj - xi[q], dy = yj - yi[q], dz = zj - zi[q];
                  const R r2 = fma_p(dx, dx, fma_p(dy, dy, fma_p(dz, dz, eps2)));
                  const R w = inv_cube(r2);
                  const R si = mj * w, sj = mi[q] * w;
                  ax[q] = fma_p(si, dx, ax[q]);
                  ay[q] = fma_p(si, dy, ay[q]);
                  az[q] = fma_p(si, dz, az[q]);
                  fx = fma_p(-sj, dx, fx);
                  fy = fma_p(-sj, dy, fy);
                  fz = fma_p(-sj, dz, fz);
                }
                xj = rotate(xj, next);
                yj = rotate(yj, next);
                zj = rotate(zj, next);
                mj = rotate(mj, next);
                fx = rotate(fx, next);
                fy = rotate(fy, next);
                fz = rotate(fz, next);
              }
              // After 32 rotations every body of the chunk is back in its own lane.
              Part *r = reac + 3 * (32 * c + lane);
              r[0] += (Part) fx;
              r[1] += (Part) fy;
              r[2] += (Part) fz;
              __syncthreads();
            }
          }

          // The sums go to this task's own partner slot J; Mixed adds each slice's fp32 sums
          // into the fp64 slot, the others carry their sums on through the slot.
#pragma unroll
          for (int q = 0; q < ILP; ++q) {
            Part *p = part + 3 * (J * npad + ib + 32 * q);
            if (MIXED && gj > 0) {
              p[0] += (Part) ax[q];
              p[1] += (Part) ay[q];
              p[2] += (Part) az[q];
            } else {
              p[0] = (Part) ax[q];
              p[1] = (Part) ay[q];
              p[2] = (Part) az[q];
            }
          }
        }
        if (!diag) {
          // The slice of J is complete: its sums over block I go to partner slot I.
          Part *p = part + 3 * (I * npad + jb);
          for (int q = threadIdx.x; q < 3 * SLICE; q += PO_THREADS) p[q] = reac[q];
          __syncthreads();
        }
      }
    }

    // One thread per pad body (n <= b < npad).
    template <class Src> __global__ void fill_pads(Src *__restrict__ src, long n, long npad)
    {
      const long b = n + blockIdx.x * (long) blockDim.x + threadIdx.x;
      if (b >= npad) return;
      src[b].x = src[b].y = src[b].z = PO_PAD_COORD;
      src[b].w = 0;
    }

    template <int PREC, int ILP>
    void launch(const PairsOnceLayout &L, void *src, long n, const GravityArgs &a, void *scratch,
                cudaStream_t st)
    {
      using T = PoTypes<PREC>;
      if (L.npad > n) {
        const unsigned grid = (unsigned) ((L.npad - n + 255) / 256);
        fill_pads<<<grid, 256, 0, st>>>((typename T::Src *) src, n, L.npad);
      }
      const unsigned tasks = (unsigned) L.nb * (L.nb + 1) / 2;
      pairs_once_kernel<PREC, ILP>
          <<<tasks, PO_THREADS, 0, st>>>((const typename T::Src *) src, L.nb, L.group, L.npad,
                                         (typename T::R) a.eps2, (typename T::Part *) scratch);
    }

    template <int PREC>
    void launch_ilp(const PairsOnceLayout &L, void *src, long n, const GravityArgs &a,
                    void *scratch, cudaStream_t st)
    {
      if (L.ilp == 2)
        launch<PREC, 2>(L, src, n, a, scratch, st);
      else if (L.ilp == 4)
        launch<PREC, 4>(L, src, n, a, scratch, st);
      else
        launch<PREC, 8>(L, src, n, a, scratch, st);
    }

    size_t part_bytes(Precision p)
    {
      return p == Precision::Single ? sizeof(float) : sizeof(double);
    }

  }    // namespace

  bool pairs_once_supported(Precision, const GravityArgs &a)
  {
    return !a.energy_virial && !(a.cutsq > 0.0) &&
           !(a.periodic[0] || a.periodic[1] || a.periodic[2]);
  }

  bool pairs_once_pays(Precision, long n)
  {
    return n >= PAIRS_ONCE_MIN_N;
  }

  PairsOnceLayout pairs_once_layout(Precision p, long n, int ilp)
  {
    PairsOnceLayout L;
    // Measured fastest on an H200 (doc/bench_gravity_gpu.md, the ILP sweep of pairs once):
    // more bodies per lane for large N, smaller slices (more tasks) for small N.
    if (ilp != 2 && ilp != 4 && ilp != 8)
      ilp = (p != Precision::Double && n >= 65536) ? 8 : (n >= 16384) ? 4 : 2;
    L.ilp = ilp;
    const long slice = (long) PO_THREADS * ilp;
    const long nsub = std::max(1L, (n + slice - 1) / slice);
    const double per_block = (double) std::max(1L, n) * 3.0 * part_bytes(p);
    const long budget = (long) (PO_SCRATCH_BUDGET / per_block);
    const long most = std::max(8L, std::min((long) PO_MAX_BLOCKS, budget));
    L.group = (int) ((nsub + most - 1) / most);
    L.nb = (int) ((nsub + L.group - 1) / L.group);
    L.npad = (long) L.nb * L.group * slice;
    return L;
  }

  size_t pairs_once_source_bytes(Precision p, const PairsOnceLayout &L)
  {
    return source_bytes(p) * (size_t) L.npad;
  }

  size_t pairs_once_scratch_bytes(Precision p, const PairsOnceLayout &L)
  {
    return part_bytes(p) * 3 * (size_t) L.nb * L.npad;
  }

  cudaError_t compute_gravity_pairs_once(Precision p, const PairsOnceLayout &L, const double *x,
                                         const double *m, long n, const int *order, const int *slot,
                                         const GravityArgs &a, void *src, void *scratch, double *f,
                                         cudaStream_t st)
  {
    if (n <= 0) return cudaSuccess;
    if (!pairs_once_supported(p, a)) return cudaErrorInvalidValue;
    cudaError_t err = pack_sources(p, x, m, n, a, src, st, order);
    if (err != cudaSuccess) return err;
    if (p == Precision::Single)
      launch_ilp<0>(L, src, n, a, scratch, st);
    else if (p == Precision::Mixed)
      launch_ilp<1>(L, src, n, a, scratch, st);
    else
      launch_ilp<2>(L, src, n, a, scratch, st);
    err = cudaGetLastError();
    if (err != cudaSuccess) return err;
    return sum_partials(p, scratch, L.nb, L.npad, n, order, slot, m, a.G, false, f, nullptr,
                        nullptr, st);
  }

}    // namespace GPU
}    // namespace HSGPU
