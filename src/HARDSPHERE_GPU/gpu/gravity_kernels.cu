/* HARDSPHERE_GPU: tiled all-pairs gravity kernels, see gravity_kernels.cuh.

   One thread block owns BLOCK*ILP targets and one range ("split") of the sources.  It walks
   the range in tiles of BLOCK sources that the block stages in shared memory; every thread
   sums the tile's pull on its ILP targets.  Splitting the sources over several block rows
   keeps all multiprocessors busy for small N; a finalize kernel adds the splits in a fixed
   order (deterministic), multiplies by G m_i and writes doubles.

   Per interaction, forces only, single precision: 3 FADD (d), 3 FFMA (r^2 + eps^2), 1 MUFU
   (rsqrt), 3 FMUL (m_j / r^3), 3 FFMA (accumulate) = 13 issued instructions; the shared-memory
   load of a source (one 16 B broadcast) is shared by the ILP targets of a thread.  Minimum
   image adds 4 per dimension in fp32 (FMUL, two FADD that round, FFMA; see rint_p, which
   avoids FRND) and 3 in fp64, energy 1 and virial 9.  Mixed precision costs the same per
   pair; converting a tile's sources to the block origin (3 DADD + 3 F2F each) and adding the
   tile's fp32 sums into fp64 are per tile.  Double precision: 3 DADD, 3 DFMA, the
   approximate reciprocal square root (one MUFU) and 7 fp64 instructions correcting it into
   m_j / r^3 (see pair_factors), 3 DFMA; fp64 runs at half the fp32 lane rate on sm_90.
   Global memory traffic is negligible: each tile is read once per block from L2. */

#include "gravity_kernels.cuh"
#include "pair_math.cuh"

#include <cub/device/device_radix_sort.cuh>

#include <algorithm>
#include <cmath>

namespace HSGPU {
namespace GPU {

  namespace {

    constexpr int REF_BLOCK = 256;

    // Arguments in the form the kernels use (floats where the precision wants them).
    template <class R> struct KArgs {
      R eps2, cut_eff;    // cut_eff = cutsq + eps2, compared with r^2 + eps^2
      R prd[3], iprd[3];
      double dprd[3], diprd[3];    // Mixed: wrap of x - O at tile load, in double
    };

    template <class R> KArgs<R> make_kargs(const GravityArgs &a)
    {
      KArgs<R> k;
      k.eps2 = (R) a.eps2;
      k.cut_eff = (R) (a.cutsq + a.eps2);
      for (int d = 0; d < 3; ++d) {
        const double p = a.periodic[d] ? a.prd[d] : 0.0;
        k.prd[d] = (R) p;
        k.iprd[d] = a.periodic[d] ? (R) (1.0 / a.prd[d]) : (R) 0;
        k.dprd[d] = p;
        k.diprd[d] = a.periodic[d] ? 1.0 / a.prd[d] : 0.0;
      }
      return k;
    }

    // ---------------------------------------------------------------- packing
    // One thread per source; reads 32 B, writes 16 or 32 B.
    // Source k is body order[k] (order null: body k).
    __global__ void pack_single(const double *__restrict__ x, const double *__restrict__ m, long n,
                                const int *__restrict__ order, double3 lo, float4 *__restrict__ src)
    {
      const long k = blockIdx.x * (long) blockDim.x + threadIdx.x;
      if (k >= n) return;
      const long i = order ? order[k] : k;
      src[k] = make_float4((float) (x[3 * i] - lo.x), (float) (x[3 * i + 1] - lo.y),
                           (float) (x[3 * i + 2] - lo.z), (float) m[i]);
    }

    __global__ void pack_double(const double *__restrict__ x, const double *__restrict__ m, long n,
                                const int *__restrict__ order, double3 lo, Src64 *__restrict__ src)
    {
      const long k = blockIdx.x * (long) blockDim.x + threadIdx.x;
      if (k >= n) return;
      const long i = order ? order[k] : k;
      src[k] = Src64{x[3 * i] - lo.x, x[3 * i + 1] - lo.y, x[3 * i + 2] - lo.z, m[i]};
    }

