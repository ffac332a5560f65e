/* HARDSPHERE_GPU driver interface: the physics core evaluated on a CUDA device, to check that
   host and device compute the same bits.

   A CoreCase holds the inputs of every host-device function of core/ (contact.h, impulse.h,
   trajectory.h, collision_step.h, event_order.h's earlier() and verlet_motion.h); evaluate_core_case() calls
   each of them once on those inputs and stores what they return or change in a CoreResult.
   The function is defined here, host-device, so that a test evaluates the very same code on
   the host (its compiler) and, through run_core_cases_on_device(), on the device (nvcc's):
   any difference between the two results is a difference of the compiled arithmetic.

   Plain C++ (no CUDA types), like the other driver headers.  Built from core_device_check.cu
   with CUDA, from core_device_check_none.cpp without (the runner then throws). */
#ifndef HSGPU_GPU_CORE_DEVICE_CHECK_H
#define HSGPU_GPU_CORE_DEVICE_CHECK_H

#include "core/collision_step.h"
#include "core/event_order.h"
#include "core/hd.h"
#include "core/verlet_motion.h"

namespace HSGPU {
namespace GPU {

  /// Inputs of one case.  Every function reads the fields it needs; p.epair and p.fpair are not
  /// read (the restitution and friction tables are passed separately, so that the runner can
  /// put them on the device).
  struct CoreCase {
    // Contact: relative position and velocity, contact distance s, approach dead zone bmin
    // (pair_contact_time, dot3, dot3_minus_square, two_sum); the wall gap, its rate and its
    // acceleration g[0..2] (wall_contact_time).
    double r[3], v[3];
    double s, bmin;
    double g[3];
    // Impulse: restitution e, times since each partner's previous collision, TC time tc,
    // normal relative velocity vn, threshold vmin, masses, impulse J along the unit normal n,
    // velocities vi, vj that receive it.
    double e, since_i, since_j, tc, vn, vmin, mi, mj, J;
    double n[3], vi[3], vj[3];
    // Trajectories and events: two bodies joined by edge (i = 0, j = 1), a time t, a
    // dimension dim (bow) and a face (process_wall when no wall event is found), the step's
    // parameters (walls, dt, tc, vmin; epair ignored).
    Collide::Body bi, bj;
    Collide::Edge edge;
    Collide::Params p;
    double t;
    int dim, face;
    // Nearest periodic image of xi - xj.
    int periodic[3];
    double xi[3], xj[3], prd[3];
    // Event order.
    Collide::Event ea, eb;
    // An atom between two steps (verlet_motion.h): x, v, f, mass m and what LAMMPS does.
    double mx[3], mv[3], mf[3], mm;
    Collide::StepMotion move;
  };

  /// Outputs of one case, one field (or group of fields) per function call.
  struct CoreResult {
    double pair_contact_time;               // (r, v, s, bmin)
    double pair_contact_time_no_dead;       // (r, v, s), bmin = 0
    double dot3_rv;                         // r.v
    double dot3_minus_square_rr;            // r.r - s^2
    double dot3_minus_square_rv;            // r.v - 0
    double two_sum_s, two_sum_e;            // r[0] + v[0]
    double wall_contact_time;               // (g0, g1, g2)
    double effective_restitution;           // (e, since_i, since_j, tc, vn, vmin)
    double reduced_mass;                    // (mi, mj)
    double pair_impulse;                    // (vn, m_eff, e)
    double energy_loss;                     // (vn, m_eff, e)
    double energy_change;                   // (J, vn, m_eff)
    double impulse_vi[3], impulse_vj[3];    // apply_pair_impulse(vi, vj, n, J, mi, mj)
    double face_sign;                       // face_sign(face)
    double drift[3];                        // drift_position(bi, t)
    double bow;                             // bow(bi, dim, t, p.dt)
    Collide::Body excursion;                // bi after note_excursion(bi, drift)
    double pair_event_time;                 // pair_event_time(bi, bj, edge, p.dt)
    double wall_event_time;                 // wall_event_time(bi, p.walls, p.dt, wall_face)
    double image_r[3], image_shift[3];      // nearest_image_separation(xi, xj, prd, periodic)
    Collide::Body pair_i, pair_j;           // process_pair at the pair event time (else t)
    Collide::Tally pair_tally;
    Collide::Body wall_b;    // process_wall at the wall event (else t, face)
    Collide::Tally wall_tally;
    Collide::Body end_b;    // end_of_step(bi, p.dt) after the wall event
    double end_x[3], end_vhalf[3];
    int face_dim;     // face_dim(face)
    int wall_face;    // the face wall_event_time found
    int earlier_ab, earlier_ba, earlier_aa;
    double moved_x[2][3], moved_v[2][3];    // move_between_steps(), plain [0] and fused [1]
  };

