// fix hardsphere with friction (issue 15), one rank: a sphere thrown spinning onto the floor
// under gravity against the analytic rebounds, for several timesteps; a rough pile in both
// orders (bitwise) and through a restart; mu = 0 bitwise equal to no friction; the moment of
// inertia of 'disc'; the input errors.
#include "harness.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

using hsgpu_test::Lammps;
using hsgpu_test::max_abs_diff;
using hsgpu_test::fmt;
using ::testing::HasSubstr;

namespace {

struct Ball {
  double x, z, vx, vz, wy;
};

/// The analytic path of a sphere (radius R, on a floor at z = zlo, g along -z) thrown with
/// horizontal speed vx and spin wy about y, bouncing with restitution e and Walton's rule
/// (mu, beta0, solid sphere: m_t = 2 m / 7), at time T.
Ball analytic_ball(Ball b, double T, double zlo, double R, double g, double e, double mu,
                   double beta0)
{
  double t = 0.0;
  while (true) {
    // Next floor contact: z + vz s - g s^2 / 2 = zlo + R.
    const double h = b.z - zlo - R;
    const double s = (b.vz + std::sqrt(b.vz * b.vz + 2 * g * h)) / g;
    if (t + s > T) {
      const double r = T - t;
      b.x += b.vx * r;
      b.z += b.vz * r - 0.5 * g * r * r;
      b.vz -= g * r;
      return b;
    }
    t += s;
    b.x += b.vx * s;
    b.z = zlo + R;
    const double un = b.vz - g * s;    // < 0
    b.vz = -e * un;
    const double gx = b.vx - R * b.wy;    // contact point velocity (n = +z)
    const double Jn = (1 + e) * -un;      // per unit mass
    const double stick = (1 + beta0) * (2.0 / 7.0) * std::fabs(gx);
    const double P =
        stick <= mu * Jn ? -(1 + beta0) * (2.0 / 7.0) * gx : -mu * Jn * (gx > 0 ? 1.0 : -1.0);
    b.vx += P;
    b.wy -= P / (0.4 * R);
  }
}

std::vector<std::string> ball_input(double dt, const std::string &hs)
{
  return {"units lj",
          "atom_style sphere",
          "atom_modify map array",
          "boundary p p f",
          "region box block -10 10 -10 10 -10 10",
          "create_box 1 box",
          "create_atoms 1 single 0.3 -0.2 -8.0 units box",
          "set atom 1 diameter 1.0",
          "set atom 1 mass 1.7",
          "velocity all set 1.2 0 0.4",
          "set atom 1 omega 0 -6.0 0",
          "comm_modify cutoff 4.0 vel yes",
          "neigh_modify every 1 delay 0 check yes",
          "fix 1 all nve/sphere",
          "fix g all gravity 1.0 vector 0 0 -1",
          "fix hs all hardsphere " + hs,
          fmt("timestep %.17g", dt),
          "thermo_modify norm no"};
}

}    // namespace

