// fix hardsphere under mpirun -np 1, 2, 4: the same system on all ranks of MPI_COMM_WORLD and
// on rank 0 alone gives the same trajectory (collisions between atoms of different ranks are
// resolved identically on every rank, in atom-ID order), in both orders; the missing
// 'comm_modify vel yes' is reported on more than one rank.
#include "harness.h"

#include "gpu/device_info.cuh"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <mpi.h>
#include <regex>
#include <string>
#include <vector>

using hsgpu_test::Lammps;
using hsgpu_test::ScopedEnv;
using hsgpu_test::max_abs_diff;
using ::testing::HasSubstr;

namespace {

// Rough spheres: friction between the types and on the floor and roof (fix arguments).
const std::string ROUGH = " friction 0.5 0.3 friction/pair 1 2 0.3 0.0 wall/friction zlo 0.6 0.2 "
                          "wall/friction zhi 0.2 -0.5";

struct Snapshot {
  std::vector<double> x, v, w;
  double f[6];
  double press;
  double sred[6], pvir[6], wsum[3];          // per-atom virial: sums, -V x the global one, weighted
  double dmean = 0.0, mmean = 0.0;           // mean |sum - global| and mean |sum| over the steps
  double comm[3];                            // f_hs[24 ... 26]: the last step's communication
  double on_device = 0.0, declined = 0.0;    // f_hs[18], f_hs[19]: steps whole on a device
};

// 500 spheres of two sizes in a box periodic in x and y with floor and roof, under gravity.
// Atoms are placed one by one and their velocities set from their IDs, so that the initial
// state does not depend on the decomposition (create_atoms on a region numbers atoms per rank,
// velocity create rescales with a sum over ranks).
// extra: commands before the run; midway: where given, the run is split in two halves with
// these commands between them; gravity false: no fix gravity (no forces at all unless
// pair_gravity).
Snapshot run_on(MPI_Comm comm, const std::string &order, int steps, bool pair_gravity = false,
                bool peratom = false, const std::vector<std::string> &extra = {},
                const std::vector<std::string> &midway = {}, bool gravity = true)
{
  Lammps lmp(comm);
  lmp.commands({"units lj", "atom_style sphere", "atom_modify map array", "boundary p p f",
                "region box block 0 11 0 11 0 11", "create_box 2 box"});
  std::vector<std::string> atoms;
  for (int iz = 0; iz < 5; ++iz)
    for (int iy = 0; iy < 10; ++iy)
      for (int ix = 0; ix < 10; ++ix) {
        char line[160];
        std::snprintf(line, sizeof(line), "create_atoms %d single %.17g %.17g %.17g units box",
                      1 + (ix + iy + iz) % 2, 0.55 + 1.1 * ix, 0.55 + 1.1 * iy, 0.55 + 1.1 * iz);
        atoms.push_back(line);
      }
  lmp.commands(atoms);
  lmp.commands({"set type 1 diameter 1.0", "set type 1 density 1.9", "set type 2 diameter 0.8",
                "set type 2 density 3.0", "variable vx atom 3.0*sin(17.31*id)",
                "variable vy atom 3.0*cos(7.77*id)", "variable vz atom 3.0*sin(3.3*id+1.1)",
                "velocity all set v_vx v_vy v_vz", "comm_modify cutoff 3.5 vel yes"});
  if (pair_gravity) lmp.commands({"pair_style gravity 0.5 0.3", "pair_coeff * *"});
  lmp.commands({"neigh_modify every 1 delay 0 check yes", "fix 1 all nve/sphere"});
  if (gravity) lmp.commands({"fix g all gravity 1.0 vector 0 0 -1"});
  lmp.commands({"fix hs all hardsphere restitution 0.95 restitution/pair 1 2 0.8 wall zlo 0.9 "
                "wall zhi 1.0 order " +
                    order,
                "compute p all pressure NULL virial", "thermo_style custom step c_p",
                "thermo_modify norm no", "timestep 0.01"});
  if (peratom)
    // Per-atom virial at every step (fix ave/time), summed, and weighted by the atom ID so that
    // values given to the wrong atoms would show.
    lmp.commands(
        {"compute s all stress/atom NULL fix",
         "compute red all reduce sum c_s[1] c_s[2] c_s[3] c_s[4] c_s[5] c_s[6]",
         "variable w1 atom c_s[1]*id", "variable w3 atom c_s[3]*id", "variable w4 atom c_s[4]*id",
         "compute wred all reduce sum v_w1 v_w3 v_w4",
         "variable d equal abs(c_red[1]+c_p[1]*vol)+abs(c_red[2]+c_p[2]*vol)+abs(c_red[3]+c_p[3]*"
         "vol)+abs(c_red[4]+c_p[4]*vol)+abs(c_red[5]+c_p[5]*vol)+abs(c_red[6]+c_p[6]*vol)",
         "variable m equal abs(c_red[1])+abs(c_red[2])+abs(c_red[3])",
         "fix avg all ave/time 1 " + std::to_string(steps) + " " + std::to_string(steps) +
             " v_d v_m",
         "thermo_style custom step c_p c_red[1] c_wred[1]"});
  lmp.commands(extra);
  if (midway.empty()) {
    lmp.commands({"run " + std::to_string(steps)});
  } else {
    lmp.commands({"run " + std::to_string(steps / 2)});
    lmp.commands(midway);
    lmp.commands({"run " + std::to_string(steps - steps / 2)});
  }
  Snapshot s;
  if (peratom) {
    const double vol = 11.0 * 11.0 * 11.0;
    for (int k = 0; k < 6; ++k) {
      s.sred[k] = lmp.compute_vector("red", k);
      s.pvir[k] = -lmp.compute_vector("p", k) * vol;
    }
    for (int k = 0; k < 3; ++k) s.wsum[k] = lmp.compute_vector("wred", k);
    s.dmean = lmp.fix_vector("avg", 0);
    s.mmean = lmp.fix_vector("avg", 1);
  }
  s.x = lmp.gather("x", 3);
  s.v = lmp.gather("v", 3);
  s.w = lmp.gather("omega", 3);
  for (int i = 0; i < 6; ++i) s.f[i] = lmp.fix_vector("hs", i);
  for (int i = 0; i < 3; ++i) s.comm[i] = lmp.fix_vector("hs", 23 + i);
  s.on_device = lmp.fix_vector("hs", 17);
  s.declined = lmp.fix_vector("hs", 18);
  s.press = lmp.compute_scalar("p");
  return s;
}

// out: the run on all ranks (on every rank).
void compare(const std::string &world_order, const std::string &single_order,
             bool pair_gravity = false, Snapshot *out = nullptr)
{
  int me = 0, np = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &me);
  MPI_Comm_size(MPI_COMM_WORLD, &np);
  const int steps = 400;
  const Snapshot world = run_on(MPI_COMM_WORLD, world_order, steps, pair_gravity);
  if (out) *out = world;
  if (me == 0) {
    const Snapshot single = run_on(MPI_COMM_SELF, single_order, steps, pair_gravity);
    ASSERT_EQ(world.x.size(), single.x.size());
    const double dx = max_abs_diff(world.x, single.x), dv = max_abs_diff(world.v, single.v);
    EXPECT_EQ(dx, 0.0);    // bitwise: fix gravity's forces do not depend on the ranks
    EXPECT_EQ(dv, 0.0);
    EXPECT_EQ(max_abs_diff(world.w, single.w), 0.0) << "spins";
    EXPECT_EQ(world.f[1], single.f[1]) << "collisions in total";
    EXPECT_EQ(world.f[2], single.f[2]) << "wall collisions";
    EXPECT_EQ(world.f[4], single.f[4]) << "most events in a step";
    EXPECT_NEAR(world.f[3], single.f[3], 1e-10 * std::fabs(single.f[3])) << "energy removed";
    EXPECT_NEAR(world.press, single.press, 1e-10 * std::fabs(single.press));
    EXPECT_GT(single.f[1], 5000.0);
    std::printf("[ MPI      ] %s%d ranks (%s) vs 1 (%s), %d steps, %.0f collisions: max |dx| %.2g "
                "|dv| %.2g, virial pressure %.17g vs %.17g\n",
                pair_gravity ? "pair gravity, " : "", np, world_order.c_str(), single_order.c_str(),
                steps, single.f[1], dx, dv, world.press, single.press);
  }
  MPI_Barrier(MPI_COMM_WORLD);
}

// Per-atom virial on several ranks: each rank tallies its own atoms' shares, also of collisions
// between atoms of different ranks (resolved on every rank); summed over the atoms and ranks it
// is minus the global collision virial at every step, and at the end the sums and the
// ID-weighted sums equal those of one rank.
void compare_peratom(const std::string &world_order, const std::string &single_order)
{
  int me = 0, np = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &me);
  MPI_Comm_size(MPI_COMM_WORLD, &np);
  const int steps = 200;
  const Snapshot world = run_on(MPI_COMM_WORLD, world_order, steps, false, true);
  EXPECT_GT(world.mmean, 1.0);
  EXPECT_LT(world.dmean, 1e-12 * world.mmean);
  if (me == 0) {
    const Snapshot single = run_on(MPI_COMM_SELF, single_order, steps, false, true);
    EXPECT_EQ(max_abs_diff(world.x, single.x), 0.0);
    EXPECT_LT(single.dmean, 1e-12 * single.mmean);
    double scale = 0.0;
    for (int k = 0; k < 3; ++k) scale = std::max(scale, std::fabs(single.sred[k]));
    EXPECT_GT(scale, 0.0);
    for (int k = 0; k < 6; ++k) {
      EXPECT_NEAR(world.sred[k], single.sred[k], 1e-12 * scale) << "component " << k;
      EXPECT_NEAR(world.sred[k], world.pvir[k], 1e-12 * scale) << "component " << k;
    }
    for (int k = 0; k < 3; ++k)
      EXPECT_NEAR(world.wsum[k], single.wsum[k], 1e-11 * scale * 500.0) << "weighted " << k;
    std::printf("[ MPI      ] per-atom virial, %d ranks (%s) vs 1 (%s): sum xx %.17g vs %.17g, "
                "ID-weighted %.17g vs %.17g\n",
                np, world_order.c_str(), single_order.c_str(), world.sred[0], single.sred[0],
                world.wsum[0], single.wsum[0]);
  }
  MPI_Barrier(MPI_COMM_WORLD);
}

}    // namespace

TEST(FixHardSphereMPI, PerAtomVirialSumsAgreeWithSingleRank)
{
  compare_peratom("parallel", "parallel");
  compare_peratom("serial", "parallel windows 3");
}

TEST(FixHardSphereMPI, ParallelOrderAgreesWithSingleRank)
{
  compare("parallel", "parallel");
}

// Groups spanning ranks always gathered (the default; the view's fall-back) and resolved in the
// view: the same bits.
TEST(FixHardSphereMPI, SpanningGatherAgreesWithSingleRankSerial)
{
  compare("parallel spanning gather", "serial");
}

