// pair_style gravity through LAMMPS: forces, energy and virial against a long-double direct
// sum, Newton's third law, energy conservation on a Kepler orbit, restarts and bad input.
#include "harness.h"

#include "../common/gravity_reference.h"
#include "../common/systems.h"
#include "gpu/device_info.cuh"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

using hsgpu_test::GravitySystem;
using hsgpu_test::Lammps;
using ::testing::HasSubstr;

namespace {

const double PRD[3] = {10.0, 10.0, 10.0};

// Runs `run 0` on the system and checks forces, pe, per-atom pe and virial against the
// long-double reference.
void check_against_reference(const GravitySystem &s, double G, double eps, double cut)
{
  Lammps lmp;
  lmp.commands(hsgpu_test::gravity_system_lines(s));
  lmp.commands({"compute pv all pressure NULL virial", "compute pea all pe/atom",
                "compute sumpe all reduce sum c_pea",
                "thermo_style custom step pe press c_pv[1] c_pv[2] c_pv[3] c_pv[4] c_pv[5] c_pv[6] "
                "c_sumpe",
                "thermo_modify norm no", "run 0"});
  const long n = lmp.natoms();
  ASSERT_EQ(n, s.n);
  const auto x = lmp.gather("x", 3);
  const auto f = lmp.gather("f", 3);
  std::vector<double> m(n);
  if (s.sphere) {
    m = lmp.gather("rmass", 1);
  } else {
    for (long i = 0; i < n; ++i) m[i] = (i % 2 == 0) ? 1.25 : 0.5;
  }
  const int per[3] = {s.periodic, s.periodic, s.periodic};
  const double prd[3] = {s.periodic ? PRD[0] : 100.0, s.periodic ? PRD[1] : 100.0,
                         s.periodic ? PRD[2] : 100.0};
  const auto ref = hsgpu_test::gravity_reference(x, m, G, eps, cut, prd, per);

  double fscale = 0.0, ftot[3] = {0, 0, 0}, fabs_sum = 0.0;
  for (long i = 0; i < 3 * n; ++i) fscale = std::max(fscale, (double) std::fabs(ref.f[i]));
  for (long i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) {
      EXPECT_NEAR(f[3 * i + k], (double) ref.f[3 * i + k], 1e-12 * fscale)
          << "atom " << i + 1 << " component " << k;
      ftot[k] += f[3 * i + k];
      fabs_sum += std::fabs(f[3 * i + k]);
    }
  for (int k = 0; k < 3; ++k) EXPECT_LT(std::fabs(ftot[k]), 1e-13 * fabs_sum) << "Newton III";

  const double pe = lmp.thermo("pe");
  EXPECT_NEAR(pe, (double) ref.pe, 1e-12 * std::fabs((double) ref.pe));
  EXPECT_NEAR(lmp.compute_scalar("sumpe"), pe, 1e-12 * std::fabs(pe));
  const double vol = prd[0] * prd[1] * prd[2];
  for (int k = 0; k < 6; ++k)
    EXPECT_NEAR(lmp.compute_vector("pv", k), (double) ref.virial[k] / vol,
                1e-11 * std::fabs((double) ref.virial[0]) / vol)
        << "virial component " << k;
}

}    // namespace

TEST(PairGravity, PeriodicSpheresMatchLongDoubleSum)
{
  GravitySystem s;
  check_against_reference(s, 1.0, 0.05, 0.0);
}

TEST(PairGravity, OpenBoxTypeMassesMatchLongDoubleSum)
{
  GravitySystem s;
  s.sphere = false;
  s.periodic = false;
  s.seed = 7;
  s.n = 150;
  s.pair = "pair_style gravity 2.5 0.0";
  check_against_reference(s, 2.5, 0.0, 0.0);
}

TEST(PairGravity, ClusteredWithCutoffMatchesLongDoubleSum)
{
  GravitySystem s;
  s.clustered = true;
  s.seed = 11;
  s.n = 173;
  s.pair = "pair_style gravity 0.5 0.02 cutoff 1.5";
  check_against_reference(s, 0.5, 0.02, 1.5);
}