// Issue 15 items 3 and 4: a sphere thrown spinning onto a rough floor under gravity.  The
// first impact slides (its contact point moves fast against the floor), the later ones stick
// (Walton's tangential restitution); at t = 7.8, after three bounces, position, velocity and
// spin equal the analytic ones to round-off at dt = 0.01, 0.013 and 0.02, and each other.
TEST(FixHardSphereFriction, SpinningSphereOnTheFloorIsExactForAnyTimestep)
{
  const double e = 0.8, mu = 0.3, beta0 = 0.4, T = 7.8, R = 0.5, zlo = -10.0;
  const Ball a = analytic_ball({0.3, -8.0, 1.2, 0.4, -6.0}, T, zlo, R, 1.0, e, mu, beta0);
  std::vector<std::vector<double>> states;
  for (double dt : {0.01, 0.013, 0.02}) {
    Lammps lmp;
    lmp.commands(ball_input(dt, fmt("wall zlo %.17g wall/friction zlo %.17g %.17g", e, mu, beta0)));
    lmp.commands({"run " + std::to_string(std::lround(T / dt))});
    const auto x = lmp.gather("x", 3), v = lmp.gather("v", 3), w = lmp.gather("omega", 3);
    EXPECT_EQ(lmp.fix_vector("hs", 2), 3.0) << "wall collisions, dt " << dt;
    EXPECT_NEAR(x[0], a.x, 1e-12) << "dt " << dt;
    EXPECT_NEAR(x[2], a.z, 1e-12) << "dt " << dt;
    EXPECT_NEAR(v[0], a.vx, 1e-12) << "dt " << dt;
    EXPECT_NEAR(v[2], a.vz, 1e-12) << "dt " << dt;
    EXPECT_NEAR(w[1], a.wy, 1e-12) << "dt " << dt;
    EXPECT_EQ(w[0], 0.0);
    EXPECT_EQ(w[2], 0.0);
    EXPECT_EQ(v[1], 0.0);
    // The rebound angle from the vertical after the last bounce (tan = vx / vz) is that of the
    // analytic path too (it follows from vx and vz above).
    std::printf("[ HS       ] rough bounce dt %.3f: x %.15f z %.15f vx %.15f vz %.15f wy %.15f "
                "(analytic %.15f %.15f %.15f %.15f %.15f)\n",
                dt, x[0], x[2], v[0], v[2], w[1], a.x, a.z, a.vx, a.vz, a.wy);
    states.push_back({x[0], x[2], v[0], v[2], w[1], lmp.fix_vector("hs", 3)});
  }
  for (size_t k = 1; k < states.size(); ++k) EXPECT_LT(max_abs_diff(states[k], states[0]), 1e-12);
}

namespace {

// 200 spheres of diameters 1 and 0.8 on a lattice, falling onto a rough floor, rough pairs.
std::vector<std::string> rough_pile(const std::string &extra)
{
  return {"units lj",
          "atom_style sphere",
          "atom_modify map array",
          "boundary p p f",
          "region box block 0 8.8 0 8.8 0 12",
          "create_box 2 box",
          "lattice sc 0.75131480090157776 origin 0.5 0.5 0.5",
          "region fill block 0 8.8 0 8.8 0 3.3 units box",
          "create_atoms 1 region fill",
          "set group all type/fraction 2 0.3 4411",
          "set type 1 diameter 1.0",
          "set type 2 diameter 0.8",
          "set type 1 density 1.9",
          "set type 2 density 3.0",
          "velocity all create 2.0 87287 loop geom",
          "variable wx atom 2.0*sin(3.1*id)",
          "variable wy atom 2.0*cos(1.7*id)",
          "variable wz atom 2.0*sin(0.9*id+1.0)",
          "set group all omega v_wx v_wy v_wz",
          "comm_modify cutoff 3.5 vel yes",
          "neigh_modify every 1 delay 0 check yes",
          "thermo_modify norm no",
          "timestep 0.005",
          "fix 1 all nve/sphere",
          "fix g all gravity 1.0 vector 0 0 -1",
          "fix hs all hardsphere restitution 0.6 wall zlo 0.7 wall zhi 1.0 " + extra};
}

struct State {
  std::vector<double> x, v, w;
  double f[6];
};

State run_pile(const std::string &extra, int steps)
{
  Lammps lmp;
  lmp.commands(rough_pile(extra));
  lmp.commands({"run " + std::to_string(steps)});
  State s;
  s.x = lmp.gather("x", 3);
  s.v = lmp.gather("v", 3);
  s.w = lmp.gather("omega", 3);
  for (int i = 0; i < 6; ++i) s.f[i] = lmp.fix_vector("hs", i);
  return s;
}

const char *kRough = "friction 0.5 0.3 friction/pair 1 2 0.3 0.0 wall/friction zlo 0.6 0.2";

}    // namespace

