/* HARDSPHERE_GPU tests: a small velocity-Verlet world of hard spheres, stepped with the
   physics core and the collision engine (serial loop, components of the whole step, or time
   windows on a given backend), and the window cases that every collision backend must get
   bit for bit equal to the serial loop.  Shared by the CPU test (unittest/core) and the
   device test (unittest/gpu): one test body per case, run against every backend. */
#ifndef HSGPU_TEST_COLLISION_WORLD_H
#define HSGPU_TEST_COLLISION_WORLD_H

#include "core/event_order.h"
#include "engine/collision_backend.h"
#include "engine/resident_step.h"
#include "engine/window_driver.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <random>
#include <vector>

namespace hsgpu_test {

using namespace HSGPU::Collide;

struct Sphere {
  long id;
  double x[3], u[3], r, m;
  double tlast = -1e30;
};

struct World {
  std::vector<Sphere> s;
  double lo[3] = {0, 0, 0}, prd[3] = {10, 10, 10};
  int periodic[3] = {1, 1, 0};
  double g = 1.0;    // gravity along -z
  double e = 0.8;    // restitution of all pairs
  double ewall = 0.9;
  bool walls = true;    // floor and roof in z
  double tc = 0.0;
};

// lattice: sites per row of the lattice (0: the fewest that hold n, k^3 >= n).  Found in
// integers: ceil(cbrt(n)) depended on the rounding of cbrt (6.0000000000000009 from glibc for
// 216, exactly 6 where the compiler folds it), and with it the whole world.
inline World random_world(int n, unsigned seed, double vscale, int lattice = 0)
{
  World w;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  // Jittered cubic lattice: no overlaps at the start.
  int k = lattice;
  if (k <= 0)
    for (k = 1; (long) k * k * k < n;) ++k;
  const double a = 10.0 / k;
  for (int i = 0; i < n; ++i) {
    Sphere sp;
    sp.id = 1 + (long) ((i * 7919L) % n);    // IDs not in memory order
    const int ix = i % k, iy = (i / k) % k, iz = i / (k * k);
    sp.r = 0.25 * a + 0.15 * a * u(rng);
    const double slack = 0.5 * a - sp.r;
    sp.x[0] = (ix + 0.5) * a + slack * (2 * u(rng) - 1);
    sp.x[1] = (iy + 0.5) * a + slack * (2 * u(rng) - 1);
    sp.x[2] = (iz + 0.5) * a + slack * (2 * u(rng) - 1);
    for (int d = 0; d < 3; ++d) sp.u[d] = vscale * (2 * u(rng) - 1);
    sp.m = sp.r * sp.r * sp.r;
    w.s.push_back(sp);
  }
  return w;
}

// The box of a world for a resident step (no reach limit).
inline ResidentBox resident_box(const World &w)
{
  ResidentBox box{};
  for (int d = 0; d < 3; ++d) {
    box.lo[d] = w.lo[d];
    box.prd[d] = w.prd[d];
    box.periodic[d] = w.periodic[d];
  }
  box.overlap_tol = 1e-9;
  box.reach = 1e300;
  return box;
}

struct StepResult {
  Tally tally;
  int redo = 0;
  int window_redo = 0;
  long max_component_events = 0;
  WindowStats stats;
  int resident = 0;    // 1: a resident step carried the step out
  int declined = 0;    // times a resident step handed the step back
};

// How a step is resolved: the global loop, components of the whole step, or time windows.
struct Order {
  enum Kind { Serial, Components, Windows } kind;
  WindowSettings windows;
};
inline const Order SERIAL{Order::Serial, {}}, COMPONENTS{Order::Components, {}};
inline Order windows(int n, double bound_factor = 1.5, long target = 0)
{
  Order o{Order::Windows, {}};
  o.windows.nwindows = n;
  o.windows.bound_factor = bound_factor;
  o.windows.target_group = target;
  // Explicit, so that the device-resident step cuts the same windows as the host driver (each
  // has its own default).
  o.windows.floor_fraction = 0.25;
  return o;
}

// One velocity-Verlet step with hard-sphere collisions resolved in the given order (time
// windows with the given backend, the CPU one by default; with a resident step, time windows
// on it, and where it declines the step, on the backend).  body_virial: where given (host
// orders only), each body's per-atom virial of the step, 6 per body in memory order.
inline StepResult step(World &w, double dt, const Order &order, CollisionBackend *backend = nullptr,
                       ResidentStep *resident = nullptr, std::vector<double> *body_virial = nullptr)
{
  const bool serial = order.kind == Order::Serial;
  const int n = (int) w.s.size();
  const double a[3] = {0, 0, -w.g};
  std::vector<double> epair = {0, 0, 0, w.e};
  Params p{};
  p.dt = dt;
  p.tc = w.tc;
  p.vmin = 0.0;
  p.ntypes = 1;
  p.epair = epair.data();
  p.maxevents = 200L * n + 1000;    // a runaway step fails the test instead of hanging it
  for (int f = 0; f < NFACES; ++f) {
    p.walls.on[f] = (w.walls && f >= 4) ? 1 : 0;
    p.walls.pos[f] = (f & 1) ? w.lo[f / 2] + w.prd[f / 2] : w.lo[f / 2];
    p.walls.e[f] = w.ewall;
  }
  // First half kick and drift start.
  std::vector<Body> start(n);
  double vmax = 0.0;
  for (int i = 0; i < n; ++i) {
    Body &b = start[i];
    std::memset(&b, 0, sizeof(b));
    for (int d = 0; d < 3; ++d) {
      b.v[d] = w.s[i].u[d] + 0.5 * dt * a[d];
      b.x[d] = b.X0[d] = w.s[i].x[d];
      b.a[d] = a[d];
      b.rest[d] = -1;
    }
    vmax = std::max(vmax, std::sqrt(b.v[0] * b.v[0] + b.v[1] * b.v[1] + b.v[2] * b.v[2]));
    b.radius = w.s[i].r;
    b.mass = w.s[i].m;
    b.tlast = w.s[i].tlast;
    b.id = w.s[i].id;
    b.type = 1;
  }
  double D = 2.0 * vmax * dt + w.g * dt * dt / 4 + 1e-12;
  StepResult out;
  Resolver res;
  std::vector<Body> bodies;
  static WindowDriver driver, fallback;    // fallback: where a resident step declines
  static std::unique_ptr<CollisionBackend> cpu = make_cpu_backend();
  if (!backend) backend = cpu.get();
  SingleRank single;
  while (true) {
    if (resident && (order.kind == Order::Windows || serial)) {
      resident->set_serial(serial);
      bodies = start;
      out.tally = Tally();
      const std::vector<double> bound(n, D);
      const ResidentBox box = resident_box(w);
      ResidentReport rep;
      resident->run(bodies.data(), bound.data(), n, box, p, order.windows, out.tally, rep);
      if (rep.outcome == ResidentOutcome::done) {
        out.resident = 1;
        out.stats = rep.stats;
        out.window_redo += (int) rep.stats.repairs;
        break;
      }
      out.declined++;
    }
    // Edges: pairs whose start points are within contact + 2 D (nearest image).
    std::vector<Edge> edges;
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) {
        if (start[i].id >= start[j].id) continue;
        double r[3], sh[3];
        nearest_image_separation(start[i].X0, start[j].X0, w.prd, w.periodic, r, sh);
        const double reach = start[i].radius + start[j].radius + 2 * D;
        if (r[0] * r[0] + r[1] * r[1] + r[2] * r[2] <= reach * reach) {
          Edge e{i, j, {sh[0], sh[1], sh[2]}};
          edges.push_back(e);
        }
      }
    bodies = start;
    out.tally = Tally();
    double *bv = nullptr;
    if (body_virial) {
      body_virial->assign(6 * (size_t) n, 0.0);
      bv = body_virial->data();
    }
    if (serial) {
      res.resolve_serial(bodies, edges, p, out.tally, bv);
    } else if (order.kind == Order::Components) {
      res.resolve_components(bodies, edges, p, out.tally, bv);
      out.max_component_events = res.max_component_events;
    } else {
      (resident ? fallback : driver)
          .run(bodies, edges, {}, {}, p, order.windows, *backend, single, out.tally, out.stats, bv);
      out.window_redo += (int) out.stats.repairs;
    }
    EXPECT_EQ(out.tally.capped, 0) << "a step needed more than " << p.maxevents << " events";
    if (out.tally.capped) return out;
    double worst = 0.0;
    for (auto &b : bodies) {
      double xe[3], ve[3];
      end_of_step(b, dt, xe, ve);
      worst = std::max(worst, std::sqrt(b.exc2));
    }
    if (worst <= D) break;
    D = 2.0 * worst;
    out.redo++;
  }
  for (int i = 0; i < n; ++i) {
    Body &b = bodies[i];
    double xe[3], ve[3];
    end_of_step(b, dt, xe, ve);
    for (int d = 0; d < 3; ++d) {
      double x = xe[d];
      if (w.periodic[d]) {
        if (x < w.lo[d]) x += w.prd[d];
        if (x >= w.lo[d] + w.prd[d]) x -= w.prd[d];
      }
      w.s[i].x[d] = x;
      w.s[i].u[d] = ve[d] + 0.5 * dt * a[d];    // second half kick
    }
    w.s[i].tlast = b.tlast - dt;
  }
  return out;
}

