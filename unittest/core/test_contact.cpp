// LAMMPS-free tests of the contact times (src/HARDSPHERE_GPU/core/contact.h) against
// extended-precision references: pairs head-on, oblique, grazing, nearly touching, receding,
// overlapping; walls on parabolas.  Also shows where the textbook root formula fails.
#include "core/contact.h"

#include <gtest/gtest.h>

#include <cfloat>
#include <cmath>
#include <cstdio>
#include <random>

using HSGPU::Contact::never;
using HSGPU::Contact::pair_contact_time;
using HSGPU::Contact::wall_contact_time;

namespace {

// Reference arithmetic: binary128, so that the products of the double inputs are exact
// (106 bits) and r.r - s^2 keeps its digits however nearly the spheres touch.  (x87 long
// double, 64 bits, would not: near contact its r.r - s^2 has only a few correct digits.)
using Quad = __float128;

Quad qsqrt(Quad x)
{
  if (x <= 0) return 0;
  Quad y = std::sqrt((double) x);
  for (int k = 0; k < 3; ++k) y = 0.5 * (y + x / y);
  return y;
}

// Earliest root of |r + v t| = s while approaching, from the exact double inputs.
double ref_pair_time(const double *r, const double *v, double s)
{
  Quad b = 0, rr = 0, vv = 0;
  for (int d = 0; d < 3; ++d) {
    b += (Quad) r[d] * v[d];
    rr += (Quad) r[d] * r[d];
    vv += (Quad) v[d] * v[d];
  }
  if (!(b < 0)) return never();
  const Quad c = rr - (Quad) s * s;
  if (c <= 0) return 0.0;
  const Quad disc = b * b - vv * c;
  if (disc < 0) return never();
  const Quad t = c / (-b + qsqrt(disc));
  // Residual of the reference itself: |r + v t|^2 - s^2 relative to s^2.
  Quad res = 0;
  for (int d = 0; d < 3; ++d)
    res += ((Quad) r[d] + (Quad) v[d] * t) * ((Quad) r[d] + (Quad) v[d] * t);
  res = (res - (Quad) s * s) / ((Quad) s * s);
  if (res < 0) res = -res;
  EXPECT_LT((double) res, 1e-28) << "reference root is not a root";
  return (double) t;
}

// The textbook formula, as usually written, in double.
double textbook_pair_time(const double *r, const double *v, double s)
{
  const double b = r[0] * v[0] + r[1] * v[1] + r[2] * v[2];
  const double c = r[0] * r[0] + r[1] * r[1] + r[2] * r[2] - s * s;
  const double vv = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
  return (-b - std::sqrt(b * b - vv * c)) / vv;
}

double rel_err(double a, double ref)
{
  return std::fabs(a - ref) / std::fabs(ref);
}

}    // namespace

TEST(ContactTime, HeadOn)
{
  const double r[3] = {3.0, 0.0, 0.0}, v[3] = {-2.0, 0.0, 0.0};
  EXPECT_EQ(pair_contact_time(r, v, 1.0), 1.0);
  const double r2[3] = {0.0, -5.5, 0.0}, v2[3] = {0.0, 0.25, 0.0};
  EXPECT_EQ(pair_contact_time(r2, v2, 0.5), 20.0);
}

TEST(ContactTime, Oblique)
{
  const double r[3] = {3.0, 0.5, 0.0}, v[3] = {-1.0, 0.0, 0.0};
  const double t = pair_contact_time(r, v, 1.0);
  EXPECT_NEAR(t, 3.0 - std::sqrt(0.75), 4e-16);
  EXPECT_LT(rel_err(t, ref_pair_time(r, v, 1.0)), 4e-16);
  const double r2[3] = {1.7, -2.3, 0.9}, v2[3] = {-0.8, 1.1, -0.3};
  const double t2 = pair_contact_time(r2, v2, 1.3);
  EXPECT_LT(rel_err(t2, ref_pair_time(r2, v2, 1.3)), 4e-16);
}

