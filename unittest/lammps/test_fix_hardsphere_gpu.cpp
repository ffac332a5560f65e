// fix hardsphere with 'gpu yes' (the CUDA collision backend) against 'gpu no' (the CPU
// backend), through LAMMPS: the same input, so both see the same forces; positions,
// velocities and collision counters must agree bit for bit after hundreds of steps.  Label
// gpu: skipped where no CUDA device is usable.  f_hs[17] proves which backend ran.
#include "harness.h"

#include "gpu/device_info.cuh"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

using hsgpu_test::Lammps;
using hsgpu_test::max_abs_diff;

namespace {

struct Result {
  std::vector<double> x, v;
  std::vector<double> omega;    // rough spheres only
  std::vector<double> f;    // f_hs[1] .. f_hs[21]
};

Result run(const std::vector<std::string> &setup, const std::string &fix, const std::string &run,
           bool spin = false)
{
  Lammps lmp;
  lmp.commands(setup);
  lmp.commands({fix, "thermo_modify norm no", run});
  Result r;
  r.x = lmp.gather("x", 3);
  r.v = lmp.gather("v", 3);
  if (spin) r.omega = lmp.gather("omega", 3);
  for (int i = 0; i < 21; ++i) r.f.push_back(lmp.fix_vector("hs", i));
  return r;
}

void expect_gpu_equals_cpu(const char *name, const std::vector<std::string> &setup,
                           const std::string &fix, const std::string &steps, double min_coll,
                           bool spin = false)
{
  if (HSGPU::GPU::device_count() == 0) GTEST_SKIP() << "no CUDA device on this machine";
  const Result cpu = run(setup, fix, steps, spin);
  const Result gpu = run(setup, fix + " gpu yes", steps, spin);
  if (spin) {
    EXPECT_EQ(max_abs_diff(cpu.omega, gpu.omega), 0.0) << name << ": angular velocities";
    double spin_max = 0.0;
    for (double w : cpu.omega) spin_max = std::max(spin_max, std::fabs(w));
    EXPECT_GT(spin_max, 0.0) << name << ": friction set the spheres spinning";
  }
  EXPECT_EQ(cpu.f[16], -1.0) << "the CPU run used the CPU backend";
  EXPECT_GE(gpu.f[16], 0.0) << "the GPU run used a CUDA device";
  ASSERT_EQ(cpu.x.size(), gpu.x.size());
  const double dx = max_abs_diff(cpu.x, gpu.x), dv = max_abs_diff(cpu.v, gpu.v);
  EXPECT_EQ(dx, 0.0) << name;
  EXPECT_EQ(dv, 0.0) << name;
  for (int i : {1, 2, 4, 5}) EXPECT_EQ(cpu.f[i], gpu.f[i]) << name << ": f_hs[" << i + 1 << "]";
  EXPECT_NEAR(cpu.f[3], gpu.f[3], 1e-12 * std::fabs(cpu.f[3])) << name << ": energy lost";
  EXPECT_GT(cpu.f[1], min_coll) << name << ": too few collisions to mean anything";
  // One rank: the device-resident step carries out the steps it can finish alone.
  const double nsteps = std::stod(steps.substr(4));
  EXPECT_EQ(cpu.f[17] + cpu.f[18], 0.0) << name << ": no device steps on the CPU backend";
  EXPECT_EQ(gpu.f[17] + gpu.f[18], nsteps) << name << ": every step tried on the device";
  EXPECT_GT(gpu.f[17], 0.5 * nsteps) << name << ": most steps carried out on the device";
  // f_hs[21]: the last step's candidate pairs, from the device's search or the host's (the same
  // criterion; a step redone with raised bounds may differ).
  EXPECT_GT(gpu.f[20], 0.0) << name << ": candidate pairs of the device's last step";
  if (cpu.f[9] == 0.0 && gpu.f[9] == 0.0) {
    EXPECT_EQ(cpu.f[20], gpu.f[20]) << name;
  }
  std::printf("[ GPU      ] %s: %.0f collisions, %.0f wall collisions, largest group %.0f, "
              "device %.0f, %.0f of %.0f steps resident (%.0f handed back): max |dx| %.2g "
              "|dv| %.2g\n",
              name, cpu.f[1], cpu.f[2], cpu.f[6], gpu.f[16], gpu.f[17], nsteps, gpu.f[18], dx, dv);
}

const std::vector<std::string> SPHERES = {"units lj", "atom_style sphere", "atom_modify map array",
                                          "boundary p p f"};

// The seed paper's third configuration at N = 4096 (examples/hardsphere/in.lattice3d).
std::vector<std::string> lattice3d()
{
  std::vector<std::string> s = SPHERES;
  s.insert(s.end(),
           {"region box block 0 32 0 32 0 36 units box", "create_box 1 box",
            "lattice sc 0.125 origin 0.5 0.5 0.5", "region fill block 0 32 0 32 0 32 units box",
            "create_atoms 1 region fill", "set type 1 diameter 1.0", "set type 1 mass 1.0",
            "velocity all create 1.0 4928459 dist uniform loop geom",
            "comm_modify cutoff 3.0 vel yes", "neigh_modify every 1 delay 0 check yes",
            "fix 1 all nve/sphere", "fix g all gravity 0.1 vector 0 0 -1", "timestep 0.1"});
  return s;
}

}    // namespace

