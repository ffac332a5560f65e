// The host's reference resident step (engine/host_resident_step.cpp) under the contract the
// CUDA step is tested against (common/collision_world.h): every window case and setting bit for
// bit equal to the serial loop, with the host driver's windows and groups; order serial with
// the serial loop's tallies; run_atoms() writing the atoms' arrays, or listing the atoms with
// events (ResidentAtoms::results) with the same values; and its declines.
#include "common/collision_world.h"
#include "common/kept_motion.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>

using namespace hsgpu_test;

TEST(ResidentStepHost, EqualsSerialBitwise)
{
  std::unique_ptr<ResidentStep> rs = make_host_resident_step();
  check_windows_equal_serial(nullptr, rs.get());
}

TEST(ResidentStepHost, SerialOrderEqualsHostSerialBitwise)
{
  std::unique_ptr<ResidentStep> rs = make_host_resident_step();
  check_resident_serial(rs.get());
}

namespace {

// The per-atom arrays of a world (the drift's end points x0 + v dt, no forces).
struct Atoms {
  std::vector<double> x, v, f, tlast, radius, rmass;
  std::vector<int> type;
  std::vector<long long> id;
  ResidentAtoms view()
  {
    ResidentAtoms a{};
    a.n = (int) radius.size();
    a.x = x.data();
    a.v = v.data();
    a.f = f.data();
    a.tlast = tlast.data();
    a.radius = radius.data();
    a.rmass = rmass.data();
    a.type = type.data();
    a.id = id.data();
    a.id_bytes = 8;
    a.ftm2v = 1.0;
    a.bound_floor = -1.0;
    a.reach = 1e300;
    a.never = -1e30;
    return a;
  }
};

Atoms atoms_of(const World &w, double dt)
{
  Atoms a;
  for (const Sphere &s : w.s) {
    for (int d = 0; d < 3; ++d) {
      a.x.push_back(s.x[d] + s.u[d] * dt);
      a.v.push_back(s.u[d]);
      a.f.push_back(0.0);
    }
    a.tlast.push_back(s.tlast);
    a.radius.push_back(s.r);
    a.rmass.push_back(s.m);
    a.type.push_back(1);
    a.id.push_back(s.id);
  }
  return a;
}

// A gas's step parameters: restitution e of its one type, no cap that matters.
Params gas_params(double dt, std::vector<double> &epair, double e)
{
  epair = {0, 0, 0, e};
  Params p{};
  p.dt = dt;
  p.ntypes = 1;
  p.epair = epair.data();
  p.maxevents = 1000000;
  return p;
}

}    // namespace

