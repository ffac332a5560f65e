/* HARDSPHERE_GPU physics core: the tangential impulse of a rough hard-sphere collision
   (Walton's rule: O.R. Walton, "Numerical simulation of inclined chute flows of monodisperse,
   inelastic, frictional spheres", Mech. Mater. 16, 239 (1993); Luding et al., Phys. Rev. E 58,
   3416 (1998)).

   At a contact with unit normal n (from partner j to sphere i) the velocity of i's contact
   point relative to j's is

       g = u_i - u_j - (r_i w_i + r_j w_j) x n,

   u the true (not the drift) velocities, w the angular velocities, r the radii (a wall: u_j = 0,
   w_j = 0, r_j = 0).  Its tangential part g_t = g - (g.n) n is what friction acts on.  An
   impulse P applied at the contact points (+P on i, -P on j) changes g_t by P_t / m_t, with the
   effective tangential mass

       1/m_t = 1/m_i + 1/m_j + r_i^2/I_i + r_j^2/I_j,     I = k m r^2,

   k the moment-of-inertia factor (0.4 for solid spheres, 0.5 for discs), so
   1/m_t = (1 + 1/k) (1/m_i + 1/m_j) (a wall: 1/m_j = 0).  Walton's rule:

       sticking:  P_t = -(1 + beta0) m_t g_t                 (g_t becomes -beta0 g_t)
       sliding:   P_t = -mu J_n g_t / |g_t|   where |sticking P_t| > mu J_n,

   J_n >= 0 the normal impulse of the collision, mu >= 0 the Coulomb coefficient, beta0 in
   [-1, 1] the tangential restitution of sticking contacts.  The spins change by
   I_i dw_i = (-r_i n) x P, I_j dw_j = (r_j n) x (-P): the angular momentum of each sphere about
   the contact point, and the total linear momentum, stay the same.  The kinetic energy changes
   by P_t.g_t + |P_t|^2 / (2 m_t), never positive: -(1 - beta0^2) m_t |g_t|^2 / 2 when sticking,
   and less than that in magnitude, but still <= 0, when sliding.

   Every function is callable from host and device code (hd.h).  Nothing here depends on
   LAMMPS, MPI or CUDA. */
#ifndef HSGPU_CORE_FRICTION_H
#define HSGPU_CORE_FRICTION_H

#include "hd.h"

#include <cmath>

namespace HSGPU {
namespace Friction {

  HSGPU_HD void cross3(const double *a, const double *b, double *c)
  {
    c[0] = a[1] * b[2] - a[2] * b[1];
    c[1] = a[2] * b[0] - a[0] * b[2];
    c[2] = a[0] * b[1] - a[1] * b[0];
  }

  /// r^2 / I of a sphere of mass m and radius r, I = k m r^2: 1 / (k m); 0 for a point (r = 0),
  /// which takes no torque about its centre.
  HSGPU_HD double rotational_compliance(double k, double m, double r)
  {
    return r > 0.0 ? 1.0 / (k * m) : 0.0;
  }

  /// The change of angular velocity of a sphere of mass m, radius r, inertia factor k whose
  /// contact point, at -r n from its centre, receives the impulse P: (-r n) x P / (k m r^2).
  HSGPU_HD void spin_change(const double *n, const double *P, double k, double m, double r,
                            double *dw)
  {
    double c[3];
    cross3(n, P, c);
    const double f = r > 0.0 ? -1.0 / (k * m * r) : 0.0;
    for (int d = 0; d < 3; ++d) dw[d] = f * c[d];
  }

  /// Walton's tangential impulse P (on sphere i) for the relative contact-point velocity g,
  /// normal n, normal impulse Jn >= 0, effective tangential mass mt, friction mu, tangential
  /// restitution beta0.  elastic: a collision the guards made elastic (collision_step.h): the
  /// perfectly rough elastic impulse -2 m_t g_t instead, with no Coulomb cap (g_t is reversed,
  /// no energy is lost).  Returns 1 when the contact slides (the Coulomb cap acted), 0 when it
  /// sticks (or has no tangential velocity); gt receives g's tangential part.
  HSGPU_HD int tangential_impulse(const double *g, const double *n, double Jn, double mt, double mu,
                                  double beta0, int elastic, double *gt, double *P)
  {
    const double gn = g[0] * n[0] + g[1] * n[1] + g[2] * n[2];
    for (int d = 0; d < 3; ++d) gt[d] = g[d] - gn * n[d];
    const double gt2 = gt[0] * gt[0] + gt[1] * gt[1] + gt[2] * gt[2];
    if (!(gt2 > 0.0)) {
      P[0] = P[1] = P[2] = 0.0;
      return 0;
    }
    if (elastic) {
      for (int d = 0; d < 3; ++d) P[d] = -2.0 * mt * gt[d];
      return 0;
    }
    const double gabs = sqrt(gt2);
    const double stick = (1.0 + beta0) * mt;    // |P| / |g_t| of the sticking impulse
    const double cap = mu * Jn;
    if (stick * gabs <= cap) {
      for (int d = 0; d < 3; ++d) P[d] = -stick * gt[d];
      return 0;
    }
    const double slide = cap / gabs;
    for (int d = 0; d < 3; ++d) P[d] = -slide * gt[d];
    return 1;
  }

  /// Kinetic energy change of the tangential impulse P for the tangential velocity gt.
  HSGPU_HD double energy_change(const double *P, const double *gt, double mt)
  {
    const double pg = P[0] * gt[0] + P[1] * gt[1] + P[2] * gt[2];
    const double pp = P[0] * P[0] + P[1] * P[1] + P[2] * P[2];
    return pg + 0.5 * pp / mt;
  }

}    // namespace Friction
}    // namespace HSGPU

#endif
