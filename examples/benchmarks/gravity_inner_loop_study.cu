// Study (prints figures; not part of the package, not a test): variants of the all-pairs
// gravity inner loop on one CUDA device, outside the engine, to see what limits the fp32 and
// fp64 kernels.  Each kernel sums one split of the sources onto ILP targets per thread from
// shared-memory tiles, forces only, open box; time from CUDA events after 2 warm-up calls,
// median of the repeats; error = relative RMS force difference from the first double variant.
//
//   gravity_inner_loop_study [--n 65536,262144] [--reps 5] [--only single|double]
//
// Variants: single_k (the package's fp32 pair arithmetic; B = threads per block, I = targets
// per thread, U = unroll, M = minimum blocks per SM in __launch_bounds__, PF = prefetch the
// next tile), equal_k (all masses taken as 1: 12 instructions per pair, a ceiling, not a
// correct result for unequal masses), scaled_k (mass folded into the coordinates,
// c = m^-1/2, x' = c x: also 12 instructions plus one more shared load), double_k with
// R0 = CUDA's rsqrt, R1 = rsqrt.approx.f64 with a second-order correction (the package's),
// R2 = third order.  probe: largest relative error of m / r^3 over r^2 = 1e-12 .. 1e12.
// Built by CMake with --use_fast_math, like the package's kernels (doc/bench_gravity_gpu.md).
#include <cuda_runtime.h>
#include <cstdio>
#include <cstdlib>
#include <cmath>
#include <vector>
#include <random>
#include <algorithm>
#include <cstring>

#define CK(x)                                                      \
  do {                                                             \
    cudaError_t e_ = (x);                                          \
    if (e_ != cudaSuccess) {                                       \
      printf("CUDA %s at %d\n", cudaGetErrorString(e_), __LINE__); \
      exit(1);                                                     \
    }                                                              \
  } while (0)

struct __align__(32) D4
{
  double x, y, z, w;
};

// ---------------- single
template <int BLOCK, int ILP, int UNROLL, int MINB, bool PF>
__global__ void __launch_bounds__(BLOCK, MINB)
    single_k(const float4 *__restrict__ src, int n, int chunk, float eps2, float *__restrict__ part)
{
  __shared__ float4 sh[BLOCK];
  const int jbeg = blockIdx.y * chunk;
  const int jend = min(n, jbeg + chunk);
  const int first = blockIdx.x * ILP * BLOCK;
  float xi[ILP][3], a[ILP][3];
  for (int q = 0; q < ILP; ++q) {
    const float4 p = src[min(first + q * BLOCK + (int) threadIdx.x, n - 1)];
    xi[q][0] = p.x;
    xi[q][1] = p.y;
    xi[q][2] = p.z;
    a[q][0] = a[q][1] = a[q][2] = 0.f;
  }
  float4 next = make_float4(0, 0, 0, 0);
  if (PF && jbeg + (int) threadIdx.x < jend) next = src[jbeg + threadIdx.x];
  for (int base = jbeg; base < jend; base += BLOCK) {
    const int j = base + threadIdx.x;
    __syncthreads();
    if (PF) {
      sh[threadIdx.x] = (j < jend) ? next : make_float4(0, 0, 1e18f, 0);
      if (j + BLOCK < jend) next = src[j + BLOCK];
    } else {
      sh[threadIdx.x] = (j < jend) ? src[j] : make_float4(0, 0, 1e18f, 0);
    }
    __syncthreads();
#pragma unroll UNROLL
    for (int jj = 0; jj < BLOCK; ++jj) {
      const float4 s = sh[jj];
#pragma unroll
      for (int q = 0; q < ILP; ++q) {
        const float dx = s.x - xi[q][0], dy = s.y - xi[q][1], dz = s.z - xi[q][2];
        const float r2 = fmaf(dx, dx, fmaf(dy, dy, fmaf(dz, dz, eps2)));
        const float inv = rsqrtf(r2);
        const float mi = s.w * inv;
        const float w = mi * (inv * inv);
        a[q][0] = fmaf(w, dx, a[q][0]);
        a[q][1] = fmaf(w, dy, a[q][1]);
        a[q][2] = fmaf(w, dz, a[q][2]);
      }
    }
  }
  for (int q = 0; q < ILP; ++q) {
    const int ti = first + q * BLOCK + threadIdx.x;
    if (ti >= n) continue;
    const long o = (long) blockIdx.y * n + ti;
    part[3 * o] = a[q][0];
    part[3 * o + 1] = a[q][1];
    part[3 * o + 2] = a[q][2];
  }
}