TEST(FixHardSphereMPI, SpanningViewAgreesWithSingleRankSerial)
{
  compare("parallel spanning view", "serial");
}

TEST(FixHardSphereMPI, FixedWindowsAgreeWithSingleRankSerial)
{
  compare("parallel windows 3", "serial");
  // One window joining every candidate pair: groups that span ranks as large as the
  // connected components of the candidates.
  compare("parallel windows 1", "serial");
}

// With pair forces (the package's all-pairs gravity on the CPU, whose sums do not depend on
// the ranks): the accelerations differ from atom to atom, and windows on several ranks still
// give the serial loop's bits on one.
TEST(FixHardSphereMPI, PairGravityWindowsAgreeWithSingleRankSerial)
{
  compare("parallel", "serial", true);
}

// The CUDA collision backend on every rank (ranks share the node's devices) against the serial
// loop on one rank.  Label gpu would skip the whole binary; this case skips itself instead.
TEST(FixHardSphereMPI, CudaBackendOnAllRanksAgreesWithSingleRankSerial)
{
  if (HSGPU::GPU::device_count() == 0) GTEST_SKIP() << "no CUDA device on this machine";
  Snapshot s;
  compare("parallel gpu yes gpu/gather no", "serial", false, &s);
  int np = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &np);
  if (np > 1) {
    EXPECT_EQ(s.on_device, 0.0);    // each rank's device resolves groups only
  }
}

// gpu yes with the whole step on a device: on one rank, and on several the atoms of every step
// gathered on rank 0 (gpu/gather yes, the default); one rank's bits in both orders, with rough
// spheres, and with tc/slow no (every collision's restitution follows the times of last
// collision, which the gathered step shifts on each rank).  At least `least` of the 400 steps
// on the device, and on several ranks the gathers counted as the fix's communication.  Returns
// the bytes the fix's communication brought to all ranks in the cases' last steps.
double check_device_steps(double least)
{
  double bytes = 0.0;
  const std::vector<std::string> cases = {"parallel gpu yes|serial", "serial gpu yes|parallel",
                                          "parallel gpu yes" + ROUGH + "|parallel" + ROUGH,
                                          "parallel gpu yes tc 0.05 tc/slow no|serial tc 0.05 "
                                          "tc/slow no"};
  int me = 0, np = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &me);
  MPI_Comm_size(MPI_COMM_WORLD, &np);
  for (const std::string &orders : cases) {
    const size_t bar = orders.find('|');
    Snapshot s;
    compare(orders.substr(0, bar), orders.substr(bar + 1), false, &s);
    EXPECT_EQ(s.on_device + s.declined, 400.0) << orders;
    EXPECT_GE(s.on_device, least) << orders;
    if (np > 1) {
      EXPECT_GT(s.comm[2], 0.0) << orders;
    }
    if (me == 0)
      std::printf("[ DEVICE   ] %.0f of 400 steps whole on the device, %.0f bytes received in "
                  "the last\n",
                  s.on_device, s.comm[2]);
    bytes += s.comm[2];
  }
  return bytes;
}

TEST(FixHardSphereMPI, CudaGatheredStepAgreesWithSingleRank)
{
  if (HSGPU::GPU::device_count() == 0) GTEST_SKIP() << "no CUDA device on this machine";
  // Each rank's x, v and f straight to rank 0's device (CUDA IPC, one node), and through MPI.
  const double ipc = check_device_steps(390.0);    // none handed back in this system
  double mpi = 0.0;
  {
    ScopedEnv through_mpi("HSGPU_GATHER_MPI", "1");
    mpi = check_device_steps(390.0);
  }
  int np = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &np);
  if (np > 1) {
    EXPECT_LT(ipc, 0.5 * mpi) << "x, v and f went through MPI";
  }
}

// The gathered step where the atoms' arrays change under it: atoms sorted every 5 steps, per-
// atom virial asked for every 7 steps (those steps run on the host, the next one gathers every
// array again), a tenth of the atoms deleted midway (compress no: delete_atoms's default
// renumbers the atoms rank by rank, and IDs order simultaneous events).  On the CUDA device
// where there is one (each rank's arrays copied to rank 0's device and the results read back
// from there, CUDA IPC), else with the host's reference step in the device step's place (it
// reads every array it is given, so stale copies on rank 0 would show); against one rank
// without either, bit for bit.
TEST(FixHardSphereMPI, GatheredStepFollowsChangedArrays)
{
  const bool cuda = HSGPU::GPU::device_count() > 0;
  int me = 0, np = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &me);
  MPI_Comm_size(MPI_COMM_WORLD, &np);
  const std::vector<std::string> extra = {
      "atom_modify sort 5 1.0", "compute sa all stress/atom NULL fix",
      "compute sred all reduce sum c_sa[1] c_sa[3]", "fix sav all ave/time 7 1 7 c_sred[1]"};
  const std::vector<std::string> midway = {"group gone id 1:500:10",
                                           "delete_atoms group gone compress no"};
  Snapshot world;
  {
    ScopedEnv host("HSGPU_RESIDENT_HOST", "1", !cuda);
    world = run_on(MPI_COMM_WORLD, "parallel gpu yes tc 0.05 tc/slow no", 300, false, false,
                   extra, midway);
  }
  if (me == 0) {
    const Snapshot single =
        run_on(MPI_COMM_SELF, "serial tc 0.05 tc/slow no", 300, false, false, extra, midway);
    ASSERT_EQ(world.x.size(), single.x.size());
    EXPECT_EQ(world.x.size(), (size_t) 3 * 450);
    EXPECT_EQ(max_abs_diff(world.x, single.x), 0.0);
    EXPECT_EQ(max_abs_diff(world.v, single.v), 0.0);
    EXPECT_EQ(world.f[1], single.f[1]) << "collisions in total";
    // Most steps on the "device"; those with per-atom virial (every seventh) on the host.
    EXPECT_GT(world.on_device, 200.0);
    EXPECT_LE(world.on_device, 300.0 - 42.0);
    std::printf("[ MPI      ] %d ranks, gathered %s step with sorts, per-atom virial and "
                "deletions: %.0f collisions, %.0f of 300 steps on the device\n",
                np, cuda ? "CUDA" : "host reference", single.f[1], world.on_device);
  }
  MPI_Barrier(MPI_COMM_WORLD);
}

// The gathered step where nothing sets forces (no fix gravity): from the run's second step the
// ranks do not copy f to rank 0's device (or gather it through MPI), which uses zeros.  On the
// CUDA device, or the host reference where there is none, against one rank, bit for bit.
TEST(FixHardSphereMPI, GatheredStepWithoutForcesAgreesWithSingleRank)
{
  const bool cuda = HSGPU::GPU::device_count() > 0;
  int me = 0, np = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &me);
  MPI_Comm_size(MPI_COMM_WORLD, &np);
  for (const bool mpi : {false, true}) {
    Snapshot world;
    {
      ScopedEnv through_mpi("HSGPU_GATHER_MPI", "1", mpi);
      ScopedEnv host("HSGPU_RESIDENT_HOST", "1", !cuda);
      world = run_on(MPI_COMM_WORLD, "parallel gpu yes", 200, false, false, {}, {}, false);
    }
    if (me == 0) {
      const Snapshot single =
          run_on(MPI_COMM_SELF, "serial", 200, false, false, {}, {}, false);
      ASSERT_EQ(world.x.size(), single.x.size());
      EXPECT_EQ(max_abs_diff(world.x, single.x), 0.0) << (mpi ? "through MPI" : "");
      EXPECT_EQ(max_abs_diff(world.v, single.v), 0.0) << (mpi ? "through MPI" : "");
      EXPECT_EQ(world.f[1], single.f[1]) << "collisions in total";
      EXPECT_GT(single.f[1], 1000.0) << "enough collisions to mean anything";
      EXPECT_GT(world.on_device, 190.0);
      std::printf("[ MPI      ] %d ranks, gathered %s step without forces%s: %.0f collisions, "
                  "%.0f of 200 steps on the device\n",
                  np, cuda ? "CUDA" : "host reference", mpi ? " (through MPI)" : "",
                  single.f[1], world.on_device);
    }
    MPI_Barrier(MPI_COMM_WORLD);
  }
}

