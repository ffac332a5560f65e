// The device-resident step (gpu/resident_step_cuda.h): the window cases of the CPU test
// (common/collision_world.h) with every fixed and adaptive window setting, bit for bit equal
// to the serial loop, with the CPU driver's windows and group sizes.  Skipped where no device
// is present.
#include "common/collision_world.h"
#include "common/kept_motion.h"
#include "common/lattice_gas.h"
#include "gpu/device_info.cuh"
#include "gpu/resident_step_cuda.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <memory>

using namespace hsgpu_test;

TEST(ResidentStepCuda, EqualsSerialBitwise)
{
  if (HSGPU::GPU::device_count() == 0) GTEST_SKIP() << "no CUDA device";
  std::unique_ptr<ResidentStep> rs = make_cuda_resident_step(0);
  ASSERT_TRUE(rs);
  check_windows_equal_serial(nullptr, rs.get());
}

// Order serial on the device (the seed paper's loop: one device-wide earliest event per
// iteration) against the host's serial loop, bit for bit, tallies summed in the same order.
TEST(ResidentStepCuda, SerialOrderEqualsHostSerialBitwise)
{
  if (HSGPU::GPU::device_count() == 0) GTEST_SKIP() << "no CUDA device";
  std::unique_ptr<ResidentStep> rs = make_cuda_resident_step(0);
  ASSERT_TRUE(rs);
  check_resident_serial(rs.get());
}

// Declines: an overlap at the start, a box too small for three cells, a cap on the events.
TEST(ResidentStepCuda, DeclinesWhatItCannotFinish)
{
  if (HSGPU::GPU::device_count() == 0) GTEST_SKIP() << "no CUDA device";
  std::unique_ptr<ResidentStep> rs = make_cuda_resident_step(0);
  World w = periodic_gas(5, 1.0);
  std::vector<double> epair = {0, 0, 0, 1.0};
  Params p{};
  p.dt = 0.1;
  p.ntypes = 1;
  p.epair = epair.data();
  p.maxevents = 1000000;
  const int n = (int) w.s.size();
  std::vector<Body> start(n);
  for (int i = 0; i < n; ++i) {
    Body &b = start[i];
    std::memset(&b, 0, sizeof(b));
    for (int d = 0; d < 3; ++d) {
      b.v[d] = w.s[i].u[d];
      b.x[d] = b.X0[d] = w.s[i].x[d];
      b.rest[d] = -1;
    }
    b.radius = w.s[i].r;
    b.mass = w.s[i].m;
    b.tlast = -1e30;
    b.id = w.s[i].id;
    b.type = 1;
  }
  const std::vector<double> bound(n, 0.8);    // twice the fastest drift, 3.5 x 0.1
  ResidentBox box;
  for (int d = 0; d < 3; ++d) {
    box.lo[d] = 0.0;
    box.prd[d] = 10.0;
    box.periodic[d] = 1;
  }
  box.overlap_tol = 1e-9;
  box.reach = 1e300;
  WindowSettings s;
  long events = 0;
  auto run = [&](std::vector<Body> b, const Params &pp, const ResidentBox &bx) {
    Tally t;
    ResidentReport rep;
    const std::vector<Body> before = b;
    rs->run(b.data(), bound.data(), n, bx, pp, s, t, rep);
    if (rep.outcome != ResidentOutcome::done) {
      EXPECT_EQ(0, std::memcmp(before.data(), b.data(), n * sizeof(Body))) << "bodies untouched";
      EXPECT_EQ(t.events, 0);
    }
    events = t.events;
    return rep.outcome;
  };
  ASSERT_EQ(run(start, p, box), ResidentOutcome::done);
  ASSERT_GT(events, 2) << "the step needs a few events for the cap test";
  const long all_events = events;
  std::vector<Body> ov = start;
  for (int d = 0; d < 3; ++d) ov[1].X0[d] = ov[1].x[d] = ov[0].X0[d] + (d == 0 ? 0.1 : 0.0);
  EXPECT_EQ(run(ov, p, box), ResidentOutcome::overlap);
  ResidentBox tiny = box;
  tiny.prd[1] = 5.0;    // fewer than three cells of width 2 (r + bound) <= 2.93 along y
  EXPECT_EQ(run(start, p, tiny), ResidentOutcome::small_box);
  Params capped = p;
  capped.maxevents = all_events - 1;
  EXPECT_EQ(run(start, capped, box), ResidentOutcome::capped);
}


