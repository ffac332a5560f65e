// The CUDA gravity engine against the CPU core (double) and a long-double direct sum, in
// every precision mode, for random and clustered particles, open and periodic boxes, with
// and without cutoff and energy/virial, at sizes that are no multiple of any tile.
// Label gpu: skipped where no CUDA device is usable.
#include "core/gravity_pair.h"
#include "gpu/device_info.cuh"
#include "gpu/gravity_engine.h"

#include "../common/gravity_reference.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <string>
#include <vector>

using HSGPU::GPU::GravityArgs;
using HSGPU::GPU::GravityEngine;
using HSGPU::GPU::Precision;

namespace {

struct Case {
  long n;
  bool periodic;
  bool clustered;
  double cut;
  double eps;
  double prd;    // box edge
};

struct Cloud {
  std::vector<double> x, m;
  HSGPU::Gravity::Box box;
};

Cloud make_cloud(const Case &c, unsigned seed)
{
  Cloud s;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> g(0.0, 1.0);
  for (int d = 0; d < 3; ++d) {
    s.box.lo[d] = -0.5 * c.prd + d;
    s.box.prd[d] = c.prd;
    s.box.periodic[d] = c.periodic;
  }
  for (long i = 0; i < c.n; ++i) {
    for (int d = 0; d < 3; ++d) {
      // clustered: a tight cloud near the upper corner, where fp32 coordinates are coarse
      double v = c.clustered ? s.box.lo[d] + 0.9 * c.prd + g(rng) : s.box.lo[d] + c.prd * u(rng);
      if (c.periodic) v = HSGPU::Gravity::wrap_coordinate(v, s.box.lo[d], s.box.prd[d]);
      s.x.push_back(v);
    }
    s.m.push_back(0.1 + u(rng));
  }
  return s;
}

struct Result {
  std::vector<double> f, e, v;
  std::vector<double> fslack, vslack;    // per target: what the half-box image choice can change
};

Result cpu_core(const Cloud &s, const std::vector<long> &tgt, double G, double eps, double cut)
{
  HSGPU::Gravity::Params p{G, eps * eps, cut * cut};
  Result r;
  for (long t : tgt) {
    HSGPU::Gravity::Accum a;
    HSGPU::Gravity::sum_on_target(&s.x[3 * t], s.m[t], t, s.x.data(), s.m.data(), (long) s.m.size(),
                                  s.box, p, a);
    r.f.insert(r.f.end(), a.f, a.f + 3);
    r.e.push_back(a.e);
    r.v.insert(r.v.end(), a.v, a.v + 6);
    // A pair whose separation along a periodic direction is within float rounding of half
    // the box may be taken through either image by fp32 arithmetic: both are nearest to
    // within round-off, and the force flips.  Allow twice that pair's force for it.
    double fs = 0.0, vs = 0.0;
    for (size_t j = 0; j < s.m.size(); ++j) {
      if ((long) j == t) continue;
      bool ambiguous = false;
      double r2 = eps * eps;
      for (int d = 0; d < 3; ++d) {
        const double dd = s.x[3 * j + d] - s.x[3 * t + d];
        r2 += dd * dd;
        if (s.box.periodic[d] &&
            std::fabs(std::fabs(dd) - 0.5 * s.box.prd[d]) < 1e-5 * s.box.prd[d])
          ambiguous = true;
      }
      if (!ambiguous) continue;
      const double fpair = G * s.m[t] * s.m[j] / r2;
      fs += 2.0 * fpair;
      vs += 2.0 * fpair * std::sqrt(r2);
    }
    r.fslack.push_back(fs);
    r.vslack.push_back(vs);
  }
  return r;
}

Result gpu(GravityEngine &eng, Precision prec, const Cloud &s, const std::vector<long> &tgt,
           double G, double eps, double cut, bool ev,
           HSGPU::GPU::GravityShape shape = HSGPU::GPU::GravityShape{0, 0, 0}, int once = 0)
{
  GravityArgs a;
  a.pairs_once = once;
  a.G = G;
  a.eps2 = eps * eps;
  a.cutsq = cut * cut;
  for (int d = 0; d < 3; ++d) {
    a.lo[d] = s.box.lo[d];
    a.prd[d] = s.box.prd[d];
    a.periodic[d] = s.box.periodic[d];
  }
  a.energy_virial = ev;
  Result r;
  r.f.resize(3 * tgt.size());
  r.e.resize(tgt.size());
  r.v.resize(6 * tgt.size());
  eng.set_sources((long) s.m.size(), s.x.data(), s.m.data(), true);
  eng.set_targets((long) tgt.size(), tgt.data());
  eng.compute(prec, a, r.f.data(), r.e.data(), r.v.data(), shape);
  return r;
}

// max (|a - b| - slack) / max |b|, with slack per target spread over its `per` components
double rel_err(const std::vector<double> &a, const std::vector<double> &b,
               const std::vector<double> *slack = nullptr, int per = 1)
{
  double num = 0.0, den = 0.0;
  for (size_t i = 0; i < b.size(); ++i) {
    const double allow = slack ? (*slack)[i / per] : 0.0;
    num = std::max(num, std::fabs(a[i] - b[i]) - allow);
    den = std::max(den, std::fabs(b[i]));
  }
  return den > 0 ? std::max(0.0, num) / den : std::max(0.0, num);
}

double tolerance(Precision p)
{
  switch (p) {
  case Precision::Single:
    return 2e-4;
  case Precision::Mixed:
    return 2e-5;
  default:
    return 1e-12;
  }
}

const char *name(Precision p)
{
  return p == Precision::Single ? "single" : p == Precision::Mixed ? "mixed" : "double";
}

class GravityGpu : public ::testing::TestWithParam<Precision> {
 protected:
  void SetUp() override
  {
    if (!HSGPU::GPU::compiled_with_cuda()) GTEST_SKIP() << "built without CUDA";
    if (HSGPU::GPU::device_count() == 0) GTEST_SKIP() << "no CUDA device on this machine";
    engine = std::make_unique<GravityEngine>(0);
  }
  // scale: how much worse than the default tolerance this case may be (ill-conditioned data)
  void check(const Case &c, bool subset, bool ev, unsigned seed, double scale = 1.0,
             HSGPU::GPU::GravityShape shape = HSGPU::GPU::GravityShape{0, 0, 0})
  {
    const Cloud s = make_cloud(c, seed);
    std::vector<long> tgt;
    for (long i = 0; i < c.n; ++i)
      if (!subset || i % 3 == 1) tgt.push_back(i);
    const double G = 0.7;
    const Result ref = cpu_core(s, tgt, G, c.eps, c.cut);
    const Result got = gpu(*engine, GetParam(), s, tgt, G, c.eps, c.cut, ev, shape, once);
    // pairs_once = 2 runs the pairs-once kernel wherever it applies: all bodies targets,
    // forces only, open box, no cutoff.
    const bool once_applies = once == 2 && !subset && !ev && !c.periodic && c.cut <= 0.0;
    EXPECT_EQ(engine->last_pairs_once(), once_applies) << "pairs once, n=" << c.n;
    const bool fp32 = GetParam() != Precision::Double;
    const double tol = tolerance(GetParam()) * scale;
    const double ef = rel_err(got.f, ref.f, fp32 ? &ref.fslack : nullptr, 3);
    EXPECT_LT(ef, tol) << "forces, n=" << c.n;
    double ee = 0, ev_ = 0;
    if (ev) {
      ee = rel_err(got.e, ref.e);
      ev_ = rel_err(got.v, ref.v, fp32 ? &ref.vslack : nullptr, 6);
      EXPECT_LT(ee, tol) << "energies, n=" << c.n;
      EXPECT_LT(ev_, tol) << "virials, n=" << c.n;
    }
    std::printf("[ GPU %-6s] n=%-6ld %s%s%s%s", name(GetParam()), c.n,
                c.periodic ? "periodic " : "open ", c.clustered ? "clustered " : "random ",
                c.cut > 0 ? "cutoff " : "", subset ? "subset " : "");
    if (engine->last_pairs_once())
      std::printf("pairs once ilp %d ", shape.splits > 0 ? shape.ilp : 0);
    else if (shape.splits > 0)
      std::printf("shape %dx%d splits %d ", shape.block, shape.ilp, shape.splits);
    std::printf("rel.err f %.2e e %.2e v %.2e\n", ef, ee, ev_);
  }
  std::unique_ptr<GravityEngine> engine;
  int once = 0;    // GravityArgs::pairs_once
};

}    // namespace