// The seed paper's third configuration (lattice3d, N = 4096), elastic, under gravity.
TEST(FixHardSphereGpu, Lattice3dEqualsCpu)
{
  const std::vector<std::string> s = lattice3d();
  expect_gpu_equals_cpu("lattice3d", s,
                        "fix hs all hardsphere wall zlo 1.0 wall zhi 1.0 reach 0.75", "run 200",
                        20000);
}

// The same with order serial: the seed paper's loop on the device (one device-wide earliest
// event per iteration) against the host's serial loop.
TEST(FixHardSphereGpu, Lattice3dSerialOrderEqualsCpu)
{
  const std::vector<std::string> s = lattice3d();
  expect_gpu_equals_cpu("lattice3d, order serial", s,
                        "fix hs all hardsphere wall zlo 1.0 wall zhi 1.0 reach 0.75 order serial",
                        "run 100", 10000);
}

// The fluid scene of the benchmarks (examples/benchmarks/in.fluid: packing fraction 0.4,
// N = 32768, 50 steps).
TEST(FixHardSphereGpu, FluidSceneEqualsCpu)
{
  std::vector<std::string> s = SPHERES;
  s[3] = "boundary p p p";
  s.insert(s.end(),
           {"lattice sc 0.763943726841098", "region box block 0 32 0 32 0 32", "create_box 1 box",
            "create_atoms 1 box", "set type 1 diameter 1.0", "set type 1 mass 1.0",
            "velocity all create 1.0 87287 dist gaussian mom no loop geom",
            "comm_modify cutoff 2.5 vel yes", "neigh_modify every 1 delay 0 check yes",
            "fix 1 all nve/sphere", "timestep 0.01"});
  expect_gpu_equals_cpu("fluid 0.4, N = 32768", s, "fix hs all hardsphere reach 0.5", "run 50",
                        100000);
}

// With no force styles the atoms' f stays on the host after the run's first device step
// (found zero there): 48 instead of 72 bytes per atom go up on the later steps.  With gpu/keep
// (the default) x and v stay on the device too, moved there as fix nve/sphere moves them, on
// every step but the first, the run's first check and the steps after a reneighboring.
// The log lines of the run give the mean per step and the steps of each kind.
TEST(FixHardSphereGpu, NoForcesStayOnTheHost)
{
  if (HSGPU::GPU::device_count() == 0) GTEST_SKIP() << "no CUDA device on this machine";
  const std::string log = "test_fix_hardsphere_gpu_noforces.log";
  for (const bool keep : {false, true})
    for (const bool gravity : {false, true}) {
      Lammps lmp;
      lmp.commands({"units lj", "atom_style sphere", "atom_modify map array", "boundary p p p",
                    "lattice sc 0.763943726841098", "region box block 0 16 0 16 0 16",
                    "create_box 1 box", "create_atoms 1 box", "set type 1 diameter 1.0",
                    "set type 1 mass 1.0", "velocity all create 1.0 87287 dist gaussian loop geom",
                    "comm_modify cutoff 2.5 vel yes", "neigh_modify every 1 delay 0 check yes",
                    "fix 1 all nve/sphere", "timestep 0.01",
                    std::string("fix hs all hardsphere reach 0.5 gpu yes gpu/keep ") +
                        (keep ? "yes" : "no")});
      if (gravity) lmp.command("fix g all gravity 0.1 vector 0 0 -1");
      lmp.commands({"log " + log, "run 20", "log none"});
      const double steps = 20.0, n = 4096.0;
      ASSERT_EQ(lmp.fix_vector("hs", 17), steps) << "every step carried out on the device";
      const std::string text = hsgpu_test::file_text(log);
      const size_t at = text.find(" MB per step up");
      ASSERT_NE(at, std::string::npos) << text;
      const size_t from = text.rfind(' ', at - 1) + 1;
      const double per_atom = std::stod(text.substr(from, at - from)) * 1e6 / n;
      int moved = 0, checked = 0;
      const size_t line = text.find("Fix hardsphere: x and v moved on the device on ");
      if (keep) {
        ASSERT_NE(line, std::string::npos) << text;
        ASSERT_EQ(std::sscanf(text.c_str() + line,
                              "Fix hardsphere: x and v moved on the device on %d steps (rounded "
                              "as fix nve rounds them, checked against LAMMPS's on %d)",
                              &moved, &checked),
                  2)
            << text.substr(line, 200);
        EXPECT_GT(moved, 5) << "most steps between reneighborings";
        EXPECT_EQ(checked, 1) << "the run's first step with kept copies";
      } else {
        EXPECT_EQ(line, std::string::npos);
      }
      // The first step copies every array (104 bytes per atom), the later ones x and v unless
      // they were moved on the device, and f only under gravity.
      const double f = gravity ? 24.0 : 0.0;
      const double expect = (104.0 + (steps - 1 - moved) * (48.0 + f) + moved * f) / steps;
      EXPECT_NEAR(per_atom, expect, 0.01 * expect) << (gravity ? "gravity" : "no forces");
      std::printf("[ GPU      ] %s, gpu/keep %s: %.4g bytes per atom and step up (%d steps moved "
                  "on the device, %d checked)\n",
                  gravity ? "gravity" : "no forces", keep ? "yes" : "no", per_atom, moved,
                  checked);
    }
  std::remove(log.c_str());
}

