/* HARDSPHERE_GPU: device arithmetic of one gravity pair, shared by the one-sided tiled kernels
   (gravity_kernels.cu) and the pairs-once kernel (gravity_pairs_once.cu), so that both use one
   definition.  CUDA device code only; included by .cu files, never by host code. */
#ifndef HSGPU_GPU_PAIR_MATH_CUH
#define HSGPU_GPU_PAIR_MATH_CUH

#include <cuda_runtime.h>

namespace HSGPU {
namespace GPU {

  // Packed double-precision source (CUDA 13 deprecates the unsized double4).
  struct __align__(32) Src64
  {
    double x, y, z, w;
  };

  // Types per precision (Precision as int): pair arithmetic R, partial sums Part, packed
  // source in global memory Src, source staged in shared memory Tile (one-sided kernels).
  template <int PREC> struct PrecTypes;
  template <> struct PrecTypes<0> {    // Single
    using R = float;
    using Part = float;
    using Src = float4;     // in global memory
    using Tile = float4;    // in shared memory
  };
  template <> struct PrecTypes<1> {    // Mixed: fp32 pairs relative to the block origin
    using R = float;
    using Part = double;
    using Src = Src64;
    using Tile = float4;
  };
  template <> struct PrecTypes<2> {    // Double
    using R = double;
    using Part = double;
    using Src = Src64;
    using Tile = Src64;
  };

  // Round to the nearest integer, ties to even: the nearest image's x / L (at most about 1.5
  // in size).  In fp32, adding and subtracting 1.5 x 2^23 rounds x in the adder exactly as
  // rintf does for |x| < 2^22 (the _rn intrinsics keep the compiler from folding the pair
  // even under --use_fast_math): two adds instead of FRND.  Measured on an H100 (periodic
  // lattice3d with gravity, bench_multi_gpu.md): the single and mixed sums 1.14-1.18 times as fast,
  // forces bitwise equal.  In fp64 the same trick (1.5 x 2^52) was 15 % slower than rint
  // there, so double keeps rint.  The trick gives +0 where rintf gives -0 (x in (-0.5, 0)),
  // which the image's fma turns into the same displacement unless that is -0.
  __device__ inline float rint_p(float x)
  {
    const float c = 12582912.0f;    // 1.5 x 2^23
    return __fsub_rn(__fadd_rn(x, c), c);
  }
  __device__ inline double rint_p(double x)
  {
    return rint(x);
  }
  __device__ inline float fma_p(float a, float b, float c)
  {
    return fmaf(a, b, c);
  }
  __device__ inline double fma_p(double a, double b, double c)
  {
    return fma(a, b, c);
  }

  // The pair factors s = m / r^3 and (EV) mi = m / r for r^2 = r2 (softening included).
  // fp32: one MUFU.RSQ (--use_fast_math), then 3 FMUL.
  template <bool EV> __device__ inline void pair_factors(float r2, float m, float &s, float &mi)
  {
    const float inv = rsqrtf(r2);
    mi = m * inv;
    s = mi * (inv * inv);
  }

  // fp64 has no full-precision reciprocal square root in hardware.  Start from the
  // approximation y (rsqrt.approx.ftz.f64) and correct it with e = 1 - r2 y^2:
  //   1/r   = y   (1 - e)^(-1/2) = y   (1 + e/2 + 3/8 e^2 + ...)
  //   1/r^3 = y^3 (1 - e)^(-3/2) = y^3 (1 + 3/2 e + 15/8 e^2 + ...)
  // The next terms are of order e^3, far below double rounding for the approximation's
  // |e| (test_gravity_gpu's PairFactorsAcrossMagnitudes checks two-body forces and energies
  // against long double).
  // Forces only: 7 fp64 instructions and one MUFU.RSQ64H here; CUDA's rsqrt also checks its
  // input for special values with integer tests and a branch to a slow path on every call.
  // In the compiled sm_90 loop the whole interaction takes 16 fp64 instructions (9 DFMA,
  // 4 DMUL, 3 DADD) against about 18 plus 7 integer, move and branch instructions with
  // rsqrt: 0.85-0.90e12 interactions/s against 0.74e12 (doc/bench_gravity_gpu.md).
  // Subnormal r2 counts as zero (ftz).
  template <bool EV> __device__ inline void pair_factors(double r2, double m, double &s, double &mi)
  {
    double y;
    asm("rsqrt.approx.ftz.f64 %0, %1;" : "=d"(y) : "d"(r2));
    const double y2 = y * y;
    const double e = fma(-r2, y2, 1.0);
    const double m1 = m * y;
    const double m3 = m1 * y2;
    s = fma(m3, e * fma(15.0 / 8.0, e, 1.5), m3);
    if (EV) mi = fma(m1, e * fma(3.0 / 8.0, e, 0.5), m1);
  }

  // 1 / r^3 for r^2 = r2 (softening included): the pair factor without a mass, for kernels
  // that scale it by both masses.
  __device__ inline float inv_cube(float r2)
  {
    const float inv = rsqrtf(r2);
    return inv * (inv * inv);
  }
  __device__ inline double inv_cube(double r2)
  {
    double s, unused;
    pair_factors<false>(r2, 1.0, s, unused);
    return s;
  }

}    // namespace GPU
}    // namespace HSGPU

#endif