    // ---------------------------------------------------------------- pair arithmetic
    template <class R> struct TargetSums {
      R a[3];    // sum m_j (x_j - x_i) / s^3
      R e;       // sum m_j / s
      R v[6];    // sum m_j d d / s^3
    };

    template <class R> __device__ inline void zero(TargetSums<R> &t)
    {
      t.a[0] = t.a[1] = t.a[2] = t.e = (R) 0;
      for (int k = 0; k < 6; ++k) t.v[k] = (R) 0;
    }

    // Adds the pull of one source (mass mj, displacement d = x_j - x_i) on one target.
    // `keep` false drops the pair (the target itself).
    template <class R, bool EV, bool CUT>
    __device__ inline void accumulate(TargetSums<R> &t, R dx, R dy, R dz, R mj, const KArgs<R> &k,
                                      bool keep = true)
    {
      R r2 = fma_p(dx, dx, fma_p(dy, dy, fma_p(dz, dz, k.eps2)));
      if (!keep) {
        r2 = (R) 1;
        mj = (R) 0;
      }
      if (CUT) mj = (r2 > k.cut_eff) ? (R) 0 : mj;
      R s, mi = (R) 0;
      pair_factors<EV>(r2, mj, s, mi);
      t.a[0] = fma_p(s, dx, t.a[0]);
      t.a[1] = fma_p(s, dy, t.a[1]);
      t.a[2] = fma_p(s, dz, t.a[2]);
      if (EV) {
        t.e += mi;
        const R sx = s * dx, sy = s * dy;
        t.v[0] = fma_p(sx, dx, t.v[0]);
        t.v[1] = fma_p(sy, dy, t.v[1]);
        t.v[2] = fma_p(s * dz, dz, t.v[2]);
        t.v[3] = fma_p(sx, dy, t.v[3]);
        t.v[4] = fma_p(sx, dz, t.v[4]);
        t.v[5] = fma_p(sy, dz, t.v[5]);
      }
    }

    template <class R, bool PER> __device__ inline R image(R d, int dim, const KArgs<R> &k)
    {
      if (PER) d = fma_p(-k.prd[dim], rint_p(d * k.iprd[dim]), d);
      return d;
    }

    // Displacement d = x_j - x_i (nearest image when PER) in the precision's arithmetic;
    // for Mixed both are already relative to the block origin.
    template <bool PER, class S, class R>
    __device__ inline void displacement(const S &s, const R *xi, const KArgs<R> &k, R *d)
    {
      d[0] = image<R, PER>(s.x - xi[0], 0, k);
      d[1] = image<R, PER>(s.y - xi[1], 1, k);
      d[2] = image<R, PER>(s.z - xi[2], 2, k);
    }

    // Mixed: x - O in double, wrapped to the nearest image when PER, then float.
    template <bool PER>
    __device__ inline float4 relative(const Src64 &g, const double *o, const KArgs<float> &k)
    {
      double r[3] = {g.x - o[0], g.y - o[1], g.z - o[2]};
      if (PER)
        for (int c = 0; c < 3; ++c) r[c] = fma(-k.dprd[c], rint(r[c] * k.diprd[c]), r[c]);
      return make_float4((float) r[0], (float) r[1], (float) r[2], (float) g.w);
    }