TEST(ContactTime, Grazing)
{
  // Impact parameter just below, at and above the contact distance 1.
  const double v[3] = {-1.0, 0.0, 0.0};
  const double below[3] = {4.0, 1.0 - 1e-9, 0.0};
  const double tb = pair_contact_time(below, v, 1.0);
  const double tref = ref_pair_time(below, v, 1.0);
  // Grazing is ill-conditioned: dt/dy = y / sqrt(1 - y^2) ~ 2e4 for impact parameter y, so a
  // relative perturbation eps of the input moves t by ~2e4 eps.  The formula is backward
  // stable: its error stays within that.
  const double cond = 1.0 / std::sqrt(1.0 - (1.0 - 1e-9) * (1.0 - 1e-9));
  EXPECT_LT(rel_err(tb, tref), 4 * DBL_EPSILON * cond);
  const double at[3] = {4.0, 1.0, 0.0};
  EXPECT_EQ(pair_contact_time(at, v, 1.0), 4.0);    // touches tangentially
  const double above[3] = {4.0, 1.0 + 1e-12, 0.0};
  EXPECT_EQ(pair_contact_time(above, v, 1.0), never());
}

TEST(ContactTime, RecedingAndParallelHaveNoEvent)
{
  const double r[3] = {2.0, 0.3, 0.0};
  const double away[3] = {0.5, 0.1, 0.0}, across[3] = {0.0, 0.0, 1.0}, none[3] = {0, 0, 0};
  EXPECT_EQ(pair_contact_time(r, away, 1.0), never());
  EXPECT_EQ(pair_contact_time(r, across, 1.0), never());    // r.v = 0
  EXPECT_EQ(pair_contact_time(r, none, 1.0), never());
}

TEST(ContactTime, OverlappingCollideNowOnlyWhenApproaching)
{
  const double r[3] = {0.9, 0.1, 0.0};
  const double in[3] = {-1.0, 0.0, 0.0}, out[3] = {1.0, 0.0, 0.0};
  EXPECT_EQ(pair_contact_time(r, in, 1.0), 0.0);
  EXPECT_EQ(pair_contact_time(r, out, 1.0), never());
  // Exactly touching and approaching: now.
  const double touch[3] = {1.0, 0.0, 0.0};
  EXPECT_EQ(pair_contact_time(touch, in, 1.0), 0.0);
  // Overlapping by far less than the terms' round-off: the sign is still right.
  const double tiny[3] = {0.6, 0.8 - 0x1p-52, 0.0};
  EXPECT_EQ(pair_contact_time(tiny, in, 1.0), 0.0);
  const double gap[3] = {0.6, 0.8 + 0x1p-52, 0.0};
  EXPECT_GT(pair_contact_time(gap, in, 1.0), 0.0);
}