// ---------------- single, equal masses (m factored out): s = inv^3
template <int BLOCK, int ILP, int UNROLL, int MINB>
__global__ void __launch_bounds__(BLOCK, MINB)
    equal_k(const float4 *__restrict__ src, int n, int chunk, float eps2, float *__restrict__ part)
{
  __shared__ float4 sh[BLOCK];
  const int jbeg = blockIdx.y * chunk;
  const int jend = min(n, jbeg + chunk);
  const int first = blockIdx.x * ILP * BLOCK;
  float xi[ILP][3], a[ILP][3];
  for (int q = 0; q < ILP; ++q) {
    const float4 p = src[min(first + q * BLOCK + (int) threadIdx.x, n - 1)];
    xi[q][0] = p.x;
    xi[q][1] = p.y;
    xi[q][2] = p.z;
    a[q][0] = a[q][1] = a[q][2] = 0.f;
  }
  for (int base = jbeg; base < jend; base += BLOCK) {
    const int j = base + threadIdx.x;
    __syncthreads();
    sh[threadIdx.x] = (j < jend) ? src[j] : make_float4(0, 0, 1e18f, 0);
    __syncthreads();
#pragma unroll UNROLL
    for (int jj = 0; jj < BLOCK; ++jj) {
      const float4 s = sh[jj];
#pragma unroll
      for (int q = 0; q < ILP; ++q) {
        const float dx = s.x - xi[q][0], dy = s.y - xi[q][1], dz = s.z - xi[q][2];
        const float r2 = fmaf(dx, dx, fmaf(dy, dy, fmaf(dz, dz, eps2)));
        const float inv = rsqrtf(r2);
        const float w = inv * (inv * inv);
        a[q][0] = fmaf(w, dx, a[q][0]);
        a[q][1] = fmaf(w, dy, a[q][1]);
        a[q][2] = fmaf(w, dz, a[q][2]);
      }
    }
  }
  for (int q = 0; q < ILP; ++q) {
    const int ti = first + q * BLOCK + threadIdx.x;
    if (ti >= n) continue;
    const long o = (long) blockIdx.y * n + ti;
    part[3 * o] = a[q][0];
    part[3 * o + 1] = a[q][1];
    part[3 * o + 2] = a[q][2];
  }
}

// ---------------- single, mass folded into the coordinates:
// c = m^-1/2, x' = c x, E = c^2 eps^2; d' = x'_j - c_j x_i = c_j d; u = rsqrt(|d'|^2 + E)
// = 1/(c_j sqrt(r^2+eps^2)); u^3 d' = m_j d / (r^2+eps^2)^1.5.  12 instructions per pair.
struct Scaled {
  float4 p;
  float e;
};
__device__ __forceinline__ Scaled scale_src(float4 s, float eps2)
{
  const float c = (float) (1.0 / sqrt((double) s.w));
  return Scaled{make_float4(c * s.x, c * s.y, c * s.z, c), eps2 * (c * c)};
}

