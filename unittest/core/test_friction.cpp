// LAMMPS-free tests of rough hard spheres (core/friction.h, and its use in process_pair and
// process_wall of core/collision_step.h): momentum and angular momentum about the contact,
// no energy gain, the sliding and sticking branches of Walton's rule against the analytic
// rebound of a sphere on a floor, and mu = 0 bitwise equal to smooth spheres.
#include "core/collision_step.h"
#include "core/friction.h"

#include <gtest/gtest.h>

#include <cfloat>
#include <cmath>
#include <cstring>
#include <random>

using namespace HSGPU::Collide;

namespace {

constexpr double K_SPHERE = 0.4;

Body body(long id, const double *x, const double *v, const double *w, const double *a, double r,
          double m)
{
  Body b{};
  for (int d = 0; d < 3; ++d) {
    b.x[d] = b.X0[d] = x[d];
    b.v[d] = v[d];
    b.omega[d] = w[d];
    b.a[d] = a[d];
    b.rest[d] = -1;
  }
  b.radius = r;
  b.mass = m;
  b.tlast = -1e30;
  b.id = id;
  b.type = 1;
  return b;
}

/// Params for one type, restitution e, friction mu and beta0 of the pair and of every wall.
struct Rough {
  double epair[4] = {1, 1, 1, 1};
  double fpair[8] = {0, -1, 0, -1, 0, -1, 0, -1};
  Params p{};
  Rough(double dt, double e, double mu, double beta0, int friction = 1)
  {
    epair[3] = e;
    fpair[6] = mu;
    fpair[7] = beta0;
    p.dt = dt;
    p.tc = 0.0;
    p.vmin = 0.0;
    p.ntypes = 1;
    p.epair = epair;
    p.maxevents = 1000000;
    p.friction = friction;
    p.inertia = K_SPHERE;
    p.fpair = fpair;
    for (int f = 0; f < NFACES; ++f) {
      p.walls.on[f] = 0;
      p.walls.pos[f] = 0.0;
      p.walls.e[f] = e;
      p.walls.mu[f] = mu;
      p.walls.beta[f] = beta0;
    }
  }
};

/// Angular momentum about the point c of a body with true velocity u and spin w.
void angular_momentum(const Body &b, const double *u, const double *c, double k, double *L)
{
  double r[3], l[3];
  for (int d = 0; d < 3; ++d) r[d] = b.x[d] - c[d];
  HSGPU::Friction::cross3(r, u, l);
  const double I = k * b.mass * b.radius * b.radius;
  for (int d = 0; d < 3; ++d) L[d] = b.mass * l[d] + I * b.omega[d];
}

double kinetic(const Body &b, const double *u, double k)
{
  const double I = k * b.mass * b.radius * b.radius;
  double e = 0.0;
  for (int d = 0; d < 3; ++d) e += 0.5 * b.mass * u[d] * u[d] + 0.5 * I * b.omega[d] * b.omega[d];
  return e;
}

void true_velocity(const Body &b, double t, double dt, double *u)
{
  for (int d = 0; d < 3; ++d) u[d] = b.v[d] + b.a[d] * (t - 0.5 * dt);
}

}    // namespace