// Two equal masses on an ellipse (e = 0.5, a = 1, G = 1): the total energy is -G m^2 / (2a)
// and velocity Verlet keeps it without drift over many periods.
TEST(PairGravity, KeplerOrbitConservesEnergy)
{
  Lammps lmp;
  const double pi = 3.14159265358979323846;
  const double vp = std::sqrt(6.0);    // relative speed at periapsis, r_p = 0.5
  const double period = 2.0 * pi / std::sqrt(2.0);
  const int steps_per_period = 2000;
  char dt[64], v1[128], v2[128];
  std::snprintf(dt, sizeof(dt), "timestep %.17g", period / steps_per_period);
  std::snprintf(v1, sizeof(v1), "velocity a set 0 %.17g 0", -0.5 * vp);
  std::snprintf(v2, sizeof(v2), "velocity b set 0 %.17g 0", 0.5 * vp);
  lmp.commands({"units lj", "atom_style atomic", "atom_modify map array", "boundary f f f",
                "region box block -5 5 -5 5 -5 5", "create_box 1 box",
                "create_atoms 1 single -0.25 0 0 units box",
                "create_atoms 1 single 0.25 0 0 units box", "mass 1 1.0", "group a id 1",
                "group b id 2", v1, v2, "pair_style gravity 1.0 0.0", "pair_coeff * *",
                "thermo_modify norm no", "fix integrate all nve", dt, "run 0"});
  const double e0 = lmp.thermo("etotal");
  EXPECT_NEAR(e0, -0.5, 1e-14);
  double worst = 0.0;
  const int periods = 20;
  for (int p = 0; p < periods; ++p) {
    for (int q = 0; q < 4; ++q) {
      lmp.commands({"run " + std::to_string(steps_per_period / 4)});
      worst = std::max(worst, std::fabs(lmp.thermo("etotal") - e0));
    }
  }
  // After whole periods the pair is back near periapsis: separation 0.5, energy unchanged.
  const auto x = lmp.gather("x", 3);
  const double sep = std::sqrt(std::pow(x[3] - x[0], 2) + std::pow(x[4] - x[1], 2));
  EXPECT_NEAR(sep, 0.5, 2e-4);
  EXPECT_LT(std::fabs(lmp.thermo("etotal") - e0), 1e-7);
  EXPECT_LT(worst, 5e-5) << "largest energy error over " << periods << " periods";
  std::printf("[ KEPLER   ] %d periods, dt = T/%d: max |dE| = %.3g, final |dE| = %.3g, r = %.6f\n",
              periods, steps_per_period, worst, std::fabs(lmp.thermo("etotal") - e0), sep);
}

TEST(PairGravity, RestartContinuationEqualsUninterruptedRun)
{
  const std::string file = "pair_gravity_test.restart";
  GravitySystem s;
  s.n = 64;
  s.pair = "pair_style gravity 0.8 0.1 cutoff 4.5";
  std::vector<double> xa, va;
  double pea;
  {
    Lammps lmp;
    lmp.commands(hsgpu_test::gravity_system_lines(s));
    lmp.commands({"velocity all create 0.5 87287 loop geom", "fix integrate all nve",
                  "timestep 0.002", "run 50", "write_restart " + file, "run 50"});
    xa = lmp.gather("x", 3);
    va = lmp.gather("v", 3);
    pea = lmp.thermo("pe");
  }
  Lammps lmp;
  lmp.commands({"read_restart " + file, "thermo_modify norm no", "fix integrate all nve",
                "timestep 0.002", "run 50"});
  const auto xb = lmp.gather("x", 3);
  const auto vb = lmp.gather("v", 3);
  for (size_t i = 0; i < xa.size(); ++i) {
    EXPECT_DOUBLE_EQ(xa[i], xb[i]);
    EXPECT_DOUBLE_EQ(va[i], vb[i]);
  }
  EXPECT_DOUBLE_EQ(lmp.thermo("pe"), pea);
  std::remove(file.c_str());
}