// Spheres so close that the textbook formula subtracts two nearly equal numbers.
TEST(ContactTime, NearlyTouchingWhereTheTextbookFormulaLosesAllDigits)
{
  // Head-on, gap 2^-52 of the diameter: the textbook formula is off by a third.
  const double r[3] = {1.0 + 0x1p-52, 0.0, 0.0}, v[3] = {-3.0, 0.0, 0.0};
  const double ref = ref_pair_time(r, v, 1.0);
  const double stable = pair_contact_time(r, v, 1.0), book = textbook_pair_time(r, v, 1.0);
  std::printf("[ CONTACT  ] gap 2^-52 head-on: reference %.17g, stable %.17g (rel err %.2g), "
              "textbook %.17g (rel err %.2g)\n",
              ref, stable, rel_err(stable, ref), book, rel_err(book, ref));
  EXPECT_LT(rel_err(stable, ref), 4e-16);
  EXPECT_GT(rel_err(book, ref), 0.1);

  // Random oblique approaches with gaps from 1e-6 to 1e-15 of the contact distance.
  std::mt19937_64 rng(20261121);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  double worst_stable = 0.0, worst_book = 0.0;
  for (int k = 0; k < 2000; ++k) {
    const double s = 0.5 + 0.5 * (u(rng) + 1.0);
    double n[3] = {u(rng), u(rng), u(rng)};
    const double nn = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    const double gap = std::pow(10.0, -6.0 - 9.0 * 0.5 * (u(rng) + 1.0));
    double r[3], v[3];
    for (int d = 0; d < 3; ++d) r[d] = s * (1.0 + gap) * n[d] / nn;
    for (int d = 0; d < 3; ++d) v[d] = -2.0 * r[d] + 0.7 * u(rng);    // approaching
    const double ref = ref_pair_time(r, v, s);
    if (ref == never() || ref == 0.0) continue;
    worst_stable = std::max(worst_stable, rel_err(pair_contact_time(r, v, s), ref));
    worst_book = std::max(worst_book, rel_err(textbook_pair_time(r, v, s), ref));
  }
  std::printf("[ CONTACT  ] 2000 random near contacts: worst rel err stable %.2g, textbook %.2g\n",
              worst_stable, worst_book);
  EXPECT_LT(worst_stable, 1e-14);
  EXPECT_GT(worst_book, 1e-3);
}

TEST(ContactTime, RandomConfigurationsMatchReference)
{
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int hits = 0;
  for (int k = 0; k < 20000; ++k) {
    const double r[3] = {3 * u(rng), 3 * u(rng), 3 * u(rng)};
    const double v[3] = {u(rng), u(rng), u(rng)};
    const double s = 0.2 + std::fabs(u(rng));
    const double ref = ref_pair_time(r, v, s), t = pair_contact_time(r, v, s);
    if (ref == never()) {
      // A miss by less than round-off may count as a (tangential) hit; nothing else may.
      if (t != never()) {
        double b = 0, vv = 0, rr = 0;
        for (int d = 0; d < 3; ++d) {
          b += r[d] * v[d];
          vv += v[d] * v[d];
          rr += r[d] * r[d];
        }
        EXPECT_LT(std::fabs(b * b - vv * (rr - s * s)), 1e-13 * b * b);
      }
      continue;
    }
    ++hits;
    if (ref == 0.0) {
      EXPECT_EQ(t, 0.0);
    } else {
      // Away from grazing the root is well conditioned.
      EXPECT_LT(rel_err(t, ref), 1e-13) << "case " << k;
    }
  }
  EXPECT_GT(hits, 500);
}

// --- walls: g(t) = g0 + g1 t + g2 t^2 / 2 --------------------------------------------------

namespace {

// Reference for the wall event: roots in binary128 (in the cancellation-free form, so that
// they keep their relative accuracy), then the rule "earliest t >= 0 with g <= 0 and g' < 0"
// applied to the candidate times: 0, the roots, and the turning point (where a sphere inside
// the wall turns back in).
double ref_wall_time(double g0, double g1, double g2)
{
  const Quad a = (Quad) g2 / 2, b = g1, c = g0;
  Quad cand[3];
  int nc = 0;
  cand[nc++] = 0;
  if (a == 0) {
    if (b != 0) cand[nc++] = -c / b;
  } else {
    const Quad disc = b * b - 4 * a * c;
    if (disc >= 0) {
      const Quad q = -(b + (b >= 0 ? qsqrt(disc) : -qsqrt(disc))) / 2;
      if (q != 0) {
        cand[nc++] = q / a;
        cand[nc++] = c / q;
      }
    }
  }
  Quad best = -1;
  for (int k = 0; k < nc; ++k) {
    const Quad t = cand[k];
    if (t < 0) continue;
    const Quad g = c + b * t + a * t * t, gp = b + 2 * a * t;
    const Quad scale =
        std::fabs((double) c) + std::fabs((double) (b * t)) + std::fabs((double) (a * t * t));
    if (g <= 1e-28 * scale && gp < 0 && (best < 0 || t < best)) best = t;
  }
  if (a < 0) {
    const Quad tp = -b / (2 * a);
    if (tp >= 0 && c + b * tp + a * tp * tp <= 0 && (best < 0 || tp < best)) best = tp;
  }
  return best < 0 ? never() : (double) best;
}

}    // namespace