  /// The doubles of the tables evaluate_core_case() reads: the restitution table
  /// ((ntypes + 1)^2 values) followed by the friction table (2 (ntypes + 1)^2: mu, beta0).
  inline long core_tables_size(int ntypes)
  {
    return 3L * (ntypes + 1) * (ntypes + 1);
  }

  /// Calls every host-device core function on the inputs of c with the tables (restitution,
  /// then friction: core_tables_size(ntypes) values) and writes what they give into out.
  HSGPU_HD void evaluate_core_case(const CoreCase &c, const double *tables, int ntypes,
                                   CoreResult &out)
  {
    using namespace Collide;
    Params p = c.p;
    p.epair = tables;
    p.fpair = tables + (ntypes + 1) * (ntypes + 1);
    p.ntypes = ntypes;

    // contact.h
    out.pair_contact_time = Contact::pair_contact_time(c.r, c.v, c.s, c.bmin);
    out.pair_contact_time_no_dead = Contact::pair_contact_time(c.r, c.v, c.s);
    out.dot3_rv = Contact::dot3(c.r, c.v);
    out.dot3_minus_square_rr = Contact::dot3_minus_square(c.r, c.r, c.s);
    out.dot3_minus_square_rv = Contact::dot3_minus_square(c.r, c.v, 0.0);
    Contact::two_sum(c.r[0], c.v[0], out.two_sum_s, out.two_sum_e);
    out.wall_contact_time = Contact::wall_contact_time(c.g[0], c.g[1], c.g[2]);

    // impulse.h
    out.effective_restitution =
        Impulse::effective_restitution(c.e, c.since_i, c.since_j, c.tc, c.vn, c.vmin);
    out.reduced_mass = Impulse::reduced_mass(c.mi, c.mj);
    out.pair_impulse = Impulse::pair_impulse(c.vn, out.reduced_mass, c.e);
    out.energy_loss = Impulse::energy_loss(c.vn, out.reduced_mass, c.e);
    out.energy_change = Impulse::energy_change(c.J, c.vn, out.reduced_mass);
    for (int d = 0; d < 3; ++d) {
      out.impulse_vi[d] = c.vi[d];
      out.impulse_vj[d] = c.vj[d];
    }
    Impulse::apply_pair_impulse(out.impulse_vi, out.impulse_vj, c.n, c.J, c.mi, c.mj);

    // trajectory.h
    out.face_dim = face_dim(c.face);
    out.face_sign = face_sign(c.face);
    drift_position(c.bi, c.t, out.drift);
    out.bow = bow(c.bi, c.dim, c.t, p.dt);
    out.excursion = c.bi;
    note_excursion(out.excursion, out.drift);
    out.pair_event_time = pair_event_time(c.bi, c.bj, c.edge, p.dt);
    out.wall_event_time = wall_event_time(c.bi, p.walls, p.dt, out.wall_face);
    nearest_image_separation(c.xi, c.xj, c.prd, c.periodic, out.image_r, out.image_shift);

    // collision_step.h: the events at the times found above (else at t, on face)
    const double tp = out.pair_event_time < p.dt ? out.pair_event_time : c.t;
    out.pair_i = c.bi;
    out.pair_j = c.bj;
    out.pair_tally = Tally();
    process_pair(out.pair_i, out.pair_j, c.edge, tp, p, out.pair_tally);
    const bool wall_found = out.wall_event_time < p.dt;
    out.wall_b = c.bi;
    out.wall_tally = Tally();
    process_wall(out.wall_b, wall_found ? out.wall_face : c.face,
                 wall_found ? out.wall_event_time : c.t, p, out.wall_tally);
    out.end_b = out.wall_b;
    end_of_step(out.end_b, p.dt, out.end_x, out.end_vhalf);

    // event_order.h
    out.earlier_ab = earlier(c.ea, c.eb) ? 1 : 0;
    out.earlier_ba = earlier(c.eb, c.ea) ? 1 : 0;
    out.earlier_aa = earlier(c.ea, c.ea) ? 1 : 0;

    // verlet_motion.h
    for (int way = 0; way < 2; ++way) {
      for (int d = 0; d < 3; ++d) {
        out.moved_x[way][d] = c.mx[d];
        out.moved_v[way][d] = c.mv[d];
      }
      move_between_steps(out.moved_x[way], out.moved_v[way], c.mf, c.mm, c.move, way == 1);
    }
  }

  /// Evaluates cases[0 .. n) on CUDA device `device`, one thread per case, with the
  /// restitution and friction tables (core_tables_size(ntypes) values, copied to the device),
  /// into out[0 .. n).
  /// Throws HSGPU::GPU::Error when CUDA fails or the package was built without CUDA.
  void run_core_cases_on_device(int device, const CoreCase *cases, int n, const double *tables,
                                int ntypes, CoreResult *out);

}    // namespace GPU
}    // namespace HSGPU

#endif