// Random rough pairs at contact (random masses, radii, spins, velocities, mu, beta0, e, and a
// common acceleration): momentum is conserved, each sphere's angular momentum about the
// contact point is conserved (the impulse acts there), the kinetic energy (translation and
// rotation) never grows, and the tally's ke_lost is what it lost.
TEST(Friction, PairConservesMomentumAndSpinAboutTheContactAndNeverGainsEnergy)
{
  std::mt19937_64 rng(15);
  std::uniform_real_distribution<double> u(-1.0, 1.0), pos(0.0, 1.0);
  for (int k = 0; k < 4000; ++k) {
    const double e = pos(rng), mu = k % 7 == 0 ? 10.0 : 0.8 * pos(rng), beta0 = u(rng);
    const double dt = 0.1;
    Rough s(dt, e, mu, beta0);
    const double ri = 0.2 + pos(rng), rj = 0.2 + pos(rng);
    const double mi = 0.1 + 3 * pos(rng), mj = 0.1 + 3 * pos(rng);
    double n[3], nn = 0.0;
    for (double &c : n) {
      c = u(rng);
      nn += c * c;
    }
    for (double &c : n) c /= std::sqrt(nn);
    const double a[3] = {0.3 * u(rng), 0.3 * u(rng), -1.0};    // uniform field
    double vi[3], vj[3], wi[3], wj[3];
    for (int d = 0; d < 3; ++d) {
      vi[d] = u(rng);
      vj[d] = u(rng);
      wi[d] = 3 * u(rng);
      wj[d] = 3 * u(rng);
    }
    double vn = 0.0;
    for (int d = 0; d < 3; ++d) vn += (vi[d] - vj[d]) * n[d];
    if (vn > -0.05)
      for (int d = 0; d < 3; ++d) vi[d] -= (vn + 0.05 + pos(rng)) * n[d];
    const double xi[3] = {(ri + rj) * n[0], (ri + rj) * n[1], (ri + rj) * n[2]}, xj[3] = {0, 0, 0};
    Body bi = body(1, xi, vi, wi, a, ri, mi), bj = body(2, xj, vj, wj, a, rj, mj);
    const double t = 0.3 * dt;
    for (Body *b : {&bi, &bj}) b->tref = t;
    const double c[3] = {rj * n[0], rj * n[1], rj * n[2]};    // the contact point
    double ui[3], uj[3], Li0[3], Lj0[3], Li1[3], Lj1[3];
    true_velocity(bi, t, dt, ui);
    true_velocity(bj, t, dt, uj);
    angular_momentum(bi, ui, c, K_SPHERE, Li0);
    angular_momentum(bj, uj, c, K_SPHERE, Lj0);
    double p0[3];
    for (int d = 0; d < 3; ++d) p0[d] = mi * ui[d] + mj * uj[d];
    const double ke0 = kinetic(bi, ui, K_SPHERE) + kinetic(bj, uj, K_SPHERE);
    Tally tally;
    const Edge edge{0, 1, {0, 0, 0}};
    process_pair(bi, bj, edge, t, s.p, tally);
    ASSERT_EQ(tally.pair, 1);
    true_velocity(bi, t, dt, ui);
    true_velocity(bj, t, dt, uj);
    angular_momentum(bi, ui, c, K_SPHERE, Li1);
    angular_momentum(bj, uj, c, K_SPHERE, Lj1);
    const double scale = ke0 > 0 ? std::sqrt(2 * ke0 * (mi + mj)) * (1 + ri + rj) : 1.0;
    for (int d = 0; d < 3; ++d) {
      EXPECT_NEAR(mi * ui[d] + mj * uj[d], p0[d], 16 * DBL_EPSILON * scale) << "momentum";
      EXPECT_NEAR(Li1[d], Li0[d], 64 * DBL_EPSILON * scale) << "angular momentum of i";
      EXPECT_NEAR(Lj1[d], Lj0[d], 64 * DBL_EPSILON * scale) << "angular momentum of j";
    }
    const double ke1 = kinetic(bi, ui, K_SPHERE) + kinetic(bj, uj, K_SPHERE);
    EXPECT_LE(ke1, ke0 * (1 + 1e-14)) << "energy gained, case " << k;
    EXPECT_NEAR(ke0 - ke1, tally.ke_lost, 1e-13 * ke0);
  }
}