// run_atoms() does a step whose check fails again on the device with raised bounds: atoms at
// rest get the tiniest step bound, the moving ones hit them and push them into neighbours
// that were not candidates.  The result is bit for bit that of the same step with bounds wide
// enough to need no second try (the step is exact whatever the candidates).
TEST(ResidentStepCuda, StepRedoneWithRaisedBoundsIsExact)
{
  if (HSGPU::GPU::device_count() == 0) GTEST_SKIP() << "no CUDA device";
  std::unique_ptr<ResidentStep> rs = make_cuda_resident_step(0);
  const double dt = 0.3;
  int redone = 0;
  // Gaps of 0.02 to 0.25 between the spheres' surfaces on the lattice.
  for (const double spacing : {1.02, 1.05, 1.1, 1.25}) {
    LatticeGas g(12, spacing, dt, 12345, 2);
    // x: the drift's end point, start point + v dt
    for (size_t k = 0; k < g.x.size(); ++k) g.x[k] += g.v[k] * dt;
    const std::vector<double> tlast(g.n, -1e30);
    struct Out {
      std::vector<double> x, v, tlast;
      Tally t;
      ResidentReport rep;
    };
    auto step = [&](double floor) {
      Out o{g.x, g.v, tlast, Tally(), ResidentReport()};
      const ResidentAtoms a =
          g.atoms(o.x.data(), o.v.data(), o.tlast.data(), g.radius.data(), floor);
      rs->run_atoms(a, g.box, g.p, g.s, o.t, o.rep);
      return o;
    };
    const Out tight = step(1e-9), wide = step(1.0);
    ASSERT_EQ(tight.rep.outcome, ResidentOutcome::done) << "spacing " << spacing;
    ASSERT_EQ(wide.rep.outcome, ResidentOutcome::done) << "spacing " << spacing;
    EXPECT_EQ(wide.rep.redone, 0) << "spacing " << spacing;
    EXPECT_GT(wide.t.pair, 20) << "enough collisions to mean anything";
    EXPECT_EQ(tight.t.pair, wide.t.pair) << "spacing " << spacing;
    EXPECT_EQ(tight.t.events, wide.t.events) << "spacing " << spacing;
    EXPECT_EQ(0, std::memcmp(tight.x.data(), wide.x.data(), g.x.size() * sizeof(double)));
    EXPECT_EQ(0, std::memcmp(tight.v.data(), wide.v.data(), g.v.size() * sizeof(double)));
    EXPECT_EQ(0, std::memcmp(tight.tlast.data(), wide.tlast.data(), tlast.size() * sizeof(double)));
    std::printf("[ REDO     ] spacing %.2f: %ld pair collisions, %d tries more with tight bounds\n",
                spacing, wide.t.pair, tight.rep.redone);
    redone += tight.rep.redone;
  }
  EXPECT_GE(redone, 1) << "the tight bounds needed a second try somewhere";
}

