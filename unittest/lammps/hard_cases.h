/* HARDSPHERE_GPU hard-case suite (issue 12 item 14): the scenes, an overlap check that does
   not use the fix, and a runner shared by the short tests (label hard) and the long mode.

   The long mode is switched on with the environment variable HSGPU_HARD_LONG=1 (see
   tools/hard_cases.sh): every scene is then built at its long size and run until the fix has
   counted at least HSGPU_HARD_EVENTS events (default 1e7), and each test prints one row of
   the table in doc/hard_cases.md. */
#ifndef HSGPU_TEST_HARD_CASES_H
#define HSGPU_TEST_HARD_CASES_H

#include "harness.h"

#include <functional>
#include <string>
#include <vector>

namespace hsgpu_hard {

// Overlap criterion of the fix: a pair closer than (1 - 1e-9) of its contact distance.
constexpr double kOverlap = 1e-9;

bool long_mode();
// Events a long run goes on to (HSGPU_HARD_EVENTS, default 1e7).
double target_events();

// The closest approach of the spheres at x (3 per atom) with radii r, relative to the contact
// distance, over all pairs (a cell list with the nearest image along periodic dimensions; the
// few spheres much larger than the rest are checked against all atoms) and against the
// non-periodic faces of the box (contact distance: the radius).  overlaps counts the pairs and
// wall contacts beyond kOverlap; worst_mixed is the closest pair of unequal radii (ratio > 2).
struct Gap {
  double worst = 1e300, worst_mixed = 1e300;
  long overlaps = 0;
};
Gap closest_gap(const std::vector<double> &x, const std::vector<double> &r, const double lo[3],
                const double hi[3], const int periodic[3], int dimension);

// One case: header (units, dimension, atom style, boundary), atoms (box, atoms, velocities) and
// fixes (integrator, fix hardsphere with ID hs, fields, timestep), no run; prepare is run
// before a data file of the scene is written (the rank comparisons).  A micro scene (place
// set) is placed anew before every chunk, with x and v in atom-ID order, and checked after it
// by verify ("" when right, else what went wrong).
struct Scene {
  std::string name;
  std::vector<std::string> header, atoms, fixes, prepare;
  int dimension = 3;
  double g = 0.0;    // magnitude of fix gravity along -axis gaxis (for the potential energy)
  int gaxis = 2;
  long steps = 0;       // steps of the run (a long run goes on in chunks to target_events())
  long chunk = 100;     // steps between the checks
  bool pour = false;    // report events per sphere per step
  // Friction: the energy balance includes the spheres' rotation.
  bool rough = false;
  std::function<void(long chunk, std::vector<double> &x, std::vector<double> &v)> place;
  std::function<std::string(long chunk, const std::vector<double> &x, const std::vector<double> &v,
                            double collisions)>
      verify;
};

struct Result {
  std::string error;    // LAMMPS's error, or the first failure of verify
  long natoms = 0, steps = 0, chunks = 0;
  double events = 0.0, collisions = 0.0, seconds = 0.0;
  Gap gap;               // over all checks
  double e0 = 0.0;       // total energy at the start (kinetic + m g h)
  double drift = 0.0;    // sum over chunks of (E_end + removed - E_start), relative to e0
  // The largest |E_end + removed - E_start| / E_start of a chunk: the figure of a micro scene,
  // whose energy is set anew before every step.
  double chunk_drift = 0.0;
  double last_per_sphere_step = 0.0;    // events per sphere per step in the last chunk
  double max_events_step = 0.0;         // f_hs[5]
  double ke_end = 0.0, energy_removed = 0.0;
};

// Total energy: kinetic (LAMMPS's energy units) plus m g (x[gaxis] - lo) for gravity g.
double total_energy(hsgpu_test::Lammps &lmp, const Scene &s);

// Builds the scene, runs it (short: s.steps; long: at least s.steps and target_events()
// events) with an overlap check and an energy balance after every chunk.
Result run_scene(hsgpu_test::Lammps &lmp, const Scene &s, bool long_run);

// One table row (the long mode's), printed on rank 0.
void print_row(const Scene &s, const Result &r);

// --- the scenes ---------------------------------------------------------------------------
// A block of spheres poured onto the floor under g = 1 with restitution e (pairs and walls),
// run to t = 75.
Scene pour(double e, bool long_size);
// The same pour with friction mu and tangential restitution 0.3 between the spheres and on
// the floor (issue 15); guard false: friction/guard none.
Scene rough_pour(double e, double mu, bool long_size, bool guard = true);
// Elastic spheres of diameter 1 on an fcc or sc lattice at packing fraction phi, T = 1.
Scene crystal(const char *style, double phi, bool long_size);
// Diameters 1 and 10 (the big ones dropped onto a bed of small ones) under gravity, e = 0.9.
Scene size_ratio_ten(bool long_size);
// Diameters spread evenly over 0.5 ... 1.5 under gravity, e = 0.8.
Scene polydisperse(bool long_size);
// Pairs on grazing courses (impact parameter contact - 1e-12) and a quarter just missing
// (contact + 1e-12), placed anew every step.
Scene grazing(bool long_size);
// Pairs starting in contact (exact, 1e-10 of contact overlapped, 1e-15 apart) and approaching
// or receding, and rows of three in contact (a cradle at t = 0), placed anew every step.
Scene touching(bool long_size);
// A sphere crossing five diameters per step into a row of five spheres with gaps of 0.6,
// placed anew every step.
Scene crossing(bool long_size);
// Grains of 1 mm under g = 9.81 m/s^2 in units si; argon-sized elastic spheres in units real;
// a pile of disks in dimension 2.
Scene units_si(bool long_size);
Scene units_real(bool long_size);
Scene disks_2d(bool long_size);
// For the rank comparisons: a settled inelastic pile and an elastic dense fluid (packing
// fraction 0.45), built on one rank; their state is then written to a data file.
Scene mpi_pile(bool long_size);
Scene mpi_fluid(bool long_size);

}    // namespace hsgpu_hard

#endif
