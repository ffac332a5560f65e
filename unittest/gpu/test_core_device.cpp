// The physics core on the device gives the host's bits.  Every host-device function of core/
// (contact.h, impulse.h, trajectory.h, collision_step.h, event_order.h's earlier) is evaluated
// on a few hundred varied inputs by gpu/core_device_check.h's evaluate_core_case, once
// compiled by the host compiler here and once by nvcc in a kernel, and each output is compared
// with memcmp.  The inputs include pairs grazing at contact (gaps down to 1e-16 of the contact
// distance, nearly tangential velocities), touching and overlapping pairs, pairs that have
// just collided with each other, bodies on and near walls under gravity (resting, falling,
// leaving, with exact zero normal speeds), periodic images at exactly half a box, and event
// keys with ties.
// Label gpu: the comparison is skipped where no CUDA device is usable (the inputs' coverage
// of the branches is still checked on the host).
#include "gpu/core_device_check.h"
#include "gpu/device_info.cuh"

#include "collide_system.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <vector>

using namespace HSGPU::Collide;
using HSGPU::GPU::CoreCase;
using HSGPU::GPU::CoreResult;

namespace {

constexpr int NCASES = 480;
constexpr int NKINDS = 8;
constexpr int NTYPES = 2;
// The restitution table ((NTYPES + 1)^2) followed by the friction table (mu, beta0 per type
// pair): core_tables_size(NTYPES) values.  Type pair 1-1 slides easily (mu 0.1), 1-2 sticks
// with a negative beta0, 2-2 is smooth (mu 0).
const std::vector<double> TABLES = {0.0, 0.0, 0.0, 0.0, 0.8, 0.7, 0.0, 0.7, 0.95,
                                    0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.1, 0.3,
                                    0.8, -0.2, 0.0, 0.0, 0.8, -0.2, 0.0, 0.0};

struct Gen {
  std::mt19937_64 rng;
  explicit Gen(unsigned seed) : rng(seed) {}
  double u(double lo = 0.0, double hi = 1.0)
  {
    return std::uniform_real_distribution<double>(lo, hi)(rng);
  }
  double n() { return std::normal_distribution<double>(0.0, 1.0)(rng); }
  int i(int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng); }
  bool coin(double p = 0.5) { return u() < p; }
  // 10^U(lo, hi)
  double logu(double lo, double hi) { return std::pow(10.0, u(lo, hi)); }
  void unit(double *e)
  {
    double r2 = 0.0;
    do {
      for (int d = 0; d < 3; ++d) e[d] = n();
      r2 = e[0] * e[0] + e[1] * e[1] + e[2] * e[2];
    } while (r2 < 1e-6);
    const double r = std::sqrt(r2);
    for (int d = 0; d < 3; ++d) e[d] /= r;
  }
};

Body random_body(Gen &g, long id, const Params &p, double gz)
{
  Body b;
  std::memset(&b, 0, sizeof(b));
  for (int d = 0; d < 3; ++d) {
    b.x[d] = g.u(0.5, 9.5);
    b.v[d] = g.n();
    b.a[d] = (d == 2) ? -gz : 0.0;
    b.rest[d] = -1;
  }
  if (g.coin(0.2))
    for (int d = 0; d < 3; ++d) b.a[d] += 0.3 * g.n();    // non-uniform forces
  b.tref = g.coin(0.4) ? 0.0 : g.u(0.0, 0.9 * p.dt);
  for (int d = 0; d < 3; ++d) {
    b.X0[d] = b.x[d] - b.v[d] * b.tref;
    b.w0[d] = b.X0[d] + 1e-3 * g.n();
  }
  b.exc2 = g.coin() ? 0.0 : g.u(0.0, 1e-4);
  b.wexc2 = g.coin() ? 0.0 : g.u(0.0, 1e-4);
  b.radius = g.u(0.2, 0.6);
  b.mass = g.u(0.3, 3.0);
  b.tlast = g.coin(0.5) ? -1.0 : g.u(0.0, b.tref);
  b.id = id;
  b.last = 0;
  b.type = g.i(1, NTYPES);
  b.nevents = g.i(0, 4);
  b.owner = (int) id;
  if (g.coin(0.7))
    for (int d = 0; d < 3; ++d) b.omega[d] = 3.0 * g.n();
  return b;
}

