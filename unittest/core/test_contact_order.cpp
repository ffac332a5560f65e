// LAMMPS-free tests of the event orders (core/event_order.h) and of the time-window driver
// (engine/window_driver.h) on the CPU backend, driven by the small velocity-Verlet world of
// common/collision_world.h: `serial`, `components` and windows give bitwise the same steps, the
// result does not depend on the order of the bodies in memory, no pair overlaps after any
// step, momentum and energy are conserved where they should be, and free flight does not
// depend on dt.  The window cases run against the CUDA backend too (unittest/gpu).
#include "common/collision_world.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>
#include <vector>

using namespace HSGPU::Collide;
using namespace hsgpu_test;

TEST(EventOrder, SerialAndComponentsAgreeBitwiseWithoutOverlaps)
{
  World ws = random_world(250, 11, 1.5), wc = ws;
  const double dt = 0.02;
  long pair_total = 0, wall_total = 0, max_events = 0, max_comp = 0;
  double worst = 1e300;
  for (int it = 0; it < 300; ++it) {
    const StepResult rs = step(ws, dt, SERIAL), rc = step(wc, dt, COMPONENTS);
    ASSERT_EQ(rs.tally.events, rc.tally.events) << "step " << it;
    ASSERT_EQ(rs.tally.pair, rc.tally.pair) << "step " << it;
    ASSERT_EQ(rs.tally.wall, rc.tally.wall) << "step " << it;
    int diff = -1;
    ASSERT_TRUE(same_state(ws, wc, diff)) << "step " << it << " body " << diff;
    EXPECT_NEAR(rs.tally.ke_lost, rc.tally.ke_lost, 1e-12 * (1 + rs.tally.ke_lost));
    pair_total += rc.tally.pair;
    wall_total += rc.tally.wall;
    max_events = std::max(max_events, rc.tally.events);
    max_comp = std::max(max_comp, rc.max_component_events);
    worst = std::min(worst, worst_overlap(wc));
  }
  std::printf("[ ORDER    ] 250 spheres, 300 steps: %ld pair and %ld wall collisions, at most %ld "
              "events in a step, %ld in one component; worst (d - s)/s = %.3g\n",
              pair_total, wall_total, max_events, max_comp, worst);
  EXPECT_GT(pair_total, 1000);    // the test is meaningful only with many collisions
  EXPECT_GT(max_events, 10);
  EXPECT_GT(worst, -1e-12);
}

TEST(EventOrder, ResultDoesNotDependOnMemoryOrder)
{
  World w1 = random_world(120, 5, 2.0);
  World w2 = w1;
  std::mt19937_64 rng(1);
  std::shuffle(w2.s.begin(), w2.s.end(), rng);
  for (int it = 0; it < 100; ++it) {
    step(w1, 0.02, windows(0));
    step(w2, 0.02, windows(0));
  }
  std::vector<const Sphere *> by1(w1.s.size() + 1), by2(w2.s.size() + 1);
  for (auto &s : w1.s) by1[s.id] = &s;
  for (auto &s : w2.s) by2[s.id] = &s;
  for (size_t id = 1; id < by1.size(); ++id)
    for (int d = 0; d < 3; ++d) {
      ASSERT_EQ(by1[id]->x[d], by2[id]->x[d]) << "atom " << id;
      ASSERT_EQ(by1[id]->u[d], by2[id]->u[d]) << "atom " << id;
    }
}

TEST(EventOrder, ElasticPeriodicGasConservesMomentumAndEnergy)
{
  World w = periodic_gas(21, 1.0);
  double p0[3] = {0, 0, 0}, pscale = 0;
  for (auto &s : w.s)
    for (int d = 0; d < 3; ++d) {
      p0[d] += s.m * s.u[d];
      pscale += s.m * std::fabs(s.u[d]);
    }
  const double k0 = kinetic(w);
  long pairs = 0;
  for (int it = 0; it < 200; ++it) pairs += step(w, 0.02, windows(0)).tally.pair;
  double p1[3] = {0, 0, 0};
  for (auto &s : w.s)
    for (int d = 0; d < 3; ++d) p1[d] += s.m * s.u[d];
  EXPECT_GT(pairs, 500);
  for (int d = 0; d < 3; ++d) EXPECT_NEAR(p1[d], p0[d], 1e-13 * pscale);
  EXPECT_NEAR(kinetic(w), k0, 1e-12 * k0);
  EXPECT_GT(worst_overlap(w), -1e-12);
}