// Friction changes the run (spins and velocities), both orders and fixed windows give the same
// bits, and the kinetic energy removed (translation and rotation) is positive.
TEST(FixHardSphereFriction, RoughPileSerialEqualsParallel)
{
  const char *orders[] = {"order serial", "order parallel", "order parallel windows 4"};
  std::vector<State> s;
  for (const char *o : orders) s.push_back(run_pile(std::string(kRough) + " " + o, 400));
  const State smooth = run_pile("", 400);
  EXPECT_GT(s[0].f[1], 1000.0) << "collisions";
  EXPECT_GT(max_abs_diff(s[0].v, smooth.v), 0.1) << "friction changed nothing";
  EXPECT_GT(max_abs_diff(s[0].w, smooth.w), 0.1) << "friction changed no spin";
  EXPECT_EQ(max_abs_diff(smooth.w, run_pile("", 0).w), 0.0) << "smooth spheres keep their spin";
  for (size_t k = 1; k < s.size(); ++k) {
    EXPECT_EQ(max_abs_diff(s[0].x, s[k].x), 0.0) << orders[k];
    EXPECT_EQ(max_abs_diff(s[0].v, s[k].v), 0.0) << orders[k];
    EXPECT_EQ(max_abs_diff(s[0].w, s[k].w), 0.0) << orders[k];
    EXPECT_EQ(s[0].f[1], s[k].f[1]) << orders[k];
    EXPECT_EQ(s[0].f[3], s[k].f[3]) << orders[k];
  }
  EXPECT_GT(s[0].f[3], smooth.f[3]) << "friction removes energy too";
  std::printf("[ HS       ] rough pile: %.0f collisions, energy removed %.6g (smooth: %.0f, "
              "%.6g)\n",
              s[0].f[1], s[0].f[3], smooth.f[1], smooth.f[3]);
}

// Issue 15 item 1: mu = 0 everywhere is the smooth fix bitwise (spins untouched too).
TEST(FixHardSphereFriction, ZeroFrictionIsBitwiseSmooth)
{
  const State smooth = run_pile("", 300);
  const State zero = run_pile("friction 0 0.5 friction/pair 1 2 0.0 -1 wall/friction zlo 0 1", 300);
  EXPECT_EQ(max_abs_diff(smooth.x, zero.x), 0.0);
  EXPECT_EQ(max_abs_diff(smooth.v, zero.v), 0.0);
  EXPECT_EQ(max_abs_diff(smooth.w, zero.w), 0.0);
  for (int i = 0; i < 6; ++i) EXPECT_EQ(smooth.f[i], zero.f[i]) << "f_hs[" << i + 1 << "]";
}

// Issue 15 item 6: a rough run split by write_restart / read_restart equals the unbroken run
// (omega travels with atom style sphere's restart data, the time of the last collision with the
// fix's per-atom restart data).
TEST(FixHardSphereFriction, RestartContinuationEqualsUninterruptedRun)
{
  const std::string file = "fix_hardsphere_friction_test.restart";
  std::vector<std::string> all = rough_pile(kRough);
  const std::vector<std::string> fixes(all.end() - 3, all.end());
  State a, b;
  {
    Lammps lmp;
    lmp.commands(all);
    lmp.commands({"run 200", "write_restart " + file, "run 200"});
    a.x = lmp.gather("x", 3);
    a.v = lmp.gather("v", 3);
    a.w = lmp.gather("omega", 3);
    for (int i = 0; i < 6; ++i) a.f[i] = lmp.fix_vector("hs", i);
  }
  {
    Lammps lmp;
    lmp.commands({"read_restart " + file, "comm_modify cutoff 3.5 vel yes",
                  "neigh_modify every 1 delay 0 check yes", "thermo_modify norm no",
                  "timestep 0.005"});
    lmp.commands(fixes);
    lmp.commands({"run 200"});
    b.x = lmp.gather("x", 3);
    b.v = lmp.gather("v", 3);
    b.w = lmp.gather("omega", 3);
    for (int i = 0; i < 6; ++i) b.f[i] = lmp.fix_vector("hs", i);
  }
  std::remove(file.c_str());
  EXPECT_GT(a.f[1], 500.0);
  EXPECT_EQ(max_abs_diff(a.x, b.x), 0.0);
  EXPECT_EQ(max_abs_diff(a.v, b.v), 0.0);
  EXPECT_EQ(max_abs_diff(a.w, b.w), 0.0);
  for (int i = 0; i < 6; ++i)
    EXPECT_NEAR(b.f[i], a.f[i], 1e-12 * std::fabs(a.f[i])) << "f_hs[" << i + 1 << "]";
  std::printf("[ HS       ] rough restart: max |dx| %.2g |dv| %.2g |dw| %.2g after 200 + 200 "
              "steps, %.0f collisions\n",
              max_abs_diff(a.x, b.x), max_abs_diff(a.v, b.v), max_abs_diff(a.w, b.w), a.f[1]);
}