// Moves bj so that at t0 = max(trefs) it is at distance s (1 + gap) from bi (through the
// periodic shift of the edge) along a random normal, with relative velocity
// -approach n + tangential.
void place_partner(Gen &g, Body &bi, Body &bj, const Edge &e, double gap, double approach,
                   double tangential)
{
  const double t0 = bi.tref > bj.tref ? bi.tref : bj.tref;
  double n[3], t[3];
  g.unit(n);
  g.unit(t);
  const double tn = t[0] * n[0] + t[1] * n[1] + t[2] * n[2];
  for (int d = 0; d < 3; ++d) t[d] -= tn * n[d];
  const double s = bi.radius + bj.radius;
  for (int d = 0; d < 3; ++d) {
    const double pi = bi.x[d] + bi.v[d] * (t0 - bi.tref);
    const double vrel = -approach * n[d] + tangential * t[d];
    bj.v[d] = bi.v[d] - vrel;
    const double pj = pi - s * (1.0 + gap) * n[d] - e.shift[d];
    bj.x[d] = pj - bj.v[d] * (t0 - bj.tref);
  }
}

Event random_event(Gen &g, double dt)
{
  Event e;
  const double times[] = {0.0, 0.25 * dt, 0.5 * dt, 0.5 * dt, HUGE_VAL, 0.1 * dt};
  e.t = times[g.i(0, 5)];
  if (g.coin(0.3)) e.t = g.u(0.0, dt);
  e.k1 = g.i(1, 4);
  e.k2 = g.coin(0.3) ? -1 - g.i(0, 5) : g.i(1, 6);
  e.index = g.i(0, 100);
  e.face = g.coin(0.3) ? g.i(0, 5) : -1;
  e.s1 = g.i(0, 3);
  e.s2 = g.i(0, 3);
  return e;
}

