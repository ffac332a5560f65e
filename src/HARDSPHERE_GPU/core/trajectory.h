/* HARDSPHERE_GPU physics core: a sphere's path through one velocity-Verlet step, and the time
   of its next event (pair contact or wall contact) on that path.

   Within a step of length dt (time t from 0 to dt) LAMMPS's integrator moves every atom on the
   straight drift line L(t) = x0 + vh t with its half-step velocity vh; the true path under the
   step's acceleration a = f/m is the parabola

       P(t) = L(t) + (a/2) t (t - dt),       true velocity u(t) = vh + a (t - dt/2).

   The bow (a/2) t (t - dt) vanishes at both ends of the step, so the drift line ends where the
   parabola does and the integrator's second half kick restores u(dt).  After an event at t_e a
   body is described again by a drift line, through x = L(t_e) at tref = t_e with a new drift
   velocity, and the same bow: the bow never changes within a step.

   Pairs are tested on their drift lines: for equal accelerations (a uniform field) the bows
   cancel in r_i - r_j and the pair contact time is exact; for unequal ones it is a second-order
   approximation.  Walls are tested on the parabola.

   Nothing here depends on LAMMPS, MPI or CUDA. */
#ifndef HSGPU_CORE_TRAJECTORY_H
#define HSGPU_CORE_TRAJECTORY_H

#include "contact.h"
#include "hd.h"

namespace HSGPU {
namespace Collide {

  constexpr int NFACES = 6;    // xlo xhi ylo yhi zlo zhi

  /// Pairs approach only if r.v < -ROUNDOFF_APPROACH s (|v_i|_1 + |v_j|_1): 64 ulps.
  constexpr double ROUNDOFF_APPROACH = 64.0 * 2.220446049250313e-16;

  /// One sphere during one step.
  struct Body {
    double x[3];     // drift-line position at time tref
    double v[3];     // drift velocity (the integrator's half-step velocity)
    double a[3];     // acceleration from the forces, f/m, fixed for the step
    double X0[3];    // drift-line position at the start of the step
    double tref;     // time of x within the step, 0 <= tref <= dt
    double radius;
    double mass;
    double tlast;    // time of the body's previous collision (negative: an earlier step)
    double exc2;     // largest squared distance of the drift line from X0 so far
    double w0[3];    // drift-line position at the start of the current time window
    double wexc2;    // largest squared distance of the drift line from w0 in the window
    long id;         // atom ID (> 0): fixes the order of simultaneous events
    long last;       // ID of the partner of the body's latest event if that was a pair
                     // collision that left its drift line unchanged since, else 0
    int type;
    int rest[3];    // per dimension, the wall face the body is resting on, or -1: that
                    // face is not tested again until the body's next pair collision
    int nevents;    // events this step (also the version stamp of its event candidates)
    int owner;      // free for the caller (a local atom index)
    // Angular velocity (friction only; zero and untouched for smooth spheres): the
    // integrator's half-step value, taken as the true one throughout the step (torques of
    // other styles are not followed within it).
    double omega[3];
  };

  /// A pair that may touch within the step: bodies i and j (id of i < id of j); the periodic
  /// image shift is subtracted from x_i - x_j.
  struct Edge {
    int i, j;
    double shift[3];
  };

  /// Flat walls on box faces: face f is normal to dimension f/2, lower side for even f.
  struct Walls {
    int on[NFACES];
    double pos[NFACES];
    double e[NFACES];
    double mu[NFACES];      // friction (Params::friction only)
    double beta[NFACES];    // tangential restitution of sticking contacts
  };

  /// The step's parameters.
  struct Params {
    double dt;
    double tc;      // TC-model time (also the resting criterion)
    double vmin;    // elastic threshold on the normal relative speed
    int tcslow;     // 1: the TC model applies only to slow collisions (collision_step.h)
    double vmin_atc;    // elastic also below vmin_atc |a| tc (|a|: the partners' larger)
    Walls walls;
    int ntypes;
    const double *epair;    // restitution of type pair (ti, tj) at ti * (ntypes + 1) + tj
    long maxevents;         // cap on events per step (all calls sharing one Tally)
    // Rough spheres (friction.h).  friction = 0 (as Params{} sets it): smooth spheres, the
    // tangential branches are never entered (nor inertia, fpair, walls.mu, walls.beta read).
    // No default member initializers: Params stays trivial, copied bytewise to the device.
    int friction;
    // Moment of inertia / (m r^2).
    double inertia;
    // mu and beta0 of type pair (ti, tj) at 2 (ti * (ntypes + 1) + tj) and the next one.
    const double *fpair;
  };