// Smallest (distance - contact distance) / contact distance over all pairs.
inline double worst_overlap(const World &w)
{
  double worst = 1e300;
  const int n = (int) w.s.size();
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j) {
      double r[3], sh[3];
      nearest_image_separation(w.s[i].x, w.s[j].x, w.prd, w.periodic, r, sh);
      const double s = w.s[i].r + w.s[j].r;
      worst = std::min(worst, (std::sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]) - s) / s);
    }
  return worst;
}

inline double kinetic(const World &w)
{
  double k = 0;
  for (const auto &s : w.s) k += 0.5 * s.m * (s.u[0] * s.u[0] + s.u[1] * s.u[1] + s.u[2] * s.u[2]);
  return k;
}

inline bool same_state(const World &a, const World &b, int &first_diff)
{
  for (size_t i = 0; i < a.s.size(); ++i)
    for (int d = 0; d < 3; ++d)
      if (a.s[i].x[d] != b.s[i].x[d] || a.s[i].u[d] != b.s[i].u[d]) {
        first_diff = (int) i;
        return false;
      }
  return true;
}

// 200 spheres without gravity or walls, periodic in z, restitution e.
inline World periodic_gas(unsigned seed, double e)
{
  World w = random_world(200, seed, 2.0);
  w.g = 0.0;
  w.walls = false;
  w.periodic[2] = 1;
  w.e = e;
  return w;
}