CoreCase make_case(Gen &g, int k)
{
  const int kind = k % NKINDS;
  CoreCase c{};
  Params &p = c.p;
  p.dt = g.coin() ? 0.01 : g.logu(-4, -1);
  p.tc = g.coin(0.3) ? 0.0 : g.u(0.0, 0.5 * p.dt);
  p.vmin = g.coin(0.5) ? 0.0 : g.logu(-4, -1);
  p.vmin_atc = g.coin(0.5) ? 0.0 : 30.0;    // vmin auto (collision_step.h)
  p.tcslow = g.coin(0.5) ? 1 : 0;
  for (int f = 0; f < NFACES; ++f) {
    p.walls.on[f] = g.coin(0.4);
    p.walls.pos[f] = (f & 1) ? 10.0 : 0.0;
    p.walls.e[f] = g.coin() ? 0.9 : g.u(0.0, 1.0);
    p.walls.mu[f] = g.coin(0.3) ? 0.0 : g.u(0.0, 0.8);
    p.walls.beta[f] = g.u(-1.0, 1.0);
  }
  // Rough spheres in about half the cases, both guard modes, spheres and discs.
  p.friction = g.coin(0.5) ? 0 : (g.coin() ? FRICTION_WALTON : FRICTION_GUARDED);
  p.inertia = g.coin(0.7) ? 0.4 : 0.5;
  p.fpair = nullptr;
  p.epair = nullptr;
  p.maxevents = 1000;
  const double gz = g.coin(0.6) ? 9.81 : 0.0;

  // Contact inputs: generic, or grazing / touching / overlapping below.
  for (int d = 0; d < 3; ++d) {
    c.r[d] = g.n();
    c.v[d] = g.n();
  }
  c.s = g.u(0.5, 2.0);
  c.bmin = g.coin() ? 0.0 : ROUNDOFF_APPROACH * c.s * g.u(0.0, 6.0);
  c.g[0] = g.n() * 0.01;
  c.g[1] = g.n();
  c.g[2] = g.coin(0.2) ? 0.0 : g.n() * 10.0;

  c.e = g.coin() ? 0.8 : g.u(0.0, 1.0);
  c.since_i = g.u(0.0, 2e-3);
  c.since_j = g.u(0.0, 2e-3);
  c.tc = g.coin(0.5) ? 0.0 : 1e-3;
  c.vn = -g.logu(-5, 1);
  c.vmin = g.coin(0.5) ? 0.0 : g.logu(-4, 0);
  c.mi = g.u(0.1, 3.0);
  c.mj = g.coin(0.2) ? c.mi : g.u(0.1, 3.0);
  c.J = g.n();
  g.unit(c.n);
  for (int d = 0; d < 3; ++d) {
    c.vi[d] = g.n();
    c.vj[d] = g.n();
  }

  c.bi = random_body(g, 1 + g.i(0, 5), p, gz);
  c.bj = random_body(g, 7 + g.i(0, 5), p, gz);
  if (g.coin(0.6))
    for (int d = 0; d < 3; ++d) c.bj.a[d] = c.bi.a[d];    // a uniform field
  c.edge.i = 0;
  c.edge.j = 1;
  for (int d = 0; d < 3; ++d) c.edge.shift[d] = g.coin(0.3) ? 10.0 * g.i(-1, 1) : 0.0;
  c.t = g.u(c.bi.tref, p.dt);
  c.dim = g.i(0, 2);
  c.face = g.i(0, 5);
  for (int d = 0; d < 3; ++d) {
    c.periodic[d] = g.coin(0.7);
    c.prd[d] = g.coin() ? 10.0 : g.u(3.0, 20.0);
    c.xi[d] = g.u(0.0, c.prd[d]);
    c.xj[d] = g.u(0.0, c.prd[d]);
  }
  c.ea = random_event(g, p.dt);
  c.eb = g.coin(0.3) ? c.ea : random_event(g, p.dt);
  // An atom between two steps: near the box's faces (or on them) where it is wrapped.
  c.move.dtv = p.dt;
  c.move.dtf = 0.5 * p.dt * (g.coin() ? 1.0 : g.u(0.5, 2.0));
  c.move.wrap = g.coin(0.7);
  for (int d = 0; d < 3; ++d) {
    c.move.periodic[d] = g.coin(0.8);
    c.move.lo[d] = g.coin() ? 0.0 : g.n();
    c.move.prd[d] = c.prd[d];
    c.move.hi[d] = c.move.lo[d] + c.move.prd[d];
    const int where = g.i(0, 3);
    c.mx[d] = where == 0   ? c.move.lo[d] - g.logu(-17, -1)
              : where == 1 ? c.move.hi[d] + g.logu(-17, -1) * (g.coin(0.2) ? 0.0 : 1.0)
                           : g.u(c.move.lo[d], c.move.hi[d]);
    c.mv[d] = g.n();
    c.mf[d] = g.coin(0.2) ? 0.0 : g.n() * 5.0;
  }
  c.mm = g.u(0.1, 3.0);

  switch (kind) {
  case 0:    // generic pair approaching at a moderate gap
    place_partner(g, c.bi, c.bj, c.edge, g.u(0.0, 0.02), g.u(0.1, 5.0), g.n());
    break;
  case 1: {    // grazing at contact: tiny gap, nearly tangential approach
    const double gap = g.coin(0.2) ? 0.0 : g.logu(-16, -6);
    place_partner(g, c.bi, c.bj, c.edge, gap, g.logu(-12, -2), g.u(0.5, 3.0));
    // The same geometry for pair_contact_time directly.
    double n[3], t[3];
    g.unit(n);
    g.unit(t);
    const double tn = t[0] * n[0] + t[1] * n[1] + t[2] * n[2];
    const double gap2 = g.logu(-16, -4), vnorm = g.logu(-12, 0);
    for (int d = 0; d < 3; ++d) {
      c.r[d] = c.s * (1.0 + gap2) * n[d];
      c.v[d] = -vnorm * n[d] + (t[d] - tn * n[d]);
    }
    break;
  }
  case 2: {    // touching or overlapping, approaching or receding
    const double gap = g.coin(0.3) ? 0.0 : -g.logu(-12, -2);
    place_partner(g, c.bi, c.bj, c.edge, gap, g.coin() ? g.u(0.01, 2.0) : -g.u(0.01, 2.0), g.n());
    double n[3];
    g.unit(n);
    const double sgn = g.coin() ? 1.0 : -1.0;
    for (int d = 0; d < 3; ++d) {
      c.r[d] = c.s * (1.0 + gap) * n[d];
      c.v[d] = -sgn * g.u(0.01, 2.0) * n[d] + 0.3 * g.n();
    }
    break;
  }
  case 3: {    // falling onto the floor (face 4) under gravity, or rising to the roof
    Body &b = c.bi;
    const int f = g.coin(0.7) ? 4 : 5;
    p.walls.on[f] = 1;
    b.a[2] = -9.81;
    const double gap = g.coin(0.2) ? 0.0 : g.coin(0.2) ? -g.logu(-10, -3) : g.logu(-10, -1);
    const double un = g.coin(0.2) ? 0.0 : -g.logu(-6, 1);    // along the wall's normal
    const double s = face_sign(f);
    const double tr = b.tref;
    const double P = p.walls.pos[f] + s * (b.radius + gap);
    b.x[2] = P - bow(b, 2, tr, p.dt);
    b.v[2] = s * un - b.a[2] * (tr - 0.5 * p.dt);
    c.face = f;
    c.g[0] = gap;
    c.g[1] = un;
    c.g[2] = g.coin(0.2) ? 0.0 : s * b.a[2];
    break;
  }
  case 4: {    // on the floor: resting, hopping, or exactly still (signed zeros)
    Body &b = c.bi;
    p.walls.on[4] = 1;
    p.walls.on[5] = g.coin();
    b.a[2] = g.coin(0.8) ? -9.81 : 0.0;
    if (g.coin(0.5)) b.rest[2] = 4;
    b.x[2] = b.radius - bow(b, 2, b.tref, p.dt);
    b.v[2] = g.coin(0.3) ? 0.0 : g.coin() ? -0.0 : -b.a[2] * (b.tref - 0.5 * p.dt);
    if (g.coin(0.3)) {    // the roof, with an exact zero normal speed: s u = -0
      b.a[2] = 0.0;
      b.v[2] = 0.0;
      b.x[2] = 10.0 - b.radius;
      c.face = 5;
    } else {
      c.face = 4;
    }
    c.t = g.coin(0.5) ? b.tref : g.u(b.tref, p.dt);
    c.g[0] = g.coin() ? 0.0 : -0.0;
    c.g[1] = g.coin() ? 0.0 : -0.0;
    c.g[2] = g.coin() ? -9.81 : 0.0;
    break;
  }
  case 5: {    // periodic images at and near half a box
    for (int d = 0; d < 3; ++d) {
      c.periodic[d] = 1;
      c.prd[d] = g.coin() ? 10.0 : 7.3;
      c.xj[d] = g.u(0.0, c.prd[d]);
      const int which = g.i(0, 4);
      double dx = 0.5 * c.prd[d];
      if (which == 1) dx = -0.5 * c.prd[d];
      if (which == 2) dx = std::nextafter(0.5 * c.prd[d], 0.0);
      if (which == 3) dx = 1.5 * c.prd[d];
      if (which == 4) dx = g.u(-2.0, 2.0) * c.prd[d];
      c.xi[d] = c.xj[d] + dx;
    }
    place_partner(g, c.bi, c.bj, c.edge, g.u(0.0, 0.05), g.u(0.1, 2.0), g.n());
    break;
  }
  case 6:    // the pair's latest events were their collision with each other
    place_partner(g, c.bi, c.bj, c.edge, g.logu(-14, -8), g.u(0.1, 2.0), g.n());
    if (g.coin(0.7)) {
      c.bi.last = c.bj.id;
      c.bj.last = c.bi.id;
    } else {
      c.bi.last = c.bj.id;    // only one of them: not the exception
    }
    break;
  default:    // guards: the TC model and the elastic threshold
    place_partner(g, c.bi, c.bj, c.edge, g.logu(-10, -3), g.logu(-4, 0), g.n());
    p.tc = p.dt;
    c.bi.tlast = g.u(0.0, c.bi.tref);
    p.vmin = g.coin() ? 0.5 : 0.0;
    c.since_i = 0.5 * c.tc;
    break;
  }
  return c;
}