// A wall is a partner of infinite mass and no spin: random impacts under gravity conserve the
// sphere's angular momentum about the contact point, never gain energy, and the tally's
// ke_lost is the loss.
TEST(Friction, WallConservesSpinAboutTheContactAndNeverGainsEnergy)
{
  std::mt19937_64 rng(1515);
  std::uniform_real_distribution<double> u(-1.0, 1.0), pos(0.0, 1.0);
  for (int k = 0; k < 4000; ++k) {
    const double e = pos(rng), mu = k % 5 == 0 ? 10.0 : 0.8 * pos(rng), beta0 = u(rng);
    const double dt = 0.05;
    Rough s(dt, e, mu, beta0);
    s.p.tc = k % 3 == 0 ? 0.01 : 0.0;    // some resting contacts (a hop, not a bounce)
    const int f = 4;                     // floor zlo at 0
    s.p.walls.on[f] = 1;
    const double r = 0.2 + pos(rng), m = 0.1 + 3 * pos(rng);
    const double a[3] = {0.2 * u(rng), 0.2 * u(rng), -1.0};
    const double w[3] = {5 * u(rng), 5 * u(rng), 5 * u(rng)};
    const double t = 0.5 * dt * pos(rng);
    double v[3] = {u(rng), u(rng), -(0.001 + pos(rng))};
    for (int d = 0; d < 3; ++d) v[d] -= a[d] * (t - 0.5 * dt);    // true velocity at t as drawn
    const double x[3] = {u(rng), u(rng), r};
    Body b = body(3, x, v, w, a, r, m);
    b.tref = t;
    // The bow is zero at tref = t only if t = 0: put the drift point so that the true
    // position at t is on the floor.
    b.x[2] = r - bow(b, 2, t, dt);
    double u0[3], u1[3], L0[3], L1[3];
    true_velocity(b, t, dt, u0);
    const double c[3] = {b.x[0], b.x[1], 0.0};
    Body at = b;
    at.x[2] = r;    // the true centre, for the angular momentum about c
    angular_momentum(at, u0, c, K_SPHERE, L0);
    const double ke0 = kinetic(b, u0, K_SPHERE);
    Tally tally;
    process_wall(b, f, t, s.p, tally);
    true_velocity(b, t, dt, u1);
    Body after = b;
    after.x[2] = r;
    angular_momentum(after, u1, c, K_SPHERE, L1);
    const double scale = std::sqrt(2 * ke0 * m) * (1 + r) + m * std::fabs(u1[2]) * r;
    // Only the tangential components: the normal impulse (the wall's support) has no arm
    // about c, the tangential one none about c either.
    for (int d = 0; d < 3; ++d) EXPECT_NEAR(L1[d], L0[d], 64 * DBL_EPSILON * scale) << k;
    const double ke1 = kinetic(b, u1, K_SPHERE);
    if (tally.rest == 0) {
      EXPECT_LE(ke1, ke0 * (1 + 1e-14)) << "energy gained, case " << k;
    }
    EXPECT_NEAR(ke0 - ke1, tally.ke_lost, 1e-13 * ke0 + 1e-15);
  }
}

// A sphere thrown spinning onto a floor (no field: the analytic rebound with the plain
// velocities): sliding impacts take mu J_n of tangential impulse, sticking impacts reverse
// the contact-point velocity to -beta0 times it; rebound angle and spin to round-off.
TEST(Friction, SphereOnAFloorReboundsAsWaltonsRuleSays)
{
  const double r = 0.5, m = 2.0, e = 0.8, beta0 = 0.4, k = K_SPHERE;
  const double vz = 3.0;    // impact speed
  struct Case {
    double mu, vx, wy;
    bool sliding;
  };
  // g_x = vx - r wy: sliding where (1 + beta0) m_t |g_x| > mu (1 + e) m vz,
  // m_t = m k / (1 + k) = 2m/7.
  const Case cases[] = {{0.1, 2.0, -1.0, true}, {0.5, 2.0, 0.0, false}, {0.2, 0.5, 8.0, true},
                        {0.9, 0.5, 8.0, false}, {0.1, -1.5, 2.0, true}, {1.0, 1.0, -2.0, false}};
  for (const Case &cs : cases) {
    Rough s(1.0, e, cs.mu, beta0);
    s.p.walls.on[4] = 1;
    const double x[3] = {0, 0, r}, v[3] = {cs.vx, 0, -vz}, w[3] = {0, cs.wy, 0}, a[3] = {0, 0, 0};
    Body b = body(1, x, v, w, a, r, m);
    Tally tally;
    process_wall(b, 4, 0.0, s.p, tally);
    const double gx = cs.vx - r * cs.wy;
    const double Jn = m * (1 + e) * vz;
    const double mt = m * k / (1 + k);
    const bool slides = (1 + beta0) * mt * std::fabs(gx) > cs.mu * Jn;
    ASSERT_EQ(slides, cs.sliding) << "case set up for the other branch";
    const double P = slides ? -cs.mu * Jn * (gx > 0 ? 1.0 : -1.0) : -(1 + beta0) * mt * gx;
    const double vx1 = cs.vx + P / m;
    const double wy1 = cs.wy - P / (k * m * r);
    const double tol = 4 * DBL_EPSILON;
    EXPECT_NEAR(b.v[2], e * vz, tol * vz);
    EXPECT_NEAR(b.v[0], vx1, tol * (std::fabs(cs.vx) + vz));
    EXPECT_EQ(b.v[1], 0.0);
    EXPECT_NEAR(b.omega[1], wy1, tol * (std::fabs(cs.wy) + vz / r) * 4);
    EXPECT_EQ(b.omega[0], 0.0);
    EXPECT_EQ(b.omega[2], 0.0);
    // Rebound angle from the normal, and the contact velocity after (-beta0 gx when sticking).
    EXPECT_NEAR(std::atan2(b.v[0], b.v[2]), std::atan2(vx1, e * vz), 8 * DBL_EPSILON);
    const double gx1 = b.v[0] - r * b.omega[1];
    if (!slides) {
      EXPECT_NEAR(gx1, -beta0 * gx, 8 * DBL_EPSILON * (std::fabs(gx) + vz));
    } else {
      // Sliding: the cap acted, the contact velocity is reversed less than sticking would.
      EXPECT_GT(gx1 / gx, -beta0);
      EXPECT_LT(gx1 / gx, 1.0);
    }
    // Energy: translation and rotation.
    const double I = k * m * r * r;
    const double ke0 = 0.5 * m * (cs.vx * cs.vx + vz * vz) + 0.5 * I * cs.wy * cs.wy;
    const double ke1 =
        0.5 * m * (b.v[0] * b.v[0] + b.v[2] * b.v[2]) + 0.5 * I * b.omega[1] * b.omega[1];
    EXPECT_NEAR(tally.ke_lost, ke0 - ke1, 1e-14 * ke0);
  }
}

