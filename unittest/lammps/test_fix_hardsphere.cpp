// fix hardsphere through LAMMPS, one rank: two-sphere collisions against the analytic outcome
// for several timesteps (also under gravity), a ball bouncing on the floor, Newton's cradle,
// the collision virial, a dense run without overlaps, serial == parallel order, restart
// continuation and the input errors.
#include "harness.h"

#include "gpu/device_info.cuh"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <array>
#include <string>
#include <vector>

using hsgpu_test::Lammps;
using hsgpu_test::max_abs_diff;
using hsgpu_test::fmt;
using ::testing::HasSubstr;

namespace {

// Box [-10,10]^3, given boundary; sphere i at x[i] with velocity v[i], diameter dia[i], mass m[i].
struct Spheres {
  std::string boundary = "p p p";
  std::vector<std::array<double, 3>> x, v;
  std::vector<double> dia, m;
};

std::vector<std::string> sphere_lines(const Spheres &s)
{
  std::vector<std::string> l = {"units lj",
                                "atom_style sphere",
                                "atom_modify map array",
                                "boundary " + s.boundary,
                                "region box block -10 10 -10 10 -10 10",
                                "create_box 2 box",
                                "comm_modify cutoff 4.0 vel yes",
                                "neigh_modify every 1 delay 0 check yes",
                                "thermo_modify norm no"};
  for (size_t i = 0; i < s.x.size(); ++i) {
    l.push_back(
        fmt("create_atoms 1 single %.17g %.17g %.17g units box", s.x[i][0], s.x[i][1], s.x[i][2]));
    const int id = (int) i + 1;
    l.push_back("set atom " + std::to_string(id) + fmt(" diameter %.17g", s.dia[i]));
    l.push_back("set atom " + std::to_string(id) + fmt(" mass %.17g", s.m[i]));
    l.push_back("group g" + std::to_string(id) + " id " + std::to_string(id));
    l.push_back("velocity g" + std::to_string(id) +
                fmt(" set %.17g %.17g %.17g", s.v[i][0], s.v[i][1], s.v[i][2]));
  }
  return l;
}

// Masses 1 and 3, diameter 1, at x = -1 and 1 moving towards each other at speeds 1:
// contact at t = 0.5.
Spheres head_on_pair()
{
  Spheres s;
  s.x = {{-1, 0, 0}, {1, 0, 0}};
  s.v = {{1, 0, 0}, {-1, 0, 0}};
  s.dia = {1, 1};
  s.m = {1, 3};
  return s;
}

}    // namespace

// Masses 1 and 3, e = 0.8, head-on at relative speed 2 from a gap of 1: contact at t = 0.5,
// then v1 = -0.5 - 0.75 * 1.6, v2 = -0.5 + 0.25 * 1.6.  At t = 3 for three timesteps.
TEST(FixHardSphere, HeadOnMatchesAnalyticForAnyTimestep)
{
  for (double dt : {0.01, 0.03, 0.1}) {
    Lammps lmp;
    lmp.commands(sphere_lines(head_on_pair()));
    lmp.commands({"fix 1 all nve/sphere", "fix hs all hardsphere restitution 0.8",
                  fmt("timestep %.17g", dt), fmt("run %.0f", std::round(3.0 / dt))});
    const auto x = lmp.gather("x", 3), v = lmp.gather("v", 3);
    const double v1 = -0.5 - 0.75 * 1.6, v2 = -0.5 + 0.25 * 1.6;
    EXPECT_NEAR(v[0], v1, 1e-14) << "dt " << dt;
    EXPECT_NEAR(v[3], v2, 1e-14) << "dt " << dt;
    EXPECT_NEAR(x[0], -1 + 0.5 + v1 * 2.5, 1e-13) << "dt " << dt;
    EXPECT_NEAR(x[3], 1 - 0.5 + v2 * 2.5, 1e-13) << "dt " << dt;
    EXPECT_EQ(lmp.fix_vector("hs", 1), 1.0);
    EXPECT_NEAR(lmp.fix_vector("hs", 3), 0.5 * (1 - 0.64) * 0.75 * 4.0, 1e-14);
    EXPECT_EQ(lmp.fix_vector("hs", 2), 0.0);
  }
}

// Equal masses, impact parameter 0.6 of the diameter 1, e = 0.9: contact at t = 1.2 with
// normal n = (-0.8, 0.6); v1 = (1,0) + 0.76 n, v2 = -0.76 n.
TEST(FixHardSphere, ObliqueMatchesAnalyticForAnyTimestep)
{
  const double n[2] = {-0.8, 0.6};
  for (double dt : {0.01, 0.03, 0.1}) {
    Spheres s;
    s.x = {{-2, 0.6, 0}, {0, 0, 0}};
    s.v = {{1, 0, 0}, {0, 0, 0}};
    s.dia = {1, 1};
    s.m = {2, 2};
    Lammps lmp;
    lmp.commands(sphere_lines(s));
    lmp.commands({"fix 1 all nve/sphere", "fix hs all hardsphere restitution 0.9",
                  fmt("timestep %.17g", dt), fmt("run %.0f", std::round(3.0 / dt))});
    const auto x = lmp.gather("x", 3), v = lmp.gather("v", 3);
    const double v1[2] = {1 + 0.76 * n[0], 0.76 * n[1]}, v2[2] = {-0.76 * n[0], -0.76 * n[1]};
    for (int d = 0; d < 2; ++d) {
      EXPECT_NEAR(v[d], v1[d], 2e-15) << "dt " << dt;
      EXPECT_NEAR(v[3 + d], v2[d], 2e-15) << "dt " << dt;
    }
    EXPECT_NEAR(x[0], -2 + 1.2 + v1[0] * 1.8, 1e-13);
    EXPECT_NEAR(x[1], 0.6 + v1[1] * 1.8, 1e-13);
    EXPECT_NEAR(x[3], v2[0] * 1.8, 1e-13);
    EXPECT_NEAR(x[4], v2[1] * 1.8, 1e-13);
  }
}

// Under a uniform field the pair's relative motion is straight: the outcome of an oblique,
// unequal-mass collision under gravity does not depend on the timestep.
TEST(FixHardSphere, CollisionUnderUniformGravityDoesNotDependOnTimestep)
{
  std::vector<std::vector<double>> xs, vs;
  for (double dt : {0.004, 0.01, 0.025}) {
    Spheres s;
    s.x = {{-2, 0.3, 1.0}, {1, -0.2, 0.5}};
    s.v = {{1.5, 0.1, 2.0}, {-1, 0.2, 1.8}};
    s.dia = {1, 1.4};
    s.m = {1, 2.5};
    Lammps lmp;
    lmp.commands(sphere_lines(s));
    lmp.commands({"fix 1 all nve/sphere", "fix g all gravity 3.0 vector 0 0 -1",
                  "fix hs all hardsphere restitution 0.7", fmt("timestep %.17g", dt),
                  fmt("run %.0f", std::round(2.0 / dt))});
    EXPECT_EQ(lmp.fix_vector("hs", 1), 1.0) << "dt " << dt;
    xs.push_back(lmp.gather("x", 3));
    vs.push_back(lmp.gather("v", 3));
  }
  for (size_t k = 1; k < xs.size(); ++k) {
    EXPECT_LT(max_abs_diff(xs[k], xs[0]), 1e-12);
    EXPECT_LT(max_abs_diff(vs[k], vs[0]), 1e-12);
  }
  std::printf("[ HS       ] gravity + oblique collision, dt 0.004/0.01/0.025: max |dx| %.2g %.2g\n",
              max_abs_diff(xs[1], xs[0]), max_abs_diff(xs[2], xs[0]));
}

// A ball dropped from h0 = 2 (above contact) onto the floor, g = 1, e = 0.8: after the n-th
// bounce its mechanical energy, hence its apex height, is e^(2n) h0 - for every timestep.
TEST(FixHardSphere, BouncingBallApexHeightsAreExactForAnyTimestep)
{
  const double e = 0.8, h0 = 2.0, R = 0.5, zlo = -10.0;
  std::vector<std::vector<double>> apex_all;
  for (double dt : {0.01, 0.013, 0.02}) {
    Spheres s;
    s.boundary = "p p f";
    s.x = {{0.3, -0.2, zlo + R + h0}};
    s.v = {{0.25, 0, 0}};
    s.dia = {2 * R};
    s.m = {1.7};
    Lammps lmp;
    lmp.commands(sphere_lines(s));
    lmp.commands({"fix 1 all nve/sphere", "fix g all gravity 1.0 vector 0 0 -1",
                  fmt("fix hs all hardsphere wall zlo %.17g", e), fmt("timestep %.17g", dt),
                  "run 0"});
    std::vector<double> apex;
    double hprev = h0;
    const int steps = (int) std::round(10.5 / dt);
    for (int k = 0; k < steps; ++k) {
      lmp.commands({"run 1 pre no post no"});
      const auto x = lmp.gather("x", 3), v = lmp.gather("v", 3);
      ASSERT_GE(x[2], zlo + R - 1e-12) << "below the floor at step " << k;
      const double h = 0.5 * (v[2] * v[2]) + (x[2] - zlo - R);    // height of the apex
      if (std::fabs(h - hprev) > 1e-6 * h0) apex.push_back(h);
      hprev = h;
    }
    ASSERT_GE(apex.size(), 4u) << "dt " << dt;
    for (size_t n = 0; n < apex.size(); ++n)
      EXPECT_NEAR(apex[n], std::pow(e, 2.0 * (n + 1)) * h0, 1e-12) << "bounce " << n + 1;
    EXPECT_EQ(lmp.fix_vector("hs", 2), (double) apex.size());
    // Energy removed: (1 - e^2) of the normal kinetic energy at each impact.
    EXPECT_NEAR(lmp.fix_vector("hs", 3), 1.7 * (h0 - apex.back()), 1e-12);
    apex_all.push_back(apex);
    std::printf("[ HS       ] bounce dt %.3f: apex heights", dt);
    for (double a : apex) std::printf(" %.15f", a);
    std::printf("\n");
  }
  for (size_t k = 1; k < apex_all.size(); ++k) {
    ASSERT_EQ(apex_all[k].size(), apex_all[0].size());
    for (size_t n = 0; n < apex_all[0].size(); ++n)
      EXPECT_NEAR(apex_all[k][n], apex_all[0][n], 1e-13);
  }
}

