// pair_style gravity on the CUDA path against the CPU path, through LAMMPS: forces, energy,
// per-atom energy and virial in every precision mode.  Label gpu: skipped without a device.
#include "harness.h"

#include "../common/systems.h"
#include "gpu/device_info.cuh"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

using hsgpu_test::GravitySystem;
using hsgpu_test::Lammps;

namespace {

struct Snapshot {
  std::vector<double> f;
  double pe, sumpe, virial[6];
};

Snapshot evaluate(GravitySystem s)
{
  Lammps lmp;
  lmp.commands(hsgpu_test::gravity_system_lines(s));
  lmp.commands(
      {"compute pv all pressure NULL virial", "compute pea all pe/atom",
       "compute sumpe all reduce sum c_pea",
       "thermo_style custom step pe c_pv[1] c_pv[2] c_pv[3] c_pv[4] c_pv[5] c_pv[6] c_sumpe",
       "thermo_modify norm no", "run 0"});
  Snapshot out;
  out.f = lmp.gather("f", 3);
  out.pe = lmp.thermo("pe");
  out.sumpe = lmp.compute_scalar("sumpe");
  for (int k = 0; k < 6; ++k) out.virial[k] = lmp.compute_vector("pv", k);
  return out;
}

void compare(const std::string &options, double tol)
{
  if (HSGPU::GPU::device_count() == 0) GTEST_SKIP() << "no CUDA device on this machine";
  GravitySystem s;
  s.n = 1500;
  s.pair = "pair_style gravity 1.0 0.05 cutoff 4.0";
  const Snapshot cpu = evaluate(s);
  s.pair += " gpu yes " + options;
  const Snapshot gpu = evaluate(s);
  double num = 0, den = 0;
  for (size_t i = 0; i < cpu.f.size(); ++i) {
    num = std::max(num, std::fabs(gpu.f[i] - cpu.f[i]));
    den = std::max(den, std::fabs(cpu.f[i]));
  }
  EXPECT_LT(num / den, tol) << options;
  EXPECT_NEAR(gpu.pe, cpu.pe, tol * std::fabs(cpu.pe));
  EXPECT_NEAR(gpu.sumpe, cpu.pe, tol * std::fabs(cpu.pe));
  for (int k = 0; k < 6; ++k)
    EXPECT_NEAR(gpu.virial[k], cpu.virial[k], tol * std::fabs(cpu.virial[0])) << "virial " << k;
  std::printf(
      "[ LAMMPS GPU ] %s: max force error %.2e (relative to max force), pe %.15g vs %.15g\n",
      options.c_str(), num / den, gpu.pe, cpu.pe);
}

}    // namespace

TEST(PairGravityGpu, DoubleMatchesCpu)
{
  compare("precision double", 1e-12);
}
TEST(PairGravityGpu, MixedMatchesCpu)
{
  compare("precision mixed", 2e-5);
}
TEST(PairGravityGpu, SingleMatchesCpu)
{
  compare("precision single device 0", 2e-4);
}

// newton on (the default) on one rank lets the GPU path evaluate each pair once on force-only
// steps, from N = 32768 on.  A short run with newton on must follow the run with newton off
// (every pair evaluated for each of its atoms): in double precision to round-off, in single
// and mixed precision to their accuracy against the double run.
namespace {
std::vector<double> run_open_cloud(const std::string &newton, const std::string &precision)
{
  Lammps lmp;
  lmp.commands({"newton " + newton, "units lj", "atom_style atomic", "atom_modify map array",
                "boundary f f f", "region box block -20 20 -20 20 -20 20", "create_box 2 box",
                "create_atoms 1 random 20000 4711 box", "create_atoms 2 random 13000 4712 box",
                "mass 1 1.0", "mass 2 0.4", "velocity all create 0.5 99 loop geom",
                "pair_style gravity 1.0 0.2 gpu yes precision " + precision, "pair_coeff * *",
                "fix step all nve", "thermo 4", "run 4"});
  std::vector<double> out = lmp.gather("x", 3);
  const std::vector<double> f = lmp.gather("f", 3);
  out.insert(out.end(), f.begin(), f.end());
  return out;
}

double max_rel(const std::vector<double> &a, const std::vector<double> &b, size_t from, size_t to)
{
  double num = 0, den = 0;
  for (size_t i = from; i < to; ++i) {
    num = std::max(num, std::fabs(a[i] - b[i]));
    den = std::max(den, std::fabs(b[i]));
  }
  return num / den;
}
}    // namespace

TEST(PairGravityGpu, NewtonOnPairsOnceFollowsNewtonOff)
{
  if (HSGPU::GPU::device_count() == 0) GTEST_SKIP() << "no CUDA device on this machine";
  const std::vector<double> off = run_open_cloud("off", "double");
  const std::vector<double> on = run_open_cloud("on", "double");
  const std::vector<double> single_on = run_open_cloud("on", "single");
  const std::vector<double> mixed_on = run_open_cloud("on", "mixed");
  const size_t n3 = off.size() / 2;
  const double dx = max_rel(on, off, 0, n3), df = max_rel(on, off, n3, 2 * n3);
  const double sx = max_rel(single_on, off, 0, n3), sf = max_rel(single_on, off, n3, 2 * n3);
  const double mx = max_rel(mixed_on, off, 0, n3), mf = max_rel(mixed_on, off, n3, 2 * n3);
  EXPECT_LT(dx, 1e-13);
  EXPECT_LT(df, 1e-11);
  EXPECT_LT(sx, 1e-6);
  EXPECT_LT(sf, 2e-4);
  EXPECT_LT(mx, 1e-7);
  EXPECT_LT(mf, 2e-5);
  std::printf("[ LAMMPS GPU ] N = 33000, 4 steps, newton on against off: double x %.2e f %.2e; "
              "single x %.2e f %.2e; mixed x %.2e f %.2e\n",
              dx, df, sx, sf, mx, mf);
}