  /// What the events of a step did.
  struct Tally {
    long pair = 0;           // pair collisions
    long wall = 0;           // wall collisions (bounces and rests)
    long rest = 0;           // of those, the ones that left the body resting on the wall
    long events = 0;         // events processed (collisions plus degenerate non-collisions)
    double ke_lost = 0.0;    // kinetic energy removed
    double virial[6] = {0, 0, 0, 0, 0, 0};    // sum of r (x) dp: xx yy zz xy xz yz
    int capped = 0;                           // 1 when maxevents stopped the step

    void add(const Tally &o)
    {
      pair += o.pair;
      wall += o.wall;
      rest += o.rest;
      events += o.events;
      ke_lost += o.ke_lost;
      for (int k = 0; k < 6; ++k) virial[k] += o.virial[k];
      capped |= o.capped;
    }
  };

  HSGPU_HD int face_dim(int f)
  {
    return f >> 1;
  }

  /// +1 for a lower wall (the gap grows with the coordinate), -1 for an upper wall.
  HSGPU_HD double face_sign(int f)
  {
    return (f & 1) ? -1.0 : 1.0;
  }

  /// The start point x - v dt of a step of length dt, from the position x and half-step
  /// velocity v after the drift: the one expression that an atom's body (start_body()) and
  /// its ghosts on other ranks (fix hardsphere's candidate search, overlap check and window
  /// start points) all form, so that every rank has the same bits for an atom.
  HSGPU_HD void start_point(const double *x, const double *v, double dt, double *p)
  {
    for (int d = 0; d < 3; ++d) p[d] = x[d] - v[d] * dt;
  }

  /// A body at the start of a step of length dt, from an atom's state after the drift: its
  /// position x, half-step velocity v and force f (3 each); the start point is x - v dt and
  /// the acceleration f ftm2v / mass.  The one definition that the host (fix hardsphere) and
  /// the device (the resident step) both use, so that both start from the same bits.
  HSGPU_HD Body start_body(const double *x, const double *v, const double *f, double radius,
                           double mass, double tlast, long id, int type, int owner, double dt,
                           double ftm2v)
  {
    Body b{};
    start_point(x, v, dt, b.X0);
    for (int d = 0; d < 3; ++d) {
      b.v[d] = v[d];
      b.x[d] = b.X0[d];
      b.a[d] = f[d] * ftm2v / mass;
      b.rest[d] = -1;
    }
    b.radius = radius;
    b.mass = mass;
    b.tlast = tlast;
    b.id = id;
    b.type = type;
    b.owner = owner;
    return b;
  }

  /// The step budget (the fastest atom's reach in a step), one definition for the host (fix
  /// hardsphere's step_budget) and the device (the resident step): an atom's squared speed,
  /// its acceleration |f| ftm2v / mass, and the least displacement a step of length dt must
  /// allow for the fastest drift and the largest acceleration.
  HSGPU_HD double speed2(const double *v)
  {
    return v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
  }