// Five equal spheres in a touching row, the first one arriving at speed 1, e = 1: the last
// leaves at speed 1, the others stay at rest.
TEST(FixHardSphere, NewtonsCradle)
{
  for (const char *order : {"parallel", "serial"}) {
    Spheres s;
    s.x = {{-3.5, 0, 0}, {-2, 0, 0}, {-1, 0, 0}, {0, 0, 0}, {1, 0, 0}};
    s.v = {{1, 0, 0}, {0, 0, 0}, {0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
    s.dia = {1, 1, 1, 1, 1};
    s.m = {1, 1, 1, 1, 1};
    Lammps lmp;
    lmp.commands(sphere_lines(s));
    lmp.commands({"fix 1 all nve/sphere", std::string("fix hs all hardsphere order ") + order,
                  "timestep 0.02", "run 100"});
    const auto v = lmp.gather("v", 3), x = lmp.gather("x", 3);
    for (int i = 0; i < 4; ++i) EXPECT_NEAR(v[3 * i], 0.0, 1e-15) << order << " ball " << i + 1;
    EXPECT_NEAR(v[12], 1.0, 1e-15) << order;
    EXPECT_NEAR(x[12], 1.0 + 1.5, 1e-14) << order;    // left at t = 0.5, moved 1.5 since
    EXPECT_NEAR(x[0], -3.0, 1e-14);                   // stopped at contact with ball 2
    EXPECT_EQ(lmp.fix_vector("hs", 1), 4.0) << order;
    // f_hs[20]: the seconds of the fix's steps, counted on and never back.
    const double t100 = lmp.fix_vector("hs", 19);
    EXPECT_GT(t100, 0.0) << order;
    lmp.commands({"run 100"});
    EXPECT_GT(lmp.fix_vector("hs", 19), t100) << order;
  }
}

// The collision's virial r . dp / dt enters compute pressure at the step of the collision.
TEST(FixHardSphere, CollisionVirialEntersThePressure)
{
  Lammps lmp;
  lmp.commands(sphere_lines(head_on_pair()));
  lmp.commands({"fix 1 all nve/sphere", "fix hs all hardsphere restitution 0.8",
                "compute pv all pressure NULL virial", "thermo_style custom step press c_pv",
                "timestep 0.1", "run 5"});
  // Contact at t = 0.5 exactly: the end of step 5, which leaves it to the start of step 6.
  EXPECT_EQ(lmp.fix_vector("hs", 1), 0.0);
  lmp.commands({"run 1"});
  EXPECT_EQ(lmp.fix_vector("hs", 0), 1.0);
  // r . dp = |r| J with |r| = 1, J = (1 + e) m_eff |vn| = 1.8 * 0.75 * 2 = 2.7.
  const double vol = 20.0 * 20.0 * 20.0;
  EXPECT_NEAR(lmp.compute_scalar("pv"), 2.7 / 0.1 / (3 * vol), 1e-15);
  lmp.commands({"run 1"});
  EXPECT_EQ(lmp.compute_scalar("pv"), 0.0);
}

// Per-atom virial (compute stress/atom, fix contributions only): the head-on pair of the test
// above gives each atom half of r (x) dp / dt, in stress units -(virial); the two add up to
// minus the collision virial that compute pressure sees (volume 20^3); none on the next step.
TEST(FixHardSphere, PerAtomVirialOfAPairIsHalfToEachAtom)
{
  Lammps lmp;
  lmp.commands(sphere_lines(head_on_pair()));
  // Each atom's values through compute reduce over its own group (sphere_lines: g1, g2).
  lmp.commands({"fix 1 all nve/sphere", "fix hs all hardsphere restitution 0.8",
                "compute s all stress/atom NULL fix",
                "compute red all reduce sum c_s[1] c_s[2] c_s[3] c_s[4] c_s[5] c_s[6]",
                "compute r1 g1 reduce sum c_s[1] c_s[2] c_s[3] c_s[4] c_s[5] c_s[6]",
                "compute r2 g2 reduce sum c_s[1] c_s[2] c_s[3] c_s[4] c_s[5] c_s[6]",
                "compute pv all pressure NULL virial",
                "thermo_style custom step c_red[1] c_r1[1] c_r2[1] c_pv[1]", "timestep 0.1",
                "run 6"});
  EXPECT_EQ(lmp.fix_vector("hs", 0), 1.0);
  // r . dp = 2.7 (see above), all of it xx: 27 in virial units, 13.5 per atom.
  EXPECT_NEAR(lmp.compute_vector("r1", 0), -13.5, 1e-12);
  EXPECT_NEAR(lmp.compute_vector("r2", 0), -13.5, 1e-12);
  for (int k = 1; k < 6; ++k) {
    EXPECT_EQ(lmp.compute_vector("r1", k), 0.0) << k;
    EXPECT_EQ(lmp.compute_vector("r2", k), 0.0) << k;
  }
  const double vol = 20.0 * 20.0 * 20.0;
  EXPECT_NEAR(lmp.compute_vector("red", 0), -lmp.compute_vector("pv", 0) * vol, 1e-12);
  EXPECT_NEAR(lmp.compute_vector("red", 0), -27.0, 1e-12);
  // The start of the next run shows the last step's values, as it does the global virial.
  lmp.commands({"run 0"});
  EXPECT_NEAR(lmp.compute_vector("r1", 0), -13.5, 1e-12);
  EXPECT_NEAR(lmp.compute_vector("red", 0), -lmp.compute_vector("pv", 0) * vol, 1e-12);
  lmp.commands({"run 1"});
  EXPECT_EQ(lmp.compute_vector("r1", 0), 0.0);
  EXPECT_EQ(lmp.compute_vector("r2", 0), 0.0);
}

// A wall collision gives all of its virial to the atom: unit mass, speed 1 onto the floor
// z = -10 with e = 1 at radius 0.5 from it: m dv (z - zwall) = 2 * 0.5, / dt = 10.
TEST(FixHardSphere, PerAtomVirialOfAWallBounceIsTheAtoms)
{
  Spheres one;
  one.x = {{0, 0, -8.05}};
  one.v = {{0, 0, -1}};
  one.dia = {1};
  one.m = {1};
  one.boundary = "p p f";
  Lammps lmp;
  lmp.commands(sphere_lines(one));
  lmp.commands({"fix 1 all nve/sphere", "fix hs all hardsphere wall zlo 1.0",
                "compute s all stress/atom NULL fix",
                "compute red all reduce sum c_s[1] c_s[2] c_s[3] c_s[4] c_s[5] c_s[6]",
                "compute pv all pressure NULL virial", "thermo_style custom step c_red[3] c_pv[3]",
                "timestep 0.1", "run 15"});
  EXPECT_EQ(lmp.fix_vector("hs", 2), 1.0);    // one wall collision
  EXPECT_NEAR(lmp.compute_vector("red", 2), -10.0, 1e-9);
  for (int k : {0, 1, 3, 4, 5}) EXPECT_EQ(lmp.compute_vector("red", k), 0.0) << k;
  EXPECT_NEAR(lmp.compute_vector("red", 2), -lmp.compute_vector("pv", 2) * 8000.0, 1e-9);
}

namespace {

// 400 spheres of diameter 1 on a simple cubic lattice of spacing 1.1 in the lower part of
// a box with a floor, falling under gravity (the fix hardsphere line is the caller's).
std::vector<std::string> dense_pile()
{
  return {"units lj",
          "atom_style sphere",
          "atom_modify map array",
          "boundary p p f",
          "region box block 0 11 0 11 0 11",
          "create_box 1 box",
          "lattice sc 0.75131480090157776 origin 0.5 0.5 0.5",    // spacing 1.1
          "region fill block 0 11 0 11 0 4.4 units box",
          "create_atoms 1 region fill",
          "set type 1 diameter 1.0",
          "set type 1 density 1.9",
          "velocity all create 4.0 4928459 loop geom",
          "comm_modify cutoff 3.5",
          "neigh_modify every 1 delay 0 check yes",
          "fix 1 all nve/sphere",
          "fix g all gravity 1.0 vector 0 0 -1",
          "thermo_modify norm no",
          "timestep 0.01"};
}

}    // namespace

// A dense system under gravity with floor and roof (pair and wall collisions): at every step
// the per-atom virials summed over the atoms equal minus the global collision virial in all six
// components, in every order; asking for them changes no trajectory (bitwise).
TEST(FixHardSphere, PerAtomVirialSumsToTheGlobalOneEveryStep)
{
  const std::vector<std::string> base = dense_pile();
  for (const char *order : {"serial", "parallel", "parallel windows 5"}) {
    std::vector<double> x[2];
    for (int with = 0; with < 2; ++with) {
      Lammps lmp;
      lmp.commands(base);
      lmp.commands({std::string("fix hs all hardsphere restitution 0.95 wall zlo 0.9 wall zhi "
                                "1.0 order ") +
                    order});
      if (with) {
        lmp.commands(
            {"compute s all stress/atom NULL fix",
             "compute red all reduce sum c_s[1] c_s[2] c_s[3] c_s[4] c_s[5] c_s[6]",
             "compute pv all pressure NULL virial",
             "variable d equal abs(c_red[1]+c_pv[1]*vol)+abs(c_red[2]+c_pv[2]*vol)+abs(c_red[3]+"
             "c_pv[3]*vol)+abs(c_red[4]+c_pv[4]*vol)+abs(c_red[5]+c_pv[5]*vol)+abs(c_red[6]+c_pv["
             "6]*vol)",
             "variable m equal abs(c_red[1])+abs(c_red[2])+abs(c_red[3])+abs(c_red[4])",
             "variable z equal abs(c_red[3])", "fix avg all ave/time 1 300 300 v_d v_m v_z"});
      }
      lmp.commands({"run 300"});
      x[with] = lmp.gather("x", 3);
      if (with) {
        const double d = lmp.fix_vector("avg", 0), m = lmp.fix_vector("avg", 1);
        EXPECT_GT(m, 1.0) << order;
        EXPECT_GT(lmp.fix_vector("avg", 2), 0.0) << order;
        EXPECT_LT(d, 1e-12 * m) << order;
        std::printf("[ HS       ] per-atom virial, order %s: mean |sum - global| %.3g of mean "
                    "|sum| %.6g over 300 steps\n",
                    order, d, m);
      }
    }
    EXPECT_EQ(max_abs_diff(x[0], x[1]), 0.0) << order;
  }
}

// 400 spheres in a box with floor and roof under gravity, 3000 steps: after every step no pair
// is closer than its contact distance by more than 1e-9 of it (the fix's overlap check, which
// stops the run, is that test; the final state is checked here too), tens of thousands of
// collisions; serial and parallel agree bitwise.
TEST(FixHardSphere, DenseRunHasNoOverlapsAndSerialEqualsParallel)
{
  std::vector<std::string> base = dense_pile();
  // The default order (adaptive time windows), fixed windows, and the global loop.
  const char *orders[] = {"serial", "parallel", "parallel windows 1", "parallel windows 5"};
  std::vector<double> x[4], v[4];
  double coll[4], maxev[4], largest[4], windows[4];
  int k = 0;
  for (const char *order : orders) {
    Lammps lmp;
    lmp.commands(base);
    lmp.commands({std::string("fix hs all hardsphere restitution 0.95 wall zlo 0.9 wall zhi 1.0 "
                              "order ") +
                      order,
                  "run 3000"});
    x[k] = lmp.gather("x", 3);
    v[k] = lmp.gather("v", 3);
    coll[k] = lmp.fix_vector("hs", 1);
    maxev[k] = lmp.fix_vector("hs", 4);
    largest[k] = lmp.fix_vector("hs", 6);
    windows[k] = lmp.fix_vector("hs", 8);
    // Explicit all-pairs check of the final state (nearest image in x and y).
    const long n = lmp.natoms();
    const double period[3] = {11.0, 11.0, 0.0};
    const double worst = hsgpu_test::closest_pair_gap(x[k], 1.0, period);
    EXPECT_GT(worst, -1e-9) << order;
    std::printf("[ HS       ] dense, order %s: %ld spheres, 3000 steps, %.0f collisions (%.2f per "
                "sphere per step), at most %.0f events in a step, closest pair %.3g from "
                "contact; last step: largest group %.0f, %.0f windows\n",
                order, n, coll[k], coll[k] / n / 3000.0, maxev[k], worst, largest[k], windows[k]);
    EXPECT_GT(coll[k] / 3000.0, 10.0) << "too few collisions per step to mean anything";
    ++k;
  }
  for (int o = 1; o < 4; ++o) {
    EXPECT_EQ(coll[0], coll[o]) << orders[o];
    EXPECT_EQ(maxev[0], maxev[o]) << orders[o];
    EXPECT_EQ(max_abs_diff(x[0], x[o]), 0.0) << orders[o];
    EXPECT_EQ(max_abs_diff(v[0], v[o]), 0.0) << orders[o];
  }
  EXPECT_EQ(windows[2], 1.0);
  EXPECT_EQ(windows[3], 5.0);
  EXPECT_LE(largest[3], largest[2]);
}

// Mixed sizes need no setting by hand: diameters 1 and 10 run with LAMMPS's defaults (no
// 'neigh_modify one', no 'comm_modify cutoff'): the fix requests no neighbor list (its own
// candidate search follows each atom's size and speed) and raises the ghost cutoff itself.
// Four big spheres among about 6000 small ones under gravity, floor and roof: no error,
// collisions between small and big spheres, no overlap at the end (all pairs, each with its own
// contact distance), and a few candidate pairs per atom, not the hundreds a big-sphere cutoff
// would give.  (The search's cells follow the small spheres, the big ones are searched apart:
// its time per step is printed; examples/hardsphere/in.sizeratio10 measures it,
// doc/fix_hardsphere.md.)
TEST(FixHardSphere, SizeRatioTenRunsWithDefaults)
{
  Lammps lmp;
  lmp.commands({"units lj",
                "atom_style sphere",
                "atom_modify map array",
                "boundary p p f",
                "region box block 0 44 0 44 0 30",
                "create_box 2 box",
                "region s1 sphere 11 11 6 5.6 units box",
                "region s2 sphere 33 11 6 5.6 units box",
                "region s3 sphere 11 33 6 5.6 units box",
                "region s4 sphere 33 33 6 5.6 units box",
                "region notbig union 4 s1 s2 s3 s4 side out",
                "region slab block 0 44 0 44 0 12 units box",
                "region small intersect 2 slab notbig",
                "lattice sc 0.2962962962962963 origin 0.5 0.5 0.5",
                "create_atoms 1 region small",
                "create_atoms 2 single 11 11 6 units box",
                "create_atoms 2 single 33 11 6 units box",
                "create_atoms 2 single 11 33 6 units box",
                "create_atoms 2 single 33 33 6 units box",
                "set type 1 diameter 1.0",
                "set type 2 diameter 10.0",
                "set type * density 1.0",
                "velocity all create 2.0 87287 loop geom",
                "fix 1 all nve/sphere",
                "fix g all gravity 1.0 vector 0 0 -1"});
#if HSGPU_LAMMPS_VERSION < 20220324
  lmp.commands({"neigh_modify delay 0"});    // LAMMPS's default before 2022 was delay 10
#endif
  lmp.commands({"fix hs all hardsphere restitution 0.9 wall zlo 0.9 wall zhi 1.0",
                "thermo_modify norm no", "timestep 0.005", "run 100"});
  const long n = lmp.natoms();
  EXPECT_GT(n, 5000);
  const double coll = lmp.fix_vector("hs", 1), walls = lmp.fix_vector("hs", 2);
  const double cand = lmp.fix_vector("hs", 20);
  const double t_step = lmp.fix_vector("hs", 19) / 100.0;
  EXPECT_GT(coll, 1000.0);
  EXPECT_GT(walls, 0.0);
  // Candidate pairs of the last step per atom: a cutoff of the big spheres' contact distance
  // (plus the step's reach) would give several hundred.
  EXPECT_GT(cand, 0.0);
  EXPECT_LT(cand / n, 10.0);
  const auto x = lmp.gather("x", 3), rad = lmp.gather("radius", 1);
  double worst = 1e300, worst_big = 1e300;
  for (long i = 0; i < n; ++i)
    for (long j = i + 1; j < n; ++j) {
      double r2 = 0.0;
      for (int d = 0; d < 3; ++d) {
        double dx = x[3 * i + d] - x[3 * j + d];
        if (d < 2) dx -= 44.0 * std::round(dx / 44.0);
        r2 += dx * dx;
      }
      const double s = rad[i] + rad[j];
      if (r2 > 4.0 * s * s) continue;
      const double gap = (std::sqrt(r2) - s) / s;
      worst = std::min(worst, gap);
      if (rad[i] != rad[j]) worst_big = std::min(worst_big, gap);
    }
  EXPECT_GT(worst, -1e-9);
  EXPECT_LT(worst_big, 1e-3) << "no small sphere near a big one: nothing tested";
  std::printf("[ HS       ] diameters 1 and 10: %ld spheres, 100 steps, %.0f collisions, %.0f "
              "wall collisions, %.2f candidate pairs per atom, %.3g ms per step (fix), closest "
              "pair %.3g of contact from it (small-big %.3g)\n",
              n, coll, walls, cand / n, 1e3 * t_step, worst, worst_big);
}

namespace {

// Smallest gap between spheres of their own radii (relative to the contact distance), all
// pairs, nearest image along each dimension d with period[d] > 0.
double closest_gap(const std::vector<double> &x, const std::vector<double> &rad,
                   const double period[3])
{
  const size_t n = rad.size();
  double worst = 1e300;
  for (size_t i = 0; i < n; ++i)
    for (size_t j = i + 1; j < n; ++j) {
      double r2 = 0.0;
      for (int d = 0; d < 3; ++d) {
        double dx = x[3 * i + d] - x[3 * j + d];
        if (period[d] > 0.0) dx -= period[d] * std::round(dx / period[d]);
        r2 += dx * dx;
      }
      const double s = rad[i] + rad[j];
      worst = std::min(worst, (std::sqrt(r2) - s) / s);
    }
  return worst;
}

// A small sphere on the floor squeezed by a big one (diameters 1 and 10, the big one falling
// onto it off-centre) is squirted sideways at about 100 while the big one falls at 5.  The
// fix's reach 0.25 (the ghost shell of a user who wants it thin) covers the big one's moves but
// not the small one's after the squeeze.
std::vector<std::string> squeeze_scene(const std::string &extra)
{
  return {"units lj",
          "atom_style sphere",
          "atom_modify map array",
          "boundary p p f",
          "region box block 0 50 0 50 0 30",
          "create_box 2 box",
          "create_atoms 1 single 25 25 0.5 units box",
          "create_atoms 2 single 25.5 25 6.6 units box",
          "set type 1 diameter 1.0",
          "set type 2 diameter 10.0",
          "set type * density 1.0",
          "neigh_modify every 1 delay 0 check yes",
          "fix 1 all nve/sphere",
          "fix g all gravity 1.0 vector 0 0 -1",
          "group big type 2",
          "velocity big set 0 0 -5",
          "variable sp atom sqrt(vx*vx+vy*vy+vz*vz)",
          "compute vm all reduce max v_sp",
          "thermo_style custom step c_vm",
          "thermo_modify norm no",
          "timestep 0.005",
          extra,
          "fix hs all hardsphere restitution 0.9 wall zlo 0.9 wall zhi 1.0 reach 0.25",
          "run 400"};
}

}    // namespace

// Issue 12 item 9: the run used to stop at step 25 ("atoms move up to 0.500163 per step ...
// more than the reach 0.25 its ghost atoms cover").  Now the fix raises the ghost cutoff at the
// end of the squeezing step (a reneighboring it asks for) and the run goes on, with the
// trajectory of a run whose ghosts covered the moves from the start.  With a communication
// cutoff that already covers them the step's reach is raised within it, with no reneighboring.
TEST(FixHardSphere, SqueezedSmallSphereOutrunsTheReachAndTheFixAdapts)
{
  std::vector<double> x[3], v[3];
  double raised[3], covered[3], vmax[3], coll[3];
  const char *extra[3] = {"comm_modify vel yes", "comm_modify cutoff 14 vel yes",
                          "comm_modify cutoff 25 vel yes"};
  for (int k = 0; k < 3; ++k) {
    Lammps lmp;
    lmp.commands(squeeze_scene(extra[k]));
    x[k] = lmp.gather("x", 3);
    v[k] = lmp.gather("v", 3);
    raised[k] = lmp.fix_vector("hs", 21);
    covered[k] = lmp.fix_vector("hs", 22);
    vmax[k] = lmp.compute_scalar("vm");
    coll[k] = lmp.fix_vector("hs", 1);
    const double period[3] = {50.0, 50.0, 0.0};
    EXPECT_GT(closest_gap(x[k], lmp.gather("radius", 1), period), -1e-9) << extra[k];
    std::printf("[ HS       ] squeeze (%s): %.0f collisions, fastest atom %.4g (moves %.4g per "
                "step), ghost cutoff raised %.0f times, the ghosts cover a reach of %.4g\n",
                extra[k], coll[k], vmax[k], vmax[k] * 0.005, raised[k], covered[k]);
  }
  EXPECT_GT(vmax[0] * 0.005, 0.25) << "the small sphere should outrun the reach";
  EXPECT_GE(coll[0], 10.0);
  EXPECT_GE(raised[0], 1.0);
  EXPECT_GT(covered[0], 2.0 * vmax[0] * 0.005 * 0.99);
  EXPECT_EQ(raised[1], 0.0);    // cutoff 14 covers a reach of 1.85
  EXPECT_EQ(raised[2], 0.0);
  // Same collisions; the run with the cutoff raised on the way (its extra reneighboring
  // wraps periodic coordinates at another step) agrees to round-off, the other bitwise.
  for (int k = 0; k < 2; ++k) {
    EXPECT_EQ(coll[k], coll[2]);
    EXPECT_LT(max_abs_diff(x[k], x[2]), 1e-10) << extra[k];
    EXPECT_LT(max_abs_diff(v[k], v[2]), 1e-10) << extra[k];
  }
  EXPECT_EQ(max_abs_diff(x[1], x[2]), 0.0);
  EXPECT_EQ(max_abs_diff(v[1], v[2]), 0.0);
}

// Where the ghosts cannot cover a move (it came within one step), the error says what to set,
// and that setting runs.  An atom kicked by a force that switches on at step 10 (its speed is
// a dt = 5000 after the half kicks on either side of the force) moves 25 in step 11, and 50 in
// step 12, for which the fix raises the ghost cutoff itself (after steps 11 and 12).
TEST(FixHardSphere, AMoveBeyondTheGhostsNamesTheReachToSet)
{
  const std::vector<std::string> scene = {"units lj",
                                          "atom_style sphere",
                                          "atom_modify map array",
                                          "boundary f f f",
                                          "region box block 0 100 0 100 0 100",
                                          "create_box 1 box",
                                          "create_atoms 1 single 20 50 50 units box",
                                          "create_atoms 1 single 60 50 50 units box",
                                          "set type 1 diameter 1.0",
                                          "set type 1 mass 1.0",
                                          "neigh_modify every 1 delay 0 check yes",
                                          "group one id 1",
                                          "variable fx equal (step>=10)*1e6",
                                          "fix 1 all nve/sphere",
                                          "fix kick one addforce v_fx 0 0",
                                          "timestep 0.005"};
  {
    Lammps lmp;
    lmp.commands(scene);
    const std::string err =
        lmp.first_error({"fix hs all hardsphere reach 0.5 wall xhi 1.0", "run 12"});
    EXPECT_THAT(err, HasSubstr("an atom moved 25 in one step (step 11), more than the 0.5 its "
                               "ghost atoms cover (communication cutoff 2.3)"));
    EXPECT_THAT(err, HasSubstr("set the fix's 'reach' to at least 25"));
  }
  {
    Lammps lmp;
    lmp.commands(scene);
    EXPECT_EQ(lmp.first_error({"fix hs all hardsphere reach 26 wall xhi 1.0", "run 12"}), "");
    EXPECT_GE(lmp.fix_vector("hs", 21), 1.0) << "ghost cutoff raised for step 12";
    EXPECT_GT(lmp.fix_vector("hs", 22), 50.0);
  }
}

TEST(FixHardSphere, RestartContinuationEqualsUninterruptedRun)
{
  const std::string file = "fix_hardsphere_test.restart";
  std::vector<std::string> base = {"units lj",
                                   "atom_style sphere",
                                   "atom_modify map array",
                                   "boundary p p f",
                                   "region box block 0 8.8 0 8.8 0 8.8",
                                   "create_box 1 box",
                                   "lattice sc 0.75131480090157776 origin 0.5 0.5 0.5",
                                   "region fill block 0 8.8 0 8.8 0 3.3 units box",
                                   "create_atoms 1 region fill",
                                   "set type 1 diameter 1.0",
                                   "set type 1 density 1.9",
                                   "velocity all create 2.0 87287 loop geom",
                                   "comm_modify cutoff 3.5",
                                   "neigh_modify every 1 delay 0 check yes",
                                   "thermo_modify norm no",
                                   "timestep 0.005"};
  const std::vector<std::string> fixes = {
      "fix 1 all nve/sphere", "fix g all gravity 1.0 vector 0 0 -1",
      "fix hs all hardsphere restitution 0.6 wall zlo 0.7 wall zhi 1.0"};
  std::vector<double> xa, va, fa(5), xb, vb, fb(5);
  {
    Lammps lmp;
    lmp.commands(base);
    lmp.commands(fixes);
    lmp.commands({"run 300", "write_restart " + file, "run 300"});
    xa = lmp.gather("x", 3);
    va = lmp.gather("v", 3);
    for (int i = 0; i < 5; ++i) fa[i] = lmp.fix_vector("hs", i);
  }
  {
    Lammps lmp;
    lmp.commands({"read_restart " + file, "comm_modify cutoff 3.5",
                  "neigh_modify every 1 delay 0 check yes", "thermo_modify norm no",
                  "timestep 0.005"});
    lmp.commands(fixes);
    lmp.commands({"run 300"});
    xb = lmp.gather("x", 3);
    vb = lmp.gather("v", 3);
    for (int i = 0; i < 5; ++i) fb[i] = lmp.fix_vector("hs", i);
  }
  std::remove(file.c_str());
  EXPECT_GT(fa[1], 1000.0);
  EXPECT_LT(max_abs_diff(xa, xb), 1e-12);
  EXPECT_LT(max_abs_diff(va, vb), 1e-12);
  for (int i = 0; i < 5; ++i)
    EXPECT_NEAR(fb[i], fa[i], 1e-9 * std::fabs(fa[i])) << "f_hs[" << i + 1 << "]";
  std::printf("[ HS       ] restart: max |dx| %.2g |dv| %.2g after 300 + 300 steps, %.0f "
              "collisions\n",
              max_abs_diff(xa, xb), max_abs_diff(va, vb), fa[1]);
}

// A dense fluid (packing fraction 0.4, elastic): the pressure at the first thermo output of a
// run, and of a run continued from a restart file, is the last step's, collisions included
// (they are most of it), not only its kinetic part.
TEST(FixHardSphere, PressureAtTheStartOfARunIsTheLastSteps)
{
  const std::string file = "fix_hardsphere_press.restart";
  const std::vector<std::string> fixes = {"fix 1 all nve/sphere",
                                          "fix hs all hardsphere",
                                          "compute pk all pressure thermo_temp ke",
                                          "thermo_style custom step press c_pk f_hs[1]",
                                          "thermo_modify norm no",
                                          "timestep 0.005"};
  double press = 0.0, kinetic = 0.0, last = 0.0;
  {
    Lammps lmp;
    lmp.commands({"units lj", "atom_style sphere", "atom_modify map array", "boundary p p p",
                  "lattice fcc 0.76", "region box block 0 5 0 5 0 5", "create_box 1 box",
                  "create_atoms 1 box", "set type 1 diameter 1.0", "set type 1 mass 1.0",
                  "velocity all create 1.0 4928459 loop geom",
                  "neigh_modify every 1 delay 0 check yes"});
    lmp.commands(fixes);
    lmp.commands({"run 200"});
    press = lmp.thermo("press");    // the last thermo output of the run
    kinetic = lmp.compute_scalar("pk");
    last = lmp.fix_vector("hs", 0);
    std::printf("[ HS       ] fluid at packing fraction 0.4: pressure %.8g, kinetic part %.8g, "
                "%.0f collisions in the last step\n",
                press, kinetic, last);
    EXPECT_GT(press, 3.0 * kinetic) << "the collisions should carry most of the pressure";
    EXPECT_GT(last, 0.0);
    lmp.commands({"run 0"});
    EXPECT_EQ(lmp.thermo("press"), press) << "first thermo output of the next run";
    EXPECT_EQ(lmp.fix_vector("hs", 0), last);
    lmp.commands({"write_restart " + file, "run 20"});
    EXPECT_NE(lmp.thermo("press"), press) << "a run goes on from there";
  }
  {
    Lammps lmp;
    lmp.commands({"read_restart " + file, "neigh_modify every 1 delay 0 check yes"});
    lmp.commands(fixes);
    lmp.commands({"run 0"});
    EXPECT_EQ(lmp.thermo("press"), press) << "first thermo output after read_restart";
    EXPECT_EQ(lmp.compute_scalar("pk"), kinetic);
    EXPECT_EQ(lmp.fix_vector("hs", 0), last);
  }
  std::remove(file.c_str());
}

// Atoms inserted by fix pour into a group that is empty when the run starts: the fix covers
// their radius from the start (fix pour's largest radius) and resolves their collisions.
TEST(FixHardSphere, PourIntoAGroupEmptyAtTheStart)
{
  Lammps lmp;
  // map hash: LAMMPS 29 Sep 2021's fix pour crashes in Atom::map_set() with 'map array' in a
  // box created empty (also without this fix).
  lmp.commands({"units lj", "atom_style sphere", "atom_modify map hash", "boundary p p f",
                "region box block 0 10 0 10 0 20", "create_box 1 box",
                "neigh_modify every 1 delay 0 check yes", "comm_modify vel yes",
                "region slab block 1 9 1 9 14 19",
                "fix g all gravity 1.0 vector 0 0 -1",    // fix pour needs it first
                "fix ins all pour 200 1 4767548 region slab diam one 1.0 vol 0.3 50",
                "fix 1 all nve/sphere", "fix hs all hardsphere wall zlo 0.5 restitution 0.5",
                "thermo_modify norm no", "timestep 0.005", "run 2000"});
  const long n = lmp.natoms();
  const double coll = lmp.fix_vector("hs", 1), walls = lmp.fix_vector("hs", 2);
  const auto x = lmp.gather("x", 3);
  const double period[3] = {10.0, 10.0, 0.0};
  double worst = hsgpu_test::closest_pair_gap(x, 1.0, period);
  for (long i = 0; i < n; ++i) worst = std::min(worst, x[3 * i + 2] - 0.5);
  std::printf("[ HS       ] fix pour into an empty group: %ld atoms, %.0f collisions, %.0f wall "
              "collisions, closest pair or floor %.3g from contact\n",
              n, coll, walls, worst);
  EXPECT_GT(n, 100);
  EXPECT_GT(coll, 100.0);
  EXPECT_GT(walls, 100.0);
  EXPECT_GT(worst, -1e-9);
}

namespace {

// The fix's outputs after a run of `steps` steps on n atoms: finite, non-negative where they
// count, and the per-step figures within what n atoms can give.
void expect_sane_outputs(Lammps &lmp, const char *id, long n)
{
  std::vector<double> f(23);
  for (int i = 0; i < 23; ++i) {
    f[i] = lmp.fix_vector(id, i);
    EXPECT_TRUE(std::isfinite(f[i])) << "f_" << id << "[" << i + 1 << "]";
    if (i != 16) {
      EXPECT_GE(f[i], 0.0) << "f_" << id << "[" << i + 1 << "]";
    }
  }
  EXPECT_LE(f[0], f[1]);                  // last step's collisions within the total
  EXPECT_LE(f[4], f[5]);                  // most events in a step within the total
  EXPECT_LE(f[6], (double) n);            // largest group
  EXPECT_LE(f[10], (double) n * f[8]);    // atoms in groups spanning ranks, all windows
  EXPECT_LT(f[20], 20.0 * (double) n);    // candidate pairs of the last step
  EXPECT_EQ(f[16], -1.0);                 // the CPU backend
}

// Largest radius among the atoms.
double largest(const std::vector<double> &rad)
{
  double r = 0.0;
  for (double q : rad) r = std::max(r, q);
  return r;
}

}    // namespace

// Issue 12 item 12: fix pour with a size distribution into a group that is empty when the run
// starts (diameters 0.4, 1 and 2 by volume fractions 0.3, 0.4, 0.3).  The fix covers the pour's
// largest radius from the start (its ghost cutoff and reach), and the spheres that arrive,
// of all three sizes, are resolved: no pair (each at its own contact distance) or sphere and
// floor overlaps at the end, collisions of every kind, and outputs that make sense.
TEST(FixHardSphere, PolydispersePourIntoAnEmptyGroup)
{
  Lammps lmp;
  lmp.commands({"units lj", "atom_style sphere", "atom_modify map hash", "boundary p p f",
                "region box block 0 12 0 12 0 30", "create_box 1 box",
                "neigh_modify every 1 delay 0 check yes", "comm_modify vel yes",
                "group grains empty", "region slab block 1 11 1 11 16 28",
                "fix g grains gravity 1.0 vector 0 0 -1",
                "fix ins grains pour 400 1 4767548 region slab diam poly 3 0.4 0.3 1.0 0.4 2.0 "
                "0.3 vol 0.25 50",
                "fix 1 grains nve/sphere", "fix hs grains hardsphere wall zlo 0.5 restitution 0.5",
                "thermo_modify norm no", "timestep 0.005", "run 0"});
  EXPECT_EQ(lmp.natoms(), 0);
  EXPECT_GE(lmp.fix_vector("hs", 22), 1.0) << "reach of the pour's largest radius";
  lmp.commands({"run 3000"});
  const long n = lmp.natoms();
  const auto x = lmp.gather("x", 3), rad = lmp.gather("radius", 1);
  const double period[3] = {12.0, 12.0, 0.0};
  const double gap = closest_gap(x, rad, period);
  double floor_gap = 1e300;
  int sizes[3] = {0, 0, 0};
  for (long i = 0; i < n; ++i) {
    floor_gap = std::min(floor_gap, (x[3 * i + 2] - rad[i]) / rad[i]);
    sizes[rad[i] < 0.3 ? 0 : rad[i] < 0.7 ? 1 : 2]++;
  }
  const double coll = lmp.fix_vector("hs", 1), walls = lmp.fix_vector("hs", 2);
  std::printf("[ HS       ] fix pour, diameters 0.4/1/2, into an empty group: %ld atoms (%d, %d, "
              "%d), %.0f collisions, %.0f wall collisions, closest pair %.3g and floor %.3g "
              "from contact, %.2f candidate pairs per atom, most events in a step %.0f\n",
              n, sizes[0], sizes[1], sizes[2], coll, walls, gap, floor_gap,
              lmp.fix_vector("hs", 20) / n, lmp.fix_vector("hs", 4));
  EXPECT_GT(n, 300);
  for (int k = 0; k < 3; ++k) EXPECT_GT(sizes[k], 20) << "size class " << k;
  EXPECT_DOUBLE_EQ(largest(rad), 1.0);
  EXPECT_GT(coll, 1000.0);
  EXPECT_GT(walls, 300.0);
  EXPECT_GT(gap, -1e-9);
  EXPECT_GT(floor_gap, -1e-9);
  expect_sane_outputs(lmp, "hs", n);
}

// Issue 12 item 12: fix deposit, one atom every 10 steps onto a floor, into a group that is
// empty when the run starts (its radius, 0.5, from fix deposit): all 250 arrive and pile up
// without overlaps, and the outputs make sense.
TEST(FixHardSphere, DepositIntoAnEmptyGroup)
{
  Lammps lmp;
  lmp.commands({"units lj", "atom_style sphere", "atom_modify map hash", "boundary p p f",
                "region box block 0 6 0 6 0 20", "create_box 1 box",
                "neigh_modify every 1 delay 0 check yes", "comm_modify vel yes",
                "group grains empty", "region top block 0.5 5.5 0.5 5.5 14 18",
                "fix dep grains deposit 250 1 10 29494 region top near 1.0 vz -2 -2",
                "fix g grains gravity 1.0 vector 0 0 -1", "fix 1 grains nve/sphere",
                "fix hs grains hardsphere wall zlo 0.5 restitution 0.5", "thermo_modify norm no",
                "timestep 0.005", "run 3000"});
  const long n = lmp.natoms();
  const auto x = lmp.gather("x", 3), rad = lmp.gather("radius", 1);
  const double period[3] = {6.0, 6.0, 0.0};
  const double gap = closest_gap(x, rad, period);
  double floor_gap = 1e300;
  for (long i = 0; i < n; ++i) floor_gap = std::min(floor_gap, x[3 * i + 2] - rad[i]);
  const double coll = lmp.fix_vector("hs", 1), maxev = lmp.fix_vector("hs", 4);
  std::printf("[ HS       ] fix deposit into an empty group: %ld atoms, %.0f collisions, most "
              "events in a step %.0f, closest pair %.3g and floor %.3g from contact\n",
              n, coll, maxev, gap, floor_gap);
  EXPECT_EQ(n, 250);
  EXPECT_DOUBLE_EQ(largest(rad), 0.5);
  EXPECT_GT(coll, 1000.0);
  EXPECT_GT(gap, -1e-9);
  EXPECT_GT(floor_gap, -1e-9);
  EXPECT_GT(maxev, 0.0);
  expect_sane_outputs(lmp, "hs", n);
}

TEST(FixHardSphere, BadInputStopsWithANamedError)
{
  const std::vector<std::string> box = {"units lj",
                                        "atom_style sphere",
                                        "boundary p p f",
                                        "region box block 0 10 0 10 0 10",
                                        "create_box 1 box",
                                        "create_atoms 1 single 5 5 5",
                                        "create_atoms 1 single 5.5 5 5",
                                        "comm_modify cutoff 4",
                                        "neigh_modify every 1 delay 0 check yes",
                                        "fix 1 all nve/sphere"};
  auto first_error = [&](const std::vector<std::string> &extra) {
    Lammps lmp;
    std::string err = lmp.first_error(box);
    if (!err.empty()) return "setup failed: " + err;
    return lmp.first_error(extra);
  };
  EXPECT_THAT(first_error({"fix hs all hardsphere bounce 1"}), HasSubstr("unknown keyword bounce"));
  EXPECT_THAT(first_error({"fix hs all hardsphere restitution 1.5"}),
              HasSubstr("restitution must be between 0 and 1"));
  EXPECT_THAT(first_error({"fix hs all hardsphere restitution/pair 1 1 -0.1"}),
              HasSubstr("restitution must be between 0 and 1"));
  EXPECT_THAT(first_error({"fix hs all hardsphere wall xlo 0.9", "run 0"}),
              HasSubstr("wall xlo is on a periodic face"));
  EXPECT_THAT(first_error({"fix hs all hardsphere wall zhi 0.9 order random"}),
              HasSubstr("order must be parallel or serial"));
  EXPECT_THAT(first_error({"fix hs all hardsphere maxevents 10 maybe"}),
              HasSubstr("maxevents takes N error|warn"));
  // The two atoms 0.5 apart with diameter 1 overlap.
  EXPECT_THAT(
      first_error({"fix hs all hardsphere", "run 0"}),
      HasSubstr("atoms 1 and 2 overlap at step 0: centre distance 0.5, contact distance 1"));
  // A communication cutoff short of what the fix needs is raised by the fix, not an error.
  EXPECT_EQ(
      first_error({"comm_modify cutoff 2", "set atom 2 x 7", "fix hs all hardsphere", "run 0"}),
      "");
  EXPECT_THAT(first_error({"neigh_modify delay 5", "fix hs all hardsphere", "run 0"}),
              HasSubstr("neigh_modify every 1 delay 0"));
  {
    Lammps lmp;
    const std::string err =
        lmp.first_error({"units lj", "atom_style atomic", "region box block 0 10 0 10 0 10",
                         "create_box 1 box", "fix hs all hardsphere"});
    EXPECT_THAT(err, HasSubstr("requires atom style sphere"));
  }
  {
    Lammps lmp;
    const std::string err = lmp.first_error(
        {"units lj", "atom_style sphere", "boundary p p s", "region box block 0 10 0 10 0 10",
         "create_box 1 box", "create_atoms 1 single 5 5 5", "comm_modify cutoff 4",
         "neigh_modify every 1 delay 0 check yes", "fix hs all hardsphere wall zhi 1.0", "run 0"});
    EXPECT_THAT(err, HasSubstr("wall zhi needs a fixed boundary ('f')"));
  }
  // Atoms too fast for what a periodic box lets the fix cover (the ghost cutoff is raised to
  // cover twice their drift, but a pair must be found through one image only).
  {
    Lammps lmp;
    lmp.commands(box);
    const std::string err = lmp.first_error({"set atom 2 x 7", "velocity all set 30 0 0",
                                             "fix hs all hardsphere", "timestep 0.1", "run 1"});
    EXPECT_THAT(err, HasSubstr("an atom moved 3 in one step (step 1), more than the periodic box "
                               "length 10 along x lets the fix cover (2:"));
    EXPECT_THAT(err, HasSubstr("reduce the timestep"));
  }
  // More events than allowed in a step: error, or warn and go on.
  {
    Lammps lmp;
    lmp.commands(box);
    const std::string err = lmp.first_error(
        {"set atom 2 x 6.5", "velocity all set 0 0 0", "group one id 1", "velocity one set 1 0 0",
         "fix hs all hardsphere maxevents 1 error", "timestep 0.01", "run 60", "set atom 1 x 3",
         "set atom 2 x 4.2", "velocity one set 3 0 0", "run 30"});
    // One event per step is within the cap.
    EXPECT_EQ(err, "");
  }
  {
    Lammps lmp;
    lmp.commands(box);
    // Three in a row: 1 hits 2, which hits 3 in the same step.
    const std::string err =
        lmp.first_error({"set atom 2 x 6.0", "create_atoms 1 single 7.0 5 5",
                         "velocity all set 0 0 0", "group one id 1", "velocity one set 1 0 0",
                         "fix hs all hardsphere maxevents 1 error", "timestep 0.01", "run 100"});
    EXPECT_THAT(err, HasSubstr("needed more than maxevents = 1 events"));
  }
  {
    Lammps lmp;
    lmp.commands(box);
    const std::string err = lmp.first_error(
        {"set atom 2 x 6.0", "create_atoms 1 single 7.0 5 5", "velocity all set 0 0 0",
         "group one id 1", "velocity one set 1 0 0",
         "fix hs all hardsphere maxevents 1 warn overlap push", "timestep 0.01", "run 100"});
    EXPECT_EQ(err, "") << "warn goes on (the collision left over is an overlap next step)";
  }
  // overlap push separates the pair instead, conserving the centre of mass.
  {
    Lammps lmp;
    lmp.commands(box);
    lmp.commands({"fix hs all hardsphere overlap push", "run 0"});
    const auto x = lmp.gather("x", 3);
    EXPECT_GE(x[3] - x[0], 1.0);
    EXPECT_NEAR(x[3] - x[0], 1.0, 2e-6);    // pushed to 1e-6 beyond contact
    EXPECT_NEAR(0.5 * (x[0] + x[3]), 5.25, 1e-12);
  }
  EXPECT_THAT(first_error({"fix hs all hardsphere overlap push maxpush 0"}),
              HasSubstr("maxpush must be >= 1"));
  EXPECT_THAT(first_error({"fix hs all hardsphere gpu maybe"}),
              HasSubstr("gpu must be yes or no, got maybe"));
  EXPECT_THAT(first_error({"fix hs all hardsphere gpu yes gpu/gather 1"}),
              HasSubstr("gpu/gather must be yes or no, got 1"));
  EXPECT_THAT(first_error({"fix hs all hardsphere gpu yes gpu/keep sometimes"}),
              HasSubstr("gpu/keep must be yes or no, got sometimes"));
  EXPECT_THAT(first_error({"fix hs all hardsphere device -2"}),
              HasSubstr("device must be auto or >= 0"));
  // The timestep: zero or negative is named (not a NaN pressure, not an overlap later on).
  EXPECT_THAT(first_error({"set atom 2 x 7", "timestep 0", "fix hs all hardsphere", "run 10"}),
              HasSubstr("requires a positive timestep, got 0"));
  EXPECT_THAT(first_error({"set atom 2 x 7", "timestep -0.01", "fix hs all hardsphere", "run 0"}),
              HasSubstr("requires a positive timestep, got -0.01"));
  // Two fixes on one atom; disjoint groups are fine (their atoms do not see each other).
  EXPECT_THAT(first_error({"fix hs all hardsphere", "fix hs2 all hardsphere", "run 0"}),
              HasSubstr("fixes hs (group all) and hs2 (group all) both act on atom 1"));
  EXPECT_THAT(
      first_error({"group b id 2", "fix hs all hardsphere", "fix hs2 b hardsphere", "run 0"}),
      HasSubstr("fixes hs (group all) and hs2 (group b) both act on atom 2"));
  EXPECT_EQ(first_error({"group a id 1", "group b id 2", "fix hs a hardsphere",
                         "fix hs2 b hardsphere", "run 10"}),
            "");
  // An empty group is allowed (atoms may join it later); a group of points is not.
  EXPECT_EQ(first_error({"group none empty", "fix hs none hardsphere", "run 10"}), "");
  EXPECT_THAT(first_error({"group none empty", "fix hs none hardsphere", "fix hs2 none hardsphere",
                           "run 0"}),
              HasSubstr("both act on the same group"));
  EXPECT_THAT(first_error({"unfix 1", "group a id 1", "set atom 1 diameter 0",
                           "fix hs a hardsphere", "run 0"}),
              HasSubstr("no atom of group a has a radius > 0"));
}

// overlap push relaxes random placements (every sphere overlapping two or three others at
// packing fraction 0.3) until no overlap is left, with pushes large enough that atoms move
// between cells and are exchanged between passes; with too few passes it says how far it got.
TEST(FixHardSphere, OverlapPushRelaxesRandomPlacement)
{
  const std::vector<std::string> base = {
      "units lj",
      "atom_style sphere",
      "atom_modify map array",
      "boundary p p f",
      "variable L equal (600*0.5235987755982988/0.3)^(1.0/3.0)",
      "region box block 0 ${L} 0 ${L} 0 ${L} units box",
      "create_box 1 box",
      "region inside block 0 ${L} 0 ${L} 0.5 $(v_L-0.5) units box",
      "create_atoms 1 random 600 20261124 inside",
      "set type 1 diameter 1.0",
      "set type 1 mass 1.0",
      "neigh_modify every 1 delay 0 check yes",
      "fix 1 all nve/sphere",
      "thermo_modify norm no",
      "timestep 0.001"};
  {
    Lammps lmp;
    lmp.commands(base);
    lmp.commands({"fix hs all hardsphere overlap push wall zlo 1 wall zhi 1", "run 0"});
    const double pushed = lmp.fix_vector("hs", 13);    // f_hs[14]
    EXPECT_GT(pushed, 600.0) << "the case should start with many overlaps";
    const auto x = lmp.gather("x", 3);
    const double L = std::cbrt(600 * 0.5235987755982988 / 0.3);
    const double period[3] = {L, L, 0.0};
    double worst = hsgpu_test::closest_pair_gap(x, 1.0, period);
    for (int i = 0; i < 600; ++i) {
      worst = std::min(worst, x[3 * i + 2] - 0.5);
      worst = std::min(worst, L - 0.5 - x[3 * i + 2]);
    }
    std::printf("[ HS       ] random placement at packing fraction 0.3: %.0f overlaps pushed, "
                "closest pair or wall %.3g from contact\n",
                pushed, worst);
    EXPECT_GT(worst, -1e-9);
  }
  {
    Lammps lmp;
    lmp.commands(base);
    const std::string err = lmp.first_error(
        {"fix hs all hardsphere overlap push maxpush 3 wall zlo 1 wall zhi 1", "run 0"});
    EXPECT_THAT(err, HasSubstr("after 3 passes of 'overlap push'"));
    EXPECT_THAT(err, HasSubstr("overlaps left, the deepest"));
  }
  {
    // Atoms placed up to the fixed faces z = 0 and L, with no wall there: a push stops just
    // inside a face instead of carrying atoms out, where LAMMPS would lose them (before, 10 of
    // the 600 were lost).
    std::vector<std::string> open = base;
    for (auto &l : open)
      if (l.rfind("create_atoms", 0) == 0) l = "create_atoms 1 random 600 20261124 box";
    Lammps lmp;
    lmp.commands(open);
    EXPECT_EQ(lmp.first_error({"fix hs all hardsphere overlap push", "run 0"}), "");
    ASSERT_EQ(lmp.natoms(), 600);
    const auto x = lmp.gather("x", 3);
    const double L = std::cbrt(600 * 0.5235987755982988 / 0.3);
    double zlo = L, zhi = 0.0;
    for (int i = 0; i < 600; ++i) {
      zlo = std::min(zlo, x[3 * i + 2]);
      zhi = std::max(zhi, x[3 * i + 2]);
    }
    EXPECT_GE(zlo, 0.0);
    EXPECT_LT(zhi, L);
    const double period[3] = {L, L, 0.0};
    EXPECT_GT(hsgpu_test::closest_pair_gap(x, 1.0, period), -1e-9);
  }
}

// A pile poured onto the floor with e = 0.5 and the default guards comes to rest and stays
// there: bounded events per step (no inelastic collapse, no runaway), kinetic energy of order
// N m (g dt)^2, its top fixed to within slow compaction.
TEST(FixHardSphere, SettledPileStaysAtRestWithDefaultGuards)
{
  Lammps lmp;
  lmp.commands({"units lj",
                "atom_style sphere",
                "atom_modify map array",
                "boundary p p f",
                "region box block 0 8.4 0 8.4 0 30",
                "create_box 1 box",
                "lattice sc 0.5787037037037037 origin 0.5 0.5 0.5",    // spacing 1.2
                "region block block 0 8.4 0 8.4 5 12.2 units box",
                "create_atoms 1 region block",
                "set type 1 diameter 1.0",
                "set type 1 mass 1.0",
                "velocity all create 0.05 87287 loop geom",
                "comm_modify cutoff 2.5",
                "neigh_modify every 1 delay 0 check yes",
                "fix 1 all nve/sphere",
                "fix g all gravity 1.0 vector 0 0 -1",
                "fix hs all hardsphere restitution 0.5 wall zlo 0.5 wall zhi 0.5",
                "compute zmax all reduce max z",
                "thermo_style custom step ke c_zmax",
                "thermo_modify norm no",
                "timestep 0.01",
                "run 4000"});
  const long n = lmp.natoms();
  const double ke1 = lmp.thermo("ke"), top1 = lmp.compute_scalar("zmax");
  const double ev1 = lmp.fix_vector("hs", 5);
  lmp.commands({"run 1000"});
  const double ke2 = lmp.thermo("ke"), top2 = lmp.compute_scalar("zmax");
  const double per_step = (lmp.fix_vector("hs", 5) - ev1) / 1000.0;
  const double scale = n * 1.0 * (1.0 * 0.01) * (1.0 * 0.01);    // N m (g dt)^2
  std::printf("[ HS       ] pile of %ld: KE %.3g and %.3g N m (g dt)^2 after 4000 and 5000 steps, "
              "top %.4f -> %.4f, %.2f events per sphere per step, most in a step %.0f\n",
              n, ke1 / scale, ke2 / scale, top1, top2, per_step / n, lmp.fix_vector("hs", 4));
  EXPECT_GT(n, 200);
  // The residual agitation of a settled pile is of order m (g dt)^2 per sphere (1 to 12 were
  // seen), some 1e-4 of the energy of the fall.
  EXPECT_LT(ke1, 30.0 * scale);
  EXPECT_LT(ke2, 30.0 * scale);
  EXPECT_LT(std::fabs(top2 - top1), 0.05);
  EXPECT_LT(per_step, 8.0 * n);
  EXPECT_LT(lmp.fix_vector("hs", 4), 20.0 * n);
}

// A pile with perfectly inelastic collisions (e = 0 between spheres and with the floor) under
// the default guards (tc/slow yes) settles and stays at rest at a bounded cost per step (the
// TC model still acts on its slow collisions; without it, tc 1e-7, a pour collapses).
TEST(FixHardSphere, PerfectlyInelasticPileSettlesAtBoundedCost)
{
  Lammps lmp;
  lmp.commands({"units lj",
                "atom_style sphere",
                "atom_modify map array",
                "boundary p p f",
                "region box block 0 8.4 0 8.4 0 30",
                "create_box 1 box",
                "lattice sc 0.5787037037037037 origin 0.5 0.5 0.5",    // spacing 1.2
                "region block block 0 8.4 0 8.4 5 12.2 units box",
                "create_atoms 1 region block",
                "set type 1 diameter 1.0",
                "set type 1 mass 1.0",
                "velocity all create 0.05 87287 loop geom",
                "comm_modify cutoff 2.5",
                "neigh_modify every 1 delay 0 check yes",
                "fix 1 all nve/sphere",
                "fix g all gravity 1.0 vector 0 0 -1",
                "fix hs all hardsphere restitution 0 wall zlo 0 wall zhi 0",
                "compute zmax all reduce max z",
                "thermo_style custom step ke c_zmax",
                "thermo_modify norm no",
                "timestep 0.01",
                "run 2000"});
  const long n = lmp.natoms();
  const double ev0 = lmp.fix_vector("hs", 5), top0 = lmp.compute_scalar("zmax");
  lmp.commands({"run 500"});
  const double per_step = (lmp.fix_vector("hs", 5) - ev0) / (500.0 * n);
  const double ke = lmp.thermo("ke"), top = lmp.compute_scalar("zmax");
  const double scale = n * 1.0 * (1.0 * 0.01) * (1.0 * 0.01);    // N m (g dt)^2
  std::printf("[ HS       ] e = 0 pile of %ld: %.2f events per sphere per step from t = 20 to 25, "
              "KE %.3g N m (g dt)^2, top %.4f -> %.4f, most in a step %.0f\n",
              n, per_step, ke / scale, top0, top, lmp.fix_vector("hs", 4));
  EXPECT_GT(n, 200);
  EXPECT_LT(per_step, 8.0);
  EXPECT_LT(lmp.fix_vector("hs", 4), 20.0 * n);
  // vmin auto keeps the pile agitated at about 15 g dt, and it still compacts a little
  // (measured: the top 3.643 -> 3.578 from t = 20 to 25; 0.008 with vmin 0, whose pile keeps
  // a tenth of the kinetic energy).
  EXPECT_LT(std::fabs(top - top0), 0.1);
  EXPECT_LT(top, 5.0);    // a pile about 4 layers high, not a gas
  EXPECT_LT(ke, 30.0 * scale);
}

// Where no CUDA device is usable (or the plugin was built without CUDA), 'gpu yes' runs the CPU
// backend (rank 0 warns): f_hs[17] says -1 and the trajectory is the CPU one.
TEST(FixHardSphere, GpuRequestFallsBackToCpuWithoutDevice)
{
  if (HSGPU::GPU::device_count() > 0) GTEST_SKIP() << "a CUDA device is present";
  const std::vector<std::string> setup = {"units lj",
                                          "atom_style sphere",
                                          "atom_modify map array",
                                          "boundary p p p",
                                          "lattice sc 0.5 origin 0.5 0.5 0.5",
                                          "region box block 0 6 0 6 0 6",
                                          "create_box 1 box",
                                          "create_atoms 1 box",
                                          "set type 1 diameter 1.0",
                                          "set type 1 mass 1.0",
                                          "velocity all create 1.0 4928459 loop geom",
                                          "neigh_modify every 1 delay 0 check yes",
                                          "fix 1 all nve/sphere",
                                          "timestep 0.01"};
  std::vector<double> x[2];
  double coll[2], device[2];
  for (int k = 0; k < 2; ++k) {
    Lammps lmp;
    lmp.commands(setup);
    lmp.commands({k ? "fix hs all hardsphere gpu yes" : "fix hs all hardsphere", "run 100"});
    x[k] = lmp.gather("x", 3);
    coll[k] = lmp.fix_vector("hs", 1);
    device[k] = lmp.fix_vector("hs", 16);    // f_hs[17]
  }
  EXPECT_EQ(device[0], -1.0);
  EXPECT_EQ(device[1], -1.0);
  EXPECT_GT(coll[0], 100.0);
  EXPECT_EQ(coll[0], coll[1]);
  EXPECT_EQ(max_abs_diff(x[0], x[1]), 0.0);
}

// gpu/keep (fix_hardsphere_motion.cpp): between whole device steps the device moves its own
// copies of x and v as fix nve/sphere moves the atoms instead of receiving them.  On the CUDA
// device where there is one, else with the host's reference resident step in the device step's
// place (HSGPU_RESIDENT_HOST; it keeps and moves its copies as the CUDA step does): a fluid
// without forces and one under gravity, against gpu no and gpu/keep no, bit for bit; the
// run's log line says on how many steps x and v were moved there and checked (the first
// step with kept copies and after every 100 moved steps).  A fix that may
// change v (fix momentum) turns it off, with the reason in the log.
TEST(FixHardSphere, KeptMotionEqualsCopiedArrays)
{
  const bool cuda = HSGPU::GPU::device_count() > 0;
  const std::string log = "test_fix_hardsphere_kept_motion.log";
  const std::vector<std::string> setup = {"units lj",
                                          "atom_style sphere",
                                          "atom_modify map array",
                                          "boundary p p p",
                                          "lattice sc 0.5 origin 0.5 0.5 0.5",
                                          "region box block 0 8 0 8 0 8",
                                          "create_box 1 box",
                                          "create_atoms 1 box",
                                          "set type 1 diameter 1.0",
                                          "set type 1 mass 1.0",
                                          "velocity all create 1.0 4928459 loop geom",
                                          "comm_modify cutoff 2.5 vel yes",
                                          "neigh_modify every 1 delay 0 check yes",
                                          "fix 1 all nve/sphere",
                                          "timestep 0.02"};
  struct Case {
    const char *name;
    std::vector<std::string> extra;
    bool moved, dropped;    // x and v moved on the device; steps run ahead dropped
    bool after = false;     // extra after the fix: a force fix whose post_force() comes later
  };
  const Case cases[] = {
      {"no forces", {}, true, false},
      {"gravity", {"fix g all gravity 0.5 vector 0 0 -1"}, true, false},
      // The step runs ahead from end_of_step() instead of the fix's post_force().
      {"gravity defined after the fix", {"fix g all gravity 0.5 vector 0 0 -1"}, true, false, true},
      // Per-atom virial every 7th step: those steps run on the host, and a step run ahead
      // for them is dropped.
      {"per-atom virial",
       {"compute sa all stress/atom NULL fix", "compute sred all reduce sum c_sa[1]",
        "fix sav all ave/time 7 1 7 c_sred"},
       true, true},
      {"fix momentum", {"fix m all momentum 5 linear 1 1 1"}, false, false}};
  for (const Case &c : cases) {
    std::vector<double> x[3], v[3];
    double coll[3], done[3];
    std::string text;
    const char *fixes[3] = {"fix hs all hardsphere reach 0.5",
                            "fix hs all hardsphere reach 0.5 gpu yes gpu/keep no",
                            "fix hs all hardsphere reach 0.5 gpu yes"};
    for (int k = 0; k < 3; ++k) {
      hsgpu_test::ScopedEnv host("HSGPU_RESIDENT_HOST", "1", !cuda);
      Lammps lmp;
      lmp.commands(setup);
      if (!c.after) lmp.commands(c.extra);
      lmp.command(fixes[k]);
      if (c.after) lmp.commands(c.extra);
      lmp.commands({"log " + log, "run 400", "log none"});
      x[k] = lmp.gather("x", 3);
      v[k] = lmp.gather("v", 3);
      coll[k] = lmp.fix_vector("hs", 1);
      done[k] = lmp.fix_vector("hs", 17);    // f_hs[18]: steps carried out on the device
      if (k == 2) text = hsgpu_test::file_text(log);
    }
    for (int k = 1; k < 3; ++k) {
      EXPECT_EQ(max_abs_diff(x[0], x[k]), 0.0) << c.name << ", " << fixes[k];
      EXPECT_EQ(max_abs_diff(v[0], v[k]), 0.0) << c.name << ", " << fixes[k];
      EXPECT_EQ(coll[0], coll[k]) << c.name;
    }
    EXPECT_GT(coll[0], 300.0) << c.name << ": enough collisions to mean anything";
    EXPECT_GT(done[2], 10.0) << c.name << ": steps on the device";
    const size_t at = text.find("Fix hardsphere: x and v ");
    ASSERT_NE(at, std::string::npos) << text;
    const std::string line = text.substr(at, text.find('\n', at) - at);
    if (c.moved) {
      int moved = 0, checked = 0, ahead = 0, dropped = 0;
      char from[32] = "";
      ASSERT_EQ(std::sscanf(line.c_str(),
                            "Fix hardsphere: x and v moved on the device on %d steps (rounded as "
                            "fix nve rounds them, checked against LAMMPS's on %d); %d steps run "
                            "ahead on the device during LAMMPS's integration (%d of them "
                            "dropped), each from the step before's %31[a-z_]",
                            &moved, &checked, &ahead, &dropped, from),
                5)
          << line;
      // From the fix's post_force() where no other fix's comes after it.
      EXPECT_STREQ(from, c.after ? "end_of_step" : "post_force") << c.name;
      // Every step that moved x and v on the device was run ahead but those after a dropped
      // one (its kept copies went with it).
      EXPECT_GE(ahead, moved) << c.name;
      if (c.dropped) {
        EXPECT_GT(dropped, 10) << c.name;
      } else {
        EXPECT_EQ(dropped, 0) << c.name;
        EXPECT_EQ(ahead, moved) << c.name;
      }
      EXPECT_GT(moved, 101) << c.name;
      // The run's first step with kept copies, and again after every 100 moved steps.
      EXPECT_GE(checked, 1 + (moved - 1) / 100) << c.name;
      EXPECT_LE(moved + checked, done[2]) << c.name;
    } else {
      EXPECT_THAT(line, HasSubstr("copied to the device every step (fix m (momentum) may change x or v)"));
    }
    std::printf("[ MOTION   ] %s: %.0f collisions, %.0f of 400 steps on the %s: %s\n", c.name,
                coll[0], done[2], cuda ? "CUDA device" : "host reference", line.c_str());
  }
  std::remove(log.c_str());
}