// gpu/keep on several ranks: the gathered step run ahead.  Every rank sends its x, v and f at
// the fix's post_force(), rank 0's device (or the host's reference step) moves x and v as fix
// nve/sphere will and runs the next step while the ranks integrate; it gives the bits of
// `gpu/keep no` (every step sent at post_integrate) and of one rank in order serial.  The
// integrator's rounding is checked on every rank's host on the run's first steps and after
// every 100 steps run ahead.  Cases: fix gravity; no forces; atoms sorted every 5 steps (the
// steps after a sort send tlast, radius, ... as well) and per-atom virial every 7th step (the
// step run ahead for it is dropped and done on the host); fix gravity defined after the fix
// (its post_force() comes later: the step runs ahead from end_of_step(), x and v sent after
// fix nve's first half kick).  Through CUDA IPC on a device, else
// through MPI with the host's reference step.
TEST(FixHardSphereMPI, GatheredStepRunAheadAgreesWithSingleRank)
{
  const bool cuda = HSGPU::GPU::device_count() > 0;
  int me = 0, np = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &me);
  MPI_Comm_size(MPI_COMM_WORLD, &np);
  if (np < 2) GTEST_SKIP() << "the gathered step takes two ranks or more";
  const std::string log = "test_fix_hardsphere_mpi_ahead.log";
  struct Case {
    const char *name;
    std::vector<std::string> extra;
    bool gravity;
    bool dropped;    // steps run ahead dropped (per-atom virial)
    bool after;      // from end_of_step() (a force fix's post_force() comes later)
  };
  const Case cases[] = {
      {"fix gravity", {}, true, false, false},
      {"no forces", {}, false, false, false},
      {"sorts and per-atom virial",
       {"atom_modify sort 5 1.0", "compute sa all stress/atom NULL fix",
        "compute sred all reduce sum c_sa[1] c_sa[3]", "fix sav all ave/time 7 1 7 c_sred[1]"},
       true, true, false},
      {"fix gravity after the fix", {"fix g2 all gravity 0.5 vector 0 0 -1"}, true, false, true}};
  // On a device also through MPI to rank 0's host (HSGPU_GATHER_MPI) for the first case.
  for (int k = 0; k < (cuda ? 5 : 4); ++k) {
    const Case &c = cases[k % 4];
    const bool mpi = k == 4;
    std::vector<std::string> extra = c.extra;
    extra.push_back("log " + log);
    Snapshot ahead, copied;
    {
      ScopedEnv host("HSGPU_RESIDENT_HOST", "1", !cuda);
      ScopedEnv through_mpi("HSGPU_GATHER_MPI", "1", mpi);
      ahead = run_on(MPI_COMM_WORLD, "parallel gpu yes", 250, false, false, extra, {}, c.gravity);
      copied = run_on(MPI_COMM_WORLD, "parallel gpu yes gpu/keep no", 250, false, false, c.extra,
                      {}, c.gravity);
    }
    if (me == 0) {
      const Snapshot single =
          run_on(MPI_COMM_SELF, "serial", 250, false, false, c.extra, {}, c.gravity);
      EXPECT_EQ(max_abs_diff(ahead.x, single.x), 0.0) << c.name;
      EXPECT_EQ(max_abs_diff(ahead.v, single.v), 0.0) << c.name;
      EXPECT_EQ(max_abs_diff(copied.x, single.x), 0.0) << c.name;
      EXPECT_EQ(max_abs_diff(copied.v, single.v), 0.0) << c.name;
      EXPECT_EQ(ahead.f[1], single.f[1]) << c.name << ": collisions in total";
      EXPECT_GT(single.f[1], 1000.0) << c.name;
      EXPECT_GT(ahead.on_device, 150.0) << c.name;
      const std::string text = hsgpu_test::file_text(log);
      int n_ahead = 0, dropped = 0, checked = 0, kept = 0, by_id = 0;
      {
        const size_t at = text.find("gathered steps run ahead on rank 0's device");
        // From the fix's post_force(), or its end_of_step() where a force fix's post_force()
        // comes after it (the x and v sent have had fix nve's first half kick then).
        EXPECT_NE(text.find(c.after ? "step before's end_of_step" : "step before's post_force"),
                  std::string::npos)
            << c.name << "\n" << text;
        ASSERT_NE(at, std::string::npos) << c.name << "\n" << text;
        const size_t from = text.rfind("Fix hardsphere: ", at);
        const std::string line = text.substr(from, text.find('\n', at) - from);
        ASSERT_EQ(std::sscanf(line.c_str(),
                              "Fix hardsphere: %d gathered steps run ahead on rank 0's device "
                              "during LAMMPS's integration (%d of them dropped)",
                              &n_ahead, &dropped),
                  2)
            << line;
        const size_t on = line.find("checked against LAMMPS's on ");
        ASSERT_NE(on, std::string::npos) << line;
        checked = std::atoi(line.c_str() + on + std::strlen("checked against LAMMPS's on "));
        // On one node with a device, where no atom moved in the arrays since the step before,
        // x and v stay on rank 0's device (wrapped there where LAMMPS reneighbored).
        const size_t kp = line.find("(on ");
        ASSERT_NE(kp, std::string::npos) << line;
        kept = std::atoi(line.c_str() + kp + 4);
        // And where atoms moved between ranks or in the arrays (the exchanges, the sorts),
        // found there by their IDs.
        const size_t rp = line.find("step before, on ");
        ASSERT_NE(rp, std::string::npos) << line;
        by_id = std::atoi(line.c_str() + rp + std::strlen("step before, on "));
        if (cuda && !mpi) {
          EXPECT_GT(kept, c.gravity ? 100 : 20) << line;
          EXPECT_GT(by_id, 10) << line;
        }
        if (!cuda || mpi) {
          EXPECT_EQ(kept, 0) << line;
          EXPECT_EQ(by_id, 0) << line;
        }
        EXPECT_NE(line.find("rounded as fix nve rounds them"), std::string::npos) << line;
        // The first check, then one after each 100 steps run ahead.
        EXPECT_GE(checked, 2) << line;
        EXPECT_GT(n_ahead, 150) << line;
        if (c.dropped)
          EXPECT_GT(dropped, 10) << line;
        else
          EXPECT_EQ(dropped, 0) << line;
      }
      std::printf("[ MPI      ] %d ranks, gathered %s step run ahead, %s%s: %.0f collisions, "
                  "%.0f of 250 steps on the device, %d run ahead (%d dropped, %d with x and v "
                  "kept, %d of them found by ID), %d checks\n",
                  np, cuda ? "CUDA" : "host reference", c.name,
                  mpi || !cuda ? " (through MPI)" : "", single.f[1], ahead.on_device, n_ahead,
                  dropped, kept, by_id, checked);
    }
    MPI_Barrier(MPI_COMM_WORLD);
  }
}

// The gathered step with a group other than all: each rank packs its group's atoms, the
// results go back to them (80 of the 500 atoms held still outside the group).  On the CUDA
// device, or the host reference where there is none, on 2 and 4 ranks against one rank in
// order serial, bit for bit.
TEST(FixHardSphereMPI, GatheredStepOfAGroup)
{
  const bool cuda = HSGPU::GPU::device_count() > 0;
  int me = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &me);
  auto extra = [](const std::string &order) {
    return std::vector<std::string>{
        "group frozen id 421:500", "group mobile subtract all frozen",
        "velocity frozen set 0 0 0", "fix fz frozen setforce 0 0 0", "unfix hs",
        "fix hs mobile hardsphere restitution 0.95 restitution/pair 1 2 0.8 wall zlo 0.9 wall "
        "zhi 1.0 tc 0.05 tc/slow no order " +
            order};
  };
  Snapshot world;
  {
    ScopedEnv host("HSGPU_RESIDENT_HOST", "1", !cuda);
    world = run_on(MPI_COMM_WORLD, "parallel", 300, false, false, extra("parallel gpu yes"));
  }
  if (me == 0) {
    const Snapshot single = run_on(MPI_COMM_SELF, "serial", 300, false, false, extra("serial"));
    EXPECT_EQ(max_abs_diff(world.x, single.x), 0.0);
    EXPECT_EQ(max_abs_diff(world.v, single.v), 0.0);
    EXPECT_EQ(world.f[1], single.f[1]) << "collisions in total";
    EXPECT_GT(single.f[1], 3000.0);
    EXPECT_GT(world.on_device, 250.0);
    std::printf("[ MPI      ] gathered %s step of a group: %.0f collisions, %.0f of 300 steps "
                "on the device\n",
                cuda ? "CUDA" : "host reference", single.f[1], world.on_device);
  }
  MPI_Barrier(MPI_COMM_WORLD);
}

// The same with the host's reference resident step in the device step's place (environment
// HSGPU_RESIDENT_HOST, where no device is present): the fix's device step on one rank and its
// gathered step on several (gather, run_atoms, results back, times of last collision shifted)
// run without a GPU.  The reference step hands back more steps (any atom beyond its bound).
TEST(FixHardSphereMPI, HostResidentStepAgreesWithSingleRank)
{
  if (HSGPU::GPU::device_count() > 0) GTEST_SKIP() << "a CUDA device is present (see above)";
  ScopedEnv host("HSGPU_RESIDENT_HOST", "1");
  check_device_steps(300.0);
}

// Issue 15: rough spheres (friction between the types and on the floor): the spins travel with
// the groups gathered across ranks, and every rank count and order gives one rank's bits.
TEST(FixHardSphereMPI, FrictionAgreesWithSingleRankInBothOrders)
{
  compare("parallel" + ROUGH, "parallel" + ROUGH);
  compare("serial" + ROUGH, "parallel windows 3" + ROUGH);
}

TEST(FixHardSphereMPI, SerialOrderOnAllRanksAgreesWithParallelOnOne)
{
  compare("serial", "parallel");
}

// Issue 12 item 9 on several ranks: a small sphere squeezed by a big one outruns the fix's
// reach 0.25 and the fix raises the ghost cutoff at a reneighboring it asks for.  The decision
// is taken from maxima over all ranks, so every decomposition raises it at the same step and
// the trajectory is that of one rank, bitwise.
TEST(FixHardSphereMPI, SqueezeRaisesTheGhostCutoffAsOnOneRank)
{
  int me = 0, np = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &me);
  MPI_Comm_size(MPI_COMM_WORLD, &np);
  struct Result {
    std::vector<double> x, v;
    double raised, coll;
  };
  auto run = [](MPI_Comm comm) {
    Lammps lmp(comm);
    lmp.commands({"units lj",
                  "atom_style sphere",
                  "atom_modify map array",
                  "boundary p p f",
                  "region box block 0 50 0 50 0 30",
                  "create_box 2 box",
                  "create_atoms 1 single 25 25 0.5 units box",
                  "create_atoms 2 single 25.5 25 6.6 units box",
                  "create_atoms 1 single 10 40 0.5 units box",
                  "set type 1 diameter 1.0",
                  "set type 2 diameter 10.0",
                  "set type * density 1.0",
                  "comm_modify vel yes",
                  "neigh_modify every 1 delay 0 check yes",
                  "fix 1 all nve/sphere",
                  "fix g all gravity 1.0 vector 0 0 -1",
                  "group big type 2",
                  "velocity big set 0 0 -5",
                  "thermo_modify norm no",
                  "timestep 0.005",
                  "fix hs all hardsphere restitution 0.9 wall zlo 0.9 wall zhi 1.0 reach 0.25",
                  "run 400"});
    Result r;
    r.x = lmp.gather("x", 3);
    r.v = lmp.gather("v", 3);
    r.raised = lmp.fix_vector("hs", 21);
    r.coll = lmp.fix_vector("hs", 1);
    return r;
  };
  const Result world = run(MPI_COMM_WORLD);
  if (me == 0) {
    const Result single = run(MPI_COMM_SELF);
    EXPECT_GE(single.raised, 1.0);
    EXPECT_GE(single.coll, 10.0);
    EXPECT_EQ(world.raised, single.raised);
    EXPECT_EQ(world.coll, single.coll);
    EXPECT_EQ(max_abs_diff(world.x, single.x), 0.0);
    EXPECT_EQ(max_abs_diff(world.v, single.v), 0.0);
    std::printf("[ MPI      ] squeeze, %d ranks vs 1: %.0f collisions, ghost cutoff raised %.0f "
                "times, max |dx| %.2g\n",
                np, single.coll, single.raised, max_abs_diff(world.x, single.x));
  }
  MPI_Barrier(MPI_COMM_WORLD);
}

TEST(FixHardSphereMPI, MissingGhostVelocitiesAreReportedOnSeveralRanks)
{
  int np = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &np);
  Lammps lmp;
  const std::string err = lmp.first_error(
      {"units lj", "atom_style sphere", "boundary p p p", "region box block 0 10 0 10 0 10",
       "create_box 1 box", "create_atoms 1 single 2 2 2", "create_atoms 1 single 7 7 7",
       "comm_modify cutoff 3", "neigh_modify every 1 delay 0 check yes", "fix 1 all nve/sphere",
       "fix hs all hardsphere", "run 1"});
  if (np > 1)
    EXPECT_THAT(err, HasSubstr("requires 'comm_modify vel yes' when running on more than one"));
  else
    EXPECT_EQ(err, "") << "one rank needs no ghost velocities";
}