    // ---------------------------------------------------------------- tiled kernel
    // Grid: x = ceil(ntgt / (BLOCK*ILP)) target groups, y = the splits of the source range
    // [jlo, jhi), chunk sources each.  Block: BLOCK threads.
    // Shared memory: BLOCK packed sources (16 or 32 B each).
    // Scratch output per (split, target): 3 (+1 +6) partial sums of type P; block row y
    // writes split split0 + y of a scratch laid out for nsplits splits.
    template <bool EV, class Part, class R>
    __device__ inline void add_into(TargetSums<Part> &dst, TargetSums<R> &src)
    {
      for (int c = 0; c < 3; ++c) {
        dst.a[c] += (Part) src.a[c];
        src.a[c] = (R) 0;
      }
      if (EV) {
        dst.e += (Part) src.e;
        src.e = (R) 0;
        for (int c = 0; c < 6; ++c) {
          dst.v[c] += (Part) src.v[c];
          src.v[c] = (R) 0;
        }
      }
    }

    template <int PREC, bool PER, bool EV, bool CUT, int BLOCK, int ILP>
    __global__ void __launch_bounds__(BLOCK)
        gravity_tiles(const typename PrecTypes<PREC>::Src *__restrict__ src, long jlo, long jhi,
                      long chunk, int split0, int nsplits, const int *__restrict__ tidx, long ntgt,
                      KArgs<typename PrecTypes<PREC>::R> k, bool self_test,
                      typename PrecTypes<PREC>::Part *__restrict__ part)
    {
      using R = typename PrecTypes<PREC>::R;
      using Part = typename PrecTypes<PREC>::Part;
      using Src = typename PrecTypes<PREC>::Src;
      using Tile = typename PrecTypes<PREC>::Tile;
      constexpr bool MIXED = (PREC == 1);
      __shared__ Tile sh[BLOCK];

      const long split = split0 + (long) blockIdx.y;
      const long jbeg = jlo + (long) blockIdx.y * chunk;
      const long jend = min(jhi, jbeg + chunk);
      const long first = blockIdx.x * (long) ILP * BLOCK;

      // Mixed: the block's origin is its first target's position.
      double origin[3] = {0.0, 0.0, 0.0};
      if constexpr (MIXED) {
        const Src o = src[tidx[min(first, ntgt - 1)]];
        origin[0] = o.x;
        origin[1] = o.y;
        origin[2] = o.z;
      }

      long self[ILP];
      R xi[ILP][3];
      TargetSums<R> t[ILP];
      TargetSums<Part> total[ILP];
      for (int q = 0; q < ILP; ++q) {
        const long ti = first + q * BLOCK + threadIdx.x;
        self[q] = (ti < ntgt) ? tidx[ti] : -1;
        const Src p = src[(self[q] >= 0) ? self[q] : 0];
        if constexpr (MIXED) {
          const float4 r = relative<PER>(p, origin, k);
          xi[q][0] = r.x;
          xi[q][1] = r.y;
          xi[q][2] = r.z;
        } else {
          xi[q][0] = p.x;
          xi[q][1] = p.y;
          xi[q][2] = p.z;
        }
        zero(t[q]);
        zero(total[q]);
      }

      for (long base = jbeg; base < jend; base += BLOCK) {
        const long j = base + threadIdx.x;
        __syncthreads();
        if (j < jend) {
          if constexpr (MIXED)
            sh[threadIdx.x] = relative<PER>(src[j], origin, k);
          else
            sh[threadIdx.x] = src[j];
        }
        __syncthreads();
        const int count = (int) min((long) BLOCK, jend - base);
        // A target meets itself at d = 0, which adds exactly zero force when r^2 = eps^2 is a
        // safe divisor; the host clears self_test then (forces only), else such tiles and the
        // last, partial one take the tested loop.
        bool checked = (count < BLOCK);
        if (self_test)
          for (int q = 0; q < ILP; ++q) checked |= (self[q] >= base && self[q] < base + BLOCK);

        if (!checked) {
#pragma unroll 8
          for (int jj = 0; jj < BLOCK; ++jj) {
            const Tile s = sh[jj];
#pragma unroll
            for (int q = 0; q < ILP; ++q) {
              R d[3];
              displacement<PER>(s, xi[q], k, d);
              accumulate<R, EV, CUT>(t[q], d[0], d[1], d[2], (R) s.w, k);
            }
          }
        } else {
          // The tile holds a target itself or is the last, partial one: test every source.
          for (int jj = 0; jj < count; ++jj) {
            const Tile s = sh[jj];
            const long jg = base + jj;
            for (int q = 0; q < ILP; ++q) {
              R d[3];
              displacement<PER>(s, xi[q], k, d);
              accumulate<R, EV, CUT>(t[q], d[0], d[1], d[2], (R) s.w, k, jg != self[q]);
            }
          }
        }
        if constexpr (MIXED)
          for (int q = 0; q < ILP; ++q) add_into<EV>(total[q], t[q]);
      }
      if constexpr (!MIXED)
        for (int q = 0; q < ILP; ++q) add_into<EV>(total[q], t[q]);

      for (int q = 0; q < ILP; ++q) {
        const long ti = first + q * BLOCK + threadIdx.x;
        if (ti >= ntgt) continue;
        const long o = split * ntgt + ti;
        part[3 * o] = total[q].a[0];
        part[3 * o + 1] = total[q].a[1];
        part[3 * o + 2] = total[q].a[2];
        if (EV) {
          Part *pe = part + 3 * ntgt * nsplits;
          pe[o] = total[q].e;
          Part *pv = pe + ntgt * nsplits;
          for (int c = 0; c < 6; ++c) pv[6 * o + c] = total[q].v[c];
        }
      }
    }

