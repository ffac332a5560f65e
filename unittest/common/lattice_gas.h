/* HARDSPHERE_GPU tests: a periodic lattice gas for the resident step's run_atoms() (the
   caller's per-atom arrays), shared by the CUDA and host tests of the resident step. */
#ifndef HSGPU_TEST_LATTICE_GAS_H
#define HSGPU_TEST_LATTICE_GAS_H

#include "engine/resident_step.h"

#include <vector>

namespace hsgpu_test {

using namespace HSGPU::Collide;

// A periodic simple cubic lattice of side^3 spheres of diameter 1 and mass 1, `spacing` apart,
// elastic, at rest or with velocities in [-1, 1) from a fixed seed (every atom, or every other
// one); x holds the lattice points.  Not copyable: p.epair points into it.
struct LatticeGas {
  int n;
  std::vector<double> x, v, f, radius, rmass;
  std::vector<int> type, id;
  std::vector<double> epair = {0, 0, 0, 1.0};
  Params p{};
  ResidentBox box;
  WindowSettings s;

  LatticeGas(int side, double spacing, double dt, unsigned seed, int moving_every) :
      n(side * side * side), x(3 * n), v(3 * n, 0.0), f(3 * n, 0.0), radius(n, 0.5), rmass(n, 1.0),
      type(n, 1), id(n)
  {
    auto uniform = [&seed]() {
      seed = seed * 1103515245u + 12345u;
      return ((seed >> 8) & 0xffff) / 32768.0 - 1.0;
    };
    for (int i = 0; i < n; ++i) {
      const int c[3] = {i % side, (i / side) % side, i / (side * side)};
      id[i] = i + 1;
      for (int d = 0; d < 3; ++d) {
        if (i % moving_every == 0) v[3 * i + d] = uniform();
        x[3 * i + d] = (c[d] + 0.5) * spacing;
      }
    }
    p.dt = dt;
    p.ntypes = 1;
    p.epair = epair.data();
    p.maxevents = 1000000;
    for (int d = 0; d < 3; ++d) {
      box.lo[d] = 0.0;
      box.prd[d] = side * spacing;
      box.periodic[d] = 1;
    }
    box.overlap_tol = 1e-9;
    box.reach = 1.0;
  }
  LatticeGas(const LatticeGas &) = delete;
  LatticeGas &operator=(const LatticeGas &) = delete;

  /// The atoms for run_atoms(): these positions, velocities, times of last collision and
  /// radii, the scene's other arrays.
  ResidentAtoms atoms(double *xs, double *vs, double *tlast, const double *rad,
                      double bound_floor) const
  {
    ResidentAtoms a;
    a.n = n;
    a.x = xs;
    a.v = vs;
    a.tlast = tlast;
    a.f = f.data();
    a.radius = rad;
    a.rmass = rmass.data();
    a.type = type.data();
    a.id = id.data();
    a.id_bytes = (int) sizeof(int);
    a.ftm2v = 1.0;
    a.bound_floor = bound_floor;
    a.reach = box.reach;
    a.never = -1e30;
    return a;
  }
};


}    // namespace hsgpu_test

#endif