TEST_P(GravityGpu, TinySystems)
{
  check({1, false, false, 0.0, 0.1, 10.0}, false, true, 1);
  check({2, false, false, 0.0, 0.0, 10.0}, false, true, 2);
  check({3, true, false, 0.0, 0.0, 10.0}, false, true, 3);
}

TEST_P(GravityGpu, RandomOpenBox)
{
  for (long n : {97L, 1000L, 1031L, 4099L})
    check({n, false, false, 0.0, 0.05, 20.0}, false, false, 10 + n);
  check({2053, false, false, 0.0, 0.05, 20.0}, false, true, 11);
}

TEST_P(GravityGpu, RandomPeriodicBox)
{
  for (long n : {257L, 3001L}) check({n, true, false, 0.0, 0.05, 20.0}, false, true, 20 + n);
}

TEST_P(GravityGpu, ClusteredPeriodicNoSoftening)
{
  // Unsoftened close pairs near the far corner: fp32 coordinates there carry about 4e-6
  // absolute error, so single precision is allowed 10x its usual tolerance.
  check({1500, true, true, 0.0, 0.0, 40.0}, false, true, 30,
        GetParam() == Precision::Single ? 10.0 : 1.0);
}

TEST_P(GravityGpu, Cutoff)
{
  check({2500, true, false, 5.0, 0.02, 20.0}, false, true, 40);
  check({2500, false, true, 1.5, 0.02, 20.0}, false, false, 41);
}