  HSGPU_HD double accel_magnitude(const double *f, double ftm2v, double mass)
  {
    return sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]) * ftm2v / mass;
  }

  HSGPU_HD double step_least(double vmax2, double amax, double dt)
  {
    return sqrt(vmax2) * dt + 0.5 * amax * dt * dt;
  }

  /// A body's displacement bound for a step of length dt: twice its drift |v| dt, at least
  /// `least` and `raised`, at most `most` (std::max/std::min order, on host and device).
  HSGPU_HD double drift_bound(const double *v, double dt, double least, double raised, double most)
  {
    const double speed = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    double d = 2.0 * speed * dt;
    d = d < least ? least : d;
    d = d < raised ? raised : d;
    return most < d ? most : d;
  }

  /// Drift-line position of b at time t.
  HSGPU_HD void drift_position(const Body &b, double t, double *p)
  {
    const double h = t - b.tref;
    for (int d = 0; d < 3; ++d) p[d] = b.x[d] + b.v[d] * h;
  }

  /// The bow of b's path at time t along dimension d.
  HSGPU_HD double bow(const Body &b, int d, double t, double dt)
  {
    return 0.5 * b.a[d] * t * (t - dt);
  }

  /// Records the distance of the drift-line point p from the step's start point and from the
  /// window's start point.
  HSGPU_HD void note_excursion(Body &b, const double *p)
  {
    double d2 = 0.0, w2 = 0.0;
    for (int d = 0; d < 3; ++d) {
      d2 += (p[d] - b.X0[d]) * (p[d] - b.X0[d]);
      w2 += (p[d] - b.w0[d]) * (p[d] - b.w0[d]);
    }
    if (d2 > b.exc2) b.exc2 = d2;
    if (w2 > b.wexc2) b.wexc2 = w2;
  }

  /// Time of the next contact of the pair on the drift lines, never() if none before dt (a
  /// contact exactly at dt is the next step's, at its start).  A
  /// function of the two bodies' states only, so that every order of processing that reaches
  /// the same states computes the same number.
  HSGPU_HD double pair_event_time(const Body &bi, const Body &bj, const Edge &e, double dt)
  {
    // Two bodies whose latest events were their collision with each other separate on their
    // drift lines (relative normal velocity -e vn >= 0) and cannot meet again until one of them
    // has another event.  Saying so explicitly keeps round-off from re-detecting the collision
    // just carried out.
    if (bi.last == bj.id && bj.last == bi.id) return Contact::never();
    const double t0 = bi.tref > bj.tref ? bi.tref : bj.tref;
    double r[3], v[3];
    const double hi = t0 - bi.tref, hj = t0 - bj.tref;
    for (int d = 0; d < 3; ++d) {
      r[d] = (bi.x[d] + bi.v[d] * hi) - (bj.x[d] + bj.v[d] * hj) - e.shift[d];
      v[d] = bi.v[d] - bj.v[d];
    }
    // Round-off dead zone: a normal relative velocity below what rounding the two velocities
    // can produce is no approach (it would otherwise let a resting body and a partner trade
    // round-off forever).  The overlap this can leave is that speed times dt.
    double vs = 0.0;
    for (int d = 0; d < 3; ++d) vs += fabs(bi.v[d]) + fabs(bj.v[d]);
    const double s = bi.radius + bj.radius;
    const double tau = Contact::pair_contact_time(r, v, s, ROUNDOFF_APPROACH * s * vs, dt - t0);
    if (tau == Contact::never()) return Contact::never();
    const double t = t0 + tau;
    return t < dt ? t : Contact::never();
  }

  /// Time and face of b's next wall contact on its parabola, never() if none before dt.  The
  /// lowest face wins a tie.
  HSGPU_HD double wall_event_time(const Body &b, const Walls &w, double dt, int &face)
  {
    double best = Contact::never();
    face = -1;
    const double tr = b.tref;
    for (int f = 0; f < NFACES; ++f) {
      if (!w.on[f]) continue;
      const int d = face_dim(f);
      if (b.rest[d] == f) continue;
      const double s = face_sign(f);
      const double p = b.x[d] + bow(b, d, tr, dt);
      const double u = b.v[d] + b.a[d] * (tr - 0.5 * dt);
      const double g0 = s * (p - w.pos[f]) - b.radius;
      const double tau = Contact::wall_contact_time(g0, s * u, s * b.a[d], dt - tr);
      if (tau == Contact::never()) continue;
      const double t = tr + tau;
      if (t < dt && t < best) {
        best = t;
        face = f;
      }
    }
    return best;
  }

  /// Separation of the start points of a pair, x_i - x_j, and the periodic image shift that
  /// makes it the nearest image.  Anti-symmetric to the last bit: swapping i and j negates
  /// both results exactly, so every rank computes the same edge from the same coordinates.
  HSGPU_HD void nearest_image_separation(const double *xi, const double *xj, const double *prd,
                                         const int *periodic, double *r, double *shift)
  {
    for (int d = 0; d < 3; ++d) {
      const double dx = xi[d] - xj[d];
      double s = 0.0;
      // Within a quarter period dx / prd rounds to a zero of dx's sign, which dx * 0 is: the
      // same bits without the division (most pairs are far closer than half a period).
      if (periodic[d]) s = fabs(dx) <= 0.25 * prd[d] ? dx * 0.0 : nearbyint(dx / prd[d]) * prd[d];
      shift[d] = s;
      r[d] = dx - s;
    }
  }

}    // namespace Collide
}    // namespace HSGPU

#endif
