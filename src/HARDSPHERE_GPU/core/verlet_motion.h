/* HARDSPHERE_GPU physics core: how LAMMPS's velocity-Verlet integrator moves an atom between
   two steps of fix hardsphere.

   The fix acts in post_integrate().  Between its call on one step and on the next, fix nve and
   fix nve/sphere move each atom of their group by the first step's final_integrate() and the
   next step's initial_integrate(), both with the forces f computed between them:

       dtfm = dtf / m;   v += dtfm f;   (final_integrate)
                         v += dtfm f;   x += dtv v;   (initial_integrate)

   with dtf = dt ftm2v / 2 and dtv = dt, component by component.  Where LAMMPS reneighbored in
   between (after the fix's first call, before the forces), Domain::pbc() first wrapped each
   atom into a periodic box: x < lo: x += prd; then x >= hi: x = max(x - prd, lo), dimension by
   dimension (the same in LAMMPS 2021 and 2025; orthogonal boxes).  A device step that keeps
   its own copies of x and v from the last step can move them the same way and get LAMMPS's
   values bit for bit, without copying them up (ResidentAtoms::motion, engine/resident_step.h).

   Each "a += b c" is one rounding of the product and one of the sum where the integrator was
   compiled without floating-point contraction (the default on x86-64 without -march), or one
   fused multiply-add where it was compiled with it (e.g. -march=native and GCC's default
   -ffp-contract=fast): `fused` picks which; the fix finds out by comparison.  The code that
   includes this is built without contraction (--fmad=false, -ffp-contract=off), so the plain
   form stays two roundings on host and device.

   Nothing here depends on LAMMPS, MPI or CUDA. */
#ifndef HSGPU_CORE_VERLET_MOTION_H
#define HSGPU_CORE_VERLET_MOTION_H

#include "hd.h"

#include <cmath>
#include <cstring>

namespace HSGPU {
namespace Collide {

  /// c + a b, rounded as the integrator rounds it (see above).
  HSGPU_HD double verlet_madd(double a, double b, double c, bool fused)
  {
#if defined(__CUDA_ARCH__)
    return fused ? __fma_rn(a, b, c) : __dadd_rn(c, __dmul_rn(a, b));
#else
    return fused ? std::fma(a, b, c) : c + a * b;
#endif
  }

  /// What happens to every atom between two of the fix's steps.
  struct StepMotion {
    double dtf = 0.0;     // the integrator's dt ftm2v / 2
    double dtv = 0.0;     // and dt
    bool wrap = false;    // a reneighboring in between: Domain::pbc() first
    // Half kicks: 2 from one step's post_integrate() (or post_force()) to the next's; 1 from
    // end_of_step(), after final_integrate()'s (FixHardSphere's gathered step run ahead).
    int kicks = 2;
    double lo[3] = {0.0, 0.0, 0.0}, hi[3] = {0.0, 0.0, 0.0}, prd[3] = {0.0, 0.0, 0.0};
    int periodic[3] = {0, 0, 0};
  };

  /// x (3) wrapped into the box as LAMMPS's Domain::pbc() wraps an atom of an orthogonal box.
  HSGPU_HD void pbc_wrap(double *x, const StepMotion &s)
  {
    for (int d = 0; d < 3; ++d) {
      if (!s.periodic[d]) continue;
      if (x[d] < s.lo[d]) x[d] += s.prd[d];
      if (x[d] >= s.hi[d]) {
        x[d] -= s.prd[d];
        x[d] = x[d] > s.lo[d] ? x[d] : s.lo[d];    // MAX(x, lo)
      }
    }
  }

  /// One atom from one step's post_integrate() to the next's: x, v (3 each) as LAMMPS's
  /// integrator leaves them, with forces f and mass m; x only where move_x; with kicks = 1
  /// only the second half kick (from the first step's end_of_step()).
  HSGPU_HD void verlet_between_steps(double *x, double *v, const double *f, double m,
                                     double dtf, double dtv, bool fused, bool move_x,
                                     int kicks = 2)
  {
    const double dtfm = dtf / m;
    for (int d = 0; d < 3; ++d) {
      if (kicks > 1) v[d] = verlet_madd(dtfm, f[d], v[d], fused);
      v[d] = verlet_madd(dtfm, f[d], v[d], fused);
      if (move_x) x[d] = verlet_madd(dtv, v[d], x[d], fused);
    }
  }

  /// The same with a possible reneighboring in between (StepMotion::wrap).
  HSGPU_HD void move_between_steps(double *x, double *v, const double *f, double m,
                                   const StepMotion &s, bool fused)
  {
    if (s.wrap) pbc_wrap(x, s);
    verlet_between_steps(x, v, f, m, s.dtf, s.dtv, fused, true, s.kicks);
  }

  /// A check of the integrator's rounding (host only): atoms [0, n) whose x0, v0 (3 each, as
  /// LAMMPS held them at the last step's forces f, or zero forces where f is null; masses m),
  /// moved by move_between_steps() both ways of rounding, differ in any bit from x, v (3
  /// each, LAMMPS's now): miss[0 .. 3] count them for x (plain), v (plain), x (fused), v (fused).
  inline void count_motion_misses(const double *x0, const double *v0, const double *f,
                                  const double *m, const double *x, const double *v, long n,
                                  const StepMotion &s, long long miss[4])
  {
    static const double none[3] = {0.0, 0.0, 0.0};
    for (int k = 0; k < 4; ++k) miss[k] = 0;
    for (long i = 0; i < n; ++i)
      for (int way = 0; way < 2; ++way) {
        double xi[3], vi[3];
        for (int d = 0; d < 3; ++d) {
          xi[d] = x0[3 * i + d];
          vi[d] = v0[3 * i + d];
        }
        move_between_steps(xi, vi, f ? f + 3 * i : none, m[i], s, way == 1);
        miss[2 * way] += std::memcmp(xi, x + 3 * i, sizeof xi) != 0;
        miss[2 * way + 1] += std::memcmp(vi, v + 3 * i, sizeof vi) != 0;
      }
  }

}    // namespace Collide
}    // namespace HSGPU

#endif
