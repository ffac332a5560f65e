/* HARDSPHERE_GPU test harness: drives a LAMMPS instance through its C library interface
   (library.h), with the package's plugin loaded. */
#ifndef HSGPU_TEST_HARNESS_H
#define HSGPU_TEST_HARNESS_H

#include <mpi.h>

#include <cstdlib>
#include <string>
#include <vector>

namespace hsgpu_test {

class Lammps {
 public:
  // A LAMMPS instance on `comm` with screen and log output off (set HSGPU_TEST_VERBOSE=1 to
  // see them); loads the plugin unless load_plugin is false.
  explicit Lammps(MPI_Comm comm = MPI_COMM_WORLD, bool load_plugin = true);
  ~Lammps();
  Lammps(const Lammps &) = delete;
  Lammps &operator=(const Lammps &) = delete;

  // Runs one input line; on a LAMMPS error returns the error message, else "".
  std::string command(const std::string &line);
  // Runs input lines, failing the current test on the first error.
  void commands(const std::vector<std::string> &lines);
  // Runs lines up to the first error and returns its message ("" when all succeeded).
  std::string first_error(const std::vector<std::string> &lines);

  long natoms();
  // Per-atom double vector ("x", "v", "f", ...) of count entries per atom, in atom-ID order,
  // on every rank.
  std::vector<double> gather(const char *name, int count);
  double thermo(const char *keyword);
  // Global scalar of compute `id`, or element i (0-based) of its global vector.
  double compute_scalar(const char *id);
  double compute_vector(const char *id, int i);
  // Element i (0-based) of fix `id`'s global vector, NaN where the fix gives none.
  double fix_vector(const char *id, int i);
  // Value of equal-style variable `name` (NaN where there is none).
  double variable(const char *name);
  // Sets per-atom double vector `name` ("x", "v") of count entries per atom, in atom-ID order
  // (atom_modify map needed), from the same data on every rank.
  void scatter(const char *name, int count, std::vector<double> &data);
  // The box bounds and its periodicity per dimension.
  void box(double lo[3], double hi[3], int periodic[3]);
  // A global value that LAMMPS's library interface extracts as a double ("mvv2e", "dt").
  double global(const char *name);
  void *handle() { return lmp; }

 private:
  void *lmp;
};

// Path of the plugin under test (set by CMake).
const char *plugin_path();

// All pairs of spheres of one diameter at x (3 per atom, as gather("x", 3) gives them): the
// smallest centre distance minus the diameter, nearest image along each dimension d with
// period[d] > 0.  Negative: an overlap.
double closest_pair_gap(const std::vector<double> &x, double diameter, const double period[3]);

// The largest |a[i] - b[i]|; infinite where the sizes differ.
double max_abs_diff(const std::vector<double> &a, const std::vector<double> &b);

// The text of a file ("" where there is none).
std::string file_text(const std::string &path);

// printf-style formatting of input lines, up to four numbers (formats are the tests' literals).
std::string fmt(const char *format, double a = 0, double b = 0, double c = 0, double d = 0);

// An environment variable set (value given) or unset (nullptr) for a scope, as it was after;
// nothing done where apply is false.
class ScopedEnv {
 public:
  ScopedEnv(const char *name, const char *value, bool apply = true) : name(name), apply(apply)
  {
    if (!apply) return;
    const char *was = std::getenv(name);
    had = was != nullptr;
    if (had) kept = was;
    if (value)
      setenv(name, value, 1);
    else
      unsetenv(name);
  }
  ScopedEnv(const ScopedEnv &) = delete;
  ScopedEnv &operator=(const ScopedEnv &) = delete;
  ~ScopedEnv()
  {
    if (!apply) return;
    if (had)
      setenv(name, kept.c_str(), 1);
    else
      unsetenv(name);
  }

 private:
  const char *name;
  bool apply;
  bool had = false;
  std::string kept;
};

}    // namespace hsgpu_test

#endif
