// pair_style gravity on the CUDA path against the CPU path, through LAMMPS: forces, energy,
// per-atom energy and virial in every precision mode.  Label gpu: skipped without a device.
#include "harness.h"

#include "../common/systems.h"
#include "gpu/device_info.cuh"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

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