    // Sums the splits of each target in split order and scales by G m_i:
    // F = G m_i a,  e = -G m_i E / 2,  W = -G m_i V / 2.  One thread per target.
    // Partials of split s for target ti sit at s * stride + ti (stride >= ntgt); tidx null:
    // target ti is source ti.
    template <class Part>
    __global__ void finalize(const Part *__restrict__ part, int splits, long stride, long ntgt,
                             const int *__restrict__ tidx, const int *__restrict__ slot,
                             const double *__restrict__ m, double G, bool ev,
                             double *__restrict__ f, double *__restrict__ e, double *__restrict__ v)
    {
      const long ti = blockIdx.x * (long) blockDim.x + threadIdx.x;
      if (ti >= ntgt) return;
      const long out = slot ? slot[ti] : ti;
      const double gm = G * m[tidx ? tidx[ti] : ti];
      double a[3] = {0, 0, 0};
      for (int s = 0; s < splits; ++s)
        for (int c = 0; c < 3; ++c) a[c] += (double) part[3 * (s * stride + ti) + c];
      for (int c = 0; c < 3; ++c) f[3 * out + c] = gm * a[c];
      if (!ev) return;
      const Part *pe = part + 3 * stride * splits;
      const Part *pv = pe + stride * splits;
      double es = 0.0, vs[6] = {0, 0, 0, 0, 0, 0};
      for (int s = 0; s < splits; ++s) {
        es += (double) pe[s * stride + ti];
        for (int c = 0; c < 6; ++c) vs[c] += (double) pv[6 * (s * stride + ti) + c];
      }
      e[out] = -0.5 * gm * es;
      for (int c = 0; c < 6; ++c) v[6 * out + c] = -0.5 * gm * vs[c];
    }