TEST(EventOrder, InelasticGasLosesExactlyTheTalliedEnergy)
{
  World w = periodic_gas(23, 0.6);
  double lost = 0;
  const double k0 = kinetic(w);
  for (int it = 0; it < 100; ++it) lost += step(w, 0.02, windows(0)).tally.ke_lost;
  EXPECT_GT(lost, 0.1 * k0);
  EXPECT_NEAR(kinetic(w), k0 - lost, 1e-12 * k0);
}

// Under no forces the trajectory is a sequence of straight flights and instantaneous
// collisions, whatever the step: the state after time T is the same for dt and dt / 4.
TEST(EventOrder, FreeFlightResultDoesNotDependOnTimestep)
{
  World base = random_world(40, 3, 1.0);
  base.g = 0.0;
  base.e = 0.7;
  base.ewall = 0.8;
  World w1 = base, w4 = base;
  long pairs = 0, walls = 0;
  for (int it = 0; it < 50; ++it) {
    const StepResult r = step(w1, 0.04, windows(0));
    pairs += r.tally.pair;
    walls += r.tally.wall;
  }
  for (int it = 0; it < 200; ++it) step(w4, 0.01, windows(0));
  double worst = 0.0;
  for (size_t i = 0; i < base.s.size(); ++i)
    for (int d = 0; d < 3; ++d) {
      worst = std::max(worst, std::fabs(w1.s[i].x[d] - w4.s[i].x[d]));
      worst = std::max(worst, std::fabs(w1.s[i].u[d] - w4.s[i].u[d]));
    }
  std::printf("[ ORDER    ] dt vs dt/4 after %ld pair and %ld wall collisions: max diff %.3g\n",
              pairs, walls, worst);
  EXPECT_GT(pairs, 5);
  EXPECT_GT(walls, 2);
  EXPECT_LT(worst, 1e-12);
}

// A pile under gravity with e = 0.5 and the fix's default guards (tc = dt / 2): the pile
// settles and stays settled: bounded events per step, kinetic energy of order M (g dt)^2, no
// overlaps, nobody inside the floor.
TEST(EventOrder, SettledPileIsStable)
{
  World w = random_world(216, 8, 0.5, 7);    // 216 spheres on 7^3 sites
  w.e = 0.5;
  w.ewall = 0.5;
  w.g = 10.0;
  const double dt = 0.005;
  w.tc = dt / 2;
  long most = 0;
  for (int it = 0; it < 2000; ++it) most = std::max(most, step(w, dt, windows(0)).tally.events);
  const double ke_settled = kinetic(w);
  long most_late = 0, events_late = 0;
  for (int it = 0; it < 500; ++it) {
    const StepResult r = step(w, dt, windows(0));
    most_late = std::max(most_late, r.tally.events);
    events_late += r.tally.events;
  }
  double mass = 0, top = 0;
  for (auto &s : w.s) {
    mass += s.m;
    top = std::max(top, s.x[2]);
  }
  std::printf("[ ORDER    ] pile of 216: at most %ld events/step while settling, %ld later "
              "(%.2f per sphere per step); KE = %.3g = %.3g M g^2 dt^2; top at z = %.3f\n",
              most, most_late, (double) events_late / 500.0 / 216.0, kinetic(w),
              kinetic(w) / (mass * w.g * w.g * dt * dt), top);
  EXPECT_LT(kinetic(w), 2.0 * mass * w.g * w.g * dt * dt);
  EXPECT_LT(ke_settled, 2.0 * mass * w.g * w.g * dt * dt);
  EXPECT_LT(most_late, 6 * 216);
  EXPECT_LT(top, 2.5);    // about three layers: nobody flies off
  EXPECT_GT(worst_overlap(w), -1e-12);
  for (auto &s : w.s) EXPECT_GE(s.x[2] - s.r, -1e-12);
}

TEST(WindowDriver, EqualsSerialBitwise)
{
  check_windows_equal_serial(nullptr);
}

