// The CUDA backend's per-group loop (gpu/collision_group_loop.h) run on the host, the way the
// backend runs it on the device (every group at once from the window's start, each with what
// the cap leaves, then again up to the group where the CPU's cap stops), against the CPU
// backend: bodies, tallies and returns equal bit for bit, in one window and in three, with and
// without the maxevents cap.  Needs no device (label unit): the device's arithmetic is
// checked separately (test_core_device) and the whole backend on a device by
// test_collision_backend_cuda.
#include "gpu/collision_group_loop.h"

#include "collide_system.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

using namespace HSGPU::Collide;
using namespace hsgpu_test;

namespace {

// The resident step's warp loop with kept edge times (group_loop_warp.cuh's
// carry_out_cached()), its lanes one after the other: every edge's pair time found once at the
// start, after each event those of the two bodies' edges, and the best events of the bodies
// and their neighbours from the kept times (cached_best_event()).
long resolve_group_cached(const GroupGraph &g, const Params &p, std::vector<double> &et,
                          const int *members, int nmembers, double t_end, long budget,
                          Tally &tally)
{
  auto times_of = [&](int b) {
    for (int k = g.adj_start[b]; k < g.adj_start[b + 1]; ++k) {
      const Edge &e = g.edges[g.adj[k]];
      et[g.adj[k]] = pair_event_time(g.bodies[e.i], g.bodies[e.j], e, p.dt);
    }
  };
  auto bests_around = [&](int b) {
    g.best[b] = cached_best_event(g, p, et.data(), b);
    for (int k = g.adj_start[b]; k < g.adj_start[b + 1]; ++k) {
      const Edge &e = g.edges[g.adj[k]];
      const int o = e.i == b ? e.j : e.i;
      g.best[o] = cached_best_event(g, p, et.data(), o);
    }
  };
  for (int k = 0; k < nmembers; ++k) times_of(members[k]);
  for (int k = 0; k < nmembers; ++k)
    g.best[members[k]] = cached_best_event(g, p, et.data(), members[k]);
  return group_event_loop(g, members, nmembers, t_end, budget, tally, [&](const Event ev) {
    int i = ev.index, j = -1;
    if (ev.face >= 0) {
      process_wall(g.bodies[i], ev.face, ev.t, p, tally);
    } else {
      i = g.edges[ev.index].i;
      j = g.edges[ev.index].j;
      process_pair(g.bodies[i], g.bodies[j], g.edges[ev.index], ev.t, p, tally);
      times_of(j);
    }
    times_of(i);
    bests_around(i);
    if (j >= 0) bests_around(j);
  });
}

bool kept_edge_times = false;    // resolve_like_device(): resolve_group_cached()

// The CUDA backend's resolve(), with the kernel's threads run one after the other.
long resolve_like_device(const WindowWork &w, const Params &p, Tally &tally)
{
  const int n = w.nbodies, ng = w.ngroups;
  if (ng <= 0) return 0;
  std::vector<Tally> tallies(ng);
  int last = -1;
  if (!tally.capped && n > 0) {
    std::vector<int> adj_start, adj, fill;
    edge_adjacency(n, w.edges, w.nedges, adj_start, adj, fill);
    const std::vector<Body> start(w.bodies, w.bodies + n);
    std::vector<Body> bodies;
    std::vector<Event> best(n);
    const long budget = p.maxevents - tally.events;
    auto pass = [&](int last_group, int capped_group, long capped_budget) {
      bodies = start;
      const GroupGraph graph{bodies.data(), w.edges, adj_start.data(), adj.data(), best.data()};
      // The kept pair times (each group finds those of its own edges first).
      std::vector<double> et(kept_edge_times ? w.nedges : 0, HSGPU::Contact::never());
      for (int g = 0; g <= last_group; ++g) {
        Tally t;
        const int lo = w.group_start[g], hi = w.group_start[g + 1];
        if (hi > lo && kept_edge_times)
          resolve_group_cached(graph, p, et, w.group_members + lo, hi - lo, w.t_end,
                               g == capped_group ? capped_budget : budget, t);
        else if (hi > lo)
          resolve_group_exact(graph, p, w.group_members + lo, hi - lo, w.t_end,
                              g == capped_group ? capped_budget : budget, t);
        tallies[g] = t;
      }
    };
    pass(ng - 1, -1, 0);
    long stop_budget = 0;
    const int stop =
        cap_stop_group(w.group_start, ng, tallies.data(), p.maxevents, tally.events, stop_budget);
    last = ng - 1;
    if (stop >= 0) {
      pass(stop, stop, stop_budget);
      last = stop;
    }
    std::copy(bodies.begin(), bodies.end(), w.bodies);
  }
  return hand_over_tallies(w.group_start, ng, tallies.data(), last, w.group_tally, tally);
}

struct Variant {
  const char *name;
  CollideSpec spec;
};

// 600 bodies at packing fraction 0.35: many groups in a short step, one group in a long one.
std::vector<Variant> variants()
{
  std::vector<Variant> v;
  CollideSpec s;
  s.n = 600;
  s.seed = 11;
  v.push_back({"periodic", s});
  s.seed = 12;
  s.g = 5.0;
  s.tc = 1e-3;
  s.dt = 0.1;
  v.push_back({"periodic_gravity_long_step", s});
  s.seed = 13;
  s.floor = true;
  s.g = 20.0;
  s.tc = 0.02;
  s.vmin = 0.05;
  s.dt = 0.01;
  v.push_back({"floor_gravity", s});
  s.dt = 0.1;
  v.push_back({"floor_gravity_long_step", s});
  return v;
}

TEST(GroupLoop, MatchesCpuBackendBitwise)
{
  auto cpu = make_cpu_backend();
  const auto cpu_resolve = through(*cpu);
  for (const Variant &v : variants()) {
    const CollideSystem sys = make_collide_system(v.spec);
    for (int nwin : {1, 3}) {
      const std::string what = std::string(v.name) + ", " + std::to_string(nwin) + " window(s)";
      const StepOutcome a = run_windows(sys, sys.p, nwin, cpu_resolve);
      const StepOutcome b = run_windows(sys, sys.p, nwin, resolve_like_device);
      EXPECT_GT(a.tally.pair, 20) << what << ": too few collisions to test anything";
      if (v.spec.floor) {
        EXPECT_GT(a.tally.wall, 0) << what;
      }
      EXPECT_EQ(a.tally.capped, 0) << what;
      expect_same_bits(a, b, what.c_str());
    }
  }
}

// The same with the edges' pair times kept between events (the resident step's warps), with
// and without the maxevents cap.
TEST(GroupLoop, KeptEdgeTimesMatchCpuBackendBitwise)
{
  auto cpu = make_cpu_backend();
  const auto cpu_resolve = through(*cpu);
  kept_edge_times = true;
  for (const Variant &v : variants()) {
    const CollideSystem sys = make_collide_system(v.spec);
    const long total = run_windows(sys, sys.p, 1, cpu_resolve).tally.events;
    for (long cap : {sys.p.maxevents, total / 2}) {
      Params p = sys.p;
      p.maxevents = cap;
      for (int nwin : {1, 3}) {
        const std::string what = std::string(v.name) + ", maxevents " + std::to_string(cap) +
                                 ", " + std::to_string(nwin) + " window(s), kept edge times";
        const StepOutcome a = run_windows(sys, p, nwin, cpu_resolve);
        const StepOutcome b = run_windows(sys, p, nwin, resolve_like_device);
        EXPECT_GT(a.tally.pair, 10) << what;
        expect_same_bits(a, b, what.c_str());
      }
    }
  }
  kept_edge_times = false;
}

// Windows change no body's bits: three windows give the one window's bodies (but for w0 and
// wexc2) and the same event counts.  The tally's sums are added per window, so their last
// bits may differ.
TEST(GroupLoop, WindowsChangeNoBody)
{
  for (const Variant &v : variants()) {
    const CollideSystem sys = make_collide_system(v.spec);
    StepOutcome one = run_windows(sys, sys.p, 1, resolve_like_device);
    StepOutcome three = run_windows(sys, sys.p, 3, resolve_like_device);
    EXPECT_NEAR(one.tally.ke_lost, three.tally.ke_lost, 1e-12 * std::fabs(one.tally.ke_lost))
        << v.name;
    for (StepOutcome *o : {&one, &three}) {
      for (Body &b : o->bodies) {
        std::fill(b.w0, b.w0 + 3, 0.0);
        b.wexc2 = 0.0;
      }
      o->most.clear();
      o->tally.ke_lost = 0.0;
      std::fill(o->tally.virial, o->tally.virial + 6, 0.0);
    }
    expect_same_bits(one, three, v.name);
  }
}

TEST(GroupLoop, CapMatchesCpuBackendBitwise)
{
  auto cpu = make_cpu_backend();
  const auto cpu_resolve = through(*cpu);
  for (const Variant &v : variants()) {
    const CollideSystem sys = make_collide_system(v.spec);
    const long total = run_windows(sys, sys.p, 1, cpu_resolve).tally.events;
    ASSERT_GT(total, 10) << v.name;
    for (long cap : {0L, 1L, total / 3, total / 2, total - 1, total}) {
      Params p = sys.p;
      p.maxevents = cap;
      for (int nwin : {1, 3}) {
        const std::string what = std::string(v.name) + ", maxevents " + std::to_string(cap) + ", " +
                                 std::to_string(nwin) + " window(s)";
        const StepOutcome a = run_windows(sys, p, nwin, cpu_resolve);
        const StepOutcome b = run_windows(sys, p, nwin, resolve_like_device);
        EXPECT_EQ(a.tally.capped, cap < total ? 1 : 0) << what;
        EXPECT_LE(a.tally.events, cap) << what;
        expect_same_bits(a, b, what.c_str());
      }
    }
  }
}

// Per-group tallies (WindowWork::group_tally), with and without a cap, and with events
// counted before the window.
TEST(GroupLoop, PerGroupTalliesMatchCpuBackend)
{
  auto cpu = make_cpu_backend();
  const auto cpu_resolve = through(*cpu);
  for (const Variant &v : variants()) {
    const CollideSystem sys = make_collide_system(v.spec);
    const long total = run_windows(sys, sys.p, 1, cpu_resolve).tally.events;
    for (long cap : {sys.p.maxevents, total / 2 + 5}) {
      Params p = sys.p;
      p.maxevents = cap;
      const std::string what = std::string(v.name) + ", maxevents " + std::to_string(cap);
      const PerGroupOutcome a = run_per_group(sys, p, 5, cpu_resolve);
      const PerGroupOutcome b = run_per_group(sys, p, 5, resolve_like_device);
      EXPECT_EQ(a.tally.events, 5) << what << ": the caller's tally gets only `capped`";
      expect_same_per_group(a, b, what);
    }
  }
}

}    // namespace