// overlap push on every rank of MPI_COMM_WORLD: random placement at packing fraction 0.3, whose
// relaxation moves atoms across subdomains (they are exchanged between passes), ends with no
// overlap and no atom lost, and a short run after it stays free of overlaps.
// f_hs[24 ... 26]: the fix's own communication in the last step.  None on one rank; on several,
// at least one collective and one ghost update, the same counts on every rank, and at least the
// ghost update's 10 values for each ghost of an atom another rank owns.
TEST(FixHardSphereMPI, CommunicationOfTheStepIsCounted)
{
  int me = 0, np = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &me);
  MPI_Comm_size(MPI_COMM_WORLD, &np);
  const std::string log = "hs_comm_np" + std::to_string(np) + ".log";
  const Snapshot s = run_on(MPI_COMM_WORLD, "parallel", 50, false, false, {"log " + log});
  if (np == 1) {
    EXPECT_EQ(s.comm[0], 0.0);
    EXPECT_EQ(s.comm[1], 0.0);
    EXPECT_EQ(s.comm[2], 0.0);
    return;
  }
  EXPECT_GE(s.comm[0], 3.0) << "the budget, the tallies and the step's check at least";
  EXPECT_GE(s.comm[1], 1.0) << "the ghosts' update of the step";
  // A 2 x 1 x 1 or finer split of an 11-wide box with a ghost cutoff of 3.5 gives every rank
  // ghosts of another rank's atoms: at least 10 doubles each.
  EXPECT_GT(s.comm[2], 80.0 * 20);
  double lo[2] = {s.comm[0], s.comm[1]}, hi[2] = {s.comm[0], s.comm[1]}, glo[2], ghi[2];
  MPI_Allreduce(lo, glo, 2, MPI_DOUBLE, MPI_MIN, MPI_COMM_WORLD);
  MPI_Allreduce(hi, ghi, 2, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
  EXPECT_EQ(glo[0], ghi[0]) << "collectives counted alike on every rank";
  EXPECT_EQ(glo[1], ghi[1]) << "ghost updates counted alike on every rank";
  if (me == 0) {
    // The run's line: the least and the most time of a rank in the communication.
    const std::string text = hsgpu_test::file_text(log);
    std::smatch m;
    ASSERT_TRUE(std::regex_search(
        text, m, std::regex("; ([0-9.eE+-]+) to ([0-9.eE+-]+) ms per step in it on a rank")))
        << "no communication time in the fix's log line";
    const double least = std::stod(m[1].str()), most = std::stod(m[2].str());
    EXPECT_GE(least, 0.0);
    EXPECT_LE(least, most);
    EXPECT_GT(most, 0.0) << "some time in the step's collectives and ghost updates";
    std::printf("[ MPI      ] %d ranks: %.3g to %.3g ms per step in the communication\n", np,
                least, most);
    // Where the ranks' steps went: every part a pair "least to most", least <= most.
    // The first line has five parts and three of the window lengths tried; the second five,
    // and two of the gather.
    const std::pair<const char *, int> lines[] = {{"a rank's search and windows", 8},
                                                  {"of the groups spanning ranks", 7}};
    for (const auto &lp : lines) {
      const char *line = lp.first;
      const size_t at = text.find(std::string("Fix hardsphere: ") + line);
      ASSERT_NE(at, std::string::npos) << "no line '" << line << "' in the log";
      const std::string rest = text.substr(at, text.find('\n', at) - at);
      const std::regex pair("([0-9.eE+-]+) to ([0-9.eE+-]+)");
      int parts = 0;
      for (auto it = std::sregex_iterator(rest.begin(), rest.end(), pair);
           it != std::sregex_iterator(); ++it, ++parts) {
        const double lo = std::stod((*it)[1].str()), hi = std::stod((*it)[2].str());
        EXPECT_GE(lo, 0.0) << rest;
        EXPECT_LE(lo, hi) << rest;
      }
      EXPECT_EQ(parts, lp.second) << rest;
    }
  }
  if (me == 0)
    std::printf("[ MPI      ] %d ranks, last step: %.0f collectives, %.0f ghost updates, %.0f "
                "bytes received\n",
                np, s.comm[0], s.comm[1], s.comm[2]);
}

// Issue 13 item 1: groups of atoms that span ranks are resolved where they lie, without the
// gather.  Two dense scenes, each run in the parallel order on all ranks and in the serial
// order on rank 0 alone (bitwise equal; the test runs under 1, 2 and 4 ranks, so the rank
// counts agree with each other too), with the step driver's figures averaged over the steps:
// f_hs[9] windows, f_hs[11] atoms in spanning groups, f_hs[16] gathers, f_hs[27] spanning
// groups resolved where they lie, f_hs[28] windows on the old path, f_hs[29] atoms gathered.
struct Spanning {
  std::vector<double> x, v, omega;
  double collisions = 0.0, events = 0.0;
  double windows = 0.0, boundary = 0.0, gathers = 0.0, local = 0.0, fallbacks = 0.0;
  double gathered = 0.0;
  double neighbour = 0.0;    // f_hs[30]: gathers with the neighbouring ranks only
  double collectives = 0.0;    // f_hs[24]: collective operations per step
  double largest = 0.0;        // f_hs[7]: the most atoms resolved together, per step
  double forwards = 0.0;       // f_hs[32]: rounds passing entries on, per step
  double round_fails = 0.0;    // f_hs[33]: passes gathered again after those rounds, per step
  double step_redos = 0.0;     // f_hs[34]: steps of planned windows done again, per step
  double ghost_updates = 0.0;  // f_hs[25]: the fix's ghost updates per step
};

// kind "fluid": 12^3 elastic spheres of diameter 1 on a simple cubic lattice at packing
// fraction 0.45, periodic (the fluid and lattice3d benchmarks, smaller); kind "pile": 1000
// spheres of two sizes dropped onto a floor under gravity, e = 0.7, settling into a pile;
// kind "rough": the pile with friction (spins carried by every exchange of the view).
// (Both with LAMMPS's default processor grid: the box's longest side is split first.)
// Atoms are placed one by one and their velocities set from their IDs (independent of the
// decomposition).
Spanning run_dense(MPI_Comm comm, const std::string &kind, const std::string &order, int steps,
                   const std::string &cutoff, const std::string &spanning = "view",
                   const std::string &logfile = "", int side = 12)
{
  Lammps lmp(comm);
  const bool fluid = kind == "fluid";
  // The pile: 20 x 10 x 5 spheres in a box longest in x, so that the ranks split it
  // sideways.  The fluid: side^3 spheres.
  const int nx = fluid ? side : 20, ny = fluid ? side : 10, nz = fluid ? side : 5;
  const double a = fluid ? std::cbrt(M_PI / (6.0 * 0.45)) : 1.05;
  const double lx = nx * a, ly = ny * a, lz = fluid ? nz * a : 1.9 * ny * a;
  lmp.commands({"units lj", "atom_style sphere", "atom_modify map array",
                fluid ? "boundary p p p" : "boundary p p f",
                "region box block 0 " + std::to_string(lx) + " 0 " + std::to_string(ly) + " 0 " +
                    std::to_string(lz),
                "create_box 2 box"});
  std::vector<std::string> atoms;
  for (int iz = 0; iz < nz; ++iz)
    for (int iy = 0; iy < ny; ++iy)
      for (int ix = 0; ix < nx; ++ix) {
        char line[160];
        std::snprintf(line, sizeof(line), "create_atoms %d single %.17g %.17g %.17g units box",
                      fluid ? 1 : 1 + (ix + iy + iz) % 2, a * (ix + 0.5), a * (iy + 0.5),
                      a * (iz + 0.5));
        atoms.push_back(line);
      }
  lmp.commands(atoms);
  lmp.commands({"set type 1 diameter 1.0", "set type 1 density 1.9098593171027443",
                "set type 2 diameter 0.8", "set type 2 density 3.0",
                "variable vx atom 1.5*sin(17.31*id)", "variable vy atom 1.5*cos(7.77*id)",
                "variable vz atom 1.5*sin(3.3*id+1.1)", "velocity all set v_vx v_vy v_vz",
                "comm_modify cutoff " + cutoff + " vel yes",
                "neigh_modify every 1 delay 0 check yes", "fix 1 all nve/sphere"});
  if (fluid)
    lmp.commands({"fix hs all hardsphere reach 0.5 spanning " + spanning + " order " + order});
  else
    lmp.commands({"fix g all gravity 1.0 vector 0 0 -1",
                  "fix hs all hardsphere restitution 0.7 wall zlo 0.7 reach 0.5 spanning " +
                      spanning + " order " + order +
                      (kind == "rough" ? " friction 0.5 0.2 wall/friction zlo 0.4 0.0" : "")});
  const std::string ns = std::to_string(steps);
  if (!logfile.empty()) lmp.commands({"log " + logfile});
  lmp.commands({"timestep 0.01", "thermo 0",
                "fix avg all ave/time 1 " + ns + " " + ns +
                    " f_hs[9] f_hs[11] f_hs[16] f_hs[27] f_hs[28] f_hs[29] f_hs[30]"
                    " f_hs[24] f_hs[7] f_hs[32] f_hs[33] f_hs[34] f_hs[25]",
                "run " + ns});
  Spanning s;
  s.x = lmp.gather("x", 3);
  s.v = lmp.gather("v", 3);
  s.omega = lmp.gather("omega", 3);
  s.collisions = lmp.fix_vector("hs", 1);
  s.events = lmp.fix_vector("hs", 5);
  s.windows = lmp.fix_vector("avg", 0);
  s.boundary = lmp.fix_vector("avg", 1);
  s.gathers = lmp.fix_vector("avg", 2);
  s.local = lmp.fix_vector("avg", 3);
  s.fallbacks = lmp.fix_vector("avg", 4);
  s.gathered = lmp.fix_vector("avg", 5);
  s.neighbour = lmp.fix_vector("avg", 6);
  s.collectives = lmp.fix_vector("avg", 7);
  s.largest = lmp.fix_vector("avg", 8);
  s.forwards = lmp.fix_vector("avg", 9);
  s.round_fails = lmp.fix_vector("avg", 10);
  s.step_redos = lmp.fix_vector("avg", 11);
  s.ghost_updates = lmp.fix_vector("avg", 12);
  return s;
}

// The run on all ranks against the serial order on one: bitwise, spins and counts included.
void expect_as_serial(const Spanning &world, const Spanning &single, const std::string &kind,
                      int np)
{
  EXPECT_EQ(max_abs_diff(world.x, single.x), 0.0) << kind << ": " << np << " ranks vs serial";
  EXPECT_EQ(max_abs_diff(world.v, single.v), 0.0) << kind << ": " << np << " ranks vs serial";
  EXPECT_EQ(max_abs_diff(world.omega, single.omega), 0.0) << kind << ": spins";
  EXPECT_EQ(world.collisions, single.collisions) << kind;
  EXPECT_EQ(world.events, single.events) << kind;
  EXPECT_GT(single.collisions, 20000.0) << kind;
}

