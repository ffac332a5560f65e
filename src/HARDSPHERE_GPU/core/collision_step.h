/* HARDSPHERE_GPU physics core: carrying out one event of a step on the bodies' paths.

   Pair collision at time t (found on the drift lines): the normal is the line of centres and
   the impulse is impulse.h's for the true normal relative velocity at t,
   vn = (vh_i - vh_j).n + (a_i - a_j).n (t - dt/2), which makes the outcome second-order
   accurate in dt when the accelerations differ (with the drift velocity it would be first
   order); it is never less than the impulse that stops the approach of the drift lines, so
   that the pair cannot overlap at the end of the step.  Under a uniform field a_i = a_j and
   both are the textbook impulse of the drift (= true) relative velocity.  Both bodies restart
   their drift lines at t.

   Wall collision at time t (on the parabola): the true velocity u = vh + a (t - dt/2) has its
   normal component reflected with restitution e, then vh' = u' - a (t - dt/2) and the drift line
   is restarted so that the position stays continuous (the bow is the same before and after).

   Resting contact: a body pressed onto a wall by its acceleration whose rebound would bring it
   back within tc (2 u_n' / |a_n| < tc, including u_n' = 0) does not rebound; it leaves with the
   normal speed |a_n| (dt - t) / 2 instead, which brings it back to the contact point exactly at
   the end of the step, and that wall is not tested again for it until its next pair
   collision.  A body sitting on a floor thus stays at the contact height, with a kinetic
   energy of order m (a dt)^2 / 8, instead of needing infinitely many ever smaller bounces.
   The kinetic energy this changes is counted like a collision's (it can add a little).

   Per-atom virial: where the caller gives a body's accumulator (6 doubles, xx yy zz xy xz yz),
   a pair collision adds half of its r (x) dp to each of the two bodies' accumulators and a
   wall collision all of its term to the body's; the sum over bodies is the tally's virial.
   Where no accumulator is given (nullptr, the default; the device code) nothing changes.

   Every function is callable from host and device code (hd.h).  Nothing here depends on
   LAMMPS, MPI or CUDA. */
#ifndef HSGPU_CORE_COLLISION_STEP_H
#define HSGPU_CORE_COLLISION_STEP_H

#include "friction.h"
#include "impulse.h"
#include "trajectory.h"

#include <cmath>

namespace HSGPU {
namespace Collide {

  /// tcslow: a collision is slow when its normal speed is below SLOW_ACCEL |a| tc' (|a| the
  /// larger acceleration of the partners, tc' = speed_tc(): what the field builds up in
  /// 16 tc') or below SLOW_FRACTION of the sum of the partners' speeds (the end of a collapse
  /// sequence, which needs no field).
  constexpr double SLOW_ACCEL = 16.0;
  constexpr double SLOW_FRACTION = 0.1;

  /// vmin auto: collisions slower than VMIN_AUTO_ATC |a| tc are elastic (15 |a| dt with the
  /// default tc = dt/2; measured in doc/fix_hardsphere.md: it bounds a settled pile's cost and
  /// leaves a falling column's kinetic energy within 0.06 %).
  constexpr double VMIN_AUTO_ATC = 30.0;

  /// The speed thresholds above (slow collisions, vmin auto) take tc at most
  /// SPEED_TC_CAP sqrt(d / |a|), d the contact distance: they act as with dt = 0.01 sqrt(d / g)
  /// at larger timesteps, so that their bias does not grow with dt (a falling column at
  /// dt = 0.1 with g = 1, d = 0.9 would otherwise make collisions below 1.5 elastic).
  constexpr double SPEED_TC_CAP = 0.005;

  /// Params::friction: rough spheres whose collisions the guards make elastic (TC model,
  /// elastic threshold: e1 = 1 where e < 1) are elastic in their tangential part too, the
  /// perfectly rough elastic impulse (friction/guard elastic, the default); or Walton's rule
  /// in every collision (friction/guard none).  Measured in doc/fix_hardsphere.md: with
  /// Walton's rule in the guarded collisions friction drains the agitation that the elastic
  /// threshold keeps in a settled pile, and its cost grows twentyfold.
  constexpr int FRICTION_GUARDED = 1;
  constexpr int FRICTION_WALTON = 2;

  /// The TC time the speed thresholds use: tc, capped at SPEED_TC_CAP sqrt(d / amax).
  HSGPU_HD double speed_tc(double tc, double amax, double d)
  {
    return amax > 0.0 ? fmin(tc, SPEED_TC_CAP * sqrt(d / amax)) : tc;
  }