template <int BLOCK, int ILP, int UNROLL, int MINB>
__global__ void __launch_bounds__(BLOCK, MINB)
    scaled_k(const float4 *__restrict__ src, int n, int chunk, float eps2, float *__restrict__ part)
{
  __shared__ float4 sh[BLOCK];
  __shared__ float se[BLOCK];
  const int jbeg = blockIdx.y * chunk;
  const int jend = min(n, jbeg + chunk);
  const int first = blockIdx.x * ILP * BLOCK;
  float xi[ILP][3], a[ILP][3];
  for (int q = 0; q < ILP; ++q) {
    const float4 p = src[min(first + q * BLOCK + (int) threadIdx.x, n - 1)];
    xi[q][0] = p.x;
    xi[q][1] = p.y;
    xi[q][2] = p.z;
    a[q][0] = a[q][1] = a[q][2] = 0.f;
  }
  for (int base = jbeg; base < jend; base += BLOCK) {
    const int j = base + threadIdx.x;
    __syncthreads();
    if (j < jend) {
      const Scaled s = scale_src(src[j], eps2);
      sh[threadIdx.x] = s.p;
      se[threadIdx.x] = s.e;
    } else {
      sh[threadIdx.x] = make_float4(0, 0, 1e18f, 1.f);
      se[threadIdx.x] = 1.f;
    }
    __syncthreads();
#pragma unroll UNROLL
    for (int jj = 0; jj < BLOCK; ++jj) {
      const float4 s = sh[jj];
      const float e = se[jj];
#pragma unroll
      for (int q = 0; q < ILP; ++q) {
        const float dx = fmaf(-s.w, xi[q][0], s.x), dy = fmaf(-s.w, xi[q][1], s.y),
                    dz = fmaf(-s.w, xi[q][2], s.z);
        const float r2 = fmaf(dx, dx, fmaf(dy, dy, fmaf(dz, dz, e)));
        const float u = rsqrtf(r2);
        const float w = u * (u * u);
        a[q][0] = fmaf(w, dx, a[q][0]);
        a[q][1] = fmaf(w, dy, a[q][1]);
        a[q][2] = fmaf(w, dz, a[q][2]);
      }
    }
  }
  for (int q = 0; q < ILP; ++q) {
    const int ti = first + q * BLOCK + threadIdx.x;
    if (ti >= n) continue;
    if (ti >= jbeg && ti < jend) {    // take out the self pair, computed exactly as in the loop
      const Scaled s = scale_src(src[ti], eps2);
      const float dx = fmaf(-s.p.w, xi[q][0], s.p.x), dy = fmaf(-s.p.w, xi[q][1], s.p.y),
                  dz = fmaf(-s.p.w, xi[q][2], s.p.z);
      const float r2 = fmaf(dx, dx, fmaf(dy, dy, fmaf(dz, dz, s.e)));
      const float u = rsqrtf(r2);
      const float w = u * (u * u);
      a[q][0] -= w * dx;
      a[q][1] -= w * dy;
      a[q][2] -= w * dz;
    }
    const long o = (long) blockIdx.y * n + ti;
    part[3 * o] = a[q][0];
    part[3 * o + 1] = a[q][1];
    part[3 * o + 2] = a[q][2];
  }
}

// ---------------- double
__device__ __forceinline__ double rsq_approx(double x)
{
  double y;
  asm("rsqrt.approx.ftz.f64 %0, %1;" : "=d"(y) : "d"(x));
  return y;
}

// RSQ 0: m * rsqrt(r2)^3 with CUDA's rsqrt.  RSQ 1: approximation y0, e = 1 - r2 y0^2,
// m y0^3 (1 + 3/2 e + 15/8 e^2).  RSQ 2: as 1 plus the 35/16 e^3 term.
template <int RSQ> __device__ __forceinline__ double mr3(double r2, double m)
{
  if (RSQ == 0) {
    const double inv = rsqrt(r2);
    return (m * inv) * (inv * inv);
  } else {
    const double y = rsq_approx(r2);
    const double y2 = y * y;
    const double e = fma(-r2, y2, 1.0);
    const double m3 = m * (y2 * y);
    double q = fma(15.0 / 8.0, e, 1.5);
    if (RSQ == 2) q = fma(fma(35.0 / 16.0, e, 15.0 / 8.0), e, 1.5);
    return fma(m3, e * q, m3);
  }
}