    // Plain baseline: one body per thread, 256-body tiles, fp32, rsqrtf, forces only.
    __global__ void __launch_bounds__(REF_BLOCK)
        reference_kernel(const float4 *__restrict__ pos, int n, float eps2,
                         float4 *__restrict__ acc)
    {
      __shared__ float4 sh[REF_BLOCK];
      const int i = blockIdx.x * REF_BLOCK + threadIdx.x;
      const float4 pi = pos[min(i, n - 1)];
      float ax = 0.f, ay = 0.f, az = 0.f;
      for (int base = 0; base < n; base += REF_BLOCK) {
        __syncthreads();
        const int j = base + threadIdx.x;
        sh[threadIdx.x] = (j < n) ? pos[j] : make_float4(0.f, 0.f, 0.f, 0.f);
        __syncthreads();
#pragma unroll 8
        for (int jj = 0; jj < REF_BLOCK; ++jj) {
          const float4 pj = sh[jj];
          const float dx = pj.x - pi.x, dy = pj.y - pi.y, dz = pj.z - pi.z;
          const float r2 = fmaf(dx, dx, fmaf(dy, dy, fmaf(dz, dz, eps2)));
          const float inv = rsqrtf(r2);
          const float s = pj.w * inv * inv * inv;
          ax = fmaf(s, dx, ax);
          ay = fmaf(s, dy, ay);
          az = fmaf(s, dz, az);
        }
      }
      if (i < n) acc[i] = make_float4(ax, ay, az, 0.f);
    }

    template <int PREC, bool PER, bool EV, bool CUT, int BLOCK, int ILP>
    void launch_tiles(const GravityShape &s, const void *src, const SourceRange &r, const int *tidx,
                      long ntgt, const GravityArgs &a, bool self_test, void *scratch,
                      cudaStream_t st)
    {
      using T = PrecTypes<PREC>;
      const long groups = (ntgt + (long) BLOCK * ILP - 1) / ((long) BLOCK * ILP);
      const long n = r.end - r.begin;
      const long chunk = ((n + s.splits - 1) / s.splits + BLOCK - 1) / BLOCK * BLOCK;
      dim3 grid((unsigned) groups, (unsigned) s.splits);
      gravity_tiles<PREC, PER, EV, CUT, BLOCK, ILP><<<grid, BLOCK, 0, st>>>(
          (const typename T::Src *) src, r.begin, r.end, chunk, r.split0, r.nsplits, tidx, ntgt,
          make_kargs<typename T::R>(a), self_test, (typename T::Part *) scratch);
    }

    // The force-only open-box kernel without cutoff (the hot path of the benchmark and of most
    // runs) is compiled in every shape of HOT_SHAPES (gravity_types.h).
    bool is_hot(const GravityArgs &a)
    {
      return !(a.periodic[0] || a.periodic[1] || a.periodic[2]) && !a.energy_virial &&
             !(a.cutsq > 0.0);
    }

    template <int PREC, bool PER, bool EV, bool CUT, int I = 0>
    cudaError_t dispatch_hot(const GravityShape &s, const void *src, const SourceRange &r,
                             const int *tidx, long ntgt, const GravityArgs &a, bool self_test, void *scratch,
                             cudaStream_t st)
    {
      if constexpr (I < NUM_HOT_SHAPES) {
        constexpr int B = HOT_SHAPES[I][0], L = HOT_SHAPES[I][1];
        if (s.block == B && s.ilp == L) {
          launch_tiles<PREC, PER, EV, CUT, B, L>(s, src, r, tidx, ntgt, a, self_test, scratch,
                                                 st);
          return cudaGetLastError();
        }
        return dispatch_hot<PREC, PER, EV, CUT, I + 1>(s, src, r, tidx, ntgt, a, self_test,
                                                       scratch, st);
      } else {
        return cudaErrorInvalidValue;    // compiled_shape only hands out listed shapes
      }
    }

    // Launches the compiled (BLOCK, ILP) variant of shape s (one that compiled_shape returned).
    template <int PREC, bool PER, bool EV, bool CUT>
    cudaError_t dispatch_shape(const GravityShape &s, const void *src, const SourceRange &r,
                               const int *tidx, long ntgt, const GravityArgs &a, bool self_test, void *scratch,
                               cudaStream_t st)
    {
      if constexpr (!PER && !EV && !CUT) {
        return dispatch_hot<PREC, PER, EV, CUT>(s, src, r, tidx, ntgt, a, self_test, scratch,
                                                st);
      } else {
        constexpr int L = (PREC == 2) ? 1 : 2;
        launch_tiles<PREC, PER, EV, CUT, 256, L>(s, src, r, tidx, ntgt, a, self_test, scratch,
                                                 st);
        return cudaGetLastError();
      }
    }