// Where no CUDA device is usable, "gpu yes" runs the CPU path (with a warning): same forces.
TEST(PairGravity, GpuRequestFallsBackToCpuWithoutDevice)
{
  if (HSGPU::GPU::device_count() > 0) GTEST_SKIP() << "a CUDA device is present";
  GravitySystem s;
  s.n = 50;
  std::vector<double> f[2];
  for (int k = 0; k < 2; ++k) {
    Lammps lmp;
    if (k == 1) s.pair += " gpu yes precision single";
    lmp.commands(hsgpu_test::gravity_system_lines(s));
    lmp.commands({"run 0"});
    f[k] = lmp.gather("f", 3);
  }
  ASSERT_EQ(f[0].size(), f[1].size());
  for (size_t i = 0; i < f[0].size(); ++i) EXPECT_EQ(f[0][i], f[1][i]);
}

// Bad input stops with an ERROR that names the problem.
namespace {
std::string error_for(const std::vector<std::string> &setup, const std::string &bad)
{
  Lammps lmp;
  std::string err = lmp.first_error(setup);
  if (!err.empty()) return "setup failed: " + err;
  return lmp.command(bad);
}

const std::vector<std::string> BOX = {"units lj",
                                      "atom_style atomic",
                                      "region box block 0 1 0 1 0 1",
                                      "create_box 1 box",
                                      "create_atoms 1 single 0.5 0.5 0.5",
                                      "mass 1 1.0"};
}    // namespace

TEST(PairGravityErrors, MissingArguments)
{
  EXPECT_THAT(error_for(BOX, "pair_style gravity"), HasSubstr("expected G and eps"));
  EXPECT_THAT(error_for(BOX, "pair_style gravity 1.0"), HasSubstr("expected G and eps"));
}

TEST(PairGravityErrors, BadValues)
{
  EXPECT_THAT(error_for(BOX, "pair_style gravity -1 0.1"), HasSubstr("G must be > 0"));
  EXPECT_THAT(error_for(BOX, "pair_style gravity 0 0.1"), HasSubstr("G must be > 0"));
  EXPECT_THAT(error_for(BOX, "pair_style gravity 1 -0.1"), HasSubstr("eps must be >= 0"));
  EXPECT_THAT(error_for(BOX, "pair_style gravity one 0.1"), HasSubstr("floating point"));
  EXPECT_THAT(error_for(BOX, "pair_style gravity 1 0.1 cutoff 0"), HasSubstr("cutoff must be > 0"));
  EXPECT_THAT(error_for(BOX, "pair_style gravity 1 0.1 cutoff"), HasSubstr("cutoff needs a value"));
  EXPECT_THAT(error_for(BOX, "pair_style gravity 1 0.1 softening 3"),
              HasSubstr("unknown keyword softening"));
  EXPECT_THAT(error_for(BOX, "pair_style gravity 1 0.1 gpu"), HasSubstr("gpu needs yes or no"));
  EXPECT_THAT(error_for(BOX, "pair_style gravity 1 0.1 gpu maybe"), HasSubstr("maybe"));
  EXPECT_THAT(error_for(BOX, "pair_style gravity 1 0.1 precision quad"),
              HasSubstr("unknown precision quad"));
  EXPECT_THAT(error_for(BOX, "pair_style gravity 1 0.1 device -3"),
              HasSubstr("device must be auto or >= 0"));
  // Squares that underflow (rc^2 = 0 would mean no cutoff, eps^2 = 0 no softening) or overflow.
  EXPECT_THAT(error_for(BOX, "pair_style gravity 1 0.1 cutoff 1e-170"),
              HasSubstr("cutoff 1e-170 has a square that underflows"));
  EXPECT_THAT(error_for(BOX, "pair_style gravity 1 0.1 cutoff 1e200"),
              HasSubstr("cutoff 1e200 has a square that overflows"));
  EXPECT_THAT(error_for(BOX, "pair_style gravity 1 1e-170"),
              HasSubstr("eps 1e-170 has a square that underflows"));
  EXPECT_THAT(error_for(BOX, "pair_style gravity 1 1e160"),
              HasSubstr("eps 1e160 has a square that overflows"));
}

