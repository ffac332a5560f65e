// LAMMPS-free tests of the collision impulse (core/impulse.h) and of carrying out single events
// on the bodies' paths (core/collision_step.h): conservation laws, restitution, the guards,
// wall bounces on the parabola and resting contacts.
#include "core/collision_step.h"
#include "core/impulse.h"

#include <gtest/gtest.h>

#include <cfloat>
#include <cmath>
#include <random>
#include <vector>

using namespace HSGPU::Collide;
using HSGPU::Contact::never;
namespace Impulse = HSGPU::Impulse;

namespace {

struct PairCase {
  double mi, mj, vi[3], vj[3], n[3];
};

PairCase random_pair(std::mt19937_64 &rng)
{
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  PairCase c;
  c.mi = 0.1 + 5.0 * (u(rng) + 1.0);
  c.mj = 0.1 + 5.0 * (u(rng) + 1.0);
  double nn = 0;
  for (int d = 0; d < 3; ++d) {
    c.vi[d] = 3.0 * u(rng);
    c.vj[d] = 3.0 * u(rng);
    c.n[d] = u(rng);
    nn += c.n[d] * c.n[d];
  }
  nn = std::sqrt(nn);
  for (int d = 0; d < 3; ++d) c.n[d] /= nn;
  double vn = 0;
  for (int d = 0; d < 3; ++d) vn += (c.vi[d] - c.vj[d]) * c.n[d];
  if (vn > 0)
    for (int d = 0; d < 3; ++d) c.n[d] = -c.n[d];    // make them approach
  return c;
}

double ke(double m, const double *v)
{
  return 0.5 * m * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
}

}    // namespace

TEST(Impulse, MomentumConservedEnergyLossIsOneMinusESquaredOfNormalKE)
{
  std::mt19937_64 rng(3);
  for (double e : {1.0, 0.9, 0.5, 0.0}) {
    for (int k = 0; k < 1000; ++k) {
      PairCase c = random_pair(rng);
      double vn = 0;
      for (int d = 0; d < 3; ++d) vn += (c.vi[d] - c.vj[d]) * c.n[d];
      const double p0[3] = {c.mi * c.vi[0] + c.mj * c.vj[0], c.mi * c.vi[1] + c.mj * c.vj[1],
                            c.mi * c.vi[2] + c.mj * c.vj[2]};
      const double ke0 = ke(c.mi, c.vi) + ke(c.mj, c.vj);
      const double meff = Impulse::reduced_mass(c.mi, c.mj);
      const double J = Impulse::pair_impulse(vn, meff, e);
      Impulse::apply_pair_impulse(c.vi, c.vj, c.n, J, c.mi, c.mj);
      // Momentum: conserved up to the rounding of the velocity updates and of the sums
      // themselves, a few ulps of the largest momentum involved.
      double vn1 = 0;
      for (int d = 0; d < 3; ++d) {
        vn1 += (c.vi[d] - c.vj[d]) * c.n[d];
        const double p1 = c.mi * c.vi[d] + c.mj * c.vj[d];
        const double pscale = c.mi * std::fabs(c.vi[d]) + c.mj * std::fabs(c.vj[d]) +
                              std::fabs(J * c.n[d]) + std::fabs(p0[d]);
        EXPECT_NEAR(p1, p0[d], 4 * DBL_EPSILON * pscale) << "momentum, e = " << e;
      }
      const double ke1 = ke(c.mi, c.vi) + ke(c.mj, c.vj);
      const double loss = Impulse::energy_loss(vn, meff, e);
      EXPECT_NEAR(loss, 0.5 * (1 - e * e) * meff * vn * vn, 1e-15 * ke0);
      EXPECT_NEAR(ke0 - ke1, loss, 1e-14 * ke0) << "energy, e = " << e;
      if (e == 1.0) {
        EXPECT_NEAR(ke1, ke0, 1e-14 * ke0);
      }
      EXPECT_NEAR(vn1, -e * vn, 1e-14 * std::fabs(vn) + 1e-15);
    }
  }
}