// cutoff: the ghost cutoff (the deeper the ghost shell, the more groups some rank holding an
// atom of them sees whole); share: the largest part of the atoms in spanning groups that may
// be gathered.
void compare_spanning(const std::string &kind, int steps, const std::string &cutoff, double share)
{
  int me = 0, np = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &me);
  MPI_Comm_size(MPI_COMM_WORLD, &np);
  const Spanning world = run_dense(MPI_COMM_WORLD, kind, "parallel", steps, cutoff);
  if (np > 1) {
    // Spanning groups are resolved where they lie, many per step; the gather is left to the
    // groups that no rank holding an atom of them sees whole, a small part of the atoms in
    // spanning groups; a whole window goes back to the old path rarely.
    EXPECT_GT(world.boundary, 20.0) << kind << ": groups span ranks";
    EXPECT_GT(world.local, 5.0) << kind << ": spanning groups resolved where they lie";
    EXPECT_LE(world.gathered, share * world.boundary) << kind << ": atoms gathered";
    EXPECT_LT(world.fallbacks, 0.2 * world.windows) << kind << ": windows on the old path";
  } else {
    EXPECT_EQ(world.gathers, 0.0);
    EXPECT_EQ(world.gathered, 0.0);
    EXPECT_EQ(world.local, 0.0);
  }
  if (me == 0) {
    const Spanning single = run_dense(MPI_COMM_SELF, kind, "serial", steps, cutoff);
    expect_as_serial(world, single, kind, np);
    std::printf("[ MPI      ] %s, cutoff %s, %d ranks (parallel) vs 1 (serial), %d steps, %.0f "
                "collisions: "
                "per step %.3g windows, %.4g atoms in spanning groups, %.4g such groups resolved "
                "where they lie, %.3g gathers of %.4g atoms, %.3g windows on the old path\n",
                kind.c_str(), cutoff.c_str(), np, steps, single.collisions, world.windows,
                world.boundary, world.local, world.gathers, world.gathered, world.fallbacks);
  }
  MPI_Barrier(MPI_COMM_WORLD);
}

// The default `spanning gather` on more than two ranks: the groups that span ranks are gathered
// from the neighbouring ranks (the owners of the foreign nodes in each group, entries passed on
// through a third rank where a group reaches further), not from every rank; each rank resolves
// the groups that hold an atom of its own.  Bitwise equal to serial on one rank.
void compare_neighbour_gather(const std::string &kind, int steps)
{
  int me = 0, np = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &me);
  MPI_Comm_size(MPI_COMM_WORLD, &np);
  const Spanning world = run_dense(MPI_COMM_WORLD, kind, "parallel", steps, "2.5", "gather");
  if (np > 2) {
    EXPECT_GT(world.gathers, 0.5) << kind << ": gathers per step";
    // Almost every gather stays with the neighbouring ranks; a group that still lacks a
    // partner after the passing on is gathered from every rank.
    EXPECT_GT(world.neighbour, 0.8 * world.gathers) << kind << ": gathers to the neighbours";
  } else {
    EXPECT_EQ(world.neighbour, 0.0) << kind << ": one or two ranks gather from every rank";
  }
  if (me == 0) {
    const Spanning single = run_dense(MPI_COMM_SELF, kind, "serial", steps, "2.5", "gather");
    expect_as_serial(world, single, kind, np);
    std::printf("[ MPI      ] %s, spanning gather, %d ranks (parallel) vs 1 (serial), %d steps, "
                "%.0f collisions: per step %.4g atoms in spanning groups, %.3g gathers, %.3g of "
                "them with the neighbouring ranks only\n",
                kind.c_str(), np, steps, single.collisions, world.boundary, world.gathers,
                world.neighbour);
  }
  MPI_Barrier(MPI_COMM_WORLD);
}

TEST(FixHardSphereMPI, SpanningGroupsGatheredFromTheNeighbouringRanks)
{
  compare_neighbour_gather("fluid", 100);
  compare_neighbour_gather("rough", 300);
}

// HSGPU_SPANNING_WIDE=1: every boundary atom goes to every rank of the spanning groups' ghosts
// at a gather, so no round passes entries on; the same bits as the gather that passes them on.
TEST(FixHardSphereMPI, WideGatherNeedsNoRoundsPassingEntriesOn)
{
  int me = 0, np = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &me);
  MPI_Comm_size(MPI_COMM_WORLD, &np);
  if (np < 3) GTEST_SKIP() << "a gather to the neighbouring ranks takes three ranks or more";
  const std::string tag = "_np" + std::to_string(np) + ".log";
  Spanning narrow, wide;
  {
    ScopedEnv off("HSGPU_SPANNING_WIDE", nullptr);
    narrow = run_dense(MPI_COMM_WORLD, "fluid", "parallel", 100, "2.5", "gather", "hs_narrow" + tag);
  }
  {
    ScopedEnv on("HSGPU_SPANNING_WIDE", "1");
    wide = run_dense(MPI_COMM_WORLD, "fluid", "parallel", 100, "2.5", "gather", "hs_wide" + tag);
  }
  EXPECT_EQ(max_abs_diff(wide.x, narrow.x), 0.0);
  EXPECT_EQ(max_abs_diff(wide.v, narrow.v), 0.0);
  EXPECT_EQ(wide.collisions, narrow.collisions);
  EXPECT_GT(narrow.neighbour, 0.5) << "gathers to the neighbouring ranks per step";
  EXPECT_GT(wide.neighbour, 0.5) << "gathers to the neighbouring ranks per step";
  if (me == 0) {
    auto rounds = [](const std::string &log) {
      const std::string text = hsgpu_test::file_text(log);
      std::smatch m;
      if (!std::regex_search(text, m, std::regex("only, ([0-9.eE+-]+) rounds passing entries on")))
        return -1.0;
      return std::stod(m[1].str());
    };
    const double rn = rounds("hs_narrow" + tag), rw = rounds("hs_wide" + tag);
    EXPECT_GT(rn, 0.0) << "rounds passing entries on per step (a group over three ranks or more)";
    // (On more than 8 ranks the 12^3 fluid's subdomains, about 3 diameters wide on 16, are
    // narrower than its groups, which then reach past the neighbouring ranks: rounds follow
    // the wide sends too.)
    if (np <= 8) {
      EXPECT_EQ(rw, 0.0) << "rounds passing entries on per step with the wide gather";
    }
    std::printf("[ MPI      ] %d ranks, fluid: %.3g rounds passing entries on per step, 0 with "
                "HSGPU_SPANNING_WIDE (%.3g); the same %.0f collisions\n",
                np, rn, rw, wide.collisions);
  }
  MPI_Barrier(MPI_COMM_WORLD);
}

// The fluid of run_dense() (`spanning gather`, 100 steps unless said) with the environment
// variables `env` set for the run (a null value: unset), given back afterwards.
using EnvList = std::initializer_list<std::pair<const char *, const char *>>;
Spanning fluid_with(EnvList env, int steps = 100, int side = 12)
{
  std::vector<std::unique_ptr<ScopedEnv>> set;
  for (const auto &e : env) set.push_back(std::make_unique<ScopedEnv>(e.first, e.second));
  return run_dense(MPI_COMM_WORLD, "fluid", "parallel", steps, "2.5", "gather", "", side);
}

// Two runs of one input: the same trajectories and collisions to the bit.
void expect_same_bits(const Spanning &a, const Spanning &b)
{
  EXPECT_EQ(max_abs_diff(a.x, b.x), 0.0);
  EXPECT_EQ(max_abs_diff(a.v, b.v), 0.0);
  EXPECT_EQ(a.collisions, b.collisions);
}

// The window bounds of the atoms next to another rank's on three ranks or more
// (WindowSettings::edge_factor, by default half what they would be for those atoms and their
// candidate partners): fewer atoms in groups that span ranks than with the same bounds
// everywhere (HSGPU_EDGE_FACTOR=1), and the same bits.
TEST(FixHardSphereMPI, SmallerBoundsAtTheRanksEdgesKeepTheBits)
{
  int me = 0, np = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &me);
  MPI_Comm_size(MPI_COMM_WORLD, &np);
  if (np < 3) GTEST_SKIP() << "the bounds at the ranks' edges are for three ranks or more";
  const Spanning fixed = fluid_with({{"HSGPU_EDGE_FACTOR", "1"}, {"HSGPU_EDGE_HOPS", "0"}});
  const Spanning edge = fluid_with({{"HSGPU_EDGE_FACTOR", nullptr}, {"HSGPU_EDGE_HOPS", nullptr}});
  expect_same_bits(edge, fixed);
  EXPECT_GT(fixed.boundary, 20.0) << "atoms per step in spanning groups, the same bounds";
  EXPECT_LT(edge.boundary, 0.9 * fixed.boundary) << "atoms per step in spanning groups";
  if (me == 0)
    std::printf("[ MPI      ] %d ranks, fluid, 100 steps: %.4g atoms per step in spanning groups "
                "(%.4g with the same bounds everywhere), %.3g gathers per step (%.3g); the same "
                "%.0f collisions\n",
                np, edge.boundary, fixed.boundary, edge.gathers, fixed.gathers, edge.collisions);
  MPI_Barrier(MPI_COMM_WORLD);
}

// On three ranks or more the gathers' messages go to the neighbouring ranks, one to each,
// without the non-blocking barrier of messages to any rank: fewer collective operations per
// step, the same bits.
TEST(FixHardSphereMPI, NeighbourMessagesKeepTheBitsWithFewerCollectives)
{
  int me = 0, np = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &me);
  MPI_Comm_size(MPI_COMM_WORLD, &np);
  if (np < 3) GTEST_SKIP() << "the gathers go to the neighbouring ranks on three ranks or more";
  const Spanning barrier = fluid_with({{"HSGPU_NEIGHBOUR_EXCHANGE", "0"}});
  const Spanning nbr = fluid_with({{"HSGPU_NEIGHBOUR_EXCHANGE", nullptr}});
  expect_same_bits(nbr, barrier);
  EXPECT_GT(nbr.neighbour, 0.5) << "gathers per step with the neighbouring ranks";
  EXPECT_LT(nbr.collectives, barrier.collectives - 1.0) << "collective operations per step";
  if (me == 0)
    std::printf("[ MPI      ] %d ranks, fluid, 100 steps: %.4g collective operations per step "
                "with messages to the neighbouring ranks, %.4g with a barrier; %.3g gathers per "
                "step; the same %.0f collisions\n",
                np, nbr.collectives, barrier.collectives, nbr.neighbour, nbr.collisions);
  MPI_Barrier(MPI_COMM_WORLD);
}