TEST(WallContact, FreeFallAndThrows)
{
  // Dropped from a gap of 2 under g = 9.81: t = sqrt(2 h / g).
  EXPECT_NEAR(wall_contact_time(2.0, 0.0, -9.81), std::sqrt(4.0 / 9.81), 1e-16);
  // Thrown up at 3 from gap 0.5: lands at the positive root of 0.5 + 3t - 4.905 t^2.
  const double t = wall_contact_time(0.5, 3.0, -9.81);
  EXPECT_NEAR(t, (3.0 + std::sqrt(9.0 + 2.0 * 9.81 * 0.5)) / 9.81, 1e-15);
  // Moving towards a roof against gravity (g2 > 0): reaches it if fast enough.
  EXPECT_NEAR(wall_contact_time(0.5, -4.0, 9.81), (4.0 - std::sqrt(16.0 - 9.81)) / 9.81, 1e-15);
  EXPECT_EQ(wall_contact_time(0.5, -2.0, 9.81), never());    // turns round before the roof
  // No acceleration: linear.
  EXPECT_EQ(wall_contact_time(3.0, -1.5, 0.0), 2.0);
  EXPECT_EQ(wall_contact_time(3.0, 1.5, 0.0), never());
}

TEST(WallContact, OverlapAndRestingCases)
{
  EXPECT_EQ(wall_contact_time(-1e-3, -1.0, -9.81), 0.0);    // inside, moving in: now
  EXPECT_EQ(wall_contact_time(0.0, -1.0, 0.0), 0.0);        // touching, moving in: now
  EXPECT_EQ(wall_contact_time(0.0, 0.0, -9.81), 0.0);       // at rest on it, pressed in: now
  EXPECT_EQ(wall_contact_time(0.0, 0.0, 0.0), never());     // at rest, no force: never
  EXPECT_EQ(wall_contact_time(0.0, 1.0, 9.81), never());    // leaving, pulled away: never
  // Just bounced (touching, moving out under gravity): back after 2 g1 / g.
  EXPECT_NEAR(wall_contact_time(0.0, 2.0, -9.81), 4.0 / 9.81, 1e-16);
  // Inside by a little, moving out slowly: comes back through at the larger root.
  const double t = wall_contact_time(-1e-6, 0.01, -9.81);
  EXPECT_NEAR(t, (0.01 + std::sqrt(1e-4 - 2.0 * 9.81 * 1e-6)) / 9.81, 1e-17);
  // Inside, moving out too slowly to get out: turns back in at g1 / |g2|.
  EXPECT_NEAR(wall_contact_time(-1e-3, 0.01, -9.81), 0.01 / 9.81, 1e-18);
}

TEST(WallContact, NearlyTouchingFastApproachKeepsDigits)
{
  // Gap 1e-14 closing at 50 under gravity: t ~ 2e-16; the textbook root loses it all.
  const double g0 = 1e-14, g1 = -50.0, g2 = -9.81;
  const double t = wall_contact_time(g0, g1, g2), ref = ref_wall_time(g0, g1, g2);
  const double a = g2 / 2;
  const double book = (-g1 - std::sqrt(g1 * g1 - 4 * a * g0)) / (2 * a);
  std::printf("[ CONTACT  ] wall gap 1e-14 at speed 50: reference %.17g, stable %.17g, textbook "
              "%.17g\n",
              ref, t, book);
  EXPECT_LT(rel_err(t, ref), 4e-16);
  EXPECT_GT(rel_err(book, ref), 1e-3);
}