TEST_P(GravityGpu, TargetSubsetAsOnOneMpiRank)
{
  check({4097, true, false, 0.0, 0.05, 20.0}, true, true, 50);
  check({4097, false, false, 0.0, 0.05, 20.0}, true, false, 51);
}

TEST_P(GravityGpu, RepeatedCallsReuseBuffersAndGrow)
{
  // Shrinking, growing and repeating must give the same answers as fresh computations.
  for (long n : {3000L, 500L, 6000L, 6000L})
    check({n, false, false, 0.0, 0.05, 20.0}, false, true, 60);
}

// Every launch shape compiled for the force-only open-box kernel (the engine picks among them
// by system size, so the small systems above reach only some), with one and with several
// source ranges, on a size that is no multiple of any tile.
TEST_P(GravityGpu, EveryHotShape)
{
  for (const auto &sh : HSGPU::GPU::HOT_SHAPES)
    for (int splits : {1, 3})
      check({3001, false, false, 0.0, 0.05, 20.0}, false, false, 80, 1.0,
            HSGPU::GPU::GravityShape{sh[0], sh[1], splits});
  // Target subset: blocks whose last targets are missing.
  check({4097, false, false, 0.0, 0.05, 20.0}, true, false, 81, 1.0,
        HSGPU::GPU::GravityShape{256, 4, 2});
}

