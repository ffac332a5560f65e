/* A dense random hard-sphere system for the collision backends' tests (test_group_loop,
   test_collision_backend_cuda): bodies at the start of a step, the step's candidate edges,
   the groups they make, the parameters, and helpers to run it through a backend in one or
   several time windows and to compare two results bit for bit. */
#ifndef HSGPU_TEST_COLLIDE_SYSTEM_H
#define HSGPU_TEST_COLLIDE_SYSTEM_H

#include "core/event_order.h"
#include "engine/collision_backend.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <vector>

namespace hsgpu_test {

using HSGPU::Collide::Body;
using HSGPU::Collide::Edge;
using HSGPU::Collide::Params;
using HSGPU::Collide::Tally;

struct CollideSpec {
  int n = 2000;
  double phi = 0.35;    // packing fraction
  unsigned seed = 1;
  bool floor = false;    // z bounded by a floor and a roof (walls), else periodic
  double g = 0.0;        // uniform acceleration along -z
  double dt = 0.01;
  double vscale = 1.0;    // velocity components ~ N(0, vscale)
  double tc = 0.0;        // TC-model time
  double vmin = 0.0;      // elastic threshold
};

struct CollideSystem {
  std::vector<Body> bodies;    // at the start of the step (after the first half kick)
  std::vector<Edge> edges;
  std::vector<int> gstart, gmembers;
  std::vector<double> epair;
  Params p{};
  double box = 0.0;
  int largest_group = 0;
};

// Radii 0.5 (type 1) and 0.4 (type 2) in random order, placed without overlap by random
// sequential insertion (large spheres first, which reaches 0.35 quickly) in a periodic cube
// of edge L chosen for the packing fraction; with a floor, z is bounded by walls at 0 and
// L + 1 instead, and spheres near the floor are put on it (within 0.003) so that wall
// collisions and resting contacts happen within a step.  Random velocities.  The candidate
// edges join pairs whose nearest-image distance is within contact + 2 vmax dt (+ the bow, the
// same for all bodies, which keeps the bound honest); groups are the connected components of
// the edges, members in increasing index, groups in the order of their smallest member.
// Restitution 0.8 between equal types, 0.7 between unequal ones (so that the type-pair table
// is read), 0.9 on the walls.
inline CollideSystem make_collide_system(const CollideSpec &s)
{
  using namespace HSGPU::Collide;
  CollideSystem out;
  std::mt19937_64 rng(s.seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> gauss(0.0, s.vscale > 0.0 ? s.vscale : 1.0);
  const double pi = 3.14159265358979323846;
  std::vector<double> radius(s.n);
  double volume = 0.0;
  for (int i = 0; i < s.n; ++i) {
    radius[i] = u(rng) < 0.5 ? 0.4 : 0.5;
    volume += 4.0 / 3.0 * pi * radius[i] * radius[i] * radius[i];
  }
  const double L = std::cbrt(volume / s.phi);
  const double Lz = s.floor ? L + 1.0 : L;
  out.box = L;
  const double prd[3] = {L, L, Lz};
  const int periodic[3] = {1, 1, s.floor ? 0 : 1};

  // Insertion, largest first, with a cell list (cells of edge >= 1 = the largest diameter).
  std::vector<int> order(s.n);
  for (int i = 0; i < s.n; ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return radius[a] > radius[b]; });
  const int nc[3] = {std::max(1, (int) L), std::max(1, (int) L), std::max(1, (int) Lz)};
  std::vector<std::vector<int>> cells(nc[0] * nc[1] * nc[2]);
  auto cell_index = [&](const double *p, int *c) {
    for (int d = 0; d < 3; ++d)
      c[d] = std::min(nc[d] - 1, std::max(0, (int) (p[d] / prd[d] * nc[d])));
  };
  std::vector<double> x(3 * s.n);
  auto overlaps = [&](int i, const double *p) {
    int c[3];
    cell_index(p, c);
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          const int cx = (c[0] + dx + nc[0]) % nc[0], cy = (c[1] + dy + nc[1]) % nc[1],
                    cz = (c[2] + dz + nc[2]) % nc[2];
          for (int j : cells[(cx * nc[1] + cy) * nc[2] + cz]) {
            if (j == i) continue;
            double r[3], sh[3];
            nearest_image_separation(p, &x[3 * j], prd, periodic, r, sh);
            const double sum = radius[i] + radius[j];
            if (r[0] * r[0] + r[1] * r[1] + r[2] * r[2] < sum * sum) return true;
          }
        }
    return false;
  };
  for (int i : order) {
    for (long attempt = 0;; ++attempt) {
      if (attempt > 10000000L) {
        ADD_FAILURE() << "cannot place sphere " << i << " at packing fraction " << s.phi;
        return out;
      }
      double p[3];
      for (int d = 0; d < 3; ++d) p[d] = prd[d] * u(rng);
      if (s.floor && (p[2] < radius[i] || p[2] > Lz - radius[i])) continue;
      if (overlaps(i, p)) continue;
      for (int d = 0; d < 3; ++d) x[3 * i + d] = p[d];
      int c[3];
      cell_index(p, c);
      cells[(c[0] * nc[1] + c[1]) * nc[2] + c[2]].push_back(i);
      break;
    }
  }
  if (s.floor)
    for (int i = 0; i < s.n; ++i) {
      if (x[3 * i + 2] - radius[i] > 0.1) continue;
      double p[3] = {x[3 * i], x[3 * i + 1], radius[i] + 0.003 * u(rng)};
      if (!overlaps(i, p)) x[3 * i + 2] = p[2];    // the same cell: z stays below 1
    }