  HSGPU_HD double norm3(const double *a)
  {
    return sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
  }

  /// The TC time a collision with normal speed |un| gets when the TC model applies only to
  /// slow collisions (tcslow): tc if the collision is slow (above), else 0.  tcs: tc' =
  /// speed_tc(tc, amax, d); amax: the larger of the partners' |a|; vsum: the sum of their
  /// drift speeds.
  HSGPU_HD double slow_tc(double tc, double tcs, double un, double amax, double vsum)
  {
    const double slow = SLOW_ACCEL * amax * tcs;
    return (fabs(un) < slow || fabs(un) < SLOW_FRACTION * vsum) ? tc : 0.0;
  }

  /// The elastic threshold on the normal speed of a collision: the larger of p.vmin and
  /// p.vmin_atc |a| tc' (vmin auto), amax the larger of the partners' |a|, tcs = tc' =
  /// speed_tc(p.tc, amax, d) with d their contact distance.  What the field
  /// builds up in a few steps: a settled pile keeps that much agitation, which bounds its cost,
  /// while a gas or a falling column, whose collisions are far faster, is not changed.
  HSGPU_HD double elastic_threshold(const Params &p, double amax, double tcs)
  {
    return fmax(p.vmin, p.vmin_atc * amax * tcs);
  }

  /// Pair collision of bodies i and j (edge e) at time t.  wi, wj: the bodies' per-atom
  /// virial accumulators, or nullptr.
  HSGPU_HD void process_pair(Body &bi, Body &bj, const Edge &e, double t, const Params &p,
                             Tally &tally, double *wi = nullptr, double *wj = nullptr)
  {
    double pi[3], pj[3], r[3];
    drift_position(bi, t, pi);
    drift_position(bj, t, pj);
    note_excursion(bi, pi);
    note_excursion(bj, pj);
    for (int d = 0; d < 3; ++d) r[d] = pi[d] - pj[d] - e.shift[d];
    const double rr = sqrt(Contact::dot3(r, r));
    double n[3] = {1.0, 0.0, 0.0};
    if (rr > 0.0)
      for (int d = 0; d < 3; ++d) n[d] = r[d] / rr;
    double vn = 0.0, an = 0.0;    // drift normal relative velocity, relative acceleration
    for (int d = 0; d < 3; ++d) {
      vn += (bi.v[d] - bj.v[d]) * n[d];
      an += (bi.a[d] - bj.a[d]) * n[d];
    }

    for (int d = 0; d < 3; ++d) {
      bi.x[d] = pi[d];
      bj.x[d] = pj[d];
      bi.rest[d] = bj.rest[d] = -1;
    }
    bi.tref = bj.tref = t;
    bi.last = bj.id;
    bj.last = bi.id;
    bi.nevents++;
    bj.nevents++;
    tally.events++;
    if (!(vn < 0.0)) return;    // round-off left the pair not approaching: nothing to do

    const double ut = vn + an * (t - 0.5 * p.dt);    // true normal relative velocity
    const double e0 = p.epair[bi.type * (p.ntypes + 1) + bj.type];
    const double amax = fmax(norm3(bi.a), norm3(bj.a));
    const double tcs = speed_tc(p.tc, amax, bi.radius + bj.radius);
    const double tcp = p.tcslow ? slow_tc(p.tc, tcs, ut, amax, norm3(bi.v) + norm3(bj.v)) : p.tc;
    const double e1 = Impulse::effective_restitution(e0, t - bi.tlast, t - bj.tlast, tcp, ut,
                                                     elastic_threshold(p, amax, tcs));
    const double meff = Impulse::reduced_mass(bi.mass, bj.mass);
    double J = Impulse::pair_impulse(ut, meff, e1);
    const double Jstop = -meff * vn;    // stops the approach of the drift lines
    if (J < Jstop) J = Jstop;
    Impulse::apply_pair_impulse(bi.v, bj.v, n, J, bi.mass, bj.mass);
    tally.ke_lost -= Impulse::energy_change(J, ut, meff);
    double dp[3] = {J * n[0], J * n[1], J * n[2]};
    if (p.friction) {
      const double *fr = p.fpair + 2 * (bi.type * (p.ntypes + 1) + bj.type);
      if (fr[0] > 0.0) {
        // Walton's rule (friction.h) on the true velocities at t; the normal impulse J above
        // changed only the normal part of the contact velocity.
        double g[3], c[3], ws[3], gt[3], P[3], dw[3];
        const double h = t - 0.5 * p.dt;
        for (int d = 0; d < 3; ++d) ws[d] = bi.radius * bi.omega[d] + bj.radius * bj.omega[d];
        Friction::cross3(ws, n, c);
        for (int d = 0; d < 3; ++d) g[d] = (bi.v[d] - bj.v[d]) + (bi.a[d] - bj.a[d]) * h - c[d];
        const double k = p.inertia;
        const double cm = 1.0 / bi.mass + 1.0 / bj.mass +
                          Friction::rotational_compliance(k, bi.mass, bi.radius) +
                          Friction::rotational_compliance(k, bj.mass, bj.radius);
        const double mt = 1.0 / cm;
        // A collision that the guards made elastic (e1 = 1 for e0 < 1) is elastic in its
        // tangential part too, with friction/guard elastic (p.friction == 1).
        const int elastic = p.friction == FRICTION_GUARDED && e1 != e0;
        Friction::tangential_impulse(g, n, J, mt, fr[0], fr[1], elastic, gt, P);
        for (int d = 0; d < 3; ++d) {
          bi.v[d] += P[d] / bi.mass;
          bj.v[d] -= P[d] / bj.mass;
        }
        // Both contact points lie at -r n from their centres (j's impulse is -P at +r_j n).
        Friction::spin_change(n, P, k, bi.mass, bi.radius, dw);
        for (int d = 0; d < 3; ++d) bi.omega[d] += dw[d];
        Friction::spin_change(n, P, k, bj.mass, bj.radius, dw);
        for (int d = 0; d < 3; ++d) bj.omega[d] += dw[d];
        tally.ke_lost -= Friction::energy_change(P, gt, mt);
        for (int d = 0; d < 3; ++d) dp[d] += P[d];
      }
    }
    tally.virial[0] += r[0] * dp[0];
    tally.virial[1] += r[1] * dp[1];
    tally.virial[2] += r[2] * dp[2];
    tally.virial[3] += r[0] * dp[1];
    tally.virial[4] += r[0] * dp[2];
    tally.virial[5] += r[1] * dp[2];
    if (wi || wj) {
      const double half[6] = {0.5 * r[0] * dp[0], 0.5 * r[1] * dp[1], 0.5 * r[2] * dp[2],
                              0.5 * r[0] * dp[1], 0.5 * r[0] * dp[2], 0.5 * r[1] * dp[2]};
      for (int k = 0; k < 6; ++k) {
        if (wi) wi[k] += half[k];
        if (wj) wj[k] += half[k];
      }
    }
    tally.pair++;
    bi.tlast = bj.tlast = t;
  }