// The same impact under gravity inside a step: the impulse acts on the true velocity at the
// contact time, so the rebound is the field-free one of that velocity.
TEST(Friction, SphereOnAFloorUnderGravityUsesTheTrueVelocity)
{
  const double r = 0.5, m = 1.0, e = 0.7, beta0 = 0.2, mu = 0.25, g = 9.81, dt = 0.02;
  Rough s(dt, e, mu, beta0);
  s.p.walls.on[4] = 1;
  const double a[3] = {0, 0, -g};
  // Integrator's half-step velocity; the true one at t is v + a (t - dt/2).
  const double vh[3] = {1.5, 0.0, -2.0}, w[3] = {0, -3.0, 0};
  const double x0[3] = {0, 0, r + 0.01};
  Body b = body(1, x0, vh, w, a, r, m);
  int face = -1;
  const double t = wall_event_time(b, s.p.walls, dt, face);
  ASSERT_EQ(face, 4);
  double u0[3];
  true_velocity(b, t, dt, u0);
  Tally tally;
  process_wall(b, face, t, s.p, tally);
  double u1[3];
  true_velocity(b, t, dt, u1);
  const double gx = u0[0] - r * w[1];
  const double Jn = m * (1 + e) * -u0[2];
  const double mt = m * 0.4 / 1.4;
  const bool slides = (1 + beta0) * mt * std::fabs(gx) > mu * Jn;
  EXPECT_TRUE(slides);
  const double P = -mu * Jn;
  EXPECT_NEAR(u1[2], -e * u0[2], 1e-14);
  EXPECT_NEAR(u1[0], u0[0] + P / m, 1e-14);
  EXPECT_NEAR(b.omega[1], w[1] - P / (0.4 * m * r), 1e-13);
}

