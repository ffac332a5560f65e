/* HARDSPHERE_GPU physics core: when do two hard spheres, or a sphere and a flat wall, touch?

   Pair contact on straight-line relative motion r(t) = r + v t: the earliest t >= 0 with
   |r(t)| = s while approaching.  With b = r.v < 0 and c = r.r - s^2 > 0 the root is taken as

       t = c / (-b + sqrt(b^2 - (v.v) c))                     (Bannerman et al., 2014)

   which has no cancellation: the textbook (-b - sqrt(b^2 - (v.v) c)) / (v.v) subtracts two
   nearly equal numbers when the spheres nearly touch, and can even come out negative.  The
   rules for overlapping pairs: overlapping and approaching collide now (t = 0), overlapping and
   receding have no event.

   Wall contact on a parabola: the gap between a sphere's surface and a wall,
   g(t) = g0 + g1 t + g2 t^2 / 2 (g1: normal velocity away from the wall, g2: normal
   acceleration away from the wall), reaches its event at the earliest t >= 0 with g(t) <= 0 and
   g'(t) < 0, again without cancellation.

   Nothing here depends on LAMMPS, MPI or CUDA. */
#ifndef HSGPU_CORE_CONTACT_H
#define HSGPU_CORE_CONTACT_H

#include "hd.h"

#include <cmath>

namespace HSGPU {
namespace Contact {

  /// "No event": later than any time a step can reach.
  HSGPU_HD double never()
  {
    return HUGE_VAL;
  }

  /// Relative margin of pair_contact_time()'s horizon test: far above the round-off of the
  /// contact time in float and in double (some ulps), far below any use of the horizon.
  constexpr double HORIZON_MARGIN = 1e-6;

  /// Whether a contact with r.r - s^2 = c and r.v = b < 0 lies beyond the horizon for certain:
  /// its time c / (-b + sqrt(b^2 - v.v c)) is at least c / (-2 b), and the margin is far above
  /// the round-off of either expression.
  template <class Real> HSGPU_HD bool beyond_horizon(Real c, Real b, Real horizon)
  {
    return c > Real(2) * (-b) * horizon * Real(1 + HORIZON_MARGIN);
  }

  template <class Real> HSGPU_HD Real dot3(const Real *a, const Real *b)
  {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  }

  /// s = a + b exactly as s + e (Knuth's TwoSum).
  template <class Real> HSGPU_HD void two_sum(Real a, Real b, Real &s, Real &e)
  {
    s = a + b;
    const Real z = s - a;
    e = (a - (s - z)) + (b - z);
  }

  /// a.b - q*q with about twice the working precision (products split exactly by fma, sums
  /// compensated): accurate even when the result is far smaller than the terms, as r.r - s^2
  /// is for spheres that nearly touch.
  template <class Real> HSGPU_HD Real dot3_minus_square(const Real *a, const Real *b, Real q)
  {
    Real p[4] = {a[0] * b[0], a[1] * b[1], a[2] * b[2], -(q * q)};
    Real err =
        fma(a[0], b[0], -p[0]) + fma(a[1], b[1], -p[1]) + fma(a[2], b[2], -p[2]) - fma(q, q, p[3]);
    Real sum = p[0];
    for (int k = 1; k < 4; ++k) {
      Real s, e;
      two_sum(sum, p[k], s, e);
      sum = s;
      err += e;
    }
    return sum + err;
  }