  const double a[3] = {0.0, 0.0, -s.g};
  out.bodies.resize(s.n);
  double vmax = 0.0;
  for (int i = 0; i < s.n; ++i) {
    Body &b = out.bodies[i];
    std::memset(&b, 0, sizeof(b));
    for (int d = 0; d < 3; ++d) {
      b.v[d] = (s.vscale > 0.0 ? gauss(rng) : 0.0) + 0.5 * s.dt * a[d];
      b.x[d] = b.X0[d] = b.w0[d] = x[3 * i + d];
      b.a[d] = a[d];
      b.rest[d] = -1;
    }
    vmax = std::max(vmax, std::sqrt(b.v[0] * b.v[0] + b.v[1] * b.v[1] + b.v[2] * b.v[2]));
    b.radius = radius[i];
    b.mass = radius[i] * radius[i] * radius[i];
    b.tlast = -1.0;
    b.id = 1 + (long) ((i * 7919L) % s.n);    // IDs not in memory order (7919 is prime)
    b.type = 1 + (i % 2);
    b.owner = i;
  }

  const double D = 2.0 * vmax * s.dt + s.g * s.dt * s.dt / 4.0;
  for (int i = 0; i < s.n; ++i)
    for (int j = 0; j < s.n; ++j) {
      const Body &bi = out.bodies[i], &bj = out.bodies[j];
      if (bi.id >= bj.id) continue;
      double r[3], sh[3];
      nearest_image_separation(bi.X0, bj.X0, prd, periodic, r, sh);
      const double reach = bi.radius + bj.radius + D;
      if (r[0] * r[0] + r[1] * r[1] + r[2] * r[2] <= reach * reach)
        out.edges.push_back(Edge{i, j, {sh[0], sh[1], sh[2]}});
    }

  UnionFind uf;
  uf.reset(s.n);
  for (const Edge &e : out.edges) uf.unite(e.i, e.j);
  std::vector<int> count(s.n + 1, 0);
  for (int b = 0; b < s.n; ++b) count[uf.find(b) + 1]++;
  for (int b = 0; b < s.n; ++b) count[b + 1] += count[b];
  std::vector<int> fill(count.begin(), count.end() - 1);
  out.gmembers.resize(s.n);
  for (int b = 0; b < s.n; ++b) out.gmembers[fill[uf.find(b)]++] = b;
  // Groups in the order of their representative; empty slots dropped.
  out.gstart.push_back(0);
  for (int r = 0; r < s.n; ++r)
    if (count[r + 1] > count[r]) {
      out.gstart.push_back(count[r + 1]);
      out.largest_group = std::max(out.largest_group, count[r + 1] - count[r]);
    }

