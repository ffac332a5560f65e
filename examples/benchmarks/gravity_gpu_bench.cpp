// Benchmark of the all-pairs gravity kernels on one CUDA device (prints figures; not a test).
//
//   gravity_gpu_bench [--nmin 1024] [--nmax 1048576] [--reps 5] [--shapes N[,N...]]
//                     [--device D]
//
// For each N (doubling) and precision: kernel time from CUDA events after two warm-up calls,
// the median of the repeats, as interactions per second (N (N-1) / t); the same for the
// pairs-once kernel ("once": each pair evaluated once for both bodies, so N (N-1) / t counts
// the pair forces delivered, not the pairs evaluated) in each precision, and
// for the energy+virial kernel up to N = 262144; the relative force error
// sqrt(sum |f - f_ref|^2 / sum |f_ref|^2) against the double-precision kernel on all bodies,
// and of the double kernel against a long-double CPU sum on 64 sampled bodies; and the plain
// reference kernel (one body per thread, 256-body tiles, fp32, rsqrtf) as the baseline,
// timed the same way.  --shapes N,... times every launch shape compiled for the force-only
// kernel at each N, with the engine's own number of splits ("auto") and with 1, 4, 16, 32, 64,
// and the pairs-once kernel with ILP 2, 4 and 8, and marks the shape the engine picks (for
// pairs once: when the engine would take it); --nmin 0 then skips the main table.
#include "gpu/device_info.cuh"
#include "gpu/gravity_engine.h"
#include "gpu/gravity_kernels.cuh"

#include <cuda_runtime.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <string>
#include <vector>

using namespace HSGPU::GPU;