template <int BLOCK, int ILP, int UNROLL, int MINB, int RSQ>
__global__ void __launch_bounds__(BLOCK, MINB)
    double_k(const D4 *__restrict__ src, int n, int chunk, double eps2, double *__restrict__ part)
{
  __shared__ D4 sh[BLOCK];
  const int jbeg = blockIdx.y * chunk;
  const int jend = min(n, jbeg + chunk);
  const int first = blockIdx.x * ILP * BLOCK;
  double xi[ILP][3], a[ILP][3];
  for (int q = 0; q < ILP; ++q) {
    const D4 p = src[min(first + q * BLOCK + (int) threadIdx.x, n - 1)];
    xi[q][0] = p.x;
    xi[q][1] = p.y;
    xi[q][2] = p.z;
    a[q][0] = a[q][1] = a[q][2] = 0.0;
  }
  for (int base = jbeg; base < jend; base += BLOCK) {
    const int j = base + threadIdx.x;
    __syncthreads();
    sh[threadIdx.x] = (j < jend) ? src[j] : D4{0, 0, 1e150, 0};
    __syncthreads();
#pragma unroll UNROLL
    for (int jj = 0; jj < BLOCK; ++jj) {
      const D4 s = sh[jj];
#pragma unroll
      for (int q = 0; q < ILP; ++q) {
        const double dx = s.x - xi[q][0], dy = s.y - xi[q][1], dz = s.z - xi[q][2];
        const double r2 = fma(dx, dx, fma(dy, dy, fma(dz, dz, eps2)));
        const double w = mr3<RSQ>(r2, s.w);
        a[q][0] = fma(w, dx, a[q][0]);
        a[q][1] = fma(w, dy, a[q][1]);
        a[q][2] = fma(w, dz, a[q][2]);
      }
    }
  }
  for (int q = 0; q < ILP; ++q) {
    const int ti = first + q * BLOCK + threadIdx.x;
    if (ti >= n) continue;
    const long o = (long) blockIdx.y * n + ti;
    part[3 * o] = a[q][0];
    part[3 * o + 1] = a[q][1];
    part[3 * o + 2] = a[q][2];
  }
}

template <int RSQ> __global__ void rsq_probe(const double *r2, const double *m, double *out, int n)
{
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) out[i] = mr3<RSQ>(r2[i], m[i]);
}

// ---------------- host
static int g_sms = 132;

template <class T, class P>
double time_launch(void (*kern)(const T *, int, int, decltype(P() * 1.0f), P *), int block, int ilp,
                   int n, const T *src, P *part, double eps2, int reps, int &splits_out)
{
  const int groups = (n + block * ilp - 1) / (block * ilp);
  int want = std::max(1, (16 * g_sms + groups - 1) / groups);
  int most = std::max(1, n / (4 * block));
  int splits = std::min(std::min(want, most), 1024);
  int chunk = ((n + splits - 1) / splits + block - 1) / block * block;
  splits = (n + chunk - 1) / chunk;
  splits_out = splits;
  dim3 grid(groups, splits);
  cudaEvent_t a, b;
  CK(cudaEventCreate(&a));
  CK(cudaEventCreate(&b));
  std::vector<float> t;
  for (int r = 0; r < reps + 2; ++r) {
    CK(cudaEventRecord(a));
    kern<<<grid, block>>>(src, n, chunk, (decltype(P() * 1.0f)) eps2, part);
    CK(cudaEventRecord(b));
    CK(cudaEventSynchronize(b));
    CK(cudaGetLastError());
    float ms;
    CK(cudaEventElapsedTime(&ms, a, b));
    if (r >= 2) t.push_back(ms);
  }
  std::sort(t.begin(), t.end());
  CK(cudaEventDestroy(a));
  CK(cudaEventDestroy(b));
  return t[t.size() / 2];
}

struct Data {
  int n;
  float4 *s32;
  D4 *s64;
  float *p32;
  double *p64;
  std::vector<double> x, m;
};