  /// Walton's rule (friction.h) at a wall collision of body b with face f (dimension d, sign s)
  /// at time t whose normal impulse was Jn >= 0, the centre at distance h from the wall: the
  /// wall has infinite mass and no spin.  elastic: the guards made the bounce elastic.
  /// (Components are picked without runtime indices, as in process_wall.)
  HSGPU_HD void rough_wall(Body &b, int d, double s, double t, double Jn, double h, int f,
                           int elastic, const Params &p, Tally &tally, double *wb)
  {
    const double n[3] = {d == 0 ? s : 0.0, d == 1 ? s : 0.0, d == 2 ? s : 0.0};
    const double tt = t - 0.5 * p.dt;
    double c[3], g[3], gt[3], P[3], dw[3], rw[3];
    for (int k = 0; k < 3; ++k) rw[k] = b.radius * b.omega[k];
    Friction::cross3(rw, n, c);
    for (int k = 0; k < 3; ++k) g[k] = b.v[k] + b.a[k] * tt - c[k];
    const double kI = p.inertia;
    const double mt = 1.0 / (1.0 / b.mass + Friction::rotational_compliance(kI, b.mass, b.radius));
    Friction::tangential_impulse(g, n, Jn, mt, p.walls.mu[f], p.walls.beta[f], elastic, gt, P);
    // P is normal to n up to round-off: the normal velocity stays the one just set.
    P[0] = d == 0 ? 0.0 : P[0];
    P[1] = d == 1 ? 0.0 : P[1];
    P[2] = d == 2 ? 0.0 : P[2];
    for (int k = 0; k < 3; ++k) b.v[k] += P[k] / b.mass;
    // The impulse moves the body along the other dimensions: a wall it rests on there (a
    // sphere in a corner, on the floor against a side wall) must be tested again, or it
    // could be driven into it unseen.
    for (int k = 0; k < 3; ++k)
      if (k != d && P[k] != 0.0) b.rest[k] = -1;
    Friction::spin_change(n, P, kI, b.mass, b.radius, dw);
    for (int k = 0; k < 3; ++k) b.omega[k] += dw[k];
    tally.ke_lost -= Friction::energy_change(P, gt, mt);
    // Virial r_a dP_b (a < b), r = h along d, as a pair's off-diagonal terms.
    const double w3 = d == 0 ? h * P[1] : 0.0;
    const double w4 = d == 0 ? h * P[2] : 0.0;
    const double w5 = d == 1 ? h * P[2] : 0.0;
    tally.virial[3] += w3;
    tally.virial[4] += w4;
    tally.virial[5] += w5;
    if (wb) {
      wb[3] += w3;
      wb[4] += w4;
      wb[5] += w5;
    }
  }