  out.epair = {0.0, 0.0, 0.0, 0.0, 0.8, 0.7, 0.0, 0.7, 0.8};
  Params &p = out.p;
  p.dt = s.dt;
  p.tc = s.tc;
  p.vmin = s.vmin;
  for (int f = 0; f < NFACES; ++f) {
    p.walls.on[f] = (s.floor && f >= 4) ? 1 : 0;
    p.walls.pos[f] = (f & 1) ? prd[f / 2] : 0.0;
    p.walls.e[f] = 0.9;
  }
  p.ntypes = 2;
  p.epair = out.epair.data();
  p.maxevents = 1000L * s.n;
  return out;
}

/// What resolving one step through a backend gave.
struct StepOutcome {
  std::vector<Body> bodies;
  Tally tally;
  std::vector<long> most;    // per window, the backend's return value
};

/// A backend as the `resolve` argument of run_windows() and run_per_group().
inline auto through(HSGPU::Collide::CollisionBackend &b)
{
  return [&b](const HSGPU::Collide::WindowWork &w, const HSGPU::Collide::Params &p,
              HSGPU::Collide::Tally &t) { return b.resolve(w, p, t); };
}

/// The work of one window ending at t_end over `bodies` (a copy of sys.bodies): all of the
/// system's edges and groups.
inline HSGPU::Collide::WindowWork
window_work(const CollideSystem &sys, std::vector<HSGPU::Collide::Body> &bodies, double t_end)
{
  return HSGPU::Collide::WindowWork{bodies.data(),
                                    (int) bodies.size(),
                                    sys.edges.data(),
                                    (int) sys.edges.size(),
                                    sys.gstart.data(),
                                    sys.gmembers.data(),
                                    (int) sys.gstart.size() - 1,
                                    t_end};
}

/// Runs the step's groups through `resolve` in nwin equal windows: before each window every
/// body's w0 is its drift position at the window's start and wexc2 = 0.  One Tally collects
/// all windows (so maxevents counts across them).
template <class Resolve>
StepOutcome run_windows(const CollideSystem &sys, const Params &p, int nwin, Resolve resolve)
{
  using namespace HSGPU::Collide;
  StepOutcome out;
  out.bodies = sys.bodies;
  for (int k = 1; k <= nwin; ++k) {
    const double t0 = (k - 1) * p.dt / nwin;
    const double t1 = (k == nwin) ? p.dt : k * p.dt / nwin;
    for (Body &b : out.bodies) {
      drift_position(b, t0, b.w0);
      b.wexc2 = 0.0;
    }
    const WindowWork w = window_work(sys, out.bodies, t1);
    out.most.push_back(resolve(w, p, out.tally));
  }
  return out;
}

/// One window [0, dt) with the groups' tallies handed back one per group
/// (WindowWork::group_tally); `tally` starts with `events_before` events.
struct PerGroupOutcome {
  std::vector<Body> bodies;
  std::vector<Tally> groups;
  Tally tally;
  long most = 0;
};

template <class Resolve>
PerGroupOutcome run_per_group(const CollideSystem &sys, const Params &p, long events_before,
                              Resolve resolve)
{
  using namespace HSGPU::Collide;
  PerGroupOutcome out;
  out.bodies = sys.bodies;
  const int ng = (int) sys.gstart.size() - 1;
  out.groups.assign(ng, Tally());
  for (Tally &t : out.groups) t.events = -7;    // every entry must be written
  out.tally.events = events_before;
  WindowWork w = window_work(sys, out.bodies, p.dt);
  w.group_tally = out.groups.data();
  out.most = resolve(w, p, out.tally);
  return out;
}

inline std::string bits(double v)
{
  unsigned long long u;
  std::memcpy(&u, &v, sizeof(u));
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.17g (0x%016llx)", v, u);
  return buf;
}