// run_atoms() keeps tlast, radius, rmass, type and id on the device between steps where the
// caller says they are unchanged (ResidentAtoms::same_atoms): three steps of a lattice gas give
// bit for bit what three steps copying everything give, with 72 bytes per atom copied up
// instead of 104; arrays that moved are copied again whatever the caller says.  Each step also
// reports the largest squared speed at its end as the host finds it.
// A caller with no forces (ResidentAtoms::zero_forces): f is neither read nor copied up, and
// the steps are those of zero forces copied up, bit for bit.  The forces given here are not
// zero, so a step that read them would differ.
TEST(ResidentStepCuda, ZeroForcesAreNotCopiedUp)
{
  if (HSGPU::GPU::device_count() == 0) GTEST_SKIP() << "no CUDA device";
  const double dt = 0.2;
  LatticeGas g(12, 1.1, dt, 4242, 1);
  const int n = g.n;
  ASSERT_TRUE(std::all_of(g.f.begin(), g.f.end(), [](double f) { return f == 0.0; }));
  const std::vector<double> junk(3 * n, 3.0);
  struct Run {
    std::unique_ptr<ResidentStep> rs = make_cuda_resident_step(0);
    std::vector<double> x, v, tlast;
    long pairs = 0, bytes_up = 0;
  };
  Run told, copied;
  for (Run *r : {&told, &copied}) {
    r->x = g.x;
    r->v = g.v;
    r->tlast.assign(n, -1e30);
  }
  for (int k = 0; k < 3; ++k)
    for (Run *r : {&told, &copied}) {
      for (int i = 0; i < 3 * n; ++i) r->x[i] += r->v[i] * dt;
      ResidentAtoms a = g.atoms(r->x.data(), r->v.data(), r->tlast.data(), g.radius.data(), -1.0);
      if (r == &told) {
        a.f = junk.data();
        a.zero_forces = true;
      }
      Tally t;
      ResidentReport rep;
      r->rs->run_atoms(a, g.box, g.p, g.s, t, rep);
      ASSERT_EQ(rep.outcome, ResidentOutcome::done);
      EXPECT_EQ(rep.amax, 0.0);
      r->pairs += t.pair;
      r->bytes_up += rep.bytes_up;
    }
  EXPECT_GT(told.pairs, 50) << "enough collisions to mean anything";
  EXPECT_EQ(told.pairs, copied.pairs);
  EXPECT_EQ(0, std::memcmp(told.x.data(), copied.x.data(), g.x.size() * sizeof(double)));
  EXPECT_EQ(0, std::memcmp(told.v.data(), copied.v.data(), g.v.size() * sizeof(double)));
  EXPECT_EQ(0, std::memcmp(told.tlast.data(), copied.tlast.data(), n * sizeof(double)));
  EXPECT_EQ(copied.bytes_up - told.bytes_up, 3L * 24 * n);
}