  /// Collision of body b with wall face f at time t.  wb: the body's per-atom virial
  /// accumulator, or nullptr.
  HSGPU_HD void process_wall(Body &b, int f, double t, const Params &p, Tally &tally,
                             double *wb = nullptr)
  {
    const int d = face_dim(f);
    const double s = face_sign(f);
    double x[3];
    drift_position(b, t, x);
    note_excursion(b, x);
    const double bw = bow(b, d, t, p.dt);
    // (x[d] and virial[d] below are picked without a runtime index: indexed so, a device
    // compiler would keep x and the caller's tally in local memory instead of registers.)
    const double P = (d == 0 ? x[0] : (d == 1 ? x[1] : x[2])) + bw;    // true normal position
    const double u = b.v[d] + b.a[d] * (t - 0.5 * p.dt);
    // The event was found with the body approaching; recomputed here at t, round-off can
    // leave a tiny outward speed: treat that as a contact at zero speed (which rests it)
    // rather than as no event, which would be found again at once.
    // The sign of a zero result is made +0 by adding +0: fmin, or a comparison that the
    // device compiler turns into a min instruction, gives -0 on the device where the host
    // gives +0, and the sign would reach the velocity.
    const double su = s * u;
    const double un = (su < 0.0 ? su : 0.0) + 0.0;
    for (int k = 0; k < 3; ++k) b.x[k] = x[k];
    b.tref = t;
    b.last = 0;
    b.nevents++;
    tally.events++;

    const double ab = norm3(b.a);
    const double tcs = speed_tc(p.tc, ab, 2.0 * b.radius);    // d: the contact distance of a pair
    const double tcw = p.tcslow ? slow_tc(p.tc, tcs, un, ab, norm3(b.v)) : p.tc;
    const double e1 = Impulse::effective_restitution(p.walls.e[f], t - b.tlast, t - b.tlast, tcw,
                                                     un, elastic_threshold(p, ab, tcs));
    double un_out = -e1 * un;
    const double an = s * b.a[d];
    if (an < 0.0 && (un_out == 0.0 || 2.0 * un_out < -an * p.tc)) {
      // Resting: a hop that lands on the contact point exactly at the end of the step.
      un_out = -0.5 * an * (p.dt - t);
      b.rest[d] = f;
      tally.rest++;
    }
    const double unew = s * un_out;
    b.v[d] = unew - b.a[d] * (t - 0.5 * p.dt);
    tally.ke_lost += 0.5 * b.mass * (un * un - un_out * un_out);
    const double w = b.mass * (unew - s * un) * (P - p.walls.pos[f]);
    tally.virial[0] = d == 0 ? tally.virial[0] + w : tally.virial[0];
    tally.virial[1] = d == 1 ? tally.virial[1] + w : tally.virial[1];
    tally.virial[2] = d == 2 ? tally.virial[2] + w : tally.virial[2];
    if (wb) wb[d] += w;
    if (p.friction && p.walls.mu[f] > 0.0) {
      // A resting contact keeps Walton's rule: it is the Coulomb friction of a sphere that
      // rolls or slides on the wall (mu |a_n| dt per step at most).
      const int resting = b.rest[d] == f;
      const int elastic = p.friction == FRICTION_GUARDED && e1 != p.walls.e[f] && !resting;
      rough_wall(b, d, s, t, b.mass * (un_out - un), P - p.walls.pos[f], f, elastic, p, tally, wb);
    }
    tally.wall++;
    b.tlast = t;
  }

  /// Position at the end of the step and the half-step velocity to hand back to the
  /// integrator (its second half kick completes the true velocity of the path).
  HSGPU_HD void end_of_step(Body &b, double dt, double *x, double *vhalf)
  {
    drift_position(b, dt, x);
    note_excursion(b, x);
    for (int d = 0; d < 3; ++d) vhalf[d] = b.v[d];
  }

}    // namespace Collide
}    // namespace HSGPU

#endif
