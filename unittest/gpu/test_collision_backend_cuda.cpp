// The CUDA collision backend against the CPU backend on dense random systems (2000 spheres of
// two types at packing fraction 0.35, random velocities, uniform gravity, periodic or with a
// floor and a roof): the same step resolved in one window and in three gives the same bodies,
// tallies and per-window returns bit for bit, with and without the maxevents cap.
// CudaBackend.SmallSystems does the same on 300 bodies, for compute-sanitizer (the 2000-body
// cases take minutes under memcheck):
//   compute-sanitizer --tool memcheck test_collision_backend_cuda
//       --gtest_filter=CudaBackend.SmallSystems:CudaBackend.EmptyWindows
// Label gpu: skipped where no CUDA device is usable.
#include "engine/collision_backend.h"
#include "gpu/collision_backend_cuda.h"
#include "gpu/device_info.cuh"
#include "gpu/gpu_error.h"

#include "collide_system.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

using namespace HSGPU::Collide;
using namespace hsgpu_test;

namespace {

#define HSGPU_SKIP_WITHOUT_DEVICE()                                                        \
  do {                                                                                     \
    if (HSGPU::GPU::device_count() == 0)                                                   \
      GTEST_SKIP() << "no usable CUDA device (or built without CUDA): the CUDA collision " \
                      "backend is not tested here";                                        \
  } while (0)

struct Variant {
  const char *name;
  CollideSpec spec;
};

// Many small groups (short steps: many threads at once) and one group of all bodies with
// over a thousand events (long steps: long sequences in one thread).
std::vector<Variant> variants()
{
  std::vector<Variant> v;
  CollideSpec s;    // n = 2000, phi = 0.35
  s.seed = 21;
  s.g = 5.0;
  s.tc = 1e-3;
  s.dt = 0.005;
  v.push_back({"periodic_gravity", s});    // ~850 groups, ~70 events
  s.dt = 0.1;
  v.push_back({"periodic_gravity_long_step", s});    // one group, ~1500 events
  s.floor = true;
  s.g = 20.0;
  s.tc = 0.02;
  s.vmin = 0.05;
  s.dt = 0.01;
  v.push_back({"floor_gravity", s});    // ~400 groups, ~160 events, ~25 on walls
  s.dt = 0.1;
  v.push_back({"floor_gravity_long_step", s});    // one group, ~1400 events, ~110 on walls
  return v;
}

TEST(CudaBackend, MatchesCpuBackendBitwise)
{
  HSGPU_SKIP_WITHOUT_DEVICE();
  auto cpu = make_cpu_backend();
  auto gpu = make_cuda_backend(0);
  EXPECT_EQ(gpu->name(), "cuda");
  for (const Variant &v : variants()) {
    const CollideSystem sys = make_collide_system(v.spec);
    for (int nwin : {1, 3}) {
      const std::string what = std::string(v.name) + ", " + std::to_string(nwin) + " window(s)";
      const StepOutcome a = run_windows(sys, sys.p, nwin, through(*cpu));
      const StepOutcome b = run_windows(sys, sys.p, nwin, through(*gpu));
      std::printf("[ info     ] %s: %d groups, largest %d bodies, %zu edges; %ld events "
                  "(%ld pair, %ld wall, %ld rest)\n",
                  what.c_str(), (int) sys.gstart.size() - 1, sys.largest_group, sys.edges.size(),
                  a.tally.events, a.tally.pair, a.tally.wall, a.tally.rest);
      EXPECT_GT(a.tally.pair, 50) << what << ": too few collisions to test anything";
      if (v.spec.floor) {
        EXPECT_GT(a.tally.wall, 0) << what;
      }
      EXPECT_EQ(a.tally.capped, 0) << what;
      expect_same_bits(a, b, what.c_str());
    }
  }
}

TEST(CudaBackend, CapMatchesCpuBackendBitwise)
{
  HSGPU_SKIP_WITHOUT_DEVICE();
  auto cpu = make_cpu_backend();
  auto gpu = make_cuda_backend(0);
  const Variant v = variants()[3];
  const CollideSystem sys = make_collide_system(v.spec);
  const long total = run_windows(sys, sys.p, 1, through(*cpu)).tally.events;
  ASSERT_GT(total, 10);
  for (long cap : {0L, 1L, total / 3, total / 2, total - 1, total}) {
    Params p = sys.p;
    p.maxevents = cap;
    for (int nwin : {1, 3}) {
      const std::string what =
          "maxevents " + std::to_string(cap) + ", " + std::to_string(nwin) + " window(s)";
      const StepOutcome a = run_windows(sys, p, nwin, through(*cpu));
      const StepOutcome b = run_windows(sys, p, nwin, through(*gpu));
      EXPECT_EQ(a.tally.capped, cap < total ? 1 : 0) << what;
      expect_same_bits(a, b, what.c_str());
    }
  }
}

// Nothing to do: no groups, or groups whose bodies have no event.
TEST(CudaBackend, EmptyWindows)
{
  HSGPU_SKIP_WITHOUT_DEVICE();
  auto gpu = make_cuda_backend(0);
  CollideSpec s;
  s.n = 50;
  s.phi = 0.01;
  s.vscale = 0.0;    // at rest, far apart: no events
  const CollideSystem sys = make_collide_system(s);
  const StepOutcome b = run_windows(sys, sys.p, 2, through(*gpu));
  EXPECT_EQ(b.tally.events, 0);
  for (size_t k = 0; k < sys.bodies.size(); ++k)
    EXPECT_EQ(0, std::memcmp(sys.bodies[k].x, b.bodies[k].x, sizeof(sys.bodies[k].x)));
  Tally t;
  std::vector<Body> bodies = sys.bodies;
  const WindowWork none{bodies.data(),     (int) bodies.size(), nullptr, 0,
                        sys.gstart.data(), sys.gmembers.data(), 0,       sys.p.dt};
  EXPECT_EQ(gpu->resolve(none, sys.p, t), 0);
  EXPECT_EQ(t.events, 0);
}

// Every kind of case on 300 bodies: quick enough for compute-sanitizer.
TEST(CudaBackend, SmallSystems)
{
  HSGPU_SKIP_WITHOUT_DEVICE();
  auto cpu = make_cpu_backend();
  auto gpu = make_cuda_backend(0);
  for (Variant v : variants()) {
    v.spec.n = 300;
    const CollideSystem sys = make_collide_system(v.spec);
    const long total = run_windows(sys, sys.p, 1, through(*cpu)).tally.events;
    for (long cap : {sys.p.maxevents, total / 2}) {
      Params p = sys.p;
      p.maxevents = cap;
      for (int nwin : {1, 3}) {
        const std::string what = std::string(v.name) + ", 300 bodies, maxevents " +
                                 std::to_string(cap) + ", " + std::to_string(nwin) + " window(s)";
        expect_same_bits(run_windows(sys, p, nwin, through(*cpu)),
                         run_windows(sys, p, nwin, through(*gpu)), what.c_str());
      }
      expect_same_per_group(run_per_group(sys, p, 3, through(*cpu)),
                            run_per_group(sys, p, 3, through(*gpu)),
                            std::string(v.name) + ", 300 bodies, per group");
    }
  }
}

// A failed make_cuda_backend leaves nothing behind: the tests after this one would see a stale
// CUDA error in their launch checks otherwise (seen once: cudaErrorInvalidDevice).
TEST(CudaBackend, BadDeviceThrows)
{
  HSGPU_SKIP_WITHOUT_DEVICE();
  EXPECT_TRUE(cuda_backend_available());
  EXPECT_THROW(make_cuda_backend(HSGPU::GPU::device_count()), HSGPU::GPU::Error);
  auto gpu = make_cuda_backend(0);
  CollideSpec s;
  s.n = 100;
  const CollideSystem sys = make_collide_system(s);
  EXPECT_NO_THROW(run_windows(sys, sys.p, 1, through(*gpu)));
}

// Per-group tallies (WindowWork::group_tally), with and without a cap, and with events
// counted before the window.
TEST(CudaBackend, PerGroupTalliesMatchCpuBackend)
{
  HSGPU_SKIP_WITHOUT_DEVICE();
  auto cpu = make_cpu_backend();
  auto gpu = make_cuda_backend(0);
  for (const Variant &v : variants()) {
    const CollideSystem sys = make_collide_system(v.spec);
    const long total = run_windows(sys, sys.p, 1, through(*cpu)).tally.events;
    for (long cap : {sys.p.maxevents, total / 2 + 5}) {
      Params p = sys.p;
      p.maxevents = cap;
      const std::string what = std::string(v.name) + ", maxevents " + std::to_string(cap);
      const PerGroupOutcome a = run_per_group(sys, p, 5, through(*cpu));
      const PerGroupOutcome b = run_per_group(sys, p, 5, through(*gpu));
      expect_same_per_group(a, b, what);
    }
  }
}

}    // namespace