// sum of split partials for target i on the host
template <class P> void fetch(const P *dpart, int n, int splits, std::vector<double> &f)
{
  std::vector<P> h((size_t) 3 * n * splits);
  CK(cudaMemcpy(h.data(), dpart, h.size() * sizeof(P), cudaMemcpyDeviceToHost));
  f.assign(3 * (size_t) n, 0.0);
  for (int s = 0; s < splits; ++s)
    for (size_t k = 0; k < 3 * (size_t) n; ++k) f[k] += (double) h[(size_t) s * 3 * n + k];
}

static int g_reps = 5;
static std::vector<double> g_ref;    // double RSQ0 forces for error columns

template <class T, class P>
void run(const char *name, void (*kern)(const T *, int, int, decltype(P() * 1.0f), P *), int block,
         int ilp, Data &d, const T *src, P *part, bool set_ref = false)
{
  int splits;
  const double ms = time_launch(kern, block, ilp, d.n, src, part, 1e-4, g_reps, splits);
  std::vector<double> f;
  fetch(part, d.n, splits, f);
  double num = 0, den = 0;
  if (set_ref) g_ref = f;
  for (size_t k = 0; k < f.size(); ++k) {
    num += (f[k] - g_ref[k]) * (f[k] - g_ref[k]);
    den += g_ref[k] * g_ref[k];
  }
  std::printf("| %d | %s | %d | %d | %d | %.4f | %.4e | %.1e |\n", d.n, name, block, ilp, splits,
              ms, (double) d.n * (d.n - 1) / (ms * 1e-3), std::sqrt(num / den));
  std::fflush(stdout);
}

#define S(B, I, U, M, PF)                                                                        \
  run("single B" #B " I" #I " U" #U " M" #M " PF" #PF, single_k<B, I, U, M, PF>, B, I, d, d.s32, \
      d.p32)