TEST(Impulse, GuardsMakeCollisionsElastic)
{
  // TC model: either partner's previous collision less than tc ago.
  EXPECT_EQ(Impulse::effective_restitution(0.5, 0.2, 5.0, 1.0, -3.0, 0.0), 1.0);
  EXPECT_EQ(Impulse::effective_restitution(0.5, 5.0, 0.2, 1.0, -3.0, 0.0), 1.0);
  EXPECT_EQ(Impulse::effective_restitution(0.5, 5.0, 5.0, 1.0, -3.0, 0.0), 0.5);
  // Elastic threshold on |vn|.
  EXPECT_EQ(Impulse::effective_restitution(0.5, 5.0, 5.0, 1.0, -0.01, 0.1), 1.0);
  EXPECT_EQ(Impulse::effective_restitution(0.5, 5.0, 5.0, 1.0, -0.2, 0.1), 0.5);
}

// --- single events on the paths ------------------------------------------------------------

namespace {

Body make_body(long id, const double *x, const double *v, const double *a, double r, double m)
{
  Body b{};
  for (int d = 0; d < 3; ++d) {
    b.x[d] = b.X0[d] = x[d];
    b.v[d] = v[d];
    b.a[d] = a[d];
    b.rest[d] = -1;
  }
  b.tref = 0.0;
  b.radius = r;
  b.mass = m;
  b.tlast = -1e30;
  b.exc2 = 0.0;
  b.id = id;
  b.type = 1;
  b.nevents = 0;
  return b;
}

struct Stepper {
  double epair[4] = {1, 1, 1, 1};
  Params p{};
  Stepper(double dt, double e)
  {
    epair[3] = e;
    p.dt = dt;
    p.tc = 0.0;
    p.vmin = 0.0;
    p.ntypes = 1;
    p.epair = epair;
    p.maxevents = 1000000;
    for (int f = 0; f < NFACES; ++f) {
      p.walls.on[f] = 0;
      p.walls.pos[f] = 0.0;
      p.walls.e[f] = 1.0;
    }
  }
};

}    // namespace

TEST(CollisionStep, HeadOnPairOnDriftLines)
{
  Stepper s(1.0, 0.8);
  const double a0[3] = {0, 0, 0};
  const double xi[3] = {0, 0, 0}, vi[3] = {1, 0, 0}, xj[3] = {3, 0, 0}, vj[3] = {-1, 0, 0};
  Body bi = make_body(1, xi, vi, a0, 0.5, 1.0), bj = make_body(2, xj, vj, a0, 0.5, 3.0);
  Edge e{0, 1, {0, 0, 0}};
  const double t = pair_event_time(bi, bj, e, 5.0);
  EXPECT_EQ(t, 1.0);    // gap 2 closing at 2
  Tally tally;
  s.p.dt = 5.0;
  process_pair(bi, bj, e, t, s.p, tally);
  // Analytic: vcm = (1 - 3)/4 = -0.5; relative -2 -> +1.6 along x (i is at lower x, n = -x).
  EXPECT_NEAR(bi.v[0], -0.5 - 0.75 * 1.6, 1e-15);
  EXPECT_NEAR(bj.v[0], -0.5 + 0.25 * 1.6, 1e-15);
  EXPECT_EQ(bi.x[0], 1.0);
  EXPECT_EQ(bj.x[0], 2.0);
  EXPECT_EQ(tally.pair, 1);
  EXPECT_NEAR(tally.ke_lost, 0.5 * (1 - 0.64) * 0.75 * 4.0, 1e-15);
  // Virial: r = x_i - x_j = -1 along x, impulse on i = m_i dv_i = -2.7: r dp = 2.7.
  EXPECT_NEAR(tally.virial[0], 2.7, 1e-15);
  for (int k = 1; k < 6; ++k) EXPECT_EQ(tally.virial[k], 0.0);
  EXPECT_EQ(pair_event_time(bi, bj, e, 5.0), never());
}