// The pairs-once kernel (each pair evaluated once for both bodies) with every ILP, on sizes
// that fill no block (padding), down to one body; unsoftened clustered bodies (the pads and
// the self pairs must add nothing); and where it does not apply (energy and virial, periodic
// box, cutoff, a target subset) the engine must fall back.
TEST_P(GravityGpu, PairsOnce)
{
  once = 2;
  for (int ilp : {2, 4, 8})
    check({3001, false, false, 0.0, 0.05, 20.0}, false, false, 100 + ilp, 1.0,
          HSGPU::GPU::GravityShape{0, ilp, 1});
  for (long n : {1L, 2L, 3L, 97L, 1031L})
    check({n, false, false, 0.0, 0.05, 20.0}, false, false, 110);
  // Unsoftened close pairs: single precision as in ClusteredPeriodicNoSoftening; in double
  // the packed x - lo rounds by up to 7e-15 near x - lo = 38, a few 1e-12 of the force of the
  // closest pair, for the one-sided kernels too (checked in the line after).
  const double scale = GetParam() == Precision::Mixed ? 1.0 : 10.0;
  check({2500, false, true, 0.0, 0.0, 40.0}, false, false, 111, scale);
  once = 0;
  check({2500, false, true, 0.0, 0.0, 40.0}, false, false, 111, scale);
  once = 2;
  check({2053, false, false, 0.0, 0.05, 20.0}, false, true, 112);
  check({2053, true, false, 0.0, 0.05, 20.0}, false, false, 113);
  check({2053, false, false, 3.0, 0.05, 20.0}, false, false, 114);
  check({4097, false, false, 0.0, 0.05, 20.0}, true, false, 115);
}

// Many blocks of several slices each (group > 1: sums carried across slices in the partial
// buffer) against the one-sided kernel of the same precision and the double one; and two
// calls give identical bits (fixed summation order, no atomics).
TEST_P(GravityGpu, PairsOnceManyBlocksDeterministic)
{
  const long n = 40000;    // ILP 2: slices of 256, 157 of them: 79 blocks of 2, padded
  const Cloud s = make_cloud({n, false, true, 0.0, 0.01, 40.0}, 120);
  std::vector<long> all(n);
  for (long i = 0; i < n; ++i) all[i] = i;
  const HSGPU::GPU::GravityShape ilp2{0, 2, 1};
  const Result once1 = gpu(*engine, GetParam(), s, all, 1.3, 0.01, 0.0, false, ilp2, 2);
  ASSERT_TRUE(engine->last_pairs_once());
  const Result once2 = gpu(*engine, GetParam(), s, all, 1.3, 0.01, 0.0, false, ilp2, 2);
  const Result twice = gpu(*engine, GetParam(), s, all, 1.3, 0.01, 0.0, false);
  ASSERT_FALSE(engine->last_pairs_once());
  const Result ref = gpu(*engine, Precision::Double, s, all, 1.3, 0.01, 0.0, false);
  long same = 0;
  for (size_t i = 0; i < once1.f.size(); ++i) same += (once1.f[i] == once2.f[i]);
  EXPECT_EQ(same, (long) once1.f.size()) << "two pairs-once calls differ";
  const double e_ref = rel_err(once1.f, ref.f), e_twice = rel_err(twice.f, ref.f);
  EXPECT_LT(e_ref, tolerance(GetParam()));
  // No worse than the one-sided kernel by more than a factor 2 (or round-off in double).
  EXPECT_LT(e_ref, 2.0 * e_twice + 1e-14);
  std::printf("[ GPU %-6s] n=%ld clustered, pairs once ilp 2 against double one-sided: %.2e "
              "(one-sided %s: %.2e); repeat identical\n",
              name(GetParam()), n, e_ref, name(GetParam()), e_twice);
}