// run_atoms(): the arrays written in place, and with ResidentAtoms::results the same values
// listed instead (the arrays then unchanged but for tlast), over several steps of a gas.
TEST(ResidentStepHost, RunAtomsListsWhatItWouldWrite)
{
  World w = periodic_gas(7, 0.9);
  const double dt = 0.05;
  std::vector<double> epair;
  const Params p = gas_params(dt, epair, 0.9);
  WindowSettings s{};
  std::unique_ptr<ResidentStep> wr = make_host_resident_step(), li = make_host_resident_step();
  Atoms a = atoms_of(w, dt);
  long changed = 0;
  long redone = 0;
  for (int step = 0; step < 20; ++step) {
    Atoms b = a;
    Tally ta, tb;
    ResidentReport ra, rb;
    std::vector<ResidentResult> res;
    // A step in which an atom moved further than its bound is declined, as given, and done
    // again with larger bounds (as its callers do).
    for (double floor : {-1.0, 0.3, 1.0}) {
      ResidentAtoms va = a.view(), vb = b.view();
      va.bound_floor = vb.bound_floor = floor;
      vb.results = &res;
      wr->run_atoms(va, resident_box(w), p, s, ta, ra);
      li->run_atoms(vb, resident_box(w), p, s, tb, rb);
      ASSERT_EQ(ra.outcome, rb.outcome) << "step " << step;
      if (ra.outcome == ResidentOutcome::done) break;
      ASSERT_EQ(ra.outcome, ResidentOutcome::excursion) << "step " << step;
      ASSERT_EQ(a.x, b.x);
      ASSERT_EQ(ta.events, 0);
      ++redone;
    }
    ASSERT_EQ(ra.outcome, ResidentOutcome::done) << "step " << step;
    ASSERT_EQ(ta.events, tb.events);
    ASSERT_EQ((long) res.size(), rb.changed);
    ASSERT_EQ(ra.changed, rb.changed);
    EXPECT_GT(ta.pair, 0) << "step " << step;
    changed += rb.changed;
    // Listed atoms in increasing index; their values are what the other step wrote.
    std::vector<char> listed(a.radius.size(), 0);
    for (size_t k = 0; k < res.size(); ++k) {
      const int i = res[k].index;
      if (k > 0) {
        ASSERT_LT(res[k - 1].index, i);
      }
      listed[i] = 1;
      for (int d = 0; d < 3; ++d) {
        ASSERT_EQ(std::memcmp(&res[k].x[d], &a.x[3 * i + d], sizeof(double)), 0);
        ASSERT_EQ(std::memcmp(&res[k].v[d], &a.v[3 * i + d], sizeof(double)), 0);
      }
    }
    for (size_t i = 0; i < listed.size(); ++i) {
      ASSERT_EQ(std::memcmp(&a.tlast[i], &b.tlast[i], sizeof(double)), 0);
      if (listed[i]) continue;
      // Not listed: as given, in both.
      for (int d = 0; d < 3; ++d) {
        ASSERT_EQ(std::memcmp(&a.x[3 * i + d], &b.x[3 * i + d], sizeof(double)), 0);
        ASSERT_EQ(std::memcmp(&a.v[3 * i + d], &b.v[3 * i + d], sizeof(double)), 0);
      }
      ASSERT_LT(a.tlast[i], -dt * (1.0 - 1e-12));    // no collision in this step
    }
    // The next step from the end of this one: drift to the next end point.
    for (size_t i = 0; i < a.radius.size(); ++i)
      for (int d = 0; d < 3; ++d) a.x[3 * i + d] += a.v[3 * i + d] * dt;
  }
  EXPECT_GT(changed, 100);
  std::printf("[ HOST     ] 20 steps, %ld atoms with events, %ld steps declined and done again\n",
              changed, redone);
}

// Declines leave everything as given: an overlap at the start, a periodic box too short for
// the candidate range, the event cap.
TEST(ResidentStepHost, DeclinesWhatItCannotFinish)
{
  World w = periodic_gas(5, 1.0);
  const double dt = 0.1;
  std::vector<double> epair;
  Params p = gas_params(dt, epair, 1.0);
  WindowSettings s{};
  std::unique_ptr<ResidentStep> rs = make_host_resident_step();
  auto outcome = [&](World world, long maxevents) {
    p.maxevents = maxevents;
    Atoms a = atoms_of(world, dt), b = a;
    ResidentAtoms v = a.view();
    Tally t;
    ResidentReport r;
    rs->run_atoms(v, resident_box(world), p, s, t, r);
    if (r.outcome != ResidentOutcome::done) {
      EXPECT_EQ(a.x, b.x);
      EXPECT_EQ(a.v, b.v);
      EXPECT_EQ(a.tlast, b.tlast);
      EXPECT_EQ(t.events, 0);
    }
    return r.outcome;
  };
  EXPECT_EQ(outcome(w, 1000000), ResidentOutcome::done);
  World ov = w;
  for (int d = 0; d < 3; ++d) ov.s[1].x[d] = ov.s[0].x[d] + (d == 0 ? 0.5 * ov.s[0].r : 0.0);
  EXPECT_EQ(outcome(ov, 1000000), ResidentOutcome::overlap);
  World small = w;
  for (int d = 0; d < 3; ++d) small.prd[d] = 0.9;
  EXPECT_EQ(outcome(small, 1000000), ResidentOutcome::small_box);
  EXPECT_EQ(outcome(w, 1), ResidentOutcome::capped);
}

// The host's reference step keeps its own copies of x and v as the CUDA step does
// (common/kept_motion.h), so that fix hardsphere's gpu/keep runs and is tested without a device.
TEST(ResidentStepHost, KeptMotionEqualsCopiesBitwise)
{
  check_kept_motion([] { return make_host_resident_step(); }, false);
}