// A fluid at packing fraction 0.5 (periodic, elastic, no gravity).
TEST(FixHardSphereGpu, DenseFluidEqualsCpu)
{
  std::vector<std::string> s = SPHERES;
  s[3] = "boundary p p p";
  s.insert(s.end(),
           {"lattice sc 0.954929658551372 origin 0.5 0.5 0.5",    // phi = 0.5
            "region box block 0 10 0 10 0 10", "create_box 1 box", "create_atoms 1 box",
            "set type 1 diameter 1.0", "set type 1 mass 1.0",
            "velocity all create 1.0 4928459 loop geom", "comm_modify vel yes",
            "neigh_modify every 1 delay 0 check yes", "fix 1 all nve/sphere", "timestep 0.005"});
  expect_gpu_equals_cpu("fluid at 0.5", s, "fix hs all hardsphere", "run 300", 20000);
}

// A poured inelastic pile of two sizes that comes to rest on the floor: resting contacts,
// the TC guard, walls.
// A block of two sizes dropped onto the floor of a box periodic in x and y.
std::vector<std::string> poured_block()
{
  std::vector<std::string> s = SPHERES;
  s.insert(s.end(), {"region box block 0 9.6 0 9.6 0 30 units box", "create_box 2 box",
                     "lattice sc 0.5787037037037037 origin 0.5 0.5 0.5",    // spacing 1.2
                     "region block block 0 9.6 0 9.6 4 16 units box", "create_atoms 1 region block",
                     "set type 1 type/fraction 2 0.4 20261121", "set type 1 diameter 1.0",
                     "set type 2 diameter 0.8", "set group all density 1.9",
                     "velocity all create 0.05 4928459 loop geom", "comm_modify vel yes",
                     "neigh_modify every 1 delay 0 check yes", "fix 1 all nve/sphere",
                     "fix g all gravity 1.0 vector 0 0 -1", "timestep 0.01"});
  return s;
}

TEST(FixHardSphereGpu, PouredInelasticPileEqualsCpu)
{
  expect_gpu_equals_cpu("poured pile", poured_block(),
                        "fix hs all hardsphere restitution 0.6 restitution/pair 1 2 0.5 "
                        "wall zlo 0.5 wall zhi 0.5",
                        "run 600", 10000);
}

// The same pile with rough spheres (friction between them and with the floor, both guard
// modes): Walton's rule on the device, the angular velocities up and back.
TEST(FixHardSphereGpu, RoughPouredPileEqualsCpu)
{
  for (const char *guard : {"elastic", "none"})
    expect_gpu_equals_cpu(guard, poured_block(),
                          std::string("fix hs all hardsphere restitution 0.6 restitution/pair 1 2 "
                                      "0.5 friction 0.5 0.2 friction/pair 1 2 0.3 -0.1 wall zlo "
                                      "0.5 wall zhi 0.5 wall/friction zlo 0.4 0.0 friction/guard ") +
                              guard,
                          "run 400", 5000, true);
}

// Continuous polydispersity (diameters 0.5 ... 1.5, masses with the volume) under gravity.
static std::vector<std::string> polydisperse()
{
  std::vector<std::string> s = SPHERES;
  s.insert(s.end(),
           {"region box block 0 16 0 16 0 24 units box", "create_box 1 box",
            "lattice sc 0.244140625 origin 0.5 0.5 0.5",    // spacing 1.6
            "region fill block 0 16 0 16 2 20 units box", "create_atoms 1 region fill",
            "variable d atom 0.5+0.5*(1.0+sin(12.9898*id))", "set group all diameter v_d",
            "set group all density 1.9", "velocity all create 2.0 4928459 loop geom",
            "comm_modify vel yes", "neigh_modify every 1 delay 0 check yes", "fix 1 all nve/sphere",
            "fix g all gravity 0.5 vector 0 0 -1", "timestep 0.01"});
  return s;
}