namespace {

const char *pname(Precision p)
{
  return p == Precision::Single ? "single" : p == Precision::Mixed ? "mixed" : "double";
}

double median(std::vector<double> v)
{
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

struct Cloud {
  std::vector<double> x, m;
  std::vector<long> all;
};

Cloud make_cloud(long n)
{
  Cloud c;
  std::mt19937_64 rng(12345 + n);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  c.x.resize(3 * n);
  c.m.resize(n);
  c.all.resize(n);
  for (long i = 0; i < n; ++i) {
    for (int d = 0; d < 3; ++d) c.x[3 * i + d] = u(rng);
    c.m[i] = 0.5 + u(rng);
    c.all[i] = i;
  }
  return c;
}

GravityArgs args(bool ev, int pairs_once = 0)
{
  GravityArgs a;
  a.pairs_once = pairs_once;
  a.G = 1.0;
  a.eps2 = 1e-4;
  a.cutsq = 0.0;
  for (int d = 0; d < 3; ++d) {
    a.lo[d] = 0.0;
    a.prd[d] = 1.0;
    a.periodic[d] = 0;
  }
  a.energy_virial = ev;
  return a;
}

// Median kernel time (ms) of reps calls after two warm-up calls.  once: evaluate each pair
// once (GravityArgs::pairs_once = 2); exits if the engine did not.
double time_engine(GravityEngine &eng, Precision p, bool ev, int reps, std::vector<double> &f,
                   GravityShape shape = GravityShape{0, 0, 0}, bool once = false)
{
  const long n = (long) f.size() / 3;
  std::vector<double> e(ev ? n : 0), v(ev ? 6 * n : 0);
  const GravityArgs a = args(ev, once ? 2 : 0);
  std::vector<double> ms;
  for (int r = 0; r < reps + 2; ++r) {
    eng.compute(p, a, f.data(), e.data(), v.data(), shape);
    if (eng.last_pairs_once() != once) {
      std::fprintf(stderr, "the engine %s the pairs-once kernel\n", once ? "did not run" : "ran");
      std::exit(1);
    }
    if (r >= 2) ms.push_back(eng.last_kernel_ms());
  }
  return median(ms);
}

double rel_rms(const std::vector<double> &f, const std::vector<double> &ref)
{
  long double num = 0, den = 0;
  for (size_t i = 0; i < f.size(); ++i) {
    num += (long double) (f[i] - ref[i]) * (f[i] - ref[i]);
    den += (long double) ref[i] * ref[i];
  }
  return (double) std::sqrt(num / den);
}

// Long-double forces on a sample of bodies, compared with f.
double sample_error(const Cloud &c, const std::vector<double> &f, int samples)
{
  const long n = (long) c.m.size();
  const GravityArgs a = args(false);
  long double num = 0, den = 0;
  for (int s = 0; s < samples; ++s) {
    const long i = (long) ((s * 2654435761UL) % (unsigned long) n);
    long double acc[3] = {0, 0, 0};
    for (long j = 0; j < n; ++j) {
      if (j == i) continue;
      long double d[3], r2 = a.eps2;
      for (int k = 0; k < 3; ++k) {
        d[k] = (long double) c.x[3 * j + k] - c.x[3 * i + k];
        r2 += d[k] * d[k];
      }
      const long double w = c.m[j] / (r2 * std::sqrt(r2));
      for (int k = 0; k < 3; ++k) acc[k] += w * d[k];
    }
    for (int k = 0; k < 3; ++k) {
      const long double ref = a.G * c.m[i] * acc[k];
      num += (f[3 * i + k] - ref) * (f[3 * i + k] - ref);
      den += ref * ref;
    }
  }
  return (double) std::sqrt(num / den);
}

#define CHECK(call)                                                    \
  do {                                                                 \
    cudaError_t e_ = (call);                                           \
    if (e_ != cudaSuccess) {                                           \
      std::fprintf(stderr, "%s: %s\n", #call, cudaGetErrorString(e_)); \
      std::exit(1);                                                    \
    }                                                                  \
  } while (0)

double time_reference(const Cloud &c, int reps)
{
  const long n = (long) c.m.size();
  std::vector<float> pos(4 * n);
  for (long i = 0; i < n; ++i) {
    for (int d = 0; d < 3; ++d) pos[4 * i + d] = (float) c.x[3 * i + d];
    pos[4 * i + 3] = (float) c.m[i];
  }
  void *dpos, *dacc;
  CHECK(cudaMalloc(&dpos, 16 * n));
  CHECK(cudaMalloc(&dacc, 16 * n));
  CHECK(cudaMemcpy(dpos, pos.data(), 16 * n, cudaMemcpyHostToDevice));
  cudaEvent_t a, b;
  CHECK(cudaEventCreate(&a));
  CHECK(cudaEventCreate(&b));
  std::vector<double> ms;
  for (int r = 0; r < reps + 2; ++r) {
    CHECK(cudaEventRecord(a));
    CHECK(reference_nbody(dpos, n, 1e-4f, dacc, nullptr));
    CHECK(cudaEventRecord(b));
    CHECK(cudaEventSynchronize(b));
    float t;
    CHECK(cudaEventElapsedTime(&t, a, b));
    if (r >= 2) ms.push_back(t);
  }
  cudaEventDestroy(a);
  cudaEventDestroy(b);
  cudaFree(dpos);
  cudaFree(dacc);
  return median(ms);
}

}    // namespace

int main(int argc, char **argv)
{
  long nmin = 1024, nmax = 1048576;
  std::vector<long> shapes_n;
  int reps = 5, device = 0;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--nmin"))
      nmin = std::atol(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--nmax"))
      nmax = std::atol(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--reps"))
      reps = std::atoi(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--shapes")) {
      for (const char *p = argv[i + 1]; *p;) {
        char *end;
        shapes_n.push_back(std::strtol(p, &end, 10));
        p = (*end == ',') ? end + 1 : end;
        if (end == p && *p) break;
      }
    } else if (!std::strcmp(argv[i], "--device"))
      device = std::atoi(argv[i + 1]);
    else {
      std::fprintf(stderr, "unknown option %s\n", argv[i]);
      return 2;
    }
  }
  if (device_count() == 0) {
    std::printf("no CUDA device: nothing to measure\n");
    return 1;
  }
  std::printf("# device %d: %s\n", device, device_description(device).c_str());
  GravityEngine eng(device);
  const Precision precs[3] = {Precision::Single, Precision::Mixed, Precision::Double};

  if (!shapes_n.empty()) {
    std::printf("\n| N | precision | block | ilp | splits | ms | interactions/s | picked "
                "|\n|---|---|---|---|---|---|---|---|\n");
    const GravityArgs a = args(false);
    for (long n : shapes_n) {
      Cloud c = make_cloud(n);
      eng.set_sources(n, c.x.data(), c.m.data(), true);
      eng.set_targets(n, c.all.data());
      std::vector<double> f(3 * n);
      const int r = (n >= 262144) ? std::min(reps, 3) : reps;
      for (Precision p : precs) {
        const GravityShape pick = choose_shape(p, a, n, n, eng.num_sms());
        for (const auto &sh : HOT_SHAPES)
          for (int splits : {0, 1, 4, 16, 32, 64}) {
            GravityShape s{sh[0], sh[1], splits};
            if (splits == 0) s.splits = auto_splits(s, n, n, eng.num_sms());
            const double ms = time_engine(eng, p, false, r, f, s);
            const bool picked = splits == 0 && pick.block == sh[0] && pick.ilp == sh[1];
            std::printf("| %ld | %s | %d | %d | %s%d | %.3f | %.3e | %s |\n", n, pname(p), sh[0],
                        sh[1], splits == 0 ? "auto " : "", s.splits, ms,
                        (double) n * (n - 1) / (ms * 1e-3), picked ? "yes" : "");
            std::fflush(stdout);
          }
        if (!pairs_once_supported(p, a)) continue;
        const int pick_ilp = pairs_once_layout(p, n).ilp;
        for (int ilp : {2, 4, 8}) {
          const double ms = time_engine(eng, p, false, r, f, GravityShape{0, ilp, 1}, true);
          const bool picked = ilp == pick_ilp && pairs_once_pays(p, n);
          std::printf("| %ld | %s | once | %d | - | %.3f | %.3e | %s |\n", n, pname(p), ilp, ms,
                      (double) n * (n - 1) / (ms * 1e-3), picked ? "yes" : "");
          std::fflush(stdout);
        }
      }
    }
    if (nmin <= 0) return 0;
  }

  std::printf("\n| N | baseline fp32 | single | ratio | single once | ratio | mixed | mixed once "
              "| double | double once | single+EV | mixed+EV | double+EV | err single | err single "
              "once | err mixed | err mixed once | err double | err double once (vs long double) "
              "|\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (long n = nmin; n <= nmax; n *= 2) {
    Cloud c = make_cloud(n);
    eng.set_sources(n, c.x.data(), c.m.data(), true);
    eng.set_targets(n, c.all.data());
    const int r = (n >= 262144) ? std::min(reps, 3) : reps;
    const double pairs = (double) n * (n - 1);
    std::vector<double> f[3], fo[3];
    double rate[3], rate_once[3] = {0, 0, 0}, rate_ev[3] = {0, 0, 0};
    for (int k = 0; k < 3; ++k) {
      f[k].resize(3 * n);
      rate[k] = pairs / (time_engine(eng, precs[k], false, r, f[k]) * 1e-3);
      if (pairs_once_supported(precs[k], args(false))) {
        fo[k].resize(3 * n);
        rate_once[k] =
            pairs /
            (time_engine(eng, precs[k], false, r, fo[k], GravityShape{0, 0, 0}, true) * 1e-3);
      }
      if (n <= 262144) {
        std::vector<double> tmp(3 * n);
        rate_ev[k] = pairs / (time_engine(eng, precs[k], true, r, tmp) * 1e-3);
      }
    }
    const double base = pairs / (time_reference(c, r) * 1e-3);
    std::printf("| %ld | %.3e | %.3e | %.2f | %.3e | %.2f | %.3e | %.3e | %.3e | %.3e | ", n, base,
                rate[0], rate[0] / base, rate_once[0], rate_once[0] / base, rate[1], rate_once[1],
                rate[2], rate_once[2]);
    for (int k = 0; k < 3; ++k) {
      if (rate_ev[k] > 0)
        std::printf("%.3e | ", rate_ev[k]);
      else
        std::printf("- | ");
    }
    std::printf("%.1e | %.1e | %.1e | %.1e | %.1e | %.1e |\n", rel_rms(f[0], f[2]),
                rel_rms(fo[0], f[2]), rel_rms(f[1], f[2]), rel_rms(fo[1], f[2]),
                sample_error(c, f[2], 64), sample_error(c, fo[2], 64));
    std::fflush(stdout);
  }
  return 0;
}