/// The fields in which two bodies differ, bit for bit, with both values ("" if none).
inline std::string body_diff(const Body &x, const Body &y)
{
  std::string msg;
  auto dbl = [&](const char *name, const double *a, const double *b, int n) {
    for (int d = 0; d < n; ++d)
      if (std::memcmp(&a[d], &b[d], sizeof(double)))
        msg += std::string(" ") + name + "[" + std::to_string(d) + "] " + bits(a[d]) + " vs " +
               bits(b[d]);
  };
  auto num = [&](const char *name, long a, long b) {
    if (a != b)
      msg += std::string(" ") + name + " " + std::to_string(a) + " vs " + std::to_string(b);
  };
  dbl("x", x.x, y.x, 3);
  dbl("v", x.v, y.v, 3);
  dbl("a", x.a, y.a, 3);
  dbl("X0", x.X0, y.X0, 3);
  dbl("tref", &x.tref, &y.tref, 1);
  dbl("radius", &x.radius, &y.radius, 1);
  dbl("mass", &x.mass, &y.mass, 1);
  dbl("tlast", &x.tlast, &y.tlast, 1);
  dbl("exc2", &x.exc2, &y.exc2, 1);
  dbl("w0", x.w0, y.w0, 3);
  dbl("wexc2", &x.wexc2, &y.wexc2, 1);
  dbl("omega", x.omega, y.omega, 3);
  num("id", x.id, y.id);
  num("last", x.last, y.last);
  num("type", x.type, y.type);
  for (int d = 0; d < 3; ++d) num("rest", x.rest[d], y.rest[d]);
  num("nevents", x.nevents, y.nevents);
  num("owner", x.owner, y.owner);
  return msg;
}

/// Expects two tallies to be equal bit for bit.
inline void expect_same_tally(const Tally &s, const Tally &t, const std::string &what)
{
  EXPECT_EQ(s.pair, t.pair) << what;
  EXPECT_EQ(s.wall, t.wall) << what;
  EXPECT_EQ(s.rest, t.rest) << what;
  EXPECT_EQ(s.events, t.events) << what;
  EXPECT_EQ(s.capped, t.capped) << what;
  EXPECT_EQ(0, std::memcmp(&s.ke_lost, &t.ke_lost, sizeof(double)))
      << what << ": ke_lost " << bits(s.ke_lost) << " vs " << bits(t.ke_lost);
  for (int k = 0; k < 6; ++k)
    EXPECT_EQ(0, std::memcmp(&s.virial[k], &t.virial[k], sizeof(double)))
        << what << ": virial[" << k << "] " << bits(s.virial[k]) << " vs " << bits(t.virial[k]);
}

/// Expects the two outcomes to be equal bit for bit: every field of every body, the tallies
/// and the per-window returns.  Reports at most a few bodies.
inline void expect_same_bits(const StepOutcome &a, const StepOutcome &b, const char *what)
{
  ASSERT_EQ(a.bodies.size(), b.bodies.size()) << what;
  int reported = 0;
  long differing = 0;
  for (size_t k = 0; k < a.bodies.size(); ++k) {
    const std::string msg = body_diff(a.bodies[k], b.bodies[k]);
    if (msg.empty()) continue;
    ++differing;
    if (reported++ < 5)
      ADD_FAILURE() << what << ": body " << k << " (id " << a.bodies[k].id << ") differs:" << msg;
  }
  EXPECT_EQ(differing, 0) << what << ": bodies that differ";
  expect_same_tally(a.tally, b.tally, what);
  EXPECT_EQ(a.most, b.most) << what << ": most events of one group, per window";
}

/// Expects two per-group outcomes to be equal bit for bit.
inline void expect_same_per_group(const PerGroupOutcome &a, const PerGroupOutcome &b,
                                  const std::string &what)
{
  ASSERT_EQ(a.bodies.size(), b.bodies.size()) << what;
  long differing = 0;
  for (size_t k = 0; k < a.bodies.size(); ++k) {
    const std::string msg = body_diff(a.bodies[k], b.bodies[k]);
    if (!msg.empty() && differing++ < 5)
      ADD_FAILURE() << what << ": body " << k << " differs:" << msg;
  }
  EXPECT_EQ(differing, 0) << what << ": bodies that differ";
  ASSERT_EQ(a.groups.size(), b.groups.size()) << what;
  for (size_t g = 0; g < a.groups.size(); ++g)
    expect_same_tally(a.groups[g], b.groups[g], what + ", group " + std::to_string(g));
  expect_same_tally(a.tally, b.tally, what + ", caller's tally");
  EXPECT_EQ(a.most, b.most) << what;
}

}    // namespace hsgpu_test

#endif
