// Run under mpirun -np 1, 2, 4: the same system on all ranks of MPI_COMM_WORLD and on rank 0
// alone gives the same forces, energy and trajectory (the all-pairs sums run in atom-ID order,
// so only the cross-rank energy reduction may differ, by round-off).  The GPU path (where a
// device is present) on all ranks, with its sources in rank order, against the CPU path on
// rank 0 alone.
#include "harness.h"

#include "../common/systems.h"
#include "gpu/device_info.cuh"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <mpi.h>

using hsgpu_test::GravitySystem;
using hsgpu_test::file_text;
using hsgpu_test::Lammps;

namespace {

struct Snapshot {
  std::vector<double> x, v, f;
  double pe = 0, press = 0;
};

// logfile: where LAMMPS writes its log (none: no file).
Snapshot run_on(MPI_Comm comm, const GravitySystem &s, const std::string &logfile = "")
{
  Lammps lmp(comm);
  if (!logfile.empty()) lmp.commands({"log " + logfile});
  lmp.commands(hsgpu_test::gravity_system_lines(s));
  lmp.commands({"velocity all create 0.3 4928459 loop geom", "fix integrate all nve",
                "timestep 0.002", "thermo_style custom step pe press", "thermo_modify norm no",
                "run 40"});
  Snapshot out;
  out.x = lmp.gather("x", 3);
  out.v = lmp.gather("v", 3);
  out.f = lmp.gather("f", 3);
  out.pe = lmp.thermo("pe");
  out.press = lmp.thermo("press");
  return out;
}

double max_rel_diff(const std::vector<double> &a, const std::vector<double> &b)
{
  double scale = 0.0, worst = 0.0;
  for (size_t i = 0; i < a.size(); ++i) scale = std::max(scale, std::fabs(b[i]));
  for (size_t i = 0; i < a.size(); ++i) worst = std::max(worst, std::fabs(a[i] - b[i]));
  return scale > 0 ? worst / scale : worst;
}

// logfile: where the run on all ranks writes its LAMMPS log.
void compare_world_with_single_rank(const GravitySystem &s, const std::string &world_pair = "",
                                    double tol = 1e-12, const std::string &logfile = "")
{
  int me = 0, np = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &me);
  MPI_Comm_size(MPI_COMM_WORLD, &np);
  GravitySystem sw = s;
  if (!world_pair.empty()) sw.pair = world_pair;
  const Snapshot world = run_on(MPI_COMM_WORLD, sw, logfile);
  if (me == 0) {
    const Snapshot single = run_on(MPI_COMM_SELF, s);
    ASSERT_EQ(world.f.size(), single.f.size());
    const double dx = max_rel_diff(world.x, single.x), dv = max_rel_diff(world.v, single.v);
    const double df = max_rel_diff(world.f, single.f);
    EXPECT_LT(dx, 0.1 * tol);
    EXPECT_LT(dv, tol);
    EXPECT_LT(df, tol);
    EXPECT_NEAR(world.pe, single.pe, tol * std::fabs(single.pe));
    EXPECT_NEAR(world.press, single.press, 10 * tol * std::fabs(single.press));
    std::printf("[ MPI      ] %d ranks%s vs 1 after 40 steps: max rel diff x %.2g v %.2g f %.2g, "
                "pe %.17g vs %.17g\n",
                np, world_pair.empty() ? "" : " (GPU)", dx, dv, df, world.pe, single.pe);
  }
  MPI_Barrier(MPI_COMM_WORLD);
}

}    // namespace

TEST(PairGravityMPI, PeriodicSpheresAgreeWithSingleRank)
{
  GravitySystem s;
  s.n = 300;
  compare_world_with_single_rank(s);
}

TEST(PairGravityMPI, ClusteredOpenBoxAgreesWithSingleRank)
{
  GravitySystem s;
  s.n = 211;
  s.periodic = false;
  s.clustered = true;
  s.sphere = false;
  s.pair = "pair_style gravity 1.0 0.1";
  compare_world_with_single_rank(s);
}

// Atoms migrate between ranks during the 40 steps, so the rank-order source list is rebuilt
// (and masses travel again).  On one node each rank copies the others' positions and masses
// from their devices (CUDA IPC); again with HSGPU_GATHER_MPI=1, through the host's gather.
TEST(PairGravityMPI, GpuPathOnAllRanksAgreesWithCpuOnOne)
{
  int skip = HSGPU::GPU::device_count() == 0 ? 1 : 0, any = 0;
  MPI_Allreduce(&skip, &any, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  if (any) GTEST_SKIP() << "no CUDA device on some rank";
  GravitySystem s;
  s.n = 300;
  int me = 0, np = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &me);
  MPI_Comm_size(MPI_COMM_WORLD, &np);
  const std::string log = "pair_gravity_mpi_gpu.log";
  compare_world_with_single_rank(s, s.pair + " gpu yes precision double", 1e-10, log);
  // On one node (these tests' mpirun) the copies between devices ran, and nothing fell back.
  const std::string peers = file_text(log);
  {
    hsgpu_test::ScopedEnv through_mpi("HSGPU_GATHER_MPI", "1");
    compare_world_with_single_rank(s, s.pair + " gpu yes precision double", 1e-10, log);
  }
  if (me == 0 && np > 1) {
    EXPECT_NE(peers.find("copies the other ranks' positions from their devices"),
              std::string::npos);
    EXPECT_EQ(peers.find("cannot read the other ranks' positions"), std::string::npos);
    EXPECT_NE(file_text(log).find("gathered through MPI"), std::string::npos);
    std::remove(log.c_str());
  }
  MPI_Barrier(MPI_COMM_WORLD);
}

// Two atoms at one point without softening, owned by whichever rank: every rank stops with the
// same error naming them.
TEST(PairGravityMPI, CoincidentAtomsAreNamedOnEveryRank)
{
  GravitySystem s;
  s.pair = "pair_style gravity 1.0 0.0";
  auto lines = hsgpu_test::gravity_system_lines(s);
  lines.insert(lines.end(), {"create_atoms 1 single 3.25 4.5 5.75 units box",
                             "create_atoms 2 single 3.25 4.5 5.75 units box",
                             "set atom 201*202 mass 1.0", "fix integrate all nve"});
  Lammps lmp;
  lmp.commands(lines);
  EXPECT_THAT(lmp.command("run 0"),
              ::testing::HasSubstr("atoms 201 and 202 are at the same position (3.25, 4.5, 5.75) "
                                   "at step 0 with eps = 0"));
}