    template <int PREC>
    cudaError_t dispatch_flags(const GravityShape &s, const void *src, const SourceRange &r,
                               const int *tidx, long ntgt, const GravityArgs &a, bool self_test, void *scratch,
                               cudaStream_t st)
    {
      const bool per = a.periodic[0] || a.periodic[1] || a.periodic[2];
      const bool ev = a.energy_virial;
      const bool cut = a.cutsq > 0.0;
#define HSGPU_CASE(P, E, C)            \
  if (per == P && ev == E && cut == C) \
    return dispatch_shape<PREC, P, E, C>(s, src, r, tidx, ntgt, a, self_test, scratch, st);
      HSGPU_CASE(false, false, false)
      HSGPU_CASE(false, false, true)
      HSGPU_CASE(false, true, false)
      HSGPU_CASE(false, true, true)
      HSGPU_CASE(true, false, false)
      HSGPU_CASE(true, false, true)
      HSGPU_CASE(true, true, false)
      HSGPU_CASE(true, true, true)
#undef HSGPU_CASE
      return cudaErrorInvalidValue;
    }

    // The shape the dispatcher actually runs for a wanted shape and flag combination.
    GravityShape compiled_shape(Precision p, const GravityShape &want, const GravityArgs &a)
    {
      GravityShape s = want;
      bool listed = false;
      for (const auto &h : HOT_SHAPES) listed |= (want.block == h[0] && want.ilp == h[1]);
      if (!is_hot(a) || !listed) {
        s.block = 256;
        s.ilp = (p == Precision::Double) ? 1 : 2;
      }
      return s;
    }

  }    // namespace

  size_t source_bytes(Precision p)
  {
    return p == Precision::Single ? 16 : 32;
  }

  namespace {
    // Spreads the low 10 bits of v to every third bit.
    __device__ inline unsigned spread3(unsigned v)
    {
      v &= 0x3ffu;
      v = (v | (v << 16)) & 0x030000ffu;
      v = (v | (v << 8)) & 0x0300f00fu;
      v = (v | (v << 4)) & 0x030c30c3u;
      v = (v | (v << 2)) & 0x09249249u;
      return v;
    }

    // One thread per target: 30-bit Z-curve key of its position in the box, and its slot.
    __global__ void morton_keys(const double *__restrict__ x, const int *__restrict__ tidx,
                                long ntgt, double3 lo, double3 inv, unsigned *__restrict__ key,
                                int *__restrict__ slot)
    {
      const long t = blockIdx.x * (long) blockDim.x + threadIdx.x;
      if (t >= ntgt) return;
      const long i = tidx[t];
      const double c[3] = {(x[3 * i] - lo.x) * inv.x, (x[3 * i + 1] - lo.y) * inv.y,
                           (x[3 * i + 2] - lo.z) * inv.z};
      unsigned q[3];
      for (int d = 0; d < 3; ++d) q[d] = (unsigned) fmin(1023.0, fmax(0.0, c[d] * 1024.0));
      key[t] = spread3(q[0]) | (spread3(q[1]) << 1) | (spread3(q[2]) << 2);
      slot[t] = (int) t;
    }

    __global__ void gather_sorted(const int *__restrict__ tidx, const int *__restrict__ slot,
                                  long ntgt, int *__restrict__ tsorted)
    {
      const long t = blockIdx.x * (long) blockDim.x + threadIdx.x;
      if (t < ntgt) tsorted[t] = tidx[slot[t]];
    }
  }    // namespace

  size_t sort_temp_bytes(long ntgt)
  {
    size_t bytes = 0;
    cub::DeviceRadixSort::SortPairs(nullptr, bytes, (const unsigned *) nullptr,
                                    (unsigned *) nullptr, (const int *) nullptr, (int *) nullptr,
                                    (int) ntgt, 0, 30);
    return bytes + 2 * ntgt * sizeof(int);
  }