// The rounds of a gather to the neighbouring ranks passing entries on are a fixed number (2,
// one more after each pass they left short), with no reduction deciding each: whether every
// group came whole to the rank that resolves it rides in the missed pairs' reduction.  Against
// rounds decided by a reduction each (HSGPU_FIXED_ROUNDS=0): the same bits with fewer
// collective operations per step.  Starting from one round, some groups do not come whole on
// four ranks or more: those passes are gathered again from every rank (f_ID[33] > 0), and the
// bits stay the same.  (On three ranks, each a
// neighbour of the others, one round brought every group whole here.)  The gathers' narrow
// sends in every run (the wide ones need no rounds).
TEST(FixHardSphereMPI, FixedRoundsNeedNoReductionAndKeepTheBits)
{
  int me = 0, np = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &me);
  MPI_Comm_size(MPI_COMM_WORLD, &np);
  if (np < 3) GTEST_SKIP() << "the gathers go to the neighbouring ranks on three ranks or more";
  const Spanning decided =
      fluid_with({{"HSGPU_FIXED_ROUNDS", "0"}, {"HSGPU_SPANNING_WIDE", nullptr}});
  const Spanning fixed =
      fluid_with({{"HSGPU_FIXED_ROUNDS", nullptr}, {"HSGPU_SPANNING_WIDE", nullptr}});
  const Spanning one = fluid_with({{"HSGPU_FIXED_ROUNDS", "1"}, {"HSGPU_SPANNING_WIDE", nullptr}});
  expect_same_bits(fixed, decided);
  expect_same_bits(one, decided);
  EXPECT_GT(fixed.neighbour, 0.5) << "gathers per step with the neighbouring ranks";
  EXPECT_GT(decided.forwards, 0.1) << "rounds passing entries on per step";
  // Two rounds per gather, one more after each pass they left short (a few at most).
  EXPECT_GE(fixed.forwards, 2.0 * fixed.neighbour - 1e-9) << "rounds per step";
  EXPECT_LE(fixed.forwards, 4.0 * fixed.neighbour + 1e-9) << "rounds per step";
  EXPECT_LT(fixed.round_fails, 0.05) << "passes gathered again per step, two rounds";
  EXPECT_LT(fixed.collectives, decided.collectives - 0.5 * decided.forwards)
      << "collective operations per step";
  if (np >= 4) {
    EXPECT_GT(one.round_fails, 0.0) << "passes gathered again per step, one round";
  }
  EXPECT_EQ(decided.round_fails, 0.0);
  if (me == 0)
    std::printf("[ MPI      ] %d ranks, fluid, 100 steps: %.4g collective operations per step "
                "with two fixed rounds, %.4g with rounds decided by a reduction (%.3g rounds "
                "per step); with one round %.3g passes per step gathered again; the same %.0f "
                "collisions\n",
                np, fixed.collectives, decided.collectives, decided.forwards, one.round_fails,
                fixed.collisions);
  MPI_Barrier(MPI_COMM_WORLD);
}

// With the halved bounds at the ranks' edges most windows take a second pass of the check for
// missed pairs anyway: every window makes two (WindowSettings::two_passes), and only the
// second one's check is a reduction.  Against a reduction after every pass
// (HSGPU_TWO_PASSES=0): the same bits, the same repairs, fewer collective operations.
TEST(FixHardSphereMPI, TwoPassesNeedOneReductionAndKeepTheBits)
{
  int me = 0, np = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &me);
  MPI_Comm_size(MPI_COMM_WORLD, &np);
  if (np < 3) GTEST_SKIP() << "the halved bounds at the ranks' edges are for three ranks or more";
  // (A reduction per window in both, as without planned windows.)
  const Spanning each = fluid_with({{"HSGPU_TWO_PASSES", "0"}, {"HSGPU_STEP_CHECKS", "0"}});
  const Spanning two = fluid_with({{"HSGPU_TWO_PASSES", nullptr}, {"HSGPU_STEP_CHECKS", "0"}});
  expect_same_bits(two, each);
  EXPECT_GE(two.gathers, each.gathers) << "passes per step (each gathers the spanning groups)";
  EXPECT_LT(two.collectives, each.collectives - 0.2) << "collective operations per step";
  if (me == 0)
    std::printf("[ MPI      ] %d ranks, fluid, 100 steps: %.4g collective operations per step "
                "with two passes per window, %.4g with a reduction after each (%.3g and %.3g "
                "gathers per step); the same %.0f collisions\n",
                np, two.collectives, each.collectives, two.gathers, each.gathers,
                two.collisions);
  MPI_Barrier(MPI_COMM_WORLD);
}

// Planned windows (WindowSettings::step_checks): a step's windows take no reduction, their
// lengths planned from the previous steps, their checks on each rank until the step's one
// reduction after them.  Against a reduction per window length tried and per window's check
// (HSGPU_STEP_CHECKS=0): the same bits with more than one collective operation fewer per window
// of the latter.
// Starting the gathers from one round passing entries on, some groups do not come whole on four
// ranks or more: those steps are done again with a reduction per window (f_ID[34]), and the
// bits stay the same.
TEST(FixHardSphereMPI, PlannedWindowsNeedNoReductionAndKeepTheBits)
{
  int me = 0, np = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &me);
  MPI_Comm_size(MPI_COMM_WORLD, &np);
  if (np < 3) GTEST_SKIP() << "planned windows are for three ranks or more";
  const Spanning each = fluid_with({{"HSGPU_STEP_CHECKS", "0"}, {"HSGPU_FIXED_ROUNDS", nullptr}});
  const Spanning planned =
      fluid_with({{"HSGPU_STEP_CHECKS", nullptr}, {"HSGPU_FIXED_ROUNDS", nullptr}});
  const Spanning again = fluid_with({{"HSGPU_STEP_CHECKS", nullptr}, {"HSGPU_FIXED_ROUNDS", "1"}});
  expect_same_bits(planned, each);
  expect_same_bits(again, each);
  EXPECT_GT(planned.neighbour, 0.5) << "gathers per step with the neighbouring ranks";
  EXPECT_LT(planned.collectives, each.collectives - each.windows)
      << "collective operations per step";
  EXPECT_LT(planned.step_redos, 0.05) << "steps done again, per step";
  EXPECT_EQ(each.step_redos, 0.0);
  if (np >= 4) {
    EXPECT_GT(again.step_redos, 0.0) << "steps done again per step, one round";
  }
  if (me == 0)
    std::printf("[ MPI      ] %d ranks, fluid, 100 steps: %.4g collective operations per step "
                "with planned windows (%.3g per step), %.4g with a reduction per window (%.3g); "
                "%.3g steps per step done again from one round passing entries on; the same %.0f "
                "collisions\n",
                np, planned.collectives, planned.windows, each.collectives, each.windows,
                again.step_redos, planned.collisions);
  MPI_Barrier(MPI_COMM_WORLD);
}

// Planned windows over a settling pile, whose touching spheres stay one group however short the
// window (where halving the windows does not shrink that group, planning stops and the chooser's
// own tries take over: test_window_chooser): the same bits as with a reduction per window, and
// about as many windows per step.
TEST(FixHardSphereMPI, PlannedWindowsGiveWayInAPile)
{
  int me = 0, np = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &me);
  MPI_Comm_size(MPI_COMM_WORLD, &np);
  if (np < 3) GTEST_SKIP() << "planned windows are for three ranks or more";
  // (A target of 32 atoms, which the pile's group exceeds in any window.)
  ScopedEnv target("HSGPU_TARGET_GROUP", "32"), span("HSGPU_SPAN_TARGET", "32");
  Spanning each, planned;
  {
    ScopedEnv off("HSGPU_STEP_CHECKS", "0");
    each = run_dense(MPI_COMM_WORLD, "pile", "parallel", 300, "2.5", "gather");
  }
  {
    ScopedEnv on("HSGPU_STEP_CHECKS", nullptr);
    planned = run_dense(MPI_COMM_WORLD, "pile", "parallel", 300, "2.5", "gather");
  }
  expect_same_bits(planned, each);
  EXPECT_LT(planned.windows, 2.0 * each.windows + 0.5) << "windows per step";
  if (me == 0)
    std::printf("[ MPI      ] %d ranks, pile, 300 steps: %.3g windows per step with planned "
                "windows (%.4g collective operations), %.3g with a reduction per window (%.4g); "
                "the same %.0f collisions\n",
                np, planned.windows, planned.collectives, each.windows, each.collectives,
                planned.collisions);
  MPI_Barrier(MPI_COMM_WORLD);
}

// Whether the log file holds `text`.
bool log_has(const std::string &file, const std::string &text)
{
  std::FILE *f = std::fopen(file.c_str(), "r");
  if (!f) return false;
  std::string all;
  char buf[4096];
  for (size_t got; (got = std::fread(buf, 1, sizeof(buf), f)) > 0;) all.append(buf, got);
  std::fclose(f);
  return all.find(text) != std::string::npos;
}

// The stack: 10 x 10 x 5 spheres of diameter 1 on a floor, each touching its neighbours, under
// gravity (every step's kick sends a chain of collisions up from the floor through every
// column), `steps` steps (with the log in `logfile` where given).  Gathered: x, v, collisions,
// and per step averaged over the run f_hs[7] (largest group), f_hs[9] (windows), f_hs[16]
// (gathers: passes over the groups that span ranks) and f_hs[24] (collectives).
Spanning stack_pile(int steps, const std::string &logfile = "")
{
  Lammps lmp(MPI_COMM_WORLD);
  const std::string ns = std::to_string(steps);
  lmp.commands({"units lj", "atom_style sphere", "atom_modify map array", "boundary p p f",
                "processors * * 1", "region box block 0 10 0 10 0 12 units box",
                "create_box 1 box", "lattice sc 1.0 origin 0.5 0.5 0.5",
                "region stack block 0 10 0 10 0 5 units box", "create_atoms 1 region stack",
                "set type 1 diameter 1.0", "set type 1 mass 1.0", "comm_modify vel yes",
                "neigh_modify every 1 delay 0 check yes", "fix 1 all nve/sphere",
                "fix g all gravity 1.0 vector 0 0 -1",
                "fix hs all hardsphere restitution 0.5 wall zlo 0.5", "timestep 0.01",
                "thermo 0"});
  if (!logfile.empty()) lmp.commands({"log " + logfile});
  lmp.commands({"fix avg all ave/time 1 " + ns + " " + ns + " f_hs[7] f_hs[9] f_hs[16] f_hs[24]",
                "run " + ns});
  EXPECT_EQ(lmp.natoms(), 500);
  Spanning s;
  s.x = lmp.gather("x", 3);
  s.v = lmp.gather("v", 3);
  s.collisions = lmp.fix_vector("hs", 1);
  s.largest = lmp.fix_vector("avg", 0);
  s.windows = lmp.fix_vector("avg", 1);
  s.gathers = lmp.fix_vector("avg", 2);
  s.collectives = lmp.fix_vector("avg", 3);
  return s;
}