// Two bodies at separations from 1e-60 to 1e60, with and without softening: the pair factors
// m / r^3 (force) and m / r (energy) against long double.  In double precision this checks the
// corrected approximate reciprocal square root of the kernels to a few units in the last place.
TEST_P(GravityGpu, PairFactorsAcrossMagnitudes)
{
  const bool fp64 = GetParam() == Precision::Double;
  const double decades = fp64 ? 60.0 : 12.0;    // fp32 covers about 1e-38 .. 1e38
  const double tol = fp64 ? 4e-15 : 2e-6;
  std::mt19937_64 rng(90);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  double worst_f = 0.0, worst_e = 0.0;
  for (int k = 0; k < 400; ++k) {
    const double r = std::pow(10.0, decades * u(rng));
    const double soft = (k % 2) ? 0.0 : 0.7 * r;
    double dir[3] = {u(rng), u(rng), u(rng)};
    const double len = std::sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
    Cloud s;
    for (int d = 0; d < 3; ++d) {
      s.box.lo[d] = -2.0 * r;
      s.box.prd[d] = 4.0 * r;
      s.box.periodic[d] = false;
    }
    s.x = {0.0, 0.0, 0.0, r * dir[0] / len, r * dir[1] / len, r * dir[2] / len};
    s.m = {0.75, 1.25};
    const Result got = gpu(*engine, GetParam(), s, {0, 1}, 1.0, soft, 0.0, true);
    long double r2 = (long double) soft * soft;
    for (int d = 0; d < 3; ++d) r2 += (long double) s.x[3 + d] * s.x[3 + d];
    const long double w = 0.75L * 1.25L / (r2 * sqrtl(r2));
    const long double fmag = w * sqrtl(r2 - (long double) soft * soft);
    for (int d = 0; d < 3; ++d) {
      const long double fd = w * s.x[3 + d];    // on body 0, towards body 1
      worst_f = std::max(worst_f, (double) (fabsl(got.f[d] - fd) / fmag));
      worst_f = std::max(worst_f, (double) (fabsl(got.f[3 + d] + fd) / fmag));
    }
    const long double e = -0.5L * 0.75L * 1.25L / sqrtl(r2);
    worst_e = std::max(worst_e, (double) (fabsl(got.e[0] - e) / fabsl(e)));
  }
  EXPECT_LT(worst_f, tol);
  EXPECT_LT(worst_e, tol);
  std::printf("[ GPU %-6s] two bodies, r = 1e-%g .. 1e%g: max rel.err f %.2e e %.2e\n",
              name(GetParam()), decades, decades, worst_f, worst_e);
}

// Large coordinates: a tight cluster at the far end of a 10^4 box.  The mixed mode keeps the
// digits that single precision loses.
TEST_P(GravityGpu, LargeCoordinatesMixedKeepsDigits)
{
  if (GetParam() == Precision::Single) GTEST_SKIP() << "fp32 positions lose these digits by design";
  // The double reference itself differs from the GPU's (x_j - lo) - (x_i - lo) by the
  // rounding of coordinates near 9000: about 1e-12 absolute on separations of 0.01.
  check({800, false, true, 0.0, 0.01, 1.0e4}, false, true, 70,
        GetParam() == Precision::Double ? 1000.0 : 1.0);
}