  cudaError_t sort_targets(const double *x, const int *tidx, long ntgt, const GravityArgs &a,
                           unsigned *keys, int *tsorted, int *slot, void *temp, size_t temp_bytes,
                           cudaStream_t st)
  {
    if (ntgt <= 0) return cudaSuccess;
    const int block = 256;
    const unsigned grid = (unsigned) ((ntgt + block - 1) / block);
    // Positions of open (shrink-wrapped or fixed) boxes lie inside the box too.
    const double3 lo = make_double3(a.lo[0], a.lo[1], a.lo[2]);
    const double3 inv = make_double3(1.0 / a.prd[0], 1.0 / a.prd[1], 1.0 / a.prd[2]);
    int *slot_in = (int *) temp;
    char *cub_temp = (char *) temp + 2 * ntgt * sizeof(int);
    size_t cub_bytes = temp_bytes - 2 * ntgt * sizeof(int);
    morton_keys<<<grid, block, 0, st>>>(x, tidx, ntgt, lo, inv, keys, slot_in);
    cudaError_t err = cudaGetLastError();
    if (err != cudaSuccess) return err;
    err = cub::DeviceRadixSort::SortPairs(cub_temp, cub_bytes, keys, keys + ntgt, slot_in, slot,
                                          (int) ntgt, 0, 30, st);
    if (err != cudaSuccess) return err;
    gather_sorted<<<grid, block, 0, st>>>(tidx, slot, ntgt, tsorted);
    return cudaGetLastError();
  }

  GravityShape choose_shape(Precision p, const GravityArgs &a, long ntgt, long nsrc, int num_sms)
  {
    // Shapes that measured fastest on an H200 (doc/bench_gravity_gpu.md, --shapes sweep),
    // picked by the system size nsrc, which all MPI ranks share: choosing by a rank's own
    // target count put ranks on either side of a threshold onto different kernels.
    GravityShape s;
    if (p == Precision::Double) {
      s.block = (nsrc >= 8192) ? 256 : 128;
      s.ilp = (nsrc >= 8192) ? 2 : 1;
    } else if (p == Precision::Mixed) {
      s.block = (nsrc >= 65536) ? 128 : (nsrc >= 8192) ? 256 : 128;
      s.ilp = (nsrc >= 65536) ? 4 : 2;
    } else {
      s.block = (nsrc >= 8192) ? 256 : 128;
      s.ilp = (nsrc >= 8192) ? 4 : 1;
    }
    s = compiled_shape(p, s, a);
    s.splits = auto_splits(s, ntgt, nsrc, num_sms);
    return s;
  }

  int auto_splits(const GravityShape &s, long ntgt, long nsrc, int num_sms)
  {
    const long per_block = (long) s.block * s.ilp;
    const long groups = std::max(1L, (ntgt + per_block - 1) / per_block);
    // Aim for about 16 blocks per multiprocessor, but keep at least 2 tiles per split.
    const long want = std::max(1L, (16L * num_sms + groups - 1) / groups);
    const long most = std::max(1L, nsrc / (2L * s.block));
    return (int) std::min(std::min(want, most), 1024L);
  }

  size_t scratch_bytes(Precision p, const GravityShape &s, long ntgt, bool energy_virial)
  {
    const size_t part = (p == Precision::Single) ? sizeof(float) : sizeof(double);
    return part * (size_t) s.splits * ntgt * (energy_virial ? 10 : 3);
  }