// The time-window driver against the global loop, bit for bit: fixed and adaptive windows, a
// small group target (many halvings), a low bound factor (many window redos), on a gas under
// gravity with walls, a dense periodic fluid and a settling inelastic pile with guards.
struct WindowCase {
  const char *name;
  World world;
  double dt;
  int steps;
};

inline std::vector<WindowCase> window_cases()
{
  std::vector<WindowCase> c;
  c.push_back({"gas with gravity and walls", random_world(250, 11, 1.5), 0.02, 150});
  // Equal spheres on a simple cubic lattice at packing fraction 0.4 (diameter 0.914 a).
  World dense = random_world(343, 31, 2.0);
  dense.g = 0.0;
  dense.walls = false;
  dense.periodic[2] = 1;
  dense.e = 1.0;
  {
    const double a = 10.0 / 7.0;
    for (size_t i = 0; i < dense.s.size(); ++i) {
      Sphere &sp = dense.s[i];
      sp.r = 0.457 * a;
      sp.m = 1.0;
      sp.x[0] = (i % 7 + 0.5) * a;
      sp.x[1] = (i / 7 % 7 + 0.5) * a;
      sp.x[2] = (i / 49 + 0.5) * a;
    }
  }
  c.push_back({"dense periodic fluid", dense, 0.02, 100});
  World pile = random_world(216, 8, 0.5, 7);
  pile.e = 0.5;
  pile.ewall = 0.5;
  pile.g = 10.0;
  pile.tc = 0.0025;
  c.push_back({"settling pile", pile, 0.005, 400});
  return c;
}

