/* HARDSPHERE_GPU tests: a resident step's own copies of x and v (ResidentAtoms::motion), one
   test body for every implementation (the CUDA step, the host's reference step).

   A caller steps a lattice gas under forces as LAMMPS does: between two run_atoms() it moves
   its arrays by verlet_between_steps() (core/verlet_motion.h), rounding plainly or with fused
   multiply-adds as a LAMMPS built with contraction would.  One run copies x and v up every
   step; the other keeps them on the step's side: copied on the first step and on one more (as
   after a sort), checked on the second, moved there (predicted) on the others, two of them
   after atoms were wrapped into the box (a reneighboring, Domain::pbc()), the step wrapping its
   copies the same way.  Both must end bit for bit alike; the checks find the
   caller's rounding and only it; a v changed by one ulp behind the step's back must show in
   the next check; after forget_host_arrays() a prediction falls back to a copy; and two of the
   steps defer their writes (ResidentAtoms::defer_writes) until deliver_atoms(). */
#ifndef HSGPU_TEST_KEPT_MOTION_H
#define HSGPU_TEST_KEPT_MOTION_H

#include "common/lattice_gas.h"
#include "core/verlet_motion.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <functional>
#include <memory>

namespace hsgpu_test {

/// bytes: the step reports the bytes it copies up (the CUDA step; the host reference does not).
inline void check_kept_motion(const std::function<std::unique_ptr<ResidentStep>()> &make,
                              bool bytes)
{
  const double dt = 0.1;
  LatticeGas g(10, 1.2, dt, 4711, 1);    // bounds of at least 0.5 below: the host
  // reference step declines any atom beyond its bound
  const int n = g.n;
  for (int i = 0; i < n; ++i) {
    g.rmass[i] = 1.0 + 0.1 * (i % 3);
    g.f[3 * i] = 0.02 * ((i % 5) - 2);
    g.f[3 * i + 2] = -0.5 * g.rmass[i];
  }
  StepMotion move;
  move.dtf = 0.5 * dt;    // ftm2v = 1
  move.dtv = dt;
  for (int d = 0; d < 3; ++d) {
    move.lo[d] = g.box.lo[d];
    move.hi[d] = g.box.lo[d] + g.box.prd[d];
    move.prd[d] = g.box.prd[d];
    move.periodic[d] = 1;
  }
  // The first step's drift end points: from the lattice points, which do not overlap.
  std::vector<double> x0 = g.x;
  for (int k = 0; k < 3 * n; ++k) x0[k] += g.v[k] * dt;
  for (const bool fused : {false, true}) {
    struct Run {
      std::unique_ptr<ResidentStep> rs;
      std::vector<double> x, v, tlast;
      long pairs = 0;
    };
    Run copy{make(), x0, g.v, std::vector<double>(n, -1e30)};
    Run kept{make(), x0, g.v, std::vector<double>(n, -1e30)};
    // Reneighborings (atoms wrapped into the box) before steps 3 and 6; step 4 copies (after
    // a sort, say).
    const MotionUse plan[7] = {MotionUse::copy,    MotionUse::check,   MotionUse::predict,
                               MotionUse::predict, MotionUse::copy,    MotionUse::predict,
                               MotionUse::check};
    long wrapped = 0;
    for (int k = 0; k < 7; ++k) {
      ResidentReport rep[2];
      StepMotion mk = move;
      mk.wrap = k == 3 || k == 6;
      for (Run *r : {&copy, &kept}) {
        if (k > 0)
          for (int i = 0; i < n; ++i) {
            double *xi = &r->x[3 * i];
            const double before[3] = {xi[0], xi[1], xi[2]};
            if (mk.wrap) pbc_wrap(xi, mk);
            wrapped += std::memcmp(before, xi, sizeof before) != 0;
            verlet_between_steps(xi, &r->v[3 * i], &g.f[3 * i], g.rmass[i], move.dtf, move.dtv,
                                 fused, true);
          }
        if (k == 6 && r == &kept) r->v[3 * 17 + 1] = std::nextafter(r->v[3 * 17 + 1], 1e300);
        ResidentAtoms a = g.atoms(r->x.data(), r->v.data(), r->tlast.data(), g.radius.data(), 0.5);
        // Steps 2 and 5 deferred (ResidentAtoms::defer_writes): the arrays untouched until
        // deliver_atoms().
        const bool defer = r == &kept && (k == 2 || k == 5);
        if (r == &kept) {
          a.motion.keep = true;
          a.motion.use = plan[k];
          a.motion.fused = fused;
          a.motion.move = mk;
          a.defer_writes = defer;
        }
        const std::vector<double> xb = r->x, vb = r->v, tb = r->tlast;
        Tally t;
        ResidentReport &re = rep[r == &kept];
        r->rs->run_atoms(a, g.box, g.p, g.s, t, re);
        ASSERT_EQ(re.outcome, ResidentOutcome::done) << "step " << k;
        if (defer) {
          EXPECT_TRUE(xb == r->x && vb == r->v && tb == r->tlast) << "written before delivery";
          r->rs->deliver_atoms();
          EXPECT_FALSE(xb == r->x) << "delivered";
        }
        r->pairs += t.pair;
      }
      const ResidentReport &r = rep[1];
      EXPECT_EQ(rep[0].motion, MotionUse::copy);
      EXPECT_EQ(r.motion, plan[k]) << "step " << k;
      const int mine = fused ? 2 : 0, other = fused ? 0 : 2;
      if (k == 1) {    // the caller's rounding fits every atom, the other does not
        EXPECT_EQ(r.motion_miss[mine], 0);
        EXPECT_EQ(r.motion_miss[mine + 1], 0);
        EXPECT_GT(r.motion_miss[other], 0) << (fused ? "fused caller" : "plain caller");
      }
      if (k == 6) {    // wrapped and moved alike, but one atom's v changed behind the step's back
        EXPECT_EQ(r.motion_miss[mine], 0);
        EXPECT_EQ(r.motion_miss[mine + 1], 1);
        EXPECT_GE(r.motion_miss[other + 1], 1);
      }
      if (plan[k] != MotionUse::check) {
        for (int j = 0; j < 4; ++j) EXPECT_EQ(r.motion_miss[j], -1);
        if (bytes) {
          EXPECT_EQ(rep[0].bytes_up - r.bytes_up, plan[k] == MotionUse::predict ? 48L * n : 0L)
              << "step " << k;
        }
      }
      if (k == 5) {    // bit for bit alike so far
        EXPECT_EQ(0, std::memcmp(copy.x.data(), kept.x.data(), copy.x.size() * sizeof(double)));
        EXPECT_EQ(0, std::memcmp(copy.v.data(), kept.v.data(), copy.v.size() * sizeof(double)));
        EXPECT_EQ(0, std::memcmp(copy.tlast.data(), kept.tlast.data(), n * sizeof(double)));
      }
    }
    EXPECT_GT(wrapped, 10) << "atoms wrapped into the box";
    EXPECT_GT(copy.pairs, 100) << "enough collisions to mean anything";
    // After forget_host_arrays() the step has no copies to move: run ahead (defer_writes) it
    // does nothing and says so; else it copies.
    kept.rs->forget_host_arrays();
    for (int i = 0; i < n; ++i)
      verlet_between_steps(&kept.x[3 * i], &kept.v[3 * i], &g.f[3 * i], g.rmass[i], move.dtf,
                           move.dtv, fused, true);
    ResidentAtoms a = g.atoms(kept.x.data(), kept.v.data(), kept.tlast.data(), g.radius.data(), 0.5);
    a.motion.keep = true;
    a.motion.use = MotionUse::predict;
    a.motion.fused = fused;
    a.motion.move = move;
    Tally t;
    ResidentReport r;
    a.defer_writes = true;
    const std::vector<double> xb = kept.x, vb = kept.v, tb = kept.tlast;
    kept.rs->run_atoms(a, g.box, g.p, g.s, t, r);
    kept.rs->deliver_atoms();
    EXPECT_EQ(r.motion, MotionUse::copy);
    EXPECT_EQ(t.pair, 0) << "nothing done";
    EXPECT_TRUE(xb == kept.x && vb == kept.v && tb == kept.tlast) << "nothing written";
    a.defer_writes = false;
    kept.rs->run_atoms(a, g.box, g.p, g.s, t, r);
    EXPECT_EQ(r.motion, MotionUse::copy);
    EXPECT_EQ(r.outcome, ResidentOutcome::done);
    EXPECT_GT(t.pair, 0);
    std::printf("[ MOTION   ] %s caller: %ld collisions in 7 steps of %d atoms\n",
                fused ? "fused" : "plain", copy.pairs, n);
  }
}

}    // namespace hsgpu_test

#endif