// The moment of inertia follows the integrator: the spin a sliding impact gives is
// mu Jn r / I, with I = 0.4 m r^2 (fix nve/sphere) or 0.5 m r^2 (fix nve/sphere disc, 2d).
// The fix's own 'disc' must agree with the integrator.
TEST(FixHardSphereFriction, DiscInertiaFollowsTheIntegrator)
{
  {
    Lammps bad;
    const std::string err = bad.first_error(
        {"units lj", "dimension 2", "atom_style sphere", "boundary p f p",
         "region box block -10 10 -10 10 -0.5 0.5", "create_box 1 box",
         "create_atoms 1 single 0 -9.0 0 units box", "comm_modify vel yes",
         "neigh_modify every 1 delay 0 check yes", "fix 1 all nve/sphere",
         "fix hs all hardsphere wall ylo 1.0 wall/friction ylo 0.1 0.5 disc", "run 0"});
    EXPECT_THAT(err, HasSubstr("the integrator of its atoms uses 0.4"));
  }
  for (const char *disc : {"", "disc"}) {
    Lammps lmp;
    lmp.commands({"units lj", "dimension 2", "atom_style sphere", "atom_modify map array",
                  "boundary p f p", "region box block -10 10 -10 10 -0.5 0.5", "create_box 1 box",
                  "create_atoms 1 single 0 -9.0 0 units box", "set atom 1 diameter 1.0",
                  "set atom 1 mass 1.0", "velocity all set 3.0 -2.0 0",
                  "comm_modify cutoff 4.0 vel yes", "neigh_modify every 1 delay 0 check yes",
                  std::string("fix 1 all nve/sphere ") + disc, "fix 2 all enforce2d",
                  "fix hs all hardsphere wall ylo 1.0 wall/friction ylo 0.1 0.5", "timestep 0.01",
                  "run 100"});
    const auto v = lmp.gather("v", 3), w = lmp.gather("omega", 3);
    // One sliding impact: Jn = 2 m 2, P = -mu Jn along x; spin dw_z = -(n x P)_z / (k m r),
    // n = +y: (n x P)_z = -P_x.
    const double k = *disc ? 0.5 : 0.4, P = -0.1 * 4.0;
    EXPECT_NEAR(v[0], 3.0 + P, 1e-13) << disc;
    EXPECT_NEAR(w[2], P / (k * 0.5), 1e-13) << disc;
  }
}

// Bad friction input stops with an error that names the problem.
TEST(FixHardSphereFriction, BadInputStopsWithANamedError)
{
  auto error_of = [](const std::string &hs, const std::vector<std::string> &more = {}) {
    Lammps lmp;
    std::vector<std::string> l = {"units lj",
                                  "atom_style sphere",
                                  "boundary p p f",
                                  "region box block 0 5 0 5 0 5",
                                  "create_box 2 box",
                                  "create_atoms 1 single 1 1 1 units box",
                                  "comm_modify vel yes",
                                  "neigh_modify every 1 delay 0 check yes"};
    l.insert(l.end(), more.begin(), more.end());
    l.push_back("fix hs all hardsphere " + hs);
    l.push_back("run 0");
    return lmp.first_error(l);
  };
  EXPECT_THAT(error_of("friction -0.1 0.5"), HasSubstr("mu must be >= 0"));
  EXPECT_THAT(error_of("friction 0.5 1.5"), HasSubstr("beta0 must be between -1 and 1"));
  EXPECT_THAT(error_of("friction 0.5"), HasSubstr("keyword friction needs 2 value(s)"));
  EXPECT_NE(error_of("friction/pair 1 3 0.5 0.1"), "");    // type 3 of 2
  EXPECT_THAT(error_of("wall/friction zlo 0.5 0.2"), HasSubstr("needs a wall on that face"));
  EXPECT_THAT(error_of("wall zlo 1 wall/friction top 0.5 0.2"), HasSubstr("unknown wall face"));
  EXPECT_THAT(error_of("friction 0.5 0.2 disc"), HasSubstr("disc requires a 2d simulation"));
  EXPECT_EQ(error_of("friction 0.5 0.2 gpu yes", {"fix a all nve/sphere"}), "")
      << "friction with gpu yes runs (on the device, or with a warning on the CPU backend "
         "where there is none)";
}

