#include "harness.h"

#define LAMMPS_LIB_MPI
#include "library.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <cstring>
#include <fstream>
#include <sstream>

namespace hsgpu_test {

double max_abs_diff(const std::vector<double> &a, const std::vector<double> &b)
{
  if (a.size() != b.size()) return INFINITY;
  double w = 0.0;
  for (size_t i = 0; i < a.size(); ++i) w = std::max(w, std::fabs(a[i] - b[i]));
  return w;
}

std::string file_text(const std::string &path)
{
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wformat-nonliteral"
std::string fmt(const char *format, double a, double b, double c, double d)
{
  char buf[512];
  std::snprintf(buf, sizeof(buf), format, a, b, c, d);
  return buf;
}
#pragma GCC diagnostic pop

double closest_pair_gap(const std::vector<double> &x, double diameter, const double period[3])
{
  const size_t n = x.size() / 3;
  double closest = 1e300;
  for (size_t i = 0; i < n; ++i)
    for (size_t j = i + 1; j < n; ++j) {
      double d2 = 0.0;
      for (int d = 0; d < 3; ++d) {
        double dx = x[3 * i + d] - x[3 * j + d];
        if (period[d] > 0.0) dx -= period[d] * std::round(dx / period[d]);
        d2 += dx * dx;
      }
      closest = std::min(closest, std::sqrt(d2) - diameter);
    }
  return closest;
}

const char *plugin_path()
{
  // HSGPU_PLUGIN overrides the build-tree path (e.g. when the tests run on another machine).
  const char *env = std::getenv("HSGPU_PLUGIN");
  return (env && *env) ? env : HSGPU_PLUGIN_PATH;
}

Lammps::Lammps(MPI_Comm comm, bool load_plugin) : lmp(nullptr)
{
  const bool verbose = std::getenv("HSGPU_TEST_VERBOSE") != nullptr;
  std::vector<std::string> args = {"hsgpu_test", "-nocite", "-log", "none"};
  if (!verbose) {
    args.insert(args.end(), {"-screen", "none", "-echo", "none"});
  } else {
    args.insert(args.end(), {"-echo", "screen"});
  }
  std::vector<char *> argv;
  for (auto &a : args) argv.push_back(const_cast<char *>(a.c_str()));
  argv.push_back(nullptr);
  lmp = lammps_open((int) args.size(), argv.data(), comm, nullptr);
  if (!lmp) throw std::runtime_error("lammps_open failed");
  if (load_plugin) {
    const std::string err = command(std::string("plugin load ") + plugin_path());
    if (!err.empty()) throw std::runtime_error("plugin load failed: " + err);
  }
}

Lammps::~Lammps()
{
  if (lmp) lammps_close(lmp);
}

std::string Lammps::command(const std::string &line)
{
  lammps_command(lmp, line.c_str());
  if (lammps_has_error(lmp)) {
    char buf[2048];
    lammps_get_last_error_message(lmp, buf, sizeof(buf));
    return std::string(buf);
  }
  return "";
}

void Lammps::commands(const std::vector<std::string> &lines)
{
  for (const auto &l : lines) {
    const std::string err = command(l);
    ASSERT_EQ(err, "") << "while running: " << l;
  }
}

std::string Lammps::first_error(const std::vector<std::string> &lines)
{
  for (const auto &l : lines) {
    const std::string err = command(l);
    if (!err.empty()) return err;
  }
  return "";
}

long Lammps::natoms()
{
  return (long) lammps_get_natoms(lmp);
}

std::vector<double> Lammps::gather(const char *name, int count)
{
  std::vector<double> out((size_t) natoms() * count);
  char buf[64];
  std::strncpy(buf, name, sizeof(buf) - 1);
  buf[sizeof(buf) - 1] = '\0';
  lammps_gather_atoms(lmp, buf, 1, count, out.data());
  return out;
}

double Lammps::thermo(const char *keyword)
{
  return lammps_get_thermo(lmp, keyword);
}

double Lammps::compute_scalar(const char *id)
{
  auto *v = (double *) lammps_extract_compute(lmp, id, LMP_STYLE_GLOBAL, LMP_TYPE_SCALAR);
  if (!v) throw std::runtime_error(std::string("no global scalar from compute ") + id);
  return *v;
}

double Lammps::compute_vector(const char *id, int i)
{
  auto *v = (double *) lammps_extract_compute(lmp, id, LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR);
  if (!v) throw std::runtime_error(std::string("no global vector from compute ") + id);
  return v[i];
}

double Lammps::fix_vector(const char *id, int i)
{
  auto *p = (double *) lammps_extract_fix(lmp, id, LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR, i, 0);
  if (!p) return NAN;
  const double v = *p;
  lammps_free(p);
  return v;
}

double Lammps::variable(const char *name)
{
  auto *p = (double *) lammps_extract_variable(lmp, name, nullptr);
  if (!p) return NAN;
  const double v = *p;
  lammps_free(p);
  return v;
}

void Lammps::scatter(const char *name, int count, std::vector<double> &data)
{
  char buf[64];
  std::strncpy(buf, name, sizeof(buf) - 1);
  buf[sizeof(buf) - 1] = '\0';
  lammps_scatter_atoms(lmp, buf, 1, count, data.data());
}

void Lammps::box(double lo[3], double hi[3], int periodic[3])
{
  double xy = 0.0, yz = 0.0, xz = 0.0;
  int changes = 0;
  lammps_extract_box(lmp, lo, hi, &xy, &yz, &xz, periodic, &changes);
}

double Lammps::global(const char *name)
{
  auto *p = (double *) lammps_extract_global(lmp, name);
  if (!p) throw std::runtime_error(std::string("no global value ") + name);
  return *p;
}

}    // namespace hsgpu_test