// Per-atom virial: in every order (windows with repairs included) the bodies' shares add up to
// the step's virial, and each body's equals its share in order serial (the same events; only
// the order of the additions differs between windows).
TEST(WindowDriver, PerBodyVirialSumsToTheTallyAndEqualsSerial)
{
  const Order orders[] = {COMPONENTS, windows(3), windows(0, 1.5, 4), windows(0, 0.25, 0),
                          windows(5, 0.1, 0)};
  for (const WindowCase &wc : window_cases()) {
    for (const Order &o : orders) {
      World ws = wc.world, wo = wc.world;
      long repairs = 0;
      double worst_sum = 0.0, worst_body = 0.0, scale = 0.0;
      for (int it = 0; it < std::min(wc.steps, 60); ++it) {
        std::vector<double> vs, vo;
        const StepResult rs = step(ws, wc.dt, SERIAL, nullptr, nullptr, &vs);
        const StepResult ro = step(wo, wc.dt, o, nullptr, nullptr, &vo);
        repairs += ro.stats.repairs;
        double sum[6] = {0, 0, 0, 0, 0, 0};
        for (size_t b = 0; b < vo.size() / 6; ++b)
          for (int k = 0; k < 6; ++k) {
            sum[k] += vo[6 * b + k];
            worst_body = std::max(worst_body, std::fabs(vo[6 * b + k] - vs[6 * b + k]));
          }
        for (int k = 0; k < 6; ++k) {
          scale = std::max(scale, std::fabs(rs.tally.virial[k]));
          worst_sum = std::max(worst_sum, std::fabs(sum[k] - ro.tally.virial[k]));
        }
      }
      EXPECT_GT(scale, 0.0) << wc.name;
      EXPECT_LE(worst_sum, 1e-12 * scale) << wc.name;
      EXPECT_LE(worst_body, 1e-12 * scale) << wc.name;
      if (o.kind == Order::Windows && o.windows.bound_factor < 0.5) {
        EXPECT_GT(repairs, 0) << wc.name << ": no repair to test";
      }
    }
  }
}

// One window per step with the step's own bound rule, or joining every candidate pair (what
// the fix takes for `windows 1`), repairs nothing where the shorter windows' rule (1.5 |v|, a
// quarter of the fastest) repairs its one large group; all equal order serial bit for bit.
TEST(WindowDriver, OneWindowWithTheStepBoundsRepairsNothing)
{
  const WindowCase wc = window_cases()[1];    // the dense periodic fluid
  Order step_rule = windows(1, STEP_BOUND_FACTOR);
  step_rule.windows.floor_fraction = STEP_FLOOR_FRACTION;
  Order joined = step_rule;    // what `windows 1` takes: every candidate joined
  joined.windows.join_all = true;
  World ws = wc.world, wa = wc.world, wb = wc.world, wc_all = wc.world;
  long repairs_step = 0, repairs_window = 0, repairs_all = 0;
  for (int it = 0; it < wc.steps; ++it) {
    const StepResult rs = step(ws, wc.dt, SERIAL);
    const StepResult ra = step(wa, wc.dt, step_rule);
    const StepResult rb = step(wb, wc.dt, windows(1));
    const StepResult rc = step(wc_all, wc.dt, joined);
    repairs_step += ra.stats.repairs;
    repairs_window += rb.stats.repairs;
    repairs_all += rc.stats.repairs;
    ASSERT_EQ(rs.tally.pair, ra.tally.pair) << "step " << it;
    ASSERT_EQ(rs.tally.pair, rb.tally.pair) << "step " << it;
    ASSERT_EQ(rs.tally.pair, rc.tally.pair) << "step " << it;
  }
  std::printf("[ WINDOWS  ] dense fluid of %zu, one window per step, %d steps: %ld repairs with "
              "the step's bounds, %ld with the windows' (k = 1.5)\n",
              wc.world.s.size(), wc.steps, repairs_step, repairs_window);
  EXPECT_EQ(repairs_step, 0);
  EXPECT_EQ(repairs_all, 0);
  EXPECT_GT(repairs_window, 0) << "the shorter bounds repaired nothing: nothing was tested";
  for (size_t i = 0; i < ws.s.size(); ++i)
    for (int d = 0; d < 3; ++d) {
      ASSERT_EQ(ws.s[i].x[d], wa.s[i].x[d]);
      ASSERT_EQ(ws.s[i].u[d], wa.s[i].u[d]);
      ASSERT_EQ(ws.s[i].x[d], wb.s[i].x[d]);
      ASSERT_EQ(ws.s[i].x[d], wc_all.s[i].x[d]);
      ASSERT_EQ(ws.s[i].u[d], wc_all.s[i].u[d]);
    }
}