  /// Time until two spheres whose centres differ by r, with relative velocity v, are at the
  /// contact distance s while approaching: 0 when they overlap (or touch) and approach, never()
  /// when they recede, stay at rest relative to each other or miss.  "Approaching" means
  /// r.v < -bmin: bmin > 0 gives a dead zone for relative velocities at the round-off level.
  /// horizon: a contact later than this may be reported as never() (it is either way when
  /// horizon is never()); one sooner is returned exactly as without it.
  template <class Real>
  HSGPU_HD Real pair_contact_time(const Real *r, const Real *v, Real s, Real bmin = Real(0),
                                  Real horizon = Real(never()))
  {
    Real b = dot3(r, v);
    const Real rr = dot3(r, r);
    Real c = rr - s * s;
    // Most pairs have no contact: they recede, or (away from contact) their contact lies
    // beyond the horizon, where the square root and the division are not needed.  Both
    // tests are made before one branch on either (each alone is taken about half the time,
    // unpredictably; the two together rarely fail).
    const bool near = c < Real(0.125) * rr;
    const bool receding = !(b < -bmin);
    const bool beyond = beyond_horizon(c, b, horizon);
    if (int(receding) | (int(!near) & int(beyond))) return Real(never());
    if (near) {
      // Near contact r.r - s^2 and r.v are small differences of large terms: recompute both
      // accurately, so that the contact time keeps its relative accuracy however small it is
      // (and its sign decides touching versus overlapping correctly), and test the horizon
      // again with them (away from contact it was tested above; an overlap, c <= 0, is never
      // beyond it).
      c = dot3_minus_square(r, r, s);
      b = dot3_minus_square(r, v, Real(0));
      if (!(b < -bmin)) return Real(never());
      if (beyond_horizon(c, b, horizon)) return Real(never());
    }
    if (c <= Real(0)) return Real(0);
    const Real disc = b * b - dot3(v, v) * c;
    if (disc < Real(0)) return Real(never());
    return c / (-b + sqrt(disc));
  }

  /// Earliest t >= 0 at which the gap g(t) = g0 + g1 t + g2 t^2 / 2 is <= 0 while decreasing
  /// (the sphere reaches the wall, or is inside it and moving further in); never() if none.
  /// A sphere inside the wall but moving out gets its event when it turns back, if it does.
  /// horizon: a contact later than this may be reported as never() (it is either way when
  /// horizon is never()); one sooner is returned exactly as without it.
  template <class Real>
  HSGPU_HD Real wall_contact_time(Real g0, Real g1, Real g2, Real horizon = Real(never()))
  {
    if (g0 <= Real(0) && g1 < Real(0)) return Real(0);
    // Within the horizon h the gap closes by at most M = max(-g1, 0) h + max(-g2, 0) h^2 / 2.
    // Where g0 exceeds M with a margin, the root lies beyond h by at least HORIZON_MARGIN h / 2
    // (the gap closes no faster than max(-g1, 0) + max(-g2, 0) h up to h), far above its
    // round-off: no square root or division is needed.  (Each body's walls are tested after
    // each of its events, and most bodies are far from every wall.)
    if (horizon != Real(never()) && g0 > Real(0)) {
      const Real closing = (g1 < Real(0) ? -g1 : Real(0)) * horizon +
                           Real(0.5) * (g2 < Real(0) ? -g2 : Real(0)) * horizon * horizon;
      if (g0 > closing * Real(1 + HORIZON_MARGIN)) return Real(never());
    }
    if (g2 == Real(0)) {
      if (g1 < Real(0)) return g0 / (-g1);
      return Real(never());
    }
    const Real disc = g1 * g1 - Real(2) * g2 * g0;
    if (g2 > Real(0)) {
      // Accelerating away from the wall: only an approaching sphere can arrive, at the
      // smaller root, and only if it gets there before turning round (a tangent touch at
      // zero speed is no collision).
      if (!(g1 < Real(0)) || !(disc > Real(0))) return Real(never());
      return Real(2) * g0 / (-g1 + sqrt(disc));
    }
    // Accelerating towards the wall (g2 < 0).
    if (g0 > Real(0)) {
      // One positive root, the one where g falls through zero; disc > g1^2 here.
      const Real q = sqrt(disc);
      if (g1 < Real(0)) return Real(2) * g0 / (-g1 + q);
      return (g1 + q) / (-g2);
    }
    // Inside the wall (g0 <= 0) and moving out (g1 >= 0): it comes back through the wall at
    // the larger root, or, if it never gets out, turns back in at g1 / (-g2).
    if (disc > Real(0)) return (g1 + sqrt(disc)) / (-g2);
    return g1 / (-g2);
  }

}    // namespace Contact
}    // namespace HSGPU

#endif
