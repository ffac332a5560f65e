/* HARDSPHERE_GPU physics core: softened Newtonian gravity between point masses.

   One definition of the pair interaction for the CPU path, the CUDA kernels and the tests:

     U_ij = -G m_i m_j / sqrt(r^2 + eps^2)
     F_i  = -G m_i m_j (x_i - x_j) / (r^2 + eps^2)^(3/2)     (attractive)

   with x_i - x_j taken through the nearest periodic image along periodic directions of an
   orthogonal box.  Nothing here depends on LAMMPS, MPI or CUDA. */
#ifndef HSGPU_CORE_GRAVITY_PAIR_H
#define HSGPU_CORE_GRAVITY_PAIR_H

#include "hd.h"

#include <cmath>

namespace HSGPU {
namespace Gravity {

  /// Orthogonal simulation box seen by the all-pairs sum.
  struct Box {
    double lo[3];
    double prd[3];
    int periodic[3];
  };

  /// Interaction parameters; cutsq <= 0 means no cutoff.
  struct Params {
    double G;
    double eps2;
    double cutsq;
  };

  /// Per-target result: force, this target's half of its pair energies and its half of the
  /// pair virials (xx, yy, zz, xy, xz, yz), the split LAMMPS uses for per-atom tallies.
  struct Accum {
    double f[3];
    double e;
    double v[6];
  };

  /// Map a coordinate into [lo, lo + prd) along a periodic direction.
  HSGPU_HD double wrap_coordinate(double x, double lo, double prd)
  {
    double s = x - lo;
    s -= prd * floor(s / prd);
    if (s >= prd) s -= prd;    // floor() round-off at the upper edge
    if (s < 0.0) s = 0.0;
    return lo + s;
  }

  /// Nearest-image displacement for coordinates that both lie in the primary cell, so that
  /// |d| < prd on entry.
  template <class Real> HSGPU_HD Real nearest_image(Real d, Real prd, int periodic)
  {
    if (periodic) {
      const Real half = Real(0.5) * prd;
      if (d > half)
        d -= prd;
      else if (d < -half)
        d += prd;
    }
    return d;
  }

  /// Pair terms for squared separation r2 and gmm = G m_i m_j: F_i = fpair * (x_i - x_j),
  /// energy e.  No cutoff test here.
  template <class Real> HSGPU_HD void pair_terms(Real r2, Real gmm, Real eps2, Real &fpair, Real &e)
  {
    const Real inv = Real(1) / sqrt(r2 + eps2);
    e = -gmm * inv;
    fpair = e * inv * inv;
  }

  /// Sum of all pair interactions of one target with n sources (positions xs[3*j] wrapped
  /// into the box, masses ms[j]), leaving out source index `self` (pass -1 for none).
  /// Accumulates in double whatever the position type.
  HSGPU_HD void sum_on_target(const double *xi, double mi, long self, const double *xs,
                              const double *ms, long n, const Box &box, const Params &p, Accum &out)
  {
    double f0 = 0.0, f1 = 0.0, f2 = 0.0, e = 0.0;
    double v0 = 0.0, v1 = 0.0, v2 = 0.0, v3 = 0.0, v4 = 0.0, v5 = 0.0;
    const double gmi = p.G * mi;
    for (long j = 0; j < n; ++j) {
      if (j == self) continue;
      const double dx = nearest_image(xi[0] - xs[3 * j], box.prd[0], box.periodic[0]);
      const double dy = nearest_image(xi[1] - xs[3 * j + 1], box.prd[1], box.periodic[1]);
      const double dz = nearest_image(xi[2] - xs[3 * j + 2], box.prd[2], box.periodic[2]);
      const double r2 = dx * dx + dy * dy + dz * dz;
      if (p.cutsq > 0.0 && r2 > p.cutsq) continue;
      double fpair, eij;
      pair_terms(r2, gmi * ms[j], p.eps2, fpair, eij);
      const double fx = fpair * dx, fy = fpair * dy, fz = fpair * dz;
      f0 += fx;
      f1 += fy;
      f2 += fz;
      e += eij;
      v0 += dx * fx;
      v1 += dy * fy;
      v2 += dz * fz;
      v3 += dx * fy;
      v4 += dx * fz;
      v5 += dy * fz;
    }
    out.f[0] = f0;
    out.f[1] = f1;
    out.f[2] = f2;
    out.e = 0.5 * e;
    out.v[0] = 0.5 * v0;
    out.v[1] = 0.5 * v1;
    out.v[2] = 0.5 * v2;
    out.v[3] = 0.5 * v3;
    out.v[4] = 0.5 * v4;
    out.v[5] = 0.5 * v5;
  }

}    // namespace Gravity
}    // namespace HSGPU

#endif