TEST(WallContact, RandomCasesMatchReference)
{
  std::mt19937_64 rng(99);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int events = 0;
  for (int k = 0; k < 20000; ++k) {
    const double g0 = (k % 3 == 0) ? 1e-3 * u(rng) : u(rng);
    const double g1 = 2.0 * u(rng);
    const double g2 = (k % 7 == 0) ? 0.0 : 10.0 * u(rng);
    const double t = wall_contact_time(g0, g1, g2), ref = ref_wall_time(g0, g1, g2);
    if (ref == never()) {
      EXPECT_EQ(t, never()) << g0 << " " << g1 << " " << g2;
      continue;
    }
    ++events;
    ASSERT_NE(t, never()) << g0 << " " << g1 << " " << g2;
    // Near a double root (a sphere that just reaches the wall before turning round) the root
    // is ill-conditioned: the discriminant g1^2 - 2 g2 g0 cancels.  Allow for that.
    const double disc = std::fabs(g1 * g1 - 2 * g2 * g0);
    const double cond = 1.0 + (disc > 0 ? g1 * g1 / disc : 1e300);
    EXPECT_LE(std::fabs(t - ref), 4 * DBL_EPSILON * cond * ref)
        << g0 << " " << g1 << " " << g2 << " t " << t << " ref " << ref;
  }
  EXPECT_GT(events, 5000);
}

// The horizons of both contact times: a contact sooner than the horizon comes out exactly as
// without it; one later may come out as never() (and does in many cases: the early exit runs).
TEST(ContactHorizon, SoonerContactsAreUnchangedAndLaterOnesMayBeDropped)
{
  std::mt19937_64 rng(2026);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  long dropped_wall = 0, kept_wall = 0, dropped_pair = 0, kept_pair = 0;
  for (int k = 0; k < 40000; ++k) {
    const double h = std::pow(10.0, -3.0 + 3.0 * std::fabs(u(rng)));
    // Walls: gaps from touching to far, under and against gravity, at rest and moving.
    const double g0 = (k % 4 == 0) ? 1e-3 * u(rng) : std::fabs(u(rng)) * std::fabs(u(rng));
    const double g1 = (k % 5 == 0) ? 0.0 : 2.0 * u(rng);
    const double g2 = (k % 7 == 0) ? 0.0 : 10.0 * u(rng);
    const double wt = wall_contact_time(g0, g1, g2), wh = wall_contact_time(g0, g1, g2, h);
    if (wt <= h) {
      ASSERT_EQ(wh, wt) << g0 << " " << g1 << " " << g2 << " h " << h;
      ++kept_wall;
    } else if (wh != wt) {
      ASSERT_EQ(wh, never()) << g0 << " " << g1 << " " << g2 << " h " << h;
      ++dropped_wall;
    }
    // Pairs: centres 0.5 ... 2 apart, contact distance 1.
    const double r[3] = {2 * u(rng), 2 * u(rng), 2 * u(rng)};
    const double v[3] = {u(rng), u(rng), u(rng)};
    const double pt = pair_contact_time(r, v, 1.0), ph = pair_contact_time(r, v, 1.0, 0.0, h);
    if (pt <= h) {
      ASSERT_EQ(ph, pt) << k << " h " << h;
      ++kept_pair;
    } else if (ph != pt) {
      ASSERT_EQ(ph, never()) << k << " h " << h;
      ++dropped_pair;
    }
  }
  std::printf("[ HORIZON  ] walls: %ld contacts within the horizon kept, %ld later ones dropped; "
              "pairs: %ld kept, %ld dropped\n",
              kept_wall, dropped_wall, kept_pair, dropped_pair);
  EXPECT_GT(kept_wall, 1000);
  EXPECT_GT(dropped_wall, 1000);
  EXPECT_GT(kept_pair, 1000);
  EXPECT_GT(dropped_pair, 1000);
}