// The smallest cutoffs that are accepted act as cutoffs: no pair of distinct atoms is within
// 1e-150 of each other, so the energy is 0, where without a cutoff it is -G m^2 / r.
TEST(PairGravity, TinyCutoffLeavesOutEveryPair)
{
  for (const char *style : {"pair_style gravity 1 0.1 cutoff 1e-150", "pair_style gravity 1 0.1"}) {
    Lammps lmp;
    lmp.commands(BOX);
    lmp.commands({"create_atoms 1 single 0.5 0.5 0.8", style, "pair_coeff * *",
                  "thermo_modify norm no", "run 0"});
    const double pe = lmp.thermo("pe");
    if (std::string(style).find("cutoff") != std::string::npos)
      EXPECT_EQ(pe, 0.0) << style;
    else
      EXPECT_NEAR(pe, -1.0 / std::sqrt(0.3 * 0.3 + 0.1 * 0.1), 1e-14) << style;
  }
}

// The style's range is negligible, so LAMMPS's default sort bins (half the neighbor cutoff)
// would number about 1e10 in this sparse box and LAMMPS would stop with "Too many atom sorting
// bins": the style picks a bin size itself unless the user gave one.
TEST(PairGravity, LargeSparseBoxSortsWithItsOwnBinSize)
{
  for (const char *sort : {"", "atom_modify sort 1000 50.0"}) {
    Lammps lmp;
    lmp.commands({"units lj", "atom_style atomic", "atom_modify map array", sort,
                  "region box block 0 2000 0 2000 0 2000", "create_box 1 box",
                  "create_atoms 1 single 10 10 10", "create_atoms 1 single 1990 1990 1990",
                  "mass 1 1.0", "pair_style gravity 1 0.1", "pair_coeff * *",
                  "thermo_modify norm no"});
    EXPECT_EQ(lmp.command("run 0"), "") << sort;
    const double r = std::sqrt(3.0 * 20.0 * 20.0 + 0.1 * 0.1);    // nearest image
    EXPECT_NEAR(lmp.thermo("pe"), -1.0 / r, 1e-14) << sort;
  }
}

// Results that cannot be right stop the run with an error naming the atoms or the setting,
// not with -inf and NaN or a later "Lost atoms".
TEST(PairGravityErrors, ImpossibleForcesAreNamed)
{
  auto setup = BOX;
  setup.insert(setup.end(),
               {"create_atoms 1 single 0.5 0.5 0.5", "create_atoms 1 single 0.2 0.3 0.4",
                "pair_style gravity 1 0.0", "pair_coeff * *", "fix 1 all nve"});
  // Atoms 1 and 2 at one point without softening (atom 3 elsewhere).
  EXPECT_THAT(error_for(setup, "run 0"),
              HasSubstr("atoms 1 and 2 are at the same position (0.5, 0.5, 0.5) at step 0 with "
                        "eps = 0"));
  // ... also when they meet during a run: atom 2 moves onto atom 1 in 8 steps (dyadic numbers,
  // exact; the forces are far too weak to change a velocity or position).
  {
    auto moving = setup;
    moving.insert(moving.end(),
                  {"set atom 2 x 0.25", "group two id 2", "velocity two set 0.03125 0 0",
                   "pair_style gravity 1e-30 0.0", "pair_coeff * *", "timestep 1"});
    EXPECT_THAT(error_for(moving, "run 20"),
                HasSubstr("atoms 1 and 2 are at the same position (0.5, 0.5, 0.5) at step 8"));
  }
  // An overflow: G m^2 is beyond double precision.
  {
    auto heavy = setup;
    heavy.insert(heavy.end(), {"set atom 2 x 0.1", "mass 1 1e10", "pair_style gravity 1e300 0.1",
                               "pair_coeff * *"});
    const std::string err = error_for(heavy, "run 0");
    EXPECT_THAT(err, HasSubstr("the force on atom 1 is not finite at step 0"));
    EXPECT_THAT(err, HasSubstr("overflow"));
  }
  // A G so large that one step would throw atoms out of the box.
  {
    auto strong = setup;
    strong.insert(strong.end(),
                  {"set atom 2 x 0.1", "pair_style gravity 1e300 0.1", "pair_coeff * *"});
    const std::string err = error_for(strong, "run 10");
    EXPECT_THAT(err, HasSubstr("more than the box length 1: atoms would be lost"));
    EXPECT_THAT(err, HasSubstr("G = 1e+300 is far too large"));
    // A G that moves the atoms less than the box in a step runs.
    strong.push_back("pair_style gravity 1 0.1");
    strong.push_back("pair_coeff * *");
    EXPECT_EQ(error_for(strong, "run 10"), "");
  }
}