TEST(FixHardSphereGpu, PolydisperseMixtureEqualsCpu)
{
  expect_gpu_equals_cpu("polydisperse", polydisperse(),
                        "fix hs all hardsphere restitution 0.9 wall zlo 0.9 wall zhi 1.0",
                        "run 400", 5000);
}

// The same with LAMMPS sorting the atoms every 5 steps: the device keeps radii, masses, types,
// IDs and times of last collision between steps only while no atom moved in the arrays, so a
// sort (as an exchange or an inserted atom) makes the next step copy them up again.
TEST(FixHardSphereGpu, PolydisperseSortedOftenEqualsCpu)
{
  std::vector<std::string> s = polydisperse();
  s.push_back("atom_modify sort 5 2.0");
  expect_gpu_equals_cpu("polydisperse, sorted every 5 steps", s,
                        "fix hs all hardsphere restitution 0.9 wall zlo 0.9 wall zhi 1.0",
                        "run 400", 5000);
}

// Lennard-Jones attraction between the spheres: accelerations differ from atom to atom.  The
// fix's group is a named one (all the atoms), so the device gets bodies gathered on the host
// rather than LAMMPS's arrays (the other cases use group all).
TEST(FixHardSphereGpu, LennardJonesForcesEqualsCpu)
{
  std::vector<std::string> s = SPHERES;
  s[3] = "boundary p p p";
  s.insert(s.end(), {"lattice sc 0.3 origin 0.5 0.5 0.5", "region box block 0 10 0 10 0 10",
                     "create_box 1 box", "create_atoms 1 box", "set type 1 diameter 1.0",
                     "set type 1 mass 1.0", "velocity all create 1.5 4928459 loop geom",
                     "pair_style lj/cut 2.5", "pair_coeff 1 1 0.5 1.0", "comm_modify vel yes",
                     "neigh_modify every 1 delay 0 check yes", "fix 1 all nve/sphere",
                     "timestep 0.005", "group spheres type 1"});
  expect_gpu_equals_cpu("lj/cut", s, "fix hs spheres hardsphere", "run 400", 2000);
}

// Per-atom virial with 'gpu yes': the steps that ask for it (here every 7th, through fix
// ave/time) run on the host with the CPU backend, the others on the device; the trajectory is
// still the CPU backend's bit for bit, and on those steps the per-atom virials summed over the
// atoms equal minus the global collision virial.
TEST(FixHardSphereGpu, PerAtomVirialStepsOnTheHostEqualCpu)
{
  if (HSGPU::GPU::device_count() == 0) GTEST_SKIP() << "no CUDA device on this machine";
  std::vector<std::string> s = lattice3d();
  s.insert(s.end(),
           {"compute st all stress/atom NULL fix",
            "compute red all reduce sum c_st[1] c_st[2] c_st[3] c_st[4] c_st[5] c_st[6]",
            "compute pv all pressure NULL virial",
            "variable d equal abs(c_red[1]+c_pv[1]*vol)+abs(c_red[2]+c_pv[2]*vol)+abs(c_red[3]+"
            "c_pv[3]*vol)",
            "variable m equal abs(c_red[1])+abs(c_red[2])+abs(c_red[3])",
            "fix avg all ave/time 7 20 140 v_d v_m"});
  double d[2], m[2];
  std::vector<double> x[2];
  double resident[2];
  for (int k = 0; k < 2; ++k) {
    Lammps lmp;
    lmp.commands(s);
    lmp.commands({std::string("fix hs all hardsphere wall zlo 1.0 wall zhi 1.0 reach 0.75") +
                      (k ? " gpu yes" : ""),
                  "thermo_modify norm no", "run 140"});
    x[k] = lmp.gather("x", 3);
    d[k] = lmp.fix_vector("avg", 0);
    m[k] = lmp.fix_vector("avg", 1);
    resident[k] = lmp.fix_vector("hs", 17);
  }
  EXPECT_EQ(max_abs_diff(x[0], x[1]), 0.0);
  EXPECT_GT(m[1], 0.0);
  EXPECT_LT(d[1], 1e-12 * m[1]);
  EXPECT_NEAR(m[0], m[1], 1e-12 * m[0]);
  EXPECT_EQ(resident[0], 0.0);
  EXPECT_GT(resident[1], 60.0);     // most other steps on the device
  EXPECT_LE(resident[1], 120.0);    // 20 steps on the host
}
