/* HARDSPHERE_GPU physics core: the impulse of a smooth hard-sphere collision.

   Two smooth spheres of masses m_i, m_j meeting along the unit normal n (from j to i) with
   normal relative velocity vn = (v_i - v_j).n < 0 exchange the impulse J n,

       J = -(1 + e) m_eff vn,        m_eff = m_i m_j / (m_i + m_j),

   v_i += (J / m_i) n, v_j -= (J / m_j) n.  Momentum is conserved; the kinetic energy drops by
   (1 - e^2) m_eff vn^2 / 2 and the normal relative velocity becomes -e vn.  A wall is a partner
   of infinite mass: m_eff = m.

   Guards against inelastic collapse make a collision elastic (e = 1):
     - TC model (Luding & McNamara 1998): either partner collided less than tc ago;
     - elastic threshold (DynamO's ElasticV): |vn| < vmin.

   Nothing here depends on LAMMPS, MPI or CUDA. */
#ifndef HSGPU_CORE_IMPULSE_H
#define HSGPU_CORE_IMPULSE_H

#include "hd.h"

#include <cmath>

namespace HSGPU {
namespace Impulse {

  /// The restitution a collision gets: e, or 1 when a guard applies.  since_i and since_j are
  /// the times since each partner's previous collision (a wall passes since_j = since_i).
  HSGPU_HD double effective_restitution(double e, double since_i, double since_j, double tc,
                                        double vn, double vmin)
  {
    if (since_i < tc || since_j < tc) return 1.0;
    if (fabs(vn) < vmin) return 1.0;
    return e;
  }

  HSGPU_HD double reduced_mass(double mi, double mj)
  {
    return mi * mj / (mi + mj);
  }

  /// Scalar impulse J along n for normal relative velocity vn and restitution e.
  HSGPU_HD double pair_impulse(double vn, double meff, double e)
  {
    return -(1.0 + e) * meff * vn;
  }

  /// Kinetic energy that a collision with normal relative velocity vn removes.
  HSGPU_HD double energy_loss(double vn, double meff, double e)
  {
    return 0.5 * (1.0 - e * e) * meff * vn * vn;
  }

  /// Kinetic energy change of a pair with normal relative velocity vn that receives the impulse
  /// J (along n on i, -n on j): J vn + J^2 / (2 m_eff).  For J = pair_impulse(vn, meff, e) this is
  /// -energy_loss(vn, meff, e).
  HSGPU_HD double energy_change(double J, double vn, double meff)
  {
    return J * vn + 0.5 * J * J / meff;
  }

  /// Applies the impulse J along the unit normal n (pointing from j to i) to both velocities.
  HSGPU_HD void apply_pair_impulse(double *vi, double *vj, const double *n, double J, double mi,
                                   double mj)
  {
    const double ai = J / mi, aj = J / mj;
    for (int d = 0; d < 3; ++d) {
      vi[d] += ai * n[d];
      vj[d] -= aj * n[d];
    }
  }

}    // namespace Impulse
}    // namespace HSGPU

#endif