std::vector<CoreCase> make_cases()
{
  Gen g(20261123);
  std::vector<CoreCase> cases;
  for (int k = 0; k < NCASES; ++k) cases.push_back(make_case(g, k));
  return cases;
}

std::vector<CoreResult> on_host(const std::vector<CoreCase> &cases)
{
  std::vector<CoreResult> out(cases.size());
  for (size_t k = 0; k < cases.size(); ++k) {
    HSGPU::GPU::evaluate_core_case(cases[k], TABLES.data(), NTYPES, out[k]);
  }
  return out;
}

std::string hex(const void *p, size_t n)
{
  std::string s;
  const unsigned char *b = static_cast<const unsigned char *>(p);
  char buf[4];
  for (size_t k = 0; k < n; ++k) {
    std::snprintf(buf, sizeof(buf), "%02x", b[n - 1 - k]);
    s += buf;
    if (k % 8 == 7 && k + 1 < n) s += ' ';
  }
  return s;
}

// Compares one output field of every case; reports the first few differing cases.
struct Comparer {
  const std::vector<CoreResult> &h, &d;
  int failures = 0;
  template <class Field> void field(const char *name, Field CoreResult::*m)
  {
    int shown = 0, differing = 0;
    for (size_t k = 0; k < h.size(); ++k) {
      if (std::memcmp(&(h[k].*m), &(d[k].*m), sizeof(Field)) == 0) continue;
      ++differing;
      if (shown++ < 4)
        ADD_FAILURE() << name << " differs in case " << k << " (kind " << k % NKINDS << "): host "
                      << hex(&(h[k].*m), sizeof(Field)) << ", device "
                      << hex(&(d[k].*m), sizeof(Field));
    }
    if (differing) {
      ++failures;
      ADD_FAILURE() << name << ": " << differing << " of " << h.size() << " cases differ";
    }
  }
  // Bodies field by field (whatever padding they have is not compared).
  void body(const char *name, Body CoreResult::*m)
  {
    int differing = 0;
    for (size_t k = 0; k < h.size(); ++k) {
      const std::string diff = hsgpu_test::body_diff(h[k].*m, d[k].*m);
      if (diff.empty()) continue;
      if (differing++ < 4)
        ADD_FAILURE() << name << " differs in case " << k << " (kind " << k % NKINDS
                      << "), host vs device:" << diff;
    }
    if (differing) {
      ++failures;
      ADD_FAILURE() << name << ": " << differing << " of " << h.size() << " cases differ";
    }
  }
  // Tally has padding after `capped`: compare its fields.
  void tally(const char *name, Tally CoreResult::*m)
  {
    int differing = 0;
    for (size_t k = 0; k < h.size(); ++k) {
      const Tally &a = h[k].*m, &b = d[k].*m;
      const bool same = a.pair == b.pair && a.wall == b.wall && a.rest == b.rest &&
                        a.events == b.events && a.capped == b.capped &&
                        std::memcmp(&a.ke_lost, &b.ke_lost, sizeof(double)) == 0 &&
                        std::memcmp(a.virial, b.virial, sizeof(a.virial)) == 0;
      if (same) continue;
      if (differing++ < 4)
        ADD_FAILURE() << name << " differs in case " << k << " (kind " << k % NKINDS
                      << "): ke_lost host " << hex(&a.ke_lost, 8) << ", device "
                      << hex(&b.ke_lost, 8);
    }
    if (differing) ++failures;
  }
};