// Several MPI ranks: the sums over the rank's own atoms started before the gather of the
// others (begin_own) and finished after it (finish_rest), for a rank at the start, in the
// middle and at the end of the gathered array and one with no atoms; periodic with energy and
// virial, unsoftened (the self pair tested), with a cutoff.  Masses change on the second of
// three calls (the third must find the others' masses on the device).  Against the host's
// double sums, and against the engine's plain compute() of the same targets.
TEST_P(GravityGpu, OwnSourcesFirstAsOnSeveralMpiRanks)
{
  const bool fp32 = GetParam() != Precision::Double;
  const double tol = tolerance(GetParam());
  const double G = 0.7;
  const Case cases[] = {{5003, true, false, 0.0, 0.05, 20.0},
                        {3001, false, true, 0.0, 0.0, 40.0},
                        {4099, true, false, 5.0, 0.02, 20.0}};
  for (const Case &c : cases) {
    Cloud s = make_cloud(c, 200 + (unsigned) c.n);
    const double scale = (c.eps == 0.0 && GetParam() == Precision::Single) ? 10.0 : 1.0;
    const long n = c.n;
    const long ranges[][2] = {{0, n / 4}, {n / 3, n / 2}, {n - n / 5, n}, {n / 2, n / 2}};
    for (const auto &rg : ranges) {
      const long first = rg[0], nown = rg[1] - rg[0];
      std::vector<long> tgt;
      for (long i = first; i < first + nown; ++i) tgt.push_back(i);
      for (int call = 0; call < 3; ++call) {
        if (call == 1)
          for (double &m : s.m) m *= 1.5;
        GravityArgs a;
        a.G = G;
        a.eps2 = c.eps * c.eps;
        a.cutsq = c.cut * c.cut;
        for (int d = 0; d < 3; ++d) {
          a.lo[d] = s.box.lo[d];
          a.prd[d] = s.box.prd[d];
          a.periodic[d] = s.box.periodic[d];
        }
        a.energy_virial = c.periodic;
        Result got;
        got.f.assign(3 * tgt.size(), -1.0);
        got.e.assign(tgt.size(), -1.0);
        got.v.assign(6 * tgt.size(), -1.0);
        engine->set_targets((long) tgt.size(), tgt.data());
        engine->begin_own(GetParam(), a, n, first, nown, s.x.data() + 3 * first,
                          s.m.data() + first, call != 2);
        engine->finish_rest(s.x.data(), s.m.data(), got.f.data(), got.e.data(), got.v.data());
        const Result ref = cpu_core(s, tgt, G, c.eps, c.cut);
        const double ef = rel_err(got.f, ref.f, fp32 ? &ref.fslack : nullptr, 3);
        EXPECT_LT(ef, tol * scale) << "forces, n=" << n << " own " << first << "+" << nown
                                   << " call " << call;
        double ee = 0.0, evv = 0.0;
        if (a.energy_virial) {
          ee = rel_err(got.e, ref.e);
          evv = rel_err(got.v, ref.v, fp32 ? &ref.vslack : nullptr, 6);
          EXPECT_LT(ee, tol) << "energies, n=" << n << " own " << first << "+" << nown;
          EXPECT_LT(evv, tol) << "virials, n=" << n << " own " << first << "+" << nown;
        }
        if (call < 2) continue;
        // The same targets through compute() (after the split calls, so that these saw only
        // their own uploads): the sums in one order, equal to round-off.
        const Result whole = gpu(*engine, GetParam(), s, tgt, G, c.eps, c.cut, a.energy_virial);
        const double ew = rel_err(got.f, whole.f, fp32 ? &ref.fslack : nullptr, 3);
        EXPECT_LT(ew, tol * scale) << "split against compute(), n=" << n;
          std::printf("[ GPU %-6s] n=%-5ld own %5ld+%-5ld %s%s: rel.err f %.2e e %.2e v %.2e, "
                      "against compute() %.2e\n",
                      name(GetParam()), n, first, nown, c.periodic ? "periodic ev" : "open",
                      c.eps == 0.0 ? " unsoftened" : c.cut > 0 ? " cutoff" : "", ef, ee, evv, ew);
      }
    }
  }
  // A target outside the own range is refused, not summed without its self-pair test.
  const Cloud s = make_cloud({100, false, false, 0.0, 0.05, 20.0}, 7);
  std::vector<long> tgt = {10, 60};
  GravityArgs a{};
  a.G = 1.0;
  a.eps2 = 0.01;
  for (int d = 0; d < 3; ++d) {
    a.lo[d] = s.box.lo[d];
    a.prd[d] = s.box.prd[d];
  }
  engine->set_targets(2, tgt.data());
  EXPECT_THROW(engine->begin_own(GetParam(), a, 100, 0, 50, s.x.data(), s.m.data(), true),
               HSGPU::GPU::Error);
}

INSTANTIATE_TEST_SUITE_P(AllPrecisions, GravityGpu,
                         ::testing::Values(Precision::Single, Precision::Mixed, Precision::Double),
                         [](const ::testing::TestParamInfo<Precision> &i) {
                           return std::string(name(i.param));
                         });