TEST(ResidentStepCuda, KeepsUnchangedArraysOnTheDevice)
{
  if (HSGPU::GPU::device_count() == 0) GTEST_SKIP() << "no CUDA device";
  const double dt = 0.2;
  const LatticeGas g(12, 1.1, dt, 777, 1);
  const int n = g.n;
  struct Run {
    std::unique_ptr<ResidentStep> rs = make_cuda_resident_step(0);
    std::vector<double> x, v, tlast;
    long pairs = 0;
    std::vector<long> bytes_up;
  };
  // One step: the drift (x += v dt, as the integrator does between steps), then the device.
  auto step = [&](Run &r, bool same, const std::vector<double> &rad) {
    for (int k = 0; k < 3 * n; ++k) r.x[k] += r.v[k] * dt;
    ResidentAtoms a = g.atoms(r.x.data(), r.v.data(), r.tlast.data(), rad.data(), -1.0);
    a.same_atoms = same;
    Tally t;
    ResidentReport rep;
    r.rs->run_atoms(a, g.box, g.p, g.s, t, rep);
    EXPECT_EQ(rep.outcome, ResidentOutcome::done);
    // The largest squared speed at the step end, as the host's apply_results() finds it.
    double vend2 = 0.0;
    for (int i = 0; i < n; ++i) {
      const double *w = &r.v[3 * i];
      vend2 = std::max(vend2, w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
    }
    EXPECT_EQ(rep.vend2, vend2);
    r.pairs += t.pair;
    r.bytes_up.push_back(rep.bytes_up);
  };
  Run keep, copy;
  for (Run *r : {&keep, &copy}) {
    r->x = g.x;
    r->v = g.v;
    r->tlast.assign(n, -1e30);
  }
  for (int k = 0; k < 3; ++k) {
    step(keep, k > 0, g.radius);
    step(copy, false, g.radius);
  }
  EXPECT_GT(keep.pairs, 50) << "enough collisions to mean anything";
  EXPECT_EQ(keep.pairs, copy.pairs);
  EXPECT_EQ(0, std::memcmp(keep.x.data(), copy.x.data(), g.x.size() * sizeof(double)));
  EXPECT_EQ(0, std::memcmp(keep.v.data(), copy.v.data(), g.v.size() * sizeof(double)));
  EXPECT_EQ(0, std::memcmp(keep.tlast.data(), copy.tlast.data(), n * sizeof(double)));
  const long all = 104L * n, moving = 72L * n;
  EXPECT_EQ(keep.bytes_up, (std::vector<long>{all, moving, moving}));
  EXPECT_EQ(copy.bytes_up, (std::vector<long>{all, all, all}));
  // The radii now lie elsewhere: copied up although the caller says nothing changed.
  const std::vector<double> moved = g.radius;
  step(keep, true, moved);
  EXPECT_EQ(keep.bytes_up.back(), all);
}

// The step's own copies of x and v moved as LAMMPS's integrator moves the caller's
// (ResidentAtoms::motion; common/kept_motion.h): the same bits as copying them up, 48 bytes
// per atom less on each step that moves them, the caller's rounding found by the checks.
TEST(ResidentStepCuda, KeptMotionEqualsCopiesBitwise)
{
  if (HSGPU::GPU::device_count() == 0) GTEST_SKIP() << "no CUDA device";
  check_kept_motion([] { return make_cuda_resident_step(0); }, true);
}

// The gathered step's atoms found by ID (ResidentAtoms::reordered, the shared buffers of
// share_inputs()): between steps the atoms are wrapped into the box and put in another order
// (as LAMMPS's reneighboring, exchange and sort do); the step that gets only their IDs and
// finds each atom's kept end state by ID gives the bits of the step that gets every array in
// the new order.  An ID the last step did not have: nothing done, and nothing kept after.
TEST(ResidentStepCuda, AtomsFoundByIdEqualCopies)
{
  if (HSGPU::GPU::device_count() == 0) GTEST_SKIP() << "no CUDA device";
  const double dt = 0.2;
  const LatticeGas g(12, 1.1, dt, 4242, 1);
  const int n = g.n;
  StepMotion wrap;
  wrap.dtf = 0.5 * dt;
  wrap.dtv = dt;
  for (int d = 0; d < 3; ++d) {
    wrap.lo[d] = g.box.lo[d];
    wrap.prd[d] = g.box.prd[d];
    wrap.hi[d] = g.box.lo[d] + g.box.prd[d];
    wrap.periodic[d] = 1;
  }
  struct Run {
    std::unique_ptr<ResidentStep> rs = make_cuda_resident_step(0);
    std::vector<double> x, v, tlast, radius, rmass;
    std::vector<int> type, id;
    std::vector<ResidentResult> res;
    long pairs = 0;
  };
  unsigned seed = 99;
  std::vector<int> perm(n);
  // The caller's arrays after a reneighboring: wrapped, then in the order perm.
  auto reorder = [&](Run &r) {
    auto take = [&](auto &a, int per) {
      auto was = a;
      for (int j = 0; j < n; ++j)
        for (int d = 0; d < per; ++d) a[per * j + d] = was[per * perm[j] + d];
    };
    for (int i = 0; i < n; ++i) pbc_wrap(&r.x[3 * i], wrap);
    take(r.x, 3);
    take(r.v, 3);
    take(r.tlast, 1);
    take(r.radius, 1);
    take(r.rmass, 1);
    take(r.type, 1);
    take(r.id, 1);
  };
  // One step; by_id: the IDs only, else every array.
  auto step = [&](Run &r, bool by_id) {
    std::vector<char> h;
    ASSERT_TRUE(r.rs->share_inputs(n, (int) sizeof(int), false, h));
    if (by_id) {
      r.rs->put_ids(0, n, r.id.data(), (int) sizeof(int));
    } else {
      r.rs->put_inputs(0, n, r.x.data(), r.v.data(), nullptr, n);
      r.rs->put_statics(0, n, r.tlast.data(), r.radius.data(), r.rmass.data(), r.type.data(),
                        r.id.data(), (int) sizeof(int));
    }
    ResidentAtoms a = g.atoms(r.x.data(), r.v.data(), r.tlast.data(), r.radius.data(), -1.0);
    a.rmass = r.rmass.data();
    a.type = r.type.data();
    a.id = r.id.data();
    a.inputs_shared = a.statics_shared = true;
    a.zero_forces = true;
    a.results = &r.res;
    a.reordered = by_id;
    a.motion.use = MotionUse::advance;
    a.motion.keep = true;
    a.motion.move = wrap;
    a.motion.move.wrap = by_id;    // the caller's arrays were wrapped, the kept state not
    Tally t;
    ResidentReport rep;
    r.rs->run_atoms(a, g.box, g.p, g.s, t, rep);
    ASSERT_EQ(rep.outcome, ResidentOutcome::done);
    ASSERT_EQ(rep.motion, MotionUse::advance);
    ASSERT_TRUE(r.rs->get_atoms(0, n, r.x.data(), r.v.data(), r.tlast.data()));
    r.pairs += t.pair;
  };
  Run ids, copies;
  for (Run *r : {&ids, &copies}) {
    r->x = g.x;
    r->v = g.v;
    r->tlast.assign(n, -1e30);
    r->radius = g.radius;
    r->rmass = g.rmass;
    r->type = g.type;
    r->id = g.id;
    // Two sizes and masses, so that a wrong atom's state would show.
    for (int i = 0; i < n; i += 3) {
      r->radius[i] = 0.4;
      r->rmass[i] = 0.6;
    }
  }
  for (int k = 0; k < 6; ++k) {
    if (k > 0) {
      for (int j = 0; j < n; ++j) perm[j] = j;
      for (int j = n - 1; j > 0; --j) {
        seed = seed * 1103515245u + 12345u;
        std::swap(perm[j], perm[(seed >> 8) % (unsigned) (j + 1)]);
      }
      reorder(ids);
      reorder(copies);
    }
    step(ids, k > 0);
    step(copies, false);
  }
  EXPECT_GT(copies.pairs, 100) << "enough collisions to mean anything";
  EXPECT_EQ(ids.pairs, copies.pairs);
  EXPECT_EQ(ids.id, copies.id);
  EXPECT_EQ(0, std::memcmp(ids.x.data(), copies.x.data(), 3 * n * sizeof(double)));
  EXPECT_EQ(0, std::memcmp(ids.v.data(), copies.v.data(), 3 * n * sizeof(double)));
  EXPECT_EQ(0, std::memcmp(ids.tlast.data(), copies.tlast.data(), n * sizeof(double)));
  // An ID the last step did not have: nothing done, and no state kept for the next.
  for (int round = 0; round < 2; ++round) {
    std::vector<char> h;
    ASSERT_TRUE(ids.rs->share_inputs(n, (int) sizeof(int), false, h));
    std::vector<int> bad = ids.id;
    if (round == 0) bad[n / 2] = 10 * n;
    ids.rs->put_ids(0, n, bad.data(), (int) sizeof(int));
    ResidentAtoms a = g.atoms(ids.x.data(), ids.v.data(), ids.tlast.data(), ids.radius.data(), -1.0);
    a.inputs_shared = a.statics_shared = a.zero_forces = a.reordered = true;
    a.results = &ids.res;
    a.motion.use = MotionUse::advance;
    a.motion.keep = true;
    a.motion.move = wrap;
    Tally t;
    ResidentReport rep;
    ids.rs->run_atoms(a, g.box, g.p, g.s, t, rep);
    EXPECT_EQ(rep.motion, MotionUse::copy) << "round " << round;
    EXPECT_EQ(t.pair, 0) << "round " << round;
    EXPECT_FALSE(ids.rs->get_atoms(0, n, ids.x.data(), ids.v.data(), ids.tlast.data()));
  }
}