// The inputs reach every branch that matters (checked on the host, device or not).
void expect_coverage(const std::vector<CoreCase> &cases, const std::vector<CoreResult> &r)
{
  int contact_finite = 0, contact_zero = 0, contact_never = 0, tiny_gap = 0;
  int wall_finite = 0, wall_zero = 0, wall_never = 0;
  int pair_event = 0, pair_never_mutual = 0, pair_impulse = 0, pair_degenerate = 0;
  int wall_event = 0, rested = 0, bounced = 0, image_shift = 0, half_box = 0;
  int ab = 0, ba = 0, tie = 0, elastic_guard = 0;
  int wrapped = 0, fused_differs = 0;    // verlet_motion.h: atoms wrapped, roundings apart
  int rough_pair = 0, rough_wall = 0, smooth_spun = 0;    // friction changed a spin
  for (size_t k = 0; k < r.size(); ++k) {
    const CoreCase &c = cases[k];
    const CoreResult &o = r[k];
    if (o.pair_contact_time == 0.0)
      ++contact_zero;
    else if (o.pair_contact_time == HUGE_VAL)
      ++contact_never;
    else
      ++contact_finite;
    if (o.pair_contact_time > 0.0 && o.pair_contact_time < HUGE_VAL &&
        std::fabs(o.dot3_minus_square_rr) < 1e-8 * c.s * c.s)
      ++tiny_gap;
    if (o.wall_contact_time == 0.0)
      ++wall_zero;
    else if (o.wall_contact_time == HUGE_VAL)
      ++wall_never;
    else
      ++wall_finite;
    if (o.pair_event_time < c.p.dt) ++pair_event;
    if (c.bi.last == c.bj.id && c.bj.last == c.bi.id) ++pair_never_mutual;
    if (o.pair_tally.pair == 1) ++pair_impulse;
    if (o.pair_tally.events == 1 && o.pair_tally.pair == 0) ++pair_degenerate;
    if (o.wall_event_time < c.p.dt) ++wall_event;
    if (o.wall_tally.rest == 1)
      ++rested;
    else
      ++bounced;
    for (int d = 0; d < 3; ++d) {
      if (o.image_shift[d] != 0.0) ++image_shift;
      if (c.periodic[d] && std::fabs(c.xi[d] - c.xj[d]) == 0.5 * c.prd[d]) ++half_box;
    }
    ab += o.earlier_ab;
    ba += o.earlier_ba;
    for (int d = 0; d < 3; ++d) {
      if (c.move.wrap && c.move.periodic[d] && (c.mx[d] < c.move.lo[d] || c.mx[d] >= c.move.hi[d]))
        ++wrapped;
      if (std::memcmp(&o.moved_x[0][d], &o.moved_x[1][d], sizeof(double)) != 0) ++fused_differs;
    }
    if (!o.earlier_ab && !o.earlier_ba) ++tie;
    if (o.effective_restitution == 1.0 && c.e != 1.0) ++elastic_guard;
    const bool pair_spun = std::memcmp(o.pair_i.omega, c.bi.omega, sizeof(c.bi.omega)) != 0;
    const bool wall_spun = std::memcmp(o.wall_b.omega, c.bi.omega, sizeof(c.bi.omega)) != 0;
    if (c.p.friction && pair_spun) ++rough_pair;
    if (c.p.friction && wall_spun) ++rough_wall;
    if (!c.p.friction && (pair_spun || wall_spun)) ++smooth_spun;
  }
  const int need = 10;
  EXPECT_GE(contact_finite, need);
  EXPECT_GE(contact_zero, need);
  EXPECT_GE(contact_never, need);
  EXPECT_GE(tiny_gap, need) << "grazing contacts";
  EXPECT_GE(wall_finite, need);
  EXPECT_GE(wall_zero, need);
  EXPECT_GE(wall_never, need);
  EXPECT_GE(pair_event, 3 * need);
  EXPECT_GE(pair_never_mutual, need);
  EXPECT_GE(pair_impulse, 3 * need);
  EXPECT_GE(pair_degenerate, need) << "pairs found not approaching at the event";
  EXPECT_GE(wall_event, 3 * need);
  EXPECT_GE(rested, need);
  EXPECT_GE(bounced, need);
  EXPECT_GE(image_shift, need);
  EXPECT_GE(half_box, need);
  EXPECT_GE(ab, need);
  EXPECT_GE(ba, need);
  EXPECT_GE(tie, need);
  EXPECT_GE(elastic_guard, need);
  EXPECT_GE(rough_pair, need) << "pair collisions with friction";
  EXPECT_GE(rough_wall, need) << "wall collisions with friction";
  EXPECT_EQ(smooth_spun, 0) << "smooth spheres never change their spin";
  EXPECT_GE(wrapped, need) << "atoms wrapped into the box between steps";
  EXPECT_GE(fused_differs, need) << "plain and fused rounding apart";
  std::printf("[ info     ] %zu cases: pair contact finite/zero/never %d/%d/%d (%d grazing), "
              "wall contact %d/%d/%d, pair events %d (%d impulses, %d degenerate), wall events "
              "%d (%d rests), %d nonzero image shifts (%d at half a box)\n",
              r.size(), contact_finite, contact_zero, contact_never, tiny_gap, wall_finite,
              wall_zero, wall_never, pair_event, pair_impulse, pair_degenerate, wall_event, rested,
              image_shift, half_box);
}

