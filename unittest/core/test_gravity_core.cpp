// LAMMPS-free tests of the gravity core (src/HARDSPHERE_GPU/core/gravity_pair.h).
#include "core/gravity_pair.h"

#include "../common/gravity_reference.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

using namespace HSGPU::Gravity;
using hsgpu_test::gravity_reference;

namespace {

struct System {
  std::vector<double> x, m;
  Box box;
};

System random_system(int n, unsigned seed, bool periodic, bool clustered)
{
  System s;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> g(0.0, 0.3);
  for (int d = 0; d < 3; ++d) {
    s.box.lo[d] = -5.0 + d;
    s.box.prd[d] = 10.0 + 2.0 * d;
    s.box.periodic[d] = periodic ? 1 : 0;
  }
  for (int i = 0; i < n; ++i) {
    for (int d = 0; d < 3; ++d) {
      double c = clustered ? s.box.lo[d] + 0.5 * s.box.prd[d] + g(rng)
                           : s.box.lo[d] + s.box.prd[d] * u(rng);
      s.x.push_back(c);
    }
    s.m.push_back(0.2 + 2.0 * u(rng));
  }
  return s;
}

void compare_to_reference(const System &s, double G, double eps, double cut)
{
  const long n = (long) s.m.size();
  Params p{G, eps * eps, cut * cut};
  const auto ref = gravity_reference(s.x, s.m, G, eps, cut, s.box.prd, s.box.periodic);
  double fscale = 0.0;
  for (long i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) fscale = std::max(fscale, (double) std::fabs(ref.f[3 * i + k]));
  double pe = 0.0, vir[6] = {0, 0, 0, 0, 0, 0};
  for (long i = 0; i < n; ++i) {
    Accum a;
    sum_on_target(&s.x[3 * i], s.m[i], i, s.x.data(), s.m.data(), n, s.box, p, a);
    for (int k = 0; k < 3; ++k)
      EXPECT_NEAR(a.f[k], (double) ref.f[3 * i + k], 1e-12 * fscale) << "atom " << i;
    EXPECT_NEAR(a.e, (double) ref.e[i], 1e-12 * std::fabs((double) ref.e[i]));
    pe += a.e;
    for (int k = 0; k < 6; ++k) vir[k] += a.v[k];
  }
  EXPECT_NEAR(pe, (double) ref.pe, 1e-12 * std::fabs((double) ref.pe));
  for (int k = 0; k < 6; ++k)
    EXPECT_NEAR(vir[k], (double) ref.virial[k], 1e-11 * std::fabs((double) ref.virial[0]) + 1e-14);
}

}    // namespace

TEST(GravityCore, WrapCoordinateMapsIntoCell)
{
  EXPECT_DOUBLE_EQ(wrap_coordinate(12.5, 0.0, 10.0), 2.5);
  EXPECT_DOUBLE_EQ(wrap_coordinate(-0.5, 0.0, 10.0), 9.5);
  EXPECT_DOUBLE_EQ(wrap_coordinate(-25.0, -5.0, 10.0), -5.0);
  const double w = wrap_coordinate(-1e-17, 0.0, 10.0);    // rounds to the upper edge
  EXPECT_GE(w, 0.0);
  EXPECT_LT(w, 10.0);
}

TEST(GravityCore, NearestImage)
{
  EXPECT_DOUBLE_EQ(nearest_image(6.0, 10.0, 1), -4.0);
  EXPECT_DOUBLE_EQ(nearest_image(-6.0, 10.0, 1), 4.0);
  EXPECT_DOUBLE_EQ(nearest_image(4.0, 10.0, 1), 4.0);
  EXPECT_DOUBLE_EQ(nearest_image(6.0, 10.0, 0), 6.0);
}

TEST(GravityCore, TwoBodiesAnalytic)
{
  // Two masses 2 and 3 at distance 4 with G = 1.5 and eps = 3: |F| = G m1 m2 r / 5^3.
  System s;
  s.x = {0, 0, 0, 4, 0, 0};
  s.m = {2, 3};
  for (int d = 0; d < 3; ++d) {
    s.box.lo[d] = -50;
    s.box.prd[d] = 100;
    s.box.periodic[d] = 0;
  }
  Params p{1.5, 9.0, 0.0};
  Accum a;
  sum_on_target(&s.x[0], 2.0, 0, s.x.data(), s.m.data(), 2, s.box, p, a);
  EXPECT_DOUBLE_EQ(a.f[0], 1.5 * 6.0 * 4.0 / 125.0);    // pulled towards +x
  EXPECT_DOUBLE_EQ(a.f[1], 0.0);
  EXPECT_DOUBLE_EQ(a.e, 0.5 * (-1.5 * 6.0 / 5.0));
  EXPECT_DOUBLE_EQ(a.v[0], 0.5 * (-4.0) * (1.5 * 6.0 * 4.0 / 125.0));
}

TEST(GravityCore, RandomOpenBoxMatchesLongDouble)
{
  compare_to_reference(random_system(300, 1, false, false), 1.0, 0.01, 0.0);
}

TEST(GravityCore, RandomPeriodicBoxMatchesLongDouble)
{
  compare_to_reference(random_system(300, 2, true, false), 0.7, 0.05, 0.0);
}

TEST(GravityCore, ClusteredNoSofteningMatchesLongDouble)
{
  compare_to_reference(random_system(257, 3, true, true), 1.0, 0.0, 0.0);
}

TEST(GravityCore, CutoffMatchesLongDouble)
{
  compare_to_reference(random_system(300, 4, true, false), 1.0, 0.1, 3.0);
}

TEST(GravityCore, NewtonThirdLaw)
{
  System s = random_system(400, 5, true, true);
  Params p{1.0, 1e-4, 0.0};
  double tot[3] = {0, 0, 0}, mag = 0;
  for (long i = 0; i < 400; ++i) {
    Accum a;
    sum_on_target(&s.x[3 * i], s.m[i], i, s.x.data(), s.m.data(), 400, s.box, p, a);
    for (int k = 0; k < 3; ++k) {
      tot[k] += a.f[k];
      mag += std::fabs(a.f[k]);
    }
  }
  for (int k = 0; k < 3; ++k) EXPECT_LT(std::fabs(tot[k]), 1e-13 * mag);
}