TEST(CollisionStep, WallBounceOnParabolaKeepsPathContinuous)
{
  // Floor at z = 0, ball of radius 0.5 at z = 2.5 falling from rest under g = 2 in a step of
  // dt = 2: contact when the centre reaches 0.5, after sqrt(2 * 2 / 2) = sqrt(2).
  const double dt = 2.0, g = 2.0, e = 0.5;
  Stepper s(dt, 1.0);
  s.p.walls.on[4] = 1;
  s.p.walls.e[4] = e;
  const double a[3] = {0, 0, -g};
  // Integrator: vh = u0 + a dt/2, drift start x0.
  const double x0[3] = {0, 0, 2.5}, vh[3] = {0, 0, -g * dt / 2};
  Body b = make_body(7, x0, vh, a, 0.5, 2.0);
  int face = -1;
  const double t = wall_event_time(b, s.p.walls, dt, face);
  EXPECT_EQ(face, 4);
  EXPECT_NEAR(t, std::sqrt(2.0), 1e-15);
  Tally tally;
  process_wall(b, face, t, s.p, tally);
  // True velocity before: -g t; after: +e g t.  Path continuous: z(t) = 0.5.
  const double u = b.v[2] + b.a[2] * (t - dt / 2);
  EXPECT_NEAR(u, e * g * t, 1e-14);
  EXPECT_NEAR(b.x[2] + bow(b, 2, t, dt), 0.5, 1e-15);
  EXPECT_NEAR(tally.ke_lost, 0.5 * 2.0 * (1 - e * e) * (g * t) * (g * t), 1e-14);
  EXPECT_NEAR(tally.virial[2], 2.0 * (1 + e) * g * t * 0.5, 1e-14);
  // Next floor contact 2 u / g later: after the end of this step.
  EXPECT_EQ(wall_event_time(b, s.p.walls, dt, face), never());
  // The state handed back lies on the exact parabola after the bounce.
  double xe[3], ve[3];
  end_of_step(b, dt, xe, ve);
  const double h = dt - t;
  EXPECT_NEAR(xe[2], 0.5 + u * h - 0.5 * g * h * h, 1e-15);
  EXPECT_NEAR(ve[2] + a[2] * dt / 2, u - g * h, 1e-15);    // after the second half kick
}

TEST(CollisionStep, BallAtRestOnTheFloorHopsBackToContactAtTheEndOfTheStep)
{
  // A ball touching the floor at rest: pressed in by gravity, it rests: it leaves with the
  // normal speed that brings it back to the contact point at the end of the step.
  const double dt = 0.01, g = 9.81;
  Stepper s(dt, 1.0);
  s.p.walls.on[4] = 1;
  s.p.walls.e[4] = 0.7;
  s.p.tc = dt / 10;
  const double a[3] = {0.3, 0, -g};
  const double x0[3] = {1.0, 0, 0.5}, vh[3] = {0.1 + 0.3 * dt / 2, 0, -g * dt / 2};
  Body b = make_body(3, x0, vh, a, 0.5, 1.0);
  int face = -1;
  const double t = wall_event_time(b, s.p.walls, dt, face);
  EXPECT_EQ(face, 4);
  EXPECT_EQ(t, 0.0);
  Tally tally;
  process_wall(b, face, t, s.p, tally);
  EXPECT_EQ(b.rest[2], 4);
  EXPECT_EQ(tally.rest, 1);
  EXPECT_EQ(tally.wall, 1);
  // It does not hit the floor again within the step (it lands exactly at its end).
  EXPECT_EQ(wall_event_time(b, s.p.walls, dt, face), never());
  double xe[3], ve[3];
  end_of_step(b, dt, xe, ve);
  EXPECT_NEAR(xe[2], 0.5, 1e-16);
  EXPECT_NEAR(ve[2] + a[2] * dt / 2, -g * dt / 2, 1e-16);    // after the second half kick
  // Its height stayed above the contact point throughout: the hop's apex is g dt^2 / 8 up.
  double top = 0;
  for (int k = 1; k < 100; ++k) {
    const double tk = dt * k / 100.0;
    double p[3];
    drift_position(b, tk, p);
    const double z = p[2] + bow(b, 2, tk, dt);
    EXPECT_GE(z, 0.5 - 1e-16);
    top = std::max(top, z - 0.5);
  }
  EXPECT_NEAR(top, g * dt * dt / 8, 1e-3 * g * dt * dt);
  // Sideways motion is untouched.
  EXPECT_NEAR(xe[0], 1.0 + vh[0] * dt, 1e-16);
  EXPECT_EQ(ve[0], vh[0]);
  // The hop's impulse m g dt / 2 with the lever 0.5 enters the virial.
  EXPECT_NEAR(tally.virial[2], g * dt / 2 * 0.5, 1e-15);
}