// compute pair/local walks a neighbor list that holds none of the style's pairs: an error
// (LAMMPS's own check only catches the values that need single()).
TEST(PairGravityErrors, ComputePairLocalIsRefused)
{
  auto setup = BOX;
  setup.insert(setup.end(),
               {"create_atoms 1 single 0.6 0.5 0.5", "pair_style gravity 1 0.1", "pair_coeff * *"});
  for (const char *values : {"dist", "eng", "dist eng"}) {
    auto with = setup;
    with.push_back(std::string("compute pl all pair/local ") + values);
    EXPECT_THAT(error_for(with, "run 0"),
                HasSubstr("Pair style gravity does not support compute pair/local (compute pl)"))
        << values;
  }
}

TEST(PairGravityErrors, CoefficientsAreOnlyStarStar)
{
  auto setup = BOX;
  setup.push_back("pair_style gravity 1 0.1");
  EXPECT_THAT(error_for(setup, "pair_coeff * * 2.0"), HasSubstr("pair_coeff * *"));
  // LAMMPS's own check; its wording differs between releases.
  EXPECT_THAT(error_for(setup, "pair_coeff 1 1"),
              ::testing::ContainsRegex("Pair_coeff must start with|Incorrect args for pair coeff"));
}

TEST(PairGravityErrors, TriclinicBox)
{
  std::vector<std::string> setup = {"units lj",
                                    "atom_style atomic",
                                    "region box prism 0 1 0 1 0 1 0.1 0 0",
                                    "create_box 1 box",
                                    "create_atoms 1 single 0.5 0.5 0.5",
                                    "mass 1 1.0",
                                    "pair_style gravity 1 0.1",
                                    "pair_coeff * *"};
  EXPECT_THAT(error_for(setup, "run 0"), HasSubstr("orthogonal box"));
}

TEST(PairGravityErrors, AtomIdsRequired)
{
  std::vector<std::string> setup = {"units lj",          "atom_style atomic",
                                    "atom_modify id no", "region box block 0 1 0 1 0 1",
                                    "create_box 1 box",  "create_atoms 1 single 0.5 0.5 0.5",
                                    "mass 1 1.0",        "pair_style gravity 1 0.1",
                                    "pair_coeff * *"};
  EXPECT_THAT(error_for(setup, "run 0"), HasSubstr("requires atom IDs"));
}

TEST(PairGravityErrors, MassesMustBeSet)
{
  std::vector<std::string> setup = {"units lj",
                                    "atom_style atomic",
                                    "region box block 0 1 0 1 0 1",
                                    "create_box 1 box",
                                    "create_atoms 1 single 0.5 0.5 0.5",
                                    "pair_style gravity 1 0.1",
                                    "pair_coeff * *"};
  EXPECT_THAT(error_for(setup, "run 0"), HasSubstr("mass"));
}