// Runs every window case with each order against order serial, bit for bit (time windows on
// the backend, or on the resident step where one is given).  With a resident step, also
// against the CPU driver: the same windows, groups and largest group.
inline void check_windows_equal_serial(CollisionBackend *backend, ResidentStep *resident = nullptr)
{
  const Order orders[] = {windows(1),         windows(3),          windows(7),        windows(0),
                          windows(0, 1.5, 4), windows(0, 0.25, 0), windows(5, 0.1, 0)};
  // HSGPU_WINDOW_CASE (a part of a case's name) runs only the matching cases.
  const char *only = std::getenv("HSGPU_WINDOW_CASE");
  for (const WindowCase &wc : window_cases()) {
    if (only && !std::strstr(wc.name, only)) continue;
    for (const Order &o : orders) {
      World ws = wc.world, ww = wc.world, wd = wc.world;
      long pairs = 0, redos = 0, largest = 0, nwin = 0, on_device = 0, declined = 0;
      // The two choosers of windows see the same steps until a step is declined or redone.
      bool same_choices = true;
      for (int it = 0; it < wc.steps; ++it) {
        const StepResult rs = step(ws, wc.dt, SERIAL), rw = step(ww, wc.dt, o, backend, resident);
        if (resident) {
          on_device += rw.resident;
          declined += rw.declined;
          const StepResult rd = step(wd, wc.dt, o);
          same_choices = same_choices && rw.resident && !rw.declined && !rd.redo;
          if (same_choices) {
            ASSERT_EQ(rd.stats.windows, rw.stats.windows) << wc.name << ", step " << it;
            ASSERT_EQ(rd.stats.largest_group, rw.stats.largest_group) << wc.name << ", step " << it;
            ASSERT_EQ(rd.stats.groups, rw.stats.groups) << wc.name << ", step " << it;
            ASSERT_NEAR(rd.tally.ke_lost, rw.tally.ke_lost, 1e-12 * std::fabs(rd.tally.ke_lost));
          }
        }
        ASSERT_EQ(rs.tally.events, rw.tally.events)
            << wc.name << ", step " << it << " (" << (rw.resident ? "resident step" : "driver")
            << ", " << rw.stats.windows << " windows, largest group " << rw.stats.largest_group
            << ", " << rw.stats.repairs << " repairs)";
        ASSERT_EQ(rs.tally.pair, rw.tally.pair) << wc.name << ", step " << it;
        ASSERT_EQ(rs.tally.wall, rw.tally.wall) << wc.name << ", step " << it;
        int diff = -1;
        ASSERT_TRUE(same_state(ws, ww, diff)) << wc.name << ", step " << it << " body " << diff;
        pairs += rw.tally.pair;
        redos += rw.window_redo;
        largest = std::max(largest, rw.stats.largest_group);
        nwin += rw.stats.windows;
      }
      std::printf("[ WINDOWS  ] %s, %s, windows %d, k %.2f, target %ld: %ld pair collisions, "
                  "largest group %ld of %zu, %.2f windows/step, %ld repairs\n",
                  resident  ? "resident step"
                  : backend ? backend->name().c_str()
                            : "cpu",
                  wc.name, o.windows.nwindows, o.windows.bound_factor, o.windows.target_group,
                  pairs, largest, wc.world.s.size(), (double) nwin / wc.steps, redos);
      if (resident) {
        std::printf("[ WINDOWS  ] resident step: %ld of %d steps on the device, %ld declined\n",
                    on_device, wc.steps, declined);
        EXPECT_GT(on_device, wc.steps / 2) << wc.name << ": most steps on the device";
      }
      EXPECT_GT(pairs, 100) << wc.name;
      if (o.windows.bound_factor < 0.5) {
        EXPECT_GT(redos, 0) << "the repair path was not taken";
      }
    }
  }
}

/// A resident step in order serial (the seed paper's loop on its backend) against the host's
/// serial loop: every window case, bit for bit, with the host's serial statistics (one
/// window, one group of all bodies).
inline void check_resident_serial(ResidentStep *resident)
{
  const char *only = std::getenv("HSGPU_WINDOW_CASE");
  for (const WindowCase &wc : window_cases()) {
    if (only && !std::strstr(wc.name, only)) continue;
    World ws = wc.world, wr = wc.world;
    long pairs = 0, on_device = 0;
    for (int it = 0; it < wc.steps; ++it) {
      const StepResult rs = step(ws, wc.dt, SERIAL),
                       rr = step(wr, wc.dt, SERIAL, nullptr, resident);
      on_device += rr.resident;
      if (rr.resident) {
        ASSERT_EQ(rr.stats.windows, 1) << wc.name << ", step " << it;
        ASSERT_EQ(rr.stats.groups, 1) << wc.name << ", step " << it;
        ASSERT_EQ(rr.stats.largest_group, (long) wc.world.s.size()) << wc.name << ", step " << it;
        ASSERT_EQ(rs.tally.ke_lost, rr.tally.ke_lost) << wc.name << ", step " << it;
        for (int c = 0; c < 6; ++c)
          ASSERT_EQ(rs.tally.virial[c], rr.tally.virial[c]) << wc.name << ", step " << it;
      }
      ASSERT_EQ(rs.tally.events, rr.tally.events) << wc.name << ", step " << it;
      ASSERT_EQ(rs.tally.pair, rr.tally.pair) << wc.name << ", step " << it;
      ASSERT_EQ(rs.tally.wall, rr.tally.wall) << wc.name << ", step " << it;
      int diff = -1;
      ASSERT_TRUE(same_state(ws, wr, diff)) << wc.name << ", step " << it << " body " << diff;
      pairs += rr.tally.pair;
    }
    std::printf("[ SERIAL   ] resident step, %s: %ld pair collisions, %ld of %d steps on the "
                "device\n",
                wc.name, pairs, on_device, wc.steps);
    EXPECT_GT(on_device, wc.steps / 2) << wc.name << ": most steps on the device";
    EXPECT_GT(pairs, 100) << wc.name;
  }
}

}    // namespace hsgpu_test

#endif