// mu = 0 (with friction on elsewhere: other pairs, or walls) and friction off give bitwise the
// same bodies and tallies: the tangential branch is not entered.
TEST(Friction, ZeroMuIsBitwiseSmooth)
{
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0), pos(0.0, 1.0);
  for (int k = 0; k < 500; ++k) {
    const double a[3] = {0, 0, -1.0}, w[3] = {u(rng), u(rng), u(rng)};
    const double xi[3] = {0.1 * u(rng), 0.1 * u(rng), 1.0 + 0.1 * u(rng)}, xj[3] = {0, 0, 0};
    const double vi[3] = {u(rng), u(rng), -1 - pos(rng)}, vj[3] = {u(rng), u(rng), u(rng)};
    Body bi0 = body(1, xi, vi, w, a, 0.5, 1.0 + pos(rng)), bj0 = body(2, xj, vj, w, a, 0.5, 1.5);
    const Edge edge{0, 1, {0, 0, 0}};
    const double t = pair_event_time(bi0, bj0, edge, 1.0);
    if (t == HSGPU::Contact::never()) continue;
    Rough smooth(1.0, 0.7, 0.0, 0.5, 0), rough0(1.0, 0.7, 0.0, 0.5, 1);
    rough0.p.walls.mu[4] = 0.5;    // friction on elsewhere
    Body bi1 = bi0, bj1 = bj0, bi2 = bi0, bj2 = bj0;
    Tally t1, t2;
    process_pair(bi1, bj1, edge, t, smooth.p, t1);
    process_pair(bi2, bj2, edge, t, rough0.p, t2);
    EXPECT_EQ(0, std::memcmp(&bi1, &bi2, sizeof(Body)));
    EXPECT_EQ(0, std::memcmp(&bj1, &bj2, sizeof(Body)));
    EXPECT_EQ(0, std::memcmp(&t1, &t2, sizeof(Tally)));
    // Walls: floor with mu = 0.
    smooth.p.walls.on[4] = rough0.p.walls.on[4] = 1;
    rough0.p.walls.mu[4] = 0.0;
    rough0.fpair[6] = 0.7;    // friction on elsewhere
    Body b1 = bi0, b2 = bi0;
    int face = -1;
    const double tw = wall_event_time(b1, smooth.p.walls, 1.0, face);
    if (tw == HSGPU::Contact::never()) continue;
    Tally w1, w2;
    process_wall(b1, face, tw, smooth.p, w1);
    process_wall(b2, face, tw, rough0.p, w2);
    EXPECT_EQ(0, std::memcmp(&b1, &b2, sizeof(Body)));
    EXPECT_EQ(0, std::memcmp(&w1, &w2, sizeof(Tally)));
  }
}

// The inertia factor enters as 1/m_t = (1 + 1/k)(1/m_i + 1/m_j): a sticking pair with beta0 = 0
// ends with no tangential contact velocity for discs (k = 0.5) as for spheres.
TEST(Friction, StickingPairWithBetaZeroEndsRollingForDiscsAndSpheres)
{
  for (double k : {0.4, 0.5}) {
    Rough s(1.0, 1.0, 100.0, 0.0);
    s.p.inertia = k;
    const double a[3] = {0, 0, 0}, w0[3] = {0, 0, 0}, wi[3] = {0, 0, 2.0};
    const double xi[3] = {1.0, 0, 0}, xj[3] = {0, 0, 0};
    const double vi[3] = {-1.0, 0.7, 0}, vj[3] = {0, -0.2, 0};
    Body bi = body(1, xi, vi, wi, a, 0.5, 1.0), bj = body(2, xj, vj, w0, a, 0.5, 2.0);
    Tally tally;
    process_pair(bi, bj, Edge{0, 1, {0, 0, 0}}, 0.0, s.p, tally);
    // n = +x; g = v_i - v_j - (r_i w_i + r_j w_j) x n; its y component after: 0.
    const double gy = (bi.v[1] - bj.v[1]) - (0.5 * bi.omega[2] + 0.5 * bj.omega[2]) * 1.0;
    EXPECT_NEAR(gy, 0.0, 1e-15) << "k = " << k;
    // The spins changed in the same sense: dw = -(n x P) / (k m r), n x P = P_y z.
    const double Py = bi.mass * (bi.v[1] - vi[1]);
    EXPECT_NEAR(bj.mass * (bj.v[1] - vj[1]), -Py, 1e-15);
    EXPECT_NEAR(bi.omega[2] - wi[2], -Py / (k * 1.0 * 0.5), 1e-14);
    EXPECT_NEAR(bj.omega[2], -Py / (k * 2.0 * 0.5), 1e-14);
  }
}