// A settled pile is one group of touching spheres over the ranks: its collisions are resolved
// one after another, however many ranks there are.  A run says so in a warning at its end, with
// the numbers that tell why (the stack); a fluid of 20^3 spheres, whose groups are small, does
// not.
TEST(FixHardSphereMPI, APileOverTheRanksIsNamedInAWarning)
{
  int me = 0, np = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &me);
  MPI_Comm_size(MPI_COMM_WORLD, &np);
  if (np < 2) GTEST_SKIP() << "the warning is for several ranks";
  const std::string warning = "WARNING: Fix hardsphere: its largest group of atoms resolved";
  const std::string pile_log = "hs_pile_warning_" + std::to_string(np) + ".log";
  const std::string fluid_log = "hs_fluid_warning_" + std::to_string(np) + ".log";
  const Spanning pile = stack_pile(50, pile_log);
  const Spanning fluid =
      run_dense(MPI_COMM_WORLD, "fluid", "parallel", 20, "2.5", "gather", fluid_log, 20);
  if (me == 0) {
    // (f_hs[7] averaged over the run: the figure the warning weighs against the atoms.)
    EXPECT_GE(pile.largest, 250.0) << "the pile's largest group, atoms per step of 500";
    EXPECT_TRUE(log_has(pile_log, warning)) << pile_log;
    EXPECT_TRUE(log_has(fluid_log, "Fix hardsphere (parallel order")) << fluid_log;
    EXPECT_LT(fluid.largest, 0.25 * 8000.0) << "the fluid's largest group, atoms per step";
    EXPECT_FALSE(log_has(fluid_log, warning)) << fluid_log;
    std::remove(pile_log.c_str());
    std::remove(fluid_log.c_str());
    std::printf("[ MPI      ] %d ranks: the pile's largest group %.4g of 500 atoms per step "
                "(warned), the fluid's %.4g of 8000 (not)\n",
                np, pile.largest, fluid.largest);
  }
  MPI_Barrier(MPI_COMM_WORLD);
}

// HSGPU_RANK_PARTS=1: a line per rank in the run's log, from rank 0, with that rank's step,
// communication and own work and the parts of the step, the parts within the step and the own
// work what is left of the step after the communication.
TEST(FixHardSphereMPI, EachRanksPartsOnALineOfItsOwn)
{
  int me = 0, np = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &me);
  MPI_Comm_size(MPI_COMM_WORLD, &np);
  if (np < 2) GTEST_SKIP() << "a line per rank is for several ranks";
  const std::string log = "hs_rank_parts_" + std::to_string(np) + ".log";
  {
    ScopedEnv parts("HSGPU_RANK_PARTS", "1");
    run_dense(MPI_COMM_WORLD, "fluid", "parallel", 10, "2.5", "gather", log, 12);
  }
  if (me == 0) {
    const std::string text = hsgpu_test::file_text(log);
    std::vector<int> seen(np, 0), seen_check(np, 0);
    std::vector<double> check_of(np, -1.0), step_of(np, -1.0);
    const std::string head = "Fix hardsphere: rank ";
    for (size_t at = text.find(head); at != std::string::npos; at = text.find(head, at + 1)) {
      const std::string line = text.substr(at, text.find('\n', at) - at);
      int q = -1;
      if (line.find(", ms per step:") != std::string::npos) {
        double step = -1, comm = -1, own = -1, search = -1, window = -1, groups = -1,
               local = -1, span = -1, spanown = -1, other = -1, prep = -1, check = -1,
               rest = -1, atoms = -1, ghosts = -1;
        const int got = std::sscanf(
            line.c_str(),
            "Fix hardsphere: rank %d, ms per step: step %lf, communication %lf, own work %lf; "
            "search %lf, window lengths %lf, groups %lf, local %lf, spanning %lf (packing, "
            "unpacking and resolving %lf), other %lf (the ghost update and overlap check %lf, "
            "the step check and the windows' reductions %lf, the rest %lf); %lf atoms, %lf "
            "ghosts",
            &q, &step, &comm, &own, &search, &window, &groups, &local, &span, &spanown, &other,
            &prep, &check, &rest, &atoms, &ghosts);
        ASSERT_EQ(got, 16) << line;
        ASSERT_GE(q, 0) << line;
        ASSERT_LT(q, np) << line;
        ++seen[q];
        check_of[q] = check;
        step_of[q] = step;
        EXPECT_GT(step, 0.0) << line;
        EXPECT_GT(comm, 0.0) << line;    // every rank takes part in the step's reductions
        EXPECT_NEAR(own, step - comm, 1e-3 * step + 1e-3) << line;
        for (double part : {search, window, groups, local, span, spanown})
          EXPECT_GE(part, 0.0) << line;
        EXPECT_GT(search, 0.0) << line;
        EXPECT_LE(spanown, span + 1e-3) << line;
        // The parts lie within the step, and "other" is the sum of its three.
        for (double part : {other, prep, check, rest}) EXPECT_GE(part, -1e-3 * step) << line;
        EXPECT_NEAR(prep + check + rest, other, 1e-3 * step + 1e-3) << line;
        EXPECT_GT(atoms, 0.0) << line;
        EXPECT_GT(ghosts, 0.0) << line;
      } else {
        double before = -1, after = -1, ends = -1, tallies = -1, cghost = -1, csearch = -1,
               creduce = -1;
        const int got = std::sscanf(
            line.c_str(),
            "Fix hardsphere: rank %d, the step check and the windows' reductions: before the "
            "windows %lf, after them %lf, the atoms' step ends %lf, the tallies' reduction %lf, "
            "the check's ghost update %lf, search %lf, reduction %lf",
            &q, &before, &after, &ends, &tallies, &cghost, &csearch, &creduce);
        ASSERT_EQ(got, 8) << line;
        ASSERT_GE(q, 0) << line;
        ASSERT_LT(q, np) << line;
        ASSERT_EQ(seen[q], 1) << "the rank's first line comes first: " << line;
        ++seen_check[q];
        for (double part : {before, after, ends, tallies, cghost, csearch, creduce})
          EXPECT_GE(part, 0.0) << line;
        EXPECT_GT(before, 0.0) << line;
        EXPECT_GT(ends, 0.0) << line;
        EXPECT_LE(before + after + ends + tallies + cghost + csearch + creduce,
                  check_of[q] + 1e-3 * step_of[q] + 1e-3)
            << "within the first line's step check and reductions: " << line;
      }
    }
    for (int q = 0; q < np; ++q) {
      EXPECT_EQ(seen[q], 1) << "rank " << q << "'s line in " << log;
      EXPECT_EQ(seen_check[q], 1) << "rank " << q << "'s second line in " << log;
    }
    std::remove(log.c_str());
  }
  MPI_Barrier(MPI_COMM_WORLD);
}

// Where planned windows give way (halving them does not shrink the largest group, weighed whole
// where it spans ranks: the stack's touching spheres are one group however short the window),
// the bounds at the ranks' edges are not halved either until planning is tried again, and with
// them each window's second pass over the groups that span ranks goes: the pile is resolved
// once per window, not twice (on 4 and 8 ranks with the default targets, before the whole
// group was weighed: two windows per step of two passes each).  The same bits as the
// reductions per window (HSGPU_STEP_CHECKS=0, where planning never starts and the bounds stay
// halved: two passes per window).
TEST(FixHardSphereMPI, APileWherePlanningGaveWayIsResolvedOncePerWindow)
{
  int me = 0, np = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &me);
  MPI_Comm_size(MPI_COMM_WORLD, &np);
  if (np < 3) GTEST_SKIP() << "planned windows and halved bounds are for three ranks or more";
  // With the default targets: each rank's part of the pile is below the spanning groups'
  // target (256 atoms), but the whole group its resolver sees is not, and the plan weighs that.
  const Spanning plain = stack_pile(100);
  // (Targets of 32 atoms, which the pile's group and each rank's part of it exceed in any
  // window, as in a pile of many atoms per rank.)
  ScopedEnv target("HSGPU_TARGET_GROUP", "32"), span("HSGPU_SPAN_TARGET", "32");
  Spanning halved, whole;
  {
    ScopedEnv off("HSGPU_STEP_CHECKS", "0");
    halved = stack_pile(100);
  }
  {
    ScopedEnv on("HSGPU_STEP_CHECKS", nullptr);
    whole = stack_pile(100);
  }
  expect_same_bits(whole, halved);
  expect_same_bits(plain, halved);
  if (me == 0) {
    EXPECT_LT(plain.windows, 1.3) << "windows per step, default targets";
    EXPECT_LT(plain.gathers, 1.3 * plain.windows) << "passes per window, default targets";
    EXPECT_GT(halved.collisions, 0.0);
    EXPECT_GE(halved.gathers, 1.9 * halved.windows) << "two passes per window, halved bounds";
    EXPECT_LT(whole.gathers, 1.3 * whole.windows) << "passes per window where planning gave way";
    std::printf("[ MPI      ] %d ranks, a stack of 500 touching spheres, 100 steps: %.3g passes "
                "over the spanning groups in %.3g windows per step (%.3g collectives) where "
                "planning gave way, %.3g in %.3g (%.3g) with the bounds halved; the same %.0f "
                "collisions\n",
                np, whole.gathers, whole.windows, whole.collectives, halved.gathers,
                halved.windows, halved.collectives, whole.collisions);
  }
  MPI_Barrier(MPI_COMM_WORLD);
}

// A window's length is chosen so that its largest group stays near a target; a group that
// spans ranks is weighed by the part of it one rank sees, against a target of its own (256),
// not the whole step's: with the step's target (here 8000 for a fluid of 13824 atoms) the parts
// stayed below it while one group threaded through the ranks' boundaries and joined most atoms.
TEST(FixHardSphereMPI, GroupsSpanningRanksHaveATargetOfTheirOwn)
{
  int me = 0, np = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &me);
  MPI_Comm_size(MPI_COMM_WORLD, &np);
  if (np < 2) GTEST_SKIP() << "groups span ranks on two ranks or more";
  const Spanning blind =
      fluid_with({{"HSGPU_TARGET_GROUP", "8000"}, {"HSGPU_SPAN_TARGET", "0"}}, 40, 24);
  const Spanning own =
      fluid_with({{"HSGPU_TARGET_GROUP", "8000"}, {"HSGPU_SPAN_TARGET", nullptr}}, 40, 24);
  expect_same_bits(own, blind);
  EXPECT_GT(blind.largest, 2000.0) << "most atoms per step in one group, the step's target";
  EXPECT_LT(own.largest, 0.25 * blind.largest) << "most atoms per step in one group";
  // (On more than 8 ranks, 864 atoms per rank on 16, nearly every atom is next to another
  // rank's, and the shortest window, dt / 16, leaves groups of about 1500 atoms.)
  if (np <= 8) {
    EXPECT_LT(own.largest, 1000.0) << "most atoms per step in one group, a target of their own";
  }
  if (me == 0)
    std::printf("[ MPI      ] %d ranks, fluid of 13824 atoms, target 8000, 40 steps: largest "
                "group %.4g atoms per step (%.4g weighed against the step's target), %.3g "
                "windows per step (%.3g); the same %.0f collisions\n",
                np, own.largest, blind.largest, own.windows, blind.windows, own.collisions);
  MPI_Barrier(MPI_COMM_WORLD);
}