// A rough sphere pressed into a corner (floor and side wall, gravity towards both) and spinning:
// the friction of one wall moves it along the other, where it may be resting; that wall is
// tested again, so the sphere never sinks into either (found in a collapsing column: a sphere
// in the corner sank 1e-6 into the floor).
TEST(FixHardSphereFriction, SphereInACornerStaysOutOfBothWalls)
{
  for (const char *guard : {"elastic", "none"}) {
    Lammps lmp;
    lmp.commands({"units lj", "atom_style sphere", "atom_modify map array", "boundary f p f",
                  "region box block 0 10 -5 5 0 10", "create_box 1 box",
                  "create_atoms 1 single 0.5 0 0.5 units box", "set atom 1 diameter 1.0",
                  "set atom 1 mass 1.0", "velocity all set -0.3 0.2 -0.1",
                  "set atom 1 omega 1.0 2.0 -3.0", "comm_modify vel yes",
                  "neigh_modify every 1 delay 0 check yes", "fix 1 all nve/sphere",
                  "fix g all gravity 1.0 vector -0.3 0 -1",
                  std::string("fix hs all hardsphere wall xlo 0.5 wall zlo 0.5 wall/friction xlo "
                              "0.5 0.3 wall/friction zlo 0.5 0.3 friction/guard ") +
                      guard,
                  "timestep 0.01"});
    double lowest[2] = {1e300, 1e300};
    for (int k = 0; k < 40; ++k) {
      ASSERT_EQ(lmp.command("run 25 pre no post no"), "") << guard;
      const auto x = lmp.gather("x", 3);
      lowest[0] = std::min(lowest[0], x[0]);
      lowest[1] = std::min(lowest[1], x[2]);
    }
    EXPECT_GT(lowest[0], 0.5 - 1e-9) << guard;
    EXPECT_GT(lowest[1], 0.5 - 1e-9) << guard;
    EXPECT_GT(lmp.fix_vector("hs", 2), 50.0) << "wall collisions";
  }
}

// The tangential impulses enter the virial: summed over the atoms, the per-atom virial of a
// rough pile (pairs and rough walls) is minus the global collision virial in all six components
// at every step, in both orders, and asking for it changes no trajectory.
TEST(FixHardSphereFriction, PerAtomVirialSumsToTheGlobalOneEveryStep)
{
  for (const char *order : {"order serial", "order parallel"}) {
    std::vector<double> x[2];
    for (int with = 0; with < 2; ++with) {
      Lammps lmp;
      lmp.commands(rough_pile(std::string(kRough) + " " + order));
      if (with)
        lmp.commands(
            {"compute s all stress/atom NULL fix",
             "compute red all reduce sum c_s[1] c_s[2] c_s[3] c_s[4] c_s[5] c_s[6]",
             "compute pv all pressure NULL virial",
             "variable d equal abs(c_red[1]+c_pv[1]*vol)+abs(c_red[2]+c_pv[2]*vol)+abs(c_red[3]+"
             "c_pv[3]*vol)+abs(c_red[4]+c_pv[4]*vol)+abs(c_red[5]+c_pv[5]*vol)+abs(c_red[6]+c_pv["
             "6]*vol)",
             "variable m equal abs(c_red[1])+abs(c_red[2])+abs(c_red[3])",
             "variable o equal abs(c_red[4])+abs(c_red[5])+abs(c_red[6])",
             "fix avg all ave/time 1 300 300 v_d v_m v_o"});
      lmp.commands({"run 300"});
      x[with] = lmp.gather("x", 3);
      if (with) {
        const double d = lmp.fix_vector("avg", 0), m = lmp.fix_vector("avg", 1);
        EXPECT_GT(m, 1.0) << order;
        EXPECT_GT(lmp.fix_vector("avg", 2), 0.0) << order << ": off-diagonal terms";
        EXPECT_LT(d, 1e-12 * m) << order;
      }
    }
    EXPECT_EQ(max_abs_diff(x[0], x[1]), 0.0) << order;
  }
}