TEST(CollisionStep, PairCollisionReenablesTheWallOfARestingBall)
{
  const double dt = 0.1, g = 1.0;
  Stepper s(dt, 1.0);
  s.p.walls.on[4] = 1;
  s.p.tc = dt;
  const double a[3] = {0, 0, -g};
  const double xb[3] = {0, 0, 0.5}, vb[3] = {0, 0, -g * dt / 2};
  // A ball (id 0) coming down fast from above at an angle will push b into the floor.
  const double xo[3] = {-0.3, 0, 1.8}, vo[3] = {0, 0, -10};
  std::vector<Body> bs = {make_body(0, xo, vo, a, 0.5, 1.0), make_body(1, xb, vb, a, 0.5, 1.0)};
  int face;
  Tally tally;
  process_wall(bs[1], 4, wall_event_time(bs[1], s.p.walls, dt, face), s.p, tally);
  ASSERT_EQ(bs[1].rest[2], 4);
  Edge e{0, 1, {0, 0, 0}};
  const double t = pair_event_time(bs[0], bs[1], e, dt);
  ASSERT_LT(t, dt);
  process_pair(bs[0], bs[1], e, t, s.p, tally);
  EXPECT_EQ(bs[1].rest[2], -1);
  // Pushed down from its hop: its next event is the floor, within the step.
  EXPECT_LT(bs[1].v[2] + bs[1].a[2] * (t - dt / 2), 0.0);
  const double tw = wall_event_time(bs[1], s.p.walls, dt, face);
  EXPECT_EQ(face, 4);
  EXPECT_GT(tw, t);
  EXPECT_LT(tw, dt);
  process_wall(bs[1], face, tw, s.p, tally);
  const double u = bs[1].v[2] + bs[1].a[2] * (tw - dt / 2);
  EXPECT_GT(u, 0.0);
  EXPECT_EQ(tally.pair, 1);
  EXPECT_EQ(tally.wall, 2);
}

// Pair forces give the partners different accelerations: the impulse uses the true normal
// relative velocity u = vh + a (t - dt/2) (second-order accurate), but never less than what
// stops the drift lines' approach (no overlap at the end of the step).
TEST(CollisionStep, UnequalAccelerationsUseTheTrueRelativeVelocity)
{
  const double dt = 1.0, zero[3] = {0, 0, 0};
  Stepper s(dt, 0.5);
  const double xi[3] = {-1, 0, 0}, vi[3] = {1, 0, 0}, xj[3] = {0, 0, 0};
  Edge e{0, 1, {0, 0, 0}};
  {
    // a_i = -1 along x: truly approaching at 1.5 at t = 0 (drift: 1).
    const double ai[3] = {-1, 0, 0};
    Body bi = make_body(1, xi, vi, ai, 0.5, 1.0), bj = make_body(2, xj, zero, zero, 0.5, 1.0);
    const double t = pair_event_time(bi, bj, e, dt);
    ASSERT_EQ(t, 0.0);
    Tally tally;
    process_pair(bi, bj, e, t, s.p, tally);
    const double ut_out = (bi.v[0] + ai[0] * (t - dt / 2)) - bj.v[0];
    EXPECT_NEAR(ut_out, -0.5 * 1.5, 1e-15);    // -e times the true approach speed
    EXPECT_NEAR(tally.ke_lost, 0.5 * (1 - 0.25) * 0.5 * 1.5 * 1.5, 1e-15);
  }
  {
    // a_i = +3 along x: truly separating already (u_i = -0.5), approaching on the drift lines:
    // the impulse just stops the drift approach.
    const double ai[3] = {3, 0, 0};
    Body bi = make_body(1, xi, vi, ai, 0.5, 1.0), bj = make_body(2, xj, zero, zero, 0.5, 1.0);
    const double t = pair_event_time(bi, bj, e, dt);
    ASSERT_EQ(t, 0.0);
    Tally tally;
    process_pair(bi, bj, e, t, s.p, tally);
    EXPECT_NEAR(bi.v[0] - bj.v[0], 0.0, 1e-15);
    EXPECT_EQ(pair_event_time(bi, bj, e, dt), never());
  }
}