// With the ghost cutoff the fluid benchmark uses (2.5), a third or more of the spanning groups'
// atoms are in groups that no rank holding an atom of them sees whole (a 12^3 box is narrow);
// two diameters deeper, a few percent on 2 and 4 ranks and about a tenth on 3 (whose slabs,
// 4.2 diameters thick, are thinner than the ghost cutoff: 161 of 1536 atoms per step gathered).
TEST(FixHardSphereMPI, SpanningGroupsOfADenseFluidResolvedWhereTheyLie)
{
  compare_spanning("fluid", 100, "2.5", 0.6);
  compare_spanning("fluid", 100, "4.5", 0.15);
}

// A settling pile: its touching spheres stay joined however short the window, and the groups
// are long; still most are resolved where they lie.
TEST(FixHardSphereMPI, SpanningGroupsOfAPileResolvedWhereTheyLie)
{
  compare_spanning("pile", 300, "4.5", 0.4);
}

// The same with rough spheres: the view's exchanges (foreign states, results to the owners,
// the gather) carry the spins.
TEST(FixHardSphereMPI, SpanningGroupsOfARoughPileResolvedWhereTheyLie)
{
  compare_spanning("rough", 300, "4.5", 0.4);
}

TEST(FixHardSphereMPI, OverlapPushRelaxesRandomPlacementAcrossRanks)
{
  int me = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &me);
  Lammps lmp;
  const double L = std::cbrt(800 * 0.5235987755982988 / 0.3);
  lmp.commands(
      {"units lj", "atom_style sphere", "atom_modify map array", "boundary p p p",
       "region box block 0 " + std::to_string(L) + " 0 " + std::to_string(L) + " 0 " +
           std::to_string(L) + " units box",
       "create_box 1 box", "create_atoms 1 random 800 20261124 NULL", "set type 1 diameter 1.0",
       "set type 1 mass 1.0", "velocity all create 1.0 4928459 loop geom", "comm_modify vel yes",
       "neigh_modify every 1 delay 0 check yes", "fix 1 all nve/sphere",
       "fix hs all hardsphere overlap push", "thermo_modify norm no", "timestep 0.002", "run 50"});
  EXPECT_EQ(lmp.natoms(), 800);
  const double pushed = lmp.fix_vector("hs", 13);    // f_hs[14]
  const auto x = lmp.gather("x", 3);
  if (me == 0) {
    const double period[3] = {L, L, L};
    const double worst = hsgpu_test::closest_pair_gap(x, 1.0, period);
    EXPECT_GT(pushed, 800.0);
    EXPECT_GT(worst, -1e-9);
    std::printf("[ MPI      ] random placement at packing fraction 0.3: %.0f overlaps pushed, "
                "closest pair %.3g from contact after 50 steps\n",
                pushed, worst);
  }
  MPI_Barrier(MPI_COMM_WORLD);
}

// The collision virial of the last step is kept across runs and in the restart file (summed
// over the ranks that wrote it): the first pressure of a run continued on all ranks, or on rank
// 0 alone, is the last one written.
TEST(FixHardSphereMPI, RestartKeepsThePressureAcrossRanks)
{
  int me = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &me);
  const std::string file = "fix_hardsphere_mpi_press.restart";
  const std::vector<std::string> fixes = {"comm_modify vel yes",
                                          "neigh_modify every 1 delay 0 check yes",
                                          "fix 1 all nve/sphere",
                                          "fix hs all hardsphere",
                                          "compute pk all pressure thermo_temp ke",
                                          "thermo_style custom step press c_pk",
                                          "thermo_modify norm no",
                                          "timestep 0.005"};
  double press = 0.0, kinetic = 0.0;
  {
    Lammps lmp;
    lmp.commands({"units lj", "atom_style sphere", "atom_modify map array", "boundary p p p",
                  "lattice fcc 0.76", "region box block 0 5 0 5 0 5", "create_box 1 box",
                  "create_atoms 1 box", "set type 1 diameter 1.0", "set type 1 mass 1.0",
                  "velocity all create 1.0 4928459 loop geom"});
    lmp.commands(fixes);
    lmp.commands({"run 100"});
    press = lmp.thermo("press");
    kinetic = lmp.compute_scalar("pk");
    EXPECT_GT(press, 3.0 * kinetic);
    lmp.commands({"write_restart " + file, "run 0"});
    EXPECT_NEAR(lmp.thermo("press"), press, 1e-13 * press);
  }
  MPI_Barrier(MPI_COMM_WORLD);
  {
    Lammps lmp;
    lmp.commands({"read_restart " + file});
    lmp.commands(fixes);
    lmp.commands({"run 0"});
    EXPECT_NEAR(lmp.thermo("press"), press, 1e-13 * press) << "continued on all ranks";
  }
  if (me == 0) {
    Lammps lmp(MPI_COMM_SELF);
    lmp.commands({"read_restart " + file});
    lmp.commands(fixes);
    lmp.commands({"run 0"});
    EXPECT_NEAR(lmp.thermo("press"), press, 1e-13 * press) << "continued on rank 0 alone";
    std::remove(file.c_str());
  }
  MPI_Barrier(MPI_COMM_WORLD);
}

// The foreign atoms' start points and bound rates of each step's first window are formed by
// the rank from the step's own ghost update (WindowSettings::start_from_step), without a ghost
// update of their own: one fewer per step than with HSGPU_START_FROM_STEP=0, the same bits;
// with HSGPU_START_CHECK=1 both are made and every value formed equals its owner's, bit for
// bit (on two ranks with the same bounds everywhere, on more with the smaller bounds at the
// ranks' edges; the fluid, and the pile with its floor, gravity and restitution).
TEST(FixHardSphereMPI, FirstWindowStartPointsComeFromTheStepsGhostUpdate)
{
  int me = 0, np = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &me);
  MPI_Comm_size(MPI_COMM_WORLD, &np);
  if (np < 2) GTEST_SKIP() << "foreign atoms on two ranks or more";
  const Spanning exchanged = fluid_with({{"HSGPU_START_FROM_STEP", "0"}});
  const Spanning formed = fluid_with({{"HSGPU_START_FROM_STEP", nullptr}});
  expect_same_bits(formed, exchanged);
  EXPECT_GE(exchanged.ghost_updates - formed.ghost_updates, 1.0 - 1e-9)
      << "ghost updates per step: " << exchanged.ghost_updates << " -> " << formed.ghost_updates;
  const std::string tag = "_np" + std::to_string(np) + ".log";
  Spanning fluid, pile;
  {
    ScopedEnv check("HSGPU_START_CHECK", "1");
    fluid = run_dense(MPI_COMM_WORLD, "fluid", "parallel", 100, "2.5", "gather",
                      "hs_start_fluid" + tag);
    pile = run_dense(MPI_COMM_WORLD, "pile", "parallel", 200, "2.5", "gather",
                     "hs_start_pile" + tag);
  }
  expect_same_bits(fluid, formed);
  if (me == 0) {
    auto checked = [](const std::string &log, double &pairs, double &differ) {
      const std::string text = hsgpu_test::file_text(log);
      std::smatch m;
      if (!std::regex_search(text, m,
                             std::regex("first windows checked: ([0-9]+) candidate pairs with a "
                                        "foreign atom, ([0-9]+) of them")))
        return false;
      pairs = std::stod(m[1].str());
      differ = std::stod(m[2].str());
      return true;
    };
    double fp = 0.0, fd = -1.0, pp = 0.0, pd = -1.0;
    ASSERT_TRUE(checked("hs_start_fluid" + tag, fp, fd)) << "the check's line in the log";
    ASSERT_TRUE(checked("hs_start_pile" + tag, pp, pd)) << "the check's line in the log";
    EXPECT_GT(fp, 1000.0) << "pairs with a foreign atom checked, the fluid";
    EXPECT_GT(pp, 1000.0) << "pairs with a foreign atom checked, the pile";
    EXPECT_EQ(fd, 0.0) << "start points or rates formed unlike the owners', the fluid";
    EXPECT_EQ(pd, 0.0) << "start points or rates formed unlike the owners', the pile";
    std::printf("[ MPI      ] %d ranks, fluid, 100 steps: %.4g ghost updates per step (%.4g with "
                "a ghost update for the first window's start points); checked against the "
                "owners': %.0f pairs with a foreign atom in the fluid, %.0f in the pile, %.0f "
                "and %.0f unlike\n",
                np, formed.ghost_updates, exchanged.ghost_updates, fp, pp, fd, pd);
  }
  MPI_Barrier(MPI_COMM_WORLD);
}

// With planned windows (three ranks or more), the foreign atoms' start points at the later
// windows of a step and their excursions after each pass go by one message to each
// neighbouring rank, holding only the atoms in a candidate pair with an atom that rank owns
// (WindowSettings::sparse_foreign), instead of a ghost update each: the same bits, at least one
// ghost update per step fewer for each window (more where a window's start needs them too),
// no step done again for it.  Where a message does not bring what a rank expects (rank 0
// leaving an atom out of its first message of each step, HSGPU_SPARSE_DROP=1), the step is
// done again with the ghost updates: the same bits.
TEST(FixHardSphereMPI, SparseForeignUpdatesKeepTheBitsWithFewerGhostUpdates)
{
  int me = 0, np = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &me);
  MPI_Comm_size(MPI_COMM_WORLD, &np);
  if (np < 3) GTEST_SKIP() << "planned windows are for three ranks or more";
  const Spanning ghosts = fluid_with({{"HSGPU_SPARSE_FOREIGN", "0"}});
  const Spanning sparse = fluid_with({{"HSGPU_SPARSE_FOREIGN", nullptr}});
  expect_same_bits(sparse, ghosts);
  EXPECT_GT(sparse.windows, 1.0) << "windows per step";
  // Each window's passes (two) and each later window's start: a ghost update each fewer
  // (on the steps of planned windows; the steps after one done again have none).
  EXPECT_GE(ghosts.ghost_updates - sparse.ghost_updates, sparse.windows)
      << "ghost updates per step: " << ghosts.ghost_updates << " -> " << sparse.ghost_updates;
  EXPECT_LE(sparse.step_redos, ghosts.step_redos) << "steps done again";
  EXPECT_EQ(sparse.round_fails, ghosts.round_fails) << "passes gathered again";
  const Spanning dropped = fluid_with({{"HSGPU_SPARSE_DROP", "1"}});
  expect_same_bits(dropped, ghosts);
  // Every step of planned windows is done again then; after each, 8, 16, 32 and 64 steps
  // with a reduction per window: 4 of 100 steps.
  EXPECT_GE(dropped.step_redos, 0.03) << "steps done again per step, an atom left out";
  EXPECT_GE(dropped.step_redos, sparse.step_redos) << "steps done again, an atom left out";
  if (me == 0)
    std::printf("[ MPI      ] %d ranks, fluid, 100 steps: %.4g ghost updates per step (%.4g "
                "without the messages to the neighbouring ranks), %.3g windows per step, %.3g "
                "steps done again per step (%.3g with an atom left out); the same %.0f "
                "collisions\n",
                np, sparse.ghost_updates, ghosts.ghost_updates, sparse.windows, sparse.step_redos,
                dropped.step_redos, sparse.collisions);
  MPI_Barrier(MPI_COMM_WORLD);
}