  cudaError_t pack_sources(Precision p, const double *x, const double *m, long n,
                           const GravityArgs &a, void *src, cudaStream_t st, const int *order)
  {
    if (n <= 0) return cudaSuccess;
    const int block = 256;
    const unsigned grid = (unsigned) ((n + block - 1) / block);
    const double3 lo = make_double3(a.lo[0], a.lo[1], a.lo[2]);
    if (p == Precision::Single)
      pack_single<<<grid, block, 0, st>>>(x, m, n, order, lo, (float4 *) src);
    else
      pack_double<<<grid, block, 0, st>>>(x, m, n, order, lo, (Src64 *) src);
    return cudaGetLastError();
  }

  bool needs_self_test(Precision p, const GravityArgs &a, double max_mass)
  {
    // The self pair adds exactly zero force when m / eps^3 is finite in the pair arithmetic.
    const double eps3 = a.eps2 * std::sqrt(a.eps2);
    const double limit = (p == Precision::Double) ? 1e300 : 1e30;
    return !(!a.energy_virial && a.eps2 > 1e-30 && max_mass < limit * eps3);
  }

  cudaError_t compute_partials(Precision p, const GravityShape &s, const void *src,
                               const SourceRange &r, const int *tidx, long ntgt,
                               const GravityArgs &a, bool self_test, void *scratch,
                               cudaStream_t st)
  {
    if (ntgt <= 0 || s.splits <= 0) return cudaSuccess;
    if (r.begin < 0 || r.end < r.begin || r.split0 < 0 || r.split0 + s.splits > r.nsplits)
      return cudaErrorInvalidValue;
    const GravityShape c = compiled_shape(p, s, a);
    if (p == Precision::Single) return dispatch_flags<0>(c, src, r, tidx, ntgt, a, self_test, scratch, st);
    if (p == Precision::Mixed) return dispatch_flags<1>(c, src, r, tidx, ntgt, a, self_test, scratch, st);
    return dispatch_flags<2>(c, src, r, tidx, ntgt, a, self_test, scratch, st);
  }

  cudaError_t compute_gravity(Precision p, const GravityShape &want, const void *src, long nsrc,
                              const int *tidx, const int *slot, long ntgt, const double *m,
                              double max_mass, const GravityArgs &a, void *scratch, double *f,
                              double *e, double *v, cudaStream_t st)
  {
    if (ntgt <= 0) return cudaSuccess;
    const GravityShape s = compiled_shape(p, want, a);
    const cudaError_t err =
        compute_partials(p, s, src, SourceRange{0, nsrc, 0, s.splits}, tidx, ntgt, a,
                         needs_self_test(p, a, max_mass), scratch, st);
    if (err != cudaSuccess) return err;
    return sum_partials(p, scratch, s.splits, ntgt, ntgt, tidx, slot, m, a.G, a.energy_virial, f, e,
                        v, st);
  }

  cudaError_t sum_partials(Precision p, const void *part, int nparts, long stride, long ntgt,
                           const int *tidx, const int *slot, const double *m, double G, bool ev,
                           double *f, double *e, double *v, cudaStream_t st)
  {
    if (ntgt <= 0) return cudaSuccess;
    const int block = 256;
    const unsigned grid = (unsigned) ((ntgt + block - 1) / block);
    if (p == Precision::Single)
      finalize<float><<<grid, block, 0, st>>>((const float *) part, nparts, stride, ntgt, tidx,
                                              slot, m, G, ev, f, e, v);
    else
      finalize<double><<<grid, block, 0, st>>>((const double *) part, nparts, stride, ntgt, tidx,
                                               slot, m, G, ev, f, e, v);
    return cudaGetLastError();
  }

  cudaError_t reference_nbody(const void *pos, long n, float eps2, void *acc, cudaStream_t st)
  {
    if (n <= 0) return cudaSuccess;
    const unsigned grid = (unsigned) ((n + REF_BLOCK - 1) / REF_BLOCK);
    reference_kernel<<<grid, REF_BLOCK, 0, st>>>((const float4 *) pos, (int) n, eps2,
                                                 (float4 *) acc);
    return cudaGetLastError();
  }

}    // namespace GPU
}    // namespace HSGPU