TEST(CoreDevice, DeviceGivesHostBits)
{
  const std::vector<CoreCase> cases = make_cases();
  const std::vector<CoreResult> host = on_host(cases);
  expect_coverage(cases, host);
  if (HSGPU::GPU::device_count() == 0)
    GTEST_SKIP() << "no usable CUDA device (or built without CUDA): host inputs checked, the "
                    "device comparison is not run";

  std::vector<CoreResult> dev(cases.size());
  HSGPU::GPU::run_core_cases_on_device(0, cases.data(), (int) cases.size(), TABLES.data(), NTYPES,
                                       dev.data());
  Comparer c{host, dev};
#define HSGPU_FIELD(f) c.field(#f, &CoreResult::f)
  HSGPU_FIELD(pair_contact_time);
  HSGPU_FIELD(pair_contact_time_no_dead);
  HSGPU_FIELD(dot3_rv);
  HSGPU_FIELD(dot3_minus_square_rr);
  HSGPU_FIELD(dot3_minus_square_rv);
  HSGPU_FIELD(two_sum_s);
  HSGPU_FIELD(two_sum_e);
  HSGPU_FIELD(wall_contact_time);
  HSGPU_FIELD(effective_restitution);
  HSGPU_FIELD(reduced_mass);
  HSGPU_FIELD(pair_impulse);
  HSGPU_FIELD(energy_loss);
  HSGPU_FIELD(energy_change);
  HSGPU_FIELD(impulse_vi);
  HSGPU_FIELD(impulse_vj);
  HSGPU_FIELD(face_sign);
  HSGPU_FIELD(drift);
  HSGPU_FIELD(bow);
  c.body("excursion", &CoreResult::excursion);
  HSGPU_FIELD(pair_event_time);
  HSGPU_FIELD(wall_event_time);
  HSGPU_FIELD(image_r);
  HSGPU_FIELD(image_shift);
  c.body("pair_i", &CoreResult::pair_i);
  c.body("pair_j", &CoreResult::pair_j);
  c.body("wall_b", &CoreResult::wall_b);
  c.body("end_b", &CoreResult::end_b);
  HSGPU_FIELD(end_x);
  HSGPU_FIELD(end_vhalf);
  HSGPU_FIELD(face_dim);
  HSGPU_FIELD(wall_face);
  HSGPU_FIELD(earlier_ab);
  HSGPU_FIELD(earlier_ba);
  HSGPU_FIELD(earlier_aa);
  HSGPU_FIELD(moved_x);
  HSGPU_FIELD(moved_v);
#undef HSGPU_FIELD
  c.tally("pair_tally", &CoreResult::pair_tally);
  c.tally("wall_tally", &CoreResult::wall_tally);
  EXPECT_EQ(c.failures, 0) << "outputs that differ between host and device";
}

}    // namespace