#define EQ(B, I, U, M) \
  run("equal B" #B " I" #I " U" #U " M" #M, equal_k<B, I, U, M>, B, I, d, d.s32, d.p32)
#define SC(B, I, U, M) \
  run("scaled B" #B " I" #I " U" #U " M" #M, scaled_k<B, I, U, M>, B, I, d, d.s32, d.p32)
#define DB(B, I, U, M, R, REF)                                                                \
  run("double B" #B " I" #I " U" #U " M" #M " R" #R, double_k<B, I, U, M, R>, B, I, d, d.s64, \
      d.p64, REF)

void probe()
{
  // pair factor m / r^3 against long double over r^2 = 10^-12 .. 10^12
  const int n = 1 << 20;
  std::vector<double> r2(n), m(n, 1.0), o0(n), o1(n), o2(n);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-12.0, 12.0);
  for (int i = 0; i < n; ++i) r2[i] = std::pow(10.0, u(rng));
  double *dr, *dm, *dout;
  CK(cudaMalloc(&dr, n * 8));
  CK(cudaMalloc(&dm, n * 8));
  CK(cudaMalloc(&dout, n * 8));
  CK(cudaMemcpy(dr, r2.data(), n * 8, cudaMemcpyHostToDevice));
  CK(cudaMemcpy(dm, m.data(), n * 8, cudaMemcpyHostToDevice));
  rsq_probe<0><<<n / 256, 256>>>(dr, dm, dout, n);
  CK(cudaMemcpy(o0.data(), dout, n * 8, cudaMemcpyDeviceToHost));
  rsq_probe<1><<<n / 256, 256>>>(dr, dm, dout, n);
  CK(cudaMemcpy(o1.data(), dout, n * 8, cudaMemcpyDeviceToHost));
  rsq_probe<2><<<n / 256, 256>>>(dr, dm, dout, n);
  CK(cudaMemcpy(o2.data(), dout, n * 8, cudaMemcpyDeviceToHost));
  double e0 = 0, e1 = 0, e2 = 0;
  for (int i = 0; i < n; ++i) {
    const long double ref = 1.0L / (sqrtl((long double) r2[i]) * (long double) r2[i]);
    e0 = std::max(e0, (double) fabsl((o0[i] - ref) / ref));
    e1 = std::max(e1, (double) fabsl((o1[i] - ref) / ref));
    e2 = std::max(e2, (double) fabsl((o2[i] - ref) / ref));
  }
  std::printf(
      "probe m/r^3 max rel error (2^20 r^2 in 1e-12..1e12): rsqrt %.3e, poly2 %.3e, poly3 %.3e\n",
      e0, e1, e2);
  CK(cudaFree(dr));
  CK(cudaFree(dm));
  CK(cudaFree(dout));
}

int main(int argc, char **argv)
{
  std::vector<int> ns = {65536, 262144};
  const char *which = "all";
  for (int i = 1; i < argc; ++i) {
    if (!strcmp(argv[i], "--n")) {
      ns.clear();
      char *p = argv[++i];
      while (*p) {
        ns.push_back(strtol(p, &p, 10));
        if (*p == ',') ++p;
      }
    } else if (!strcmp(argv[i], "--reps"))
      g_reps = atoi(argv[++i]);
    else if (!strcmp(argv[i], "--only"))
      which = argv[++i];
  }
  cudaDeviceProp prop;
  CK(cudaGetDeviceProperties(&prop, 0));
  g_sms = prop.multiProcessorCount;
  std::printf("device %s, %d SMs\n", prop.name, g_sms);
  probe();
  std::printf("| N | variant | block | ilp | splits | ms | interactions/s | rel err vs double "
              "|\n|---|---|---|---|---|---|---|---|\n");
  for (int n : ns) {
    Data d;
    d.n = n;
    std::mt19937_64 rng(12345 + n);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    std::vector<float4> h32(n);
    std::vector<D4> h64(n);
    for (int i = 0; i < n; ++i) {
      double p[3] = {u(rng), u(rng), u(rng)};
      double mm = 0.5 + u(rng);
      h32[i] = make_float4((float) p[0], (float) p[1], (float) p[2], (float) mm);
      h64[i] = D4{p[0], p[1], p[2], mm};
    }
    CK(cudaMalloc(&d.s32, n * sizeof(float4)));
    CK(cudaMalloc(&d.s64, n * sizeof(D4)));
    CK(cudaMemcpy(d.s32, h32.data(), n * sizeof(float4), cudaMemcpyHostToDevice));
    CK(cudaMemcpy(d.s64, h64.data(), n * sizeof(D4), cudaMemcpyHostToDevice));
    const size_t pb = (size_t) 3 * n * 1100;
    CK(cudaMalloc(&d.p32, pb * 4));
    CK(cudaMalloc(&d.p64, pb * 8));
    const bool dbl = strcmp(which, "single") != 0, sgl = strcmp(which, "double") != 0;
    DB(256, 1, 8, 1, 0, true);
    if (dbl) {
      DB(256, 1, 8, 1, 1, false);
      DB(256, 1, 8, 1, 2, false);
      DB(128, 2, 8, 1, 1, false);
      DB(256, 2, 4, 1, 1, false);
      DB(256, 1, 16, 1, 1, false);
      DB(256, 1, 8, 2, 1, false);
      DB(256, 1, 8, 4, 1, false);
      DB(128, 1, 8, 1, 1, false);
    }
    if (sgl) {
      S(256, 2, 8, 1, false);
      S(256, 2, 8, 5, false);
      S(256, 2, 8, 6, false);
      S(256, 4, 8, 1, false);
      S(256, 4, 8, 2, false);
      S(256, 4, 4, 3, false);
      S(128, 4, 8, 1, false);
      S(256, 8, 4, 1, false);
      EQ(256, 2, 8, 1);
      EQ(256, 4, 8, 1);
      SC(256, 2, 8, 1);
      SC(256, 2, 8, 5);
      SC(256, 4, 8, 1);
      SC(256, 4, 8, 2);
      SC(256, 4, 4, 3);
      SC(128, 4, 8, 1);
      SC(256, 8, 4, 1);
      SC(512, 4, 8, 1);
    }
    CK(cudaFree(d.s32));
    CK(cudaFree(d.s64));
    CK(cudaFree(d.p32));
    CK(cudaFree(d.p64));
  }
  return 0;
}