// vmin auto and the slow-collision criterion: speed thresholds of |a| tc', with
// tc' = min(tc, SPEED_TC_CAP sqrt(d / |a|)), so that they follow the field at small timesteps and
// stop growing at large ones.
TEST(CollisionStep, SpeedThresholdsFollowTheFieldAndStopGrowingWithTheTimestep)
{
  Params p{};
  p.vmin = 0.0;
  p.vmin_atc = VMIN_AUTO_ATC;
  // Small timestep (tc = 0.001): the cap 0.005 sqrt(1 / 1) does not bind.
  p.tc = 0.001;
  EXPECT_DOUBLE_EQ(elastic_threshold(p, 1.0, speed_tc(p.tc, 1.0, 1.0)),
                   VMIN_AUTO_ATC * 1.0 * 0.001);
  // Large timestep (tc = 0.05): the cap binds, 30 x 1 x 0.005 = 0.15, whatever tc is.
  p.tc = 0.05;
  const double cap = VMIN_AUTO_ATC * 1.0 * (SPEED_TC_CAP * std::sqrt(1.0 / 1.0));
  EXPECT_DOUBLE_EQ(elastic_threshold(p, 1.0, speed_tc(p.tc, 1.0, 1.0)), cap);
  p.tc = 0.5;
  EXPECT_DOUBLE_EQ(elastic_threshold(p, 1.0, speed_tc(p.tc, 1.0, 1.0)), cap);
  // The cap scales as sqrt(|a| d): four times the contact distance, twice the threshold.
  EXPECT_DOUBLE_EQ(elastic_threshold(p, 1.0, speed_tc(p.tc, 1.0, 4.0)), 2.0 * cap);
  // No field, no threshold; a user's vmin is a floor.
  EXPECT_EQ(elastic_threshold(p, 0.0, speed_tc(p.tc, 0.0, 1.0)), 0.0);
  p.vmin = 0.2;
  EXPECT_EQ(elastic_threshold(p, 1.0, speed_tc(p.tc, 1.0, 1.0)), 0.2);
  // vmin given as a number (vmin_atc 0): only that.
  p.vmin_atc = 0.0;
  EXPECT_EQ(elastic_threshold(p, 1.0, speed_tc(p.tc, 1.0, 1.0)), 0.2);
  // The slow criterion: 16 |a| tc' (0.08 here) or 0.1 of the speeds' sum.
  EXPECT_EQ(slow_tc(0.05, speed_tc(0.05, 1.0, 1.0), 0.07, 1.0, 0.0), 0.05);
  EXPECT_EQ(slow_tc(0.05, speed_tc(0.05, 1.0, 1.0), 0.09, 1.0, 0.0), 0.0);
  // below 0.1 x (|v_i| + |v_j|):
  EXPECT_EQ(slow_tc(0.05, speed_tc(0.05, 1.0, 1.0), 0.09, 1.0, 1.0), 0.05);
  // 16 x 0.001 = 0.016:
  EXPECT_EQ(slow_tc(0.001, speed_tc(0.001, 1.0, 1.0), 0.017, 1.0, 0.0), 0.0);
}

// A pair under a uniform field meeting at a normal speed below vmin auto bounces elastically;
// above it, with the pair's restitution.
TEST(CollisionStep, VminAutoMakesSlowCollisionsUnderAFieldElastic)
{
  for (double speed : {0.05, 0.5}) {
    Stepper s(0.1, 0.5);
    s.p.tc = 0.05;
    s.p.vmin_atc = VMIN_AUTO_ATC;    // threshold 0.15 (g = 1, d = 1, capped)
    const double a[3] = {0, 0, -1.0};
    // In contact at t = 0.05, inside the step.
    const double xi[3] = {0, 0, 5}, vi[3] = {0.5 * speed, 0, 0},
                 xj[3] = {1.0 + 0.05 * speed, 0, 5}, vj[3] = {-0.5 * speed, 0, 0};
    Body bi = make_body(1, xi, vi, a, 0.5, 1.0), bj = make_body(2, xj, vj, a, 0.5, 1.0);
    bi.tlast = bj.tlast = -1.0;    // no recent collision: the TC model does not apply
    Edge e{0, 1, {0, 0, 0}};
    const double t = pair_event_time(bi, bj, e, s.p.dt);
    ASSERT_LT(t, never());
    Tally tally;
    process_pair(bi, bj, e, t, s.p, tally);
    const double out = bj.v[0] - bi.v[0];    // separating speed
    if (speed < 0.15)
      EXPECT_NEAR(out, speed, 1e-15) << "elastic below the threshold";
    else
      EXPECT_NEAR(out, 0.5 * speed, 1e-15) << "restitution 0.5 above it";
  }
}