// friction/guard elastic (Params::friction = FRICTION_GUARDED): a collision that the TC model
// makes elastic is elastic in its tangential part too (the contact velocity reversed, no cap,
// no energy lost); with FRICTION_WALTON it gets Walton's rule.  A collision the guards leave
// alone gets Walton's rule either way.
TEST(Friction, GuardedCollisionsAreTangentiallyElastic)
{
  const double a[3] = {0, 0, 0}, wi[3] = {0, 0, 10.0}, w0[3] = {0, 0, 0};
  const double xi[3] = {1.0, 0, 0}, xj[3] = {0, 0, 0};
  const double vi[3] = {-1.0, 0.7, 0}, vj[3] = {0, -0.2, 0};
  for (int mode : {FRICTION_GUARDED, FRICTION_WALTON}) {
    for (double since : {0.01, 10.0}) {    // within tc = 0.1 of i's last collision, or not
      Rough s(1.0, 0.5, 0.2, 0.3);
      s.p.tc = 0.1;
      s.p.friction = mode;
      Body bi = body(1, xi, vi, wi, a, 0.5, 1.0), bj = body(2, xj, vj, w0, a, 0.5, 2.0);
      bi.tlast = -since;
      Tally tally;
      process_pair(bi, bj, Edge{0, 1, {0, 0, 0}}, 0.0, s.p, tally);
      const double g0 = (vi[1] - vj[1]) - 0.5 * wi[2];
      const double g1 = (bi.v[1] - bj.v[1]) - (0.5 * bi.omega[2] + 0.5 * bj.omega[2]);
      const double vn1 = bi.v[0] - bj.v[0];
      if (since < 0.1) {
        EXPECT_NEAR(vn1, 1.0, 1e-15) << "the TC model made it elastic";
      } else {
        EXPECT_NEAR(vn1, 0.5, 1e-15);
      }
      if (since < 0.1 && mode == FRICTION_GUARDED) {
        EXPECT_NEAR(g1, -g0, 1e-15) << "perfectly rough elastic, no Coulomb cap";
        EXPECT_NEAR(tally.ke_lost, 0.0, 1e-15);
      } else {
        // Walton: mu Jn = 0.2 (1 + e1) m_eff 1 caps the sticking impulse (1.3 m_t |g0|).
        const double e1 = since < 0.1 ? 1.0 : 0.5, meff = 2.0 / 3.0, mt = meff * 0.4 / 1.4;
        const double cap = 0.2 * (1 + e1) * meff, stick = 1.3 * mt * std::fabs(g0);
        ASSERT_GT(stick, cap);
        EXPECT_NEAR(g1, g0 + (g0 > 0 ? -cap : cap) / mt, 1e-14);
        EXPECT_GT(tally.ke_lost, 0.0);
      }
    }
  }
}

// A sphere resting on the floor (not tested against it until its next pair collision) that
// hits a rough side wall: that wall's friction pushes it down, so the floor is tested again
// and found at once (before, the sphere sank into the floor unseen).
TEST(Friction, SideWallFrictionWakesTheFloorContact)
{
  const double dt = 0.1, r = 0.5, t = 0.04;
  Rough s(dt, 0.5, 0.5, 0.3);
  s.p.walls.on[0] = s.p.walls.on[4] = 1;
  const double x[3] = {r, 0, r}, v[3] = {-1.0, 0, 0}, w[3] = {0, 2.0, 0}, a[3] = {0, 0, -1.0};
  Body b = body(1, x, v, w, a, r, 1.0);
  b.tref = t;
  b.x[2] = r - bow(b, 2, t, dt);        // on the floor at t
  b.v[2] = -b.a[2] * (t - 0.5 * dt);    // true vertical velocity 0 at t: resting there
  b.rest[2] = 4;
  Tally tally;
  process_wall(b, 0, t, s.p, tally);
  // n = +x, w x n = (0, 0, -w_y): g_z = u_z + r w_y = 1 > 0, so P_z < 0.
  EXPECT_LT(b.v[2] + b.a[2] * (t - 0.5 * dt), 0.0) << "pushed down";
  EXPECT_EQ(b.rest[2], -1) << "the floor is tested again";
  int face = -1;
  EXPECT_EQ(wall_event_time(b, s.p.walls, dt, face), t);
  EXPECT_EQ(face, 4);
}