TEST(WindowDriver, SmallGroupsInADenseFluid)
{
  // With windows the dense fluid splits into small groups; one window of the whole step with
  // every candidate joined does not.
  World w = window_cases()[1].world, w1 = w;
  long largest = 0, largest1 = 0;
  for (int it = 0; it < 30; ++it) {
    largest = std::max(largest, step(w, 0.02, windows(0, 1.5, 16)).stats.largest_group);
    largest1 = std::max(largest1, step(w1, 0.02, windows(1, 1e9, 0)).stats.largest_group);
  }
  std::printf("[ WINDOWS  ] dense fluid of %zu: largest group %ld adaptive, %ld one window\n",
              w.s.size(), largest, largest1);
  EXPECT_LT(largest, largest1);
  EXPECT_LT(largest, (long) w.s.size() / 4);
}

// The resolution's event queue (time buckets) pops events in the order earlier() gives,
// including ties in time, events pushed below the lowest filled bucket and events beyond the
// buckets' range, interleaved with pushes of later events as a resolution makes them.
TEST(EventQueue, PopsInTheOrderOfEarlier)
{
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  auto make = [&](double t) {
    Event e{};
    e.t = t;
    e.k1 = 1 + (long) (u(rng) * 20);
    e.k2 = (long) (u(rng) * 40) - 6;
    e.index = (int) (u(rng) * 1000);
    return e;
  };
  for (int trial = 0; trial < 20; ++trial) {
    EventQueue q;
    std::vector<Event> ref;
    const int n = 1 + trial * 37;
    q.reset(0.1, 0.9, n / 2 + 1);
    for (int k = 0; k < n; ++k) {
      // Some times repeat (ties broken by the keys), some lie outside [0.1, 0.9) (below it:
      // into the lowest bucket; above it: into the highest).
      const double t = (k % 5 == 0)    ? 0.5
                       : (k % 7 == 0)  ? 0.95
                       : (k % 11 == 0) ? 0.05
                                       : 0.1 + 0.8 * u(rng);
      ref.push_back(make(t));
      q.push(ref.back());
    }
    double last = -1.0;
    long popped = 0;
    while (!q.empty()) {
      const Event e = q.pop();
      auto best = std::min_element(ref.begin(), ref.end(), [](const Event &a, const Event &b) {
        return earlier(a, b);
      });
      ASSERT_FALSE(earlier(*best, e)) << "trial " << trial << " pop " << popped;
      ASSERT_FALSE(earlier(e, *best)) << "trial " << trial << " pop " << popped;
      ref.erase(best);
      // As a resolution does: new events at or after the one just taken (some just after
      // it, in the bucket it came from).
      ASSERT_GE(e.t, last);
      last = e.t;
      if (popped++ % 3 == 0) {
        const double t = e.t + (1.0 - e.t) * u(rng) * (popped % 2 ? 1.0 : 1e-3);
        ref.push_back(make(t));
        q.push(ref.back());
      }
    }
    EXPECT_TRUE(ref.empty());
    EXPECT_GT(popped, n);
  }
}

// A burst of events at one time (touching spheres that approach, at a step's start) all falls
// in one bucket: popped in key order, each at a heap's cost (50000 of them here; a scan of the
// bucket per pop would be quadratic in the burst).
TEST(EventQueue, BurstAtOneTimeComesOutInKeyOrder)
{
  std::mt19937_64 rng(11);
  EventQueue q;
  const int n = 50000;
  q.reset(0.0, 1.0, n / 2 + 1);
  std::vector<Event> ref(n);
  for (int k = 0; k < n; ++k) {
    Event e{};
    e.t = (k % 10 == 0) ? 0.5 : 0.0;
    e.k1 = 1 + (long) (rng() % 100000);
    e.k2 = 1 + (long) (rng() % 100000);
    ref[k] = e;
    q.push(e);
  }
  std::sort(ref.begin(), ref.end(), [](const Event &a, const Event &b) { return earlier(a, b); });
  for (int k = 0; k < n; ++k) {
    const Event e = q.pop();
    ASSERT_TRUE(!earlier(e, ref[k]) && !earlier(ref[k], e)) << "pop " << k;
  }
  EXPECT_TRUE(q.empty());
}
