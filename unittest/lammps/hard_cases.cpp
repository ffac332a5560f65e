#include "hard_cases.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <mpi.h>
#include <random>

using hsgpu_test::Lammps;

namespace hsgpu_hard {

namespace {

  __attribute__((format(printf, 1, 2))) std::string line(const char *format, ...)
  {
    char buf[512];
    va_list ap;
    va_start(ap, format);
    std::vsnprintf(buf, sizeof(buf), format, ap);
    va_end(ap);
    return buf;
  }

  std::vector<std::string> cat(std::vector<std::string> a, const std::vector<std::string> &b)
  {
    a.insert(a.end(), b.begin(), b.end());
    return a;
  }

  // The run settings every scene shares (LAMMPS 2021's default neighbor delay is 10).
  std::vector<std::string> dynamics(const std::string &fix_hs, double dt)
  {
    return {"comm_modify vel yes",      "neigh_modify every 1 delay 0 check yes",
            "fix 1 all nve/sphere",     "fix hs all hardsphere " + fix_hs,
            line("timestep %.17g", dt), "thermo_modify norm no"};
  }

}    // namespace

bool long_mode()
{
  const char *e = std::getenv("HSGPU_HARD_LONG");
  return e && *e && std::string(e) != "0";
}

double target_events()
{
  const char *e = std::getenv("HSGPU_HARD_EVENTS");
  return (e && *e) ? std::atof(e) : 1e7;
}

Gap closest_gap(const std::vector<double> &x, const std::vector<double> &r, const double lo[3],
                const double hi[3], const int periodic[3], int dimension)
{
  Gap g;
  const long n = (long) r.size();
  if (n == 0) return g;
  std::vector<double> sorted(r);
  std::nth_element(sorted.begin(), sorted.begin() + n / 2, sorted.end());
  const double rbig = 2.0 * sorted[n / 2];
  double rcell = 0.0;
  for (double ri : r)
    if (ri <= rbig) rcell = std::max(rcell, ri);
  const double c = 2.0 * rcell;
  double len[3];
  int nc[3];
  for (int d = 0; d < 3; ++d) {
    len[d] = hi[d] - lo[d];
    nc[d] = 1;
    if (d < dimension) nc[d] = std::max(1, std::min(200, (int) std::floor(len[d] / c)));
    if (periodic[d] && nc[d] < 3) nc[d] = 1;
  }
  auto cell_of = [&](long i, int d) {
    double u = (x[3 * i + d] - lo[d]) / len[d];
    if (periodic[d]) u -= std::floor(u);
    return std::max(0, std::min(nc[d] - 1, (int) std::floor(u * nc[d])));
  };
  const long ncell = (long) nc[0] * nc[1] * nc[2];
  std::vector<long> head(ncell, -1), next(n, -1);
  std::vector<long> big;
  for (long i = n - 1; i >= 0; --i) {
    if (r[i] > rbig) {
      big.push_back(i);
      continue;
    }
    const long k = ((long) cell_of(i, 2) * nc[1] + cell_of(i, 1)) * nc[0] + cell_of(i, 0);
    next[i] = head[k];
    head[k] = i;
  }
  auto pair = [&](long i, long j) {
    double d2 = 0.0;
    for (int d = 0; d < 3; ++d) {
      double dx = x[3 * i + d] - x[3 * j + d];
      if (periodic[d]) dx -= len[d] * std::round(dx / len[d]);
      d2 += dx * dx;
    }
    const double s = r[i] + r[j];
    const double gap = (std::sqrt(d2) - s) / s;
    g.worst = std::min(g.worst, gap);
    if (std::max(r[i], r[j]) > 2.0 * std::min(r[i], r[j]))
      g.worst_mixed = std::min(g.worst_mixed, gap);
    if (gap < -kOverlap) ++g.overlaps;
  };
  for (int cz = 0; cz < nc[2]; ++cz)
    for (int cy = 0; cy < nc[1]; ++cy)
      for (int cx = 0; cx < nc[0]; ++cx) {
        const int cc[3] = {cx, cy, cz};
        for (long i = head[((long) cz * nc[1] + cy) * nc[0] + cx]; i >= 0; i = next[i])
          for (int oz = -1; oz <= 1; ++oz)
            for (int oy = -1; oy <= 1; ++oy)
              for (int ox = -1; ox <= 1; ++ox) {
                const int o[3] = {ox, oy, oz};
                int nb[3];
                bool skip = false;
                for (int d = 0; d < 3; ++d) {
                  if (nc[d] == 1 && o[d] != 0) skip = true;
                  nb[d] = cc[d] + o[d];
                  if (periodic[d])
                    nb[d] = (nb[d] + nc[d]) % nc[d];
                  else if (nb[d] < 0 || nb[d] >= nc[d])
                    skip = true;
                }
                if (skip) continue;
                for (long j = head[((long) nb[2] * nc[1] + nb[1]) * nc[0] + nb[0]]; j >= 0;
                     j = next[j])
                  if (j > i) pair(i, j);
              }
      }
  for (long b : big)
    for (long j = 0; j < n; ++j)
      if (j != b && !(r[j] > rbig && j < b)) pair(b, j);
  for (long i = 0; i < n; ++i)
    for (int d = 0; d < dimension; ++d) {
      if (periodic[d]) continue;
      const double glo = (x[3 * i + d] - lo[d] - r[i]) / r[i];
      const double ghi = (hi[d] - x[3 * i + d] - r[i]) / r[i];
      g.worst = std::min(g.worst, std::min(glo, ghi));
      if (glo < -kOverlap) ++g.overlaps;
      if (ghi < -kOverlap) ++g.overlaps;
    }
  return g;
}

double total_energy(Lammps &lmp, const Scene &s)
{
  const auto v = lmp.gather("v", 3), m = lmp.gather("rmass", 1);
  double ke = 0.0, pe = 0.0;
  for (size_t i = 0; i < m.size(); ++i)
    ke += 0.5 * m[i] *
          (v[3 * i] * v[3 * i] + v[3 * i + 1] * v[3 * i + 1] + v[3 * i + 2] * v[3 * i + 2]);
  if (s.rough) {
    // Rotation of solid spheres (0.4 m r^2), which friction exchanges with translation.
    const auto w = lmp.gather("omega", 3), r = lmp.gather("radius", 1);
    for (size_t i = 0; i < m.size(); ++i)
      ke += 0.5 * 0.4 * m[i] * r[i] * r[i] *
            (w[3 * i] * w[3 * i] + w[3 * i + 1] * w[3 * i + 1] + w[3 * i + 2] * w[3 * i + 2]);
  }
  if (s.g != 0.0) {
    double lo[3], hi[3];
    int per[3];
    lmp.box(lo, hi, per);
    const auto x = lmp.gather("x", 3);
    for (size_t i = 0; i < m.size(); ++i) pe += m[i] * s.g * (x[3 * i + s.gaxis] - lo[s.gaxis]);
  }
  return ke * lmp.global("mvv2e") + pe;
}

Result run_scene(Lammps &lmp, const Scene &s, bool long_run)
{
  Result r;
  r.error = lmp.first_error(cat(cat(s.header, s.atoms), s.fixes));
  if (!r.error.empty()) return r;
  r.natoms = lmp.natoms();
  double lo[3], hi[3];
  int per[3];
  lmp.box(lo, hi, per);
  const double target = long_run ? target_events() : 0.0;
  double events = 0.0, removed = 0.0;
  bool first = true;
  const bool trace = std::getenv("HSGPU_HARD_TRACE") != nullptr;
  while (r.steps < s.steps || events < target) {
    const long k = long_run ? s.chunk : std::min(s.chunk, s.steps - r.steps);
    if (s.place) {
      auto x = lmp.gather("x", 3), v = lmp.gather("v", 3);
      s.place(r.chunks, x, v);
      lmp.scatter("x", 3, x);
      lmp.scatter("v", 3, v);
    }
    const double e_start = total_energy(lmp, s);
    if (first) r.e0 = e_start;
    first = false;
    const auto t0 = std::chrono::steady_clock::now();
    r.error = lmp.command(line("run %ld post no", k));
    const auto t1 = std::chrono::steady_clock::now();
    if (!r.error.empty()) break;
    r.seconds += std::chrono::duration<double>(t1 - t0).count();
    r.steps += k;
    ++r.chunks;
    const double ev = lmp.fix_vector("hs", 5), rem = lmp.fix_vector("hs", 3);
    r.last_per_sphere_step = (ev - events) / ((double) r.natoms * k);
    const double balance = total_energy(lmp, s) + (rem - removed) - e_start;
    r.drift += balance;
    if (e_start != 0.0) r.chunk_drift = std::max(r.chunk_drift, std::fabs(balance / e_start));
    events = ev;
    removed = rem;
    if (trace) {
      int me = 0;
      MPI_Comm_rank(MPI_COMM_WORLD, &me);
      if (me == 0)
        std::printf("[ trace    ] %s: step %ld, %.6g events, %.3f per sphere per step in the last "
                    "%ld, %.1f s\n",
                    s.name.c_str(), r.steps, events, r.last_per_sphere_step, k, r.seconds);
    }
    const auto x = lmp.gather("x", 3), rad = lmp.gather("radius", 1);
    const Gap g = closest_gap(x, rad, lo, hi, per, s.dimension);
    r.gap.worst = std::min(r.gap.worst, g.worst);
    r.gap.worst_mixed = std::min(r.gap.worst_mixed, g.worst_mixed);
    r.gap.overlaps += g.overlaps;
    if (s.verify) {
      r.error = s.verify(r.chunks - 1, x, lmp.gather("v", 3), lmp.fix_vector("hs", 0));
      if (!r.error.empty()) break;
    }
  }
  r.events = events;
  r.energy_removed = removed;
  r.collisions = lmp.fix_vector("hs", 1);
  r.max_events_step = lmp.fix_vector("hs", 4);
  if (r.e0 != 0.0) r.drift /= std::fabs(r.e0);
  Scene kinetic = s;
  kinetic.g = 0.0;
  r.ke_end = total_energy(lmp, kinetic);
  return r;
}

void print_row(const Scene &s, const Result &r)
{
  int me = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &me);
  if (me != 0) return;
  char per[64] = "";
  if (s.pour)
    std::snprintf(per, sizeof(per), "%.2f (%.1f)", r.last_per_sphere_step,
                  r.max_events_step / (double) r.natoms);
  char balance[64];
  if (s.place)
    std::snprintf(balance, sizeof(balance), "%.1e per step", r.chunk_drift);
  else
    std::snprintf(balance, sizeof(balance), "%.1e", r.drift);
  std::printf("[ HARD     ] | %s | %ld | %ld | %.4g | %.3g | %.2e | %ld | %s | %s |%s\n",
              s.name.c_str(), r.natoms, r.steps, r.events,
              r.seconds > 0.0 ? r.events / r.seconds : 0.0, r.gap.worst, r.gap.overlaps, balance,
              per, r.error.empty() ? "" : (" ERROR: " + r.error).c_str());
  std::fflush(stdout);
}

// --- scenes ---------------------------------------------------------------------------------

namespace {

  // A block of `layers` sc layers of spacing a, n x n sites, from z = zb up, in a box periodic in
  // x and y (n a + margin wide) with a floor and a roof.
  std::vector<std::string> block_on_floor(int n, int layers, double a, double zb, double top,
                                          double margin = 0.0)
  {
    const double side = n * a + margin;
    return {line("region box block 0 %.17g 0 %.17g 0 %.17g units box", side, side, top),
            "create_box 1 box", line("lattice sc %.17g origin 0.5 0.5 0.5", 1.0 / (a * a * a)),
            line("region block block 0 %.17g 0 %.17g %.17g %.17g units box", side, side, zb,
                 zb + layers * a - 1e-9),
            "create_atoms 1 region block"};
  }

  const std::vector<std::string> kHeader3d = {"units lj", "atom_style sphere",
                                              "atom_modify map array", "boundary p p f"};

}    // namespace

Scene pour(double e, bool long_size)
{
  Scene s;
  s.name = line("pour, e = %g, to t = 75", e);
  const int n = long_size ? 12 : 5, layers = 4;
  const double dt = long_size ? 0.01 : 0.02, a = 1.2;
  s.header = kHeader3d;
  // The short box, 5 x 1.2 = 6 diameters wide, gets 0.1 more: a whole number of diameters lets
  // a bottom row close into a ring of touching spheres round the periodic width, which the
  // guards do not cover (DISABLED_JammedRingOfDisksStaysBounded); with tc/slow yes and vmin 0
  // the e = 0.5 pour settled into such rows and stopped at step 2036 on maxevents.
  const double margin = long_size ? 0.0 : 0.1;
  s.atoms = block_on_floor(n, layers, a, 5.0, 5.0 + layers * a + 5.0, margin);
  s.atoms.insert(s.atoms.end(), {"set type 1 diameter 1.0", "set type 1 mass 1.0",
                                 "velocity all create 0.05 87287 loop geom"});
  s.fixes = dynamics(line("restitution %g wall zlo %g wall zhi %g", e, e, e), dt);
  s.fixes.push_back("fix g all gravity 1.0 vector 0 0 -1");
  s.g = 1.0;
  s.steps = std::lround(75.0 / dt);
  s.chunk = long_size ? 500 : s.steps / 10;
  s.pour = true;
  return s;
}

Scene rough_pour(double e, double mu, bool long_size, bool guard)
{
  Scene s = pour(e, long_size);
  s.name = line("rough pour, e = %g, mu = %g, to t = 75", e, mu) +
           (guard ? "" : ", friction/guard none");
  s.fixes =
      dynamics(line("restitution %g wall zlo %g wall zhi %g friction %g 0.3 ", e, e, e, mu) +
                   line("wall/friction zlo %g 0.3", mu) + (guard ? "" : " friction/guard none"),
               long_size ? 0.01 : 0.02);
  s.fixes.push_back("fix g all gravity 1.0 vector 0 0 -1");
  s.rough = true;
  return s;
}

Scene crystal(const char *style, double phi, bool long_size)
{
  Scene s;
  const bool fcc = std::string(style) == "fcc";
  s.name = line("%s at packing fraction %g, elastic", style, phi);
  const int n = fcc ? (long_size ? 6 : 4) : (long_size ? 10 : 6);
  s.header = {"units lj", "atom_style sphere", "atom_modify map array", "boundary p p p"};
  s.atoms = {line("lattice %s %.17g", style, 6.0 * phi / M_PI),
             line("region box block 0 %d 0 %d 0 %d", n, n, n),
             "create_box 1 box",
             "create_atoms 1 box",
             "set type 1 diameter 1.0",
             "set type 1 mass 1.0",
             "velocity all create 1.0 4928459 loop geom"};
  s.fixes = dynamics("", 0.01);
  s.steps = 1000;
  s.chunk = long_size ? 1000 : 250;
  return s;
}

Scene size_ratio_ten(bool long_size)
{
  Scene s;
  s.name = "diameters 1 and 10 under gravity, e = 0.9";
  const int layers = long_size ? 4 : 2, nbig = long_size ? 2 : 1;
  const double a = 1.2, side = 22 * a, zbig = layers * a + 6.5;
  s.header = kHeader3d;
  s.atoms = {
      line("region box block 0 %.17g 0 %.17g 0 %.17g units box", side, side, zbig + 8.0),
      "create_box 2 box", line("lattice sc %.17g origin 0.5 0.5 0.5", 1.0 / (a * a * a)),
      line("region bed block 0 %.17g 0 %.17g 0 %.17g units box", side, side, layers * a - 1e-9),
      "create_atoms 1 region bed"};
  for (int b = 0; b < nbig; ++b)
    s.atoms.push_back(line("create_atoms 2 single %.17g %.17g %.17g units box",
                           nbig == 1 ? side / 2 : side * (0.25 + 0.5 * b), side / 2, zbig));
  s.atoms.insert(s.atoms.end(),
                 {"set type 1 diameter 1.0", "set type 2 diameter 10.0", "set type * density 1.0",
                  "velocity all create 1.0 87287 loop geom"});
  // reach 1 (not the default 5, the big radius) keeps the ghost shell and the periodic length
  // the fix needs small enough for a box 26.4 wide.
  s.fixes = dynamics("restitution 0.9 wall zlo 0.9 wall zhi 0.9 reach 1.0", 0.01);
  s.fixes.push_back("fix g all gravity 1.0 vector 0 0 -1");
  s.g = 1.0;
  s.steps = 400;
  s.chunk = long_size ? 200 : 100;
  return s;
}

Scene polydisperse(bool long_size)
{
  Scene s;
  s.name = "diameters 0.5 ... 1.5 under gravity, e = 0.8";
  const int n = long_size ? 14 : 6, layers = long_size ? 4 : 3;
  const double a = 1.6;
  s.header = kHeader3d;
  s.atoms = block_on_floor(n, layers, a, 2.0, 2.0 + layers * a + 10.0);
  // Evenly spread diameters from the atom ID (golden-ratio sequence): the same on any ranks.
  s.atoms.insert(s.atoms.end(),
                 {"variable d atom 0.5+(id*0.6180339887498949-floor(id*0.6180339887498949))",
                  "set group all diameter v_d", "set group all density 1.0",
                  "velocity all create 0.5 87287 loop geom"});
  s.fixes = dynamics("restitution 0.8 wall zlo 0.8 wall zhi 0.8", 0.01);
  s.fixes.push_back("fix g all gravity 1.0 vector 0 0 -1");
  s.g = 1.0;
  s.steps = 1500;
  s.chunk = long_size ? 500 : 300;
  s.pour = true;
  return s;
}

Scene units_si(bool long_size)
{
  Scene s;
  s.name = "units si: 1 mm grains, g = 9.81, e = 0.5";
  const int n = long_size ? 12 : 6, layers = 4;
  const double a = 1.2e-3, side = n * a, zb = 5e-3, top = zb + layers * a + 5e-3;
  s.header = {"units si", "atom_style sphere", "atom_modify map array", "boundary p p f"};
  s.atoms = {line("region box block 0 %.17g 0 %.17g 0 %.17g units box", side, side, top),
             "create_box 1 box",
             line("lattice sc %.17g origin 0.5 0.5 0.5", a),
             line("region block block 0 %.17g 0 %.17g %.17g %.17g units box", side, side, zb,
                  zb + layers * a - 1e-12),
             "create_atoms 1 region block",
             "set type 1 diameter 1.0e-3",
             "set type 1 density 2500",
             "variable vx atom 0.05*sin(17.31*id)",
             "variable vy atom 0.05*cos(7.77*id)",
             "variable vz atom 0.05*sin(3.3*id+1.1)",
             "velocity all set v_vx v_vy v_vz"};
  s.fixes = dynamics("restitution 0.5 wall zlo 0.5 wall zhi 0.5", 2e-4);
  s.fixes.push_back("fix g all gravity 9.81 vector 0 0 -1");
  s.g = 9.81;
  s.steps = 2500;    // 0.5 s
  s.chunk = long_size ? 1000 : 500;
  s.pour = true;
  return s;
}

Scene units_real(bool long_size)
{
  Scene s;
  s.name = "units real: argon-sized spheres (3.4 A) at packing fraction 0.45, 300 K";
  const int n = long_size ? 6 : 4;
  const double sigma = 3.4, phi = 0.45;
  const double a = sigma * std::cbrt(4.0 * M_PI / 6.0 / phi);
  s.header = {"units real", "atom_style sphere", "atom_modify map array", "boundary p p p"};
  s.atoms = {line("lattice fcc %.17g", a),
             line("region box block 0 %d 0 %d 0 %d", n, n, n),
             "create_box 1 box",
             "create_atoms 1 box",
             line("set type 1 diameter %.17g", sigma),
             "set type 1 mass 39.948",
             "velocity all create 300.0 4928459 loop geom"};
  s.fixes = dynamics("", 20.0);
  s.steps = 1000;
  s.chunk = long_size ? 1000 : 250;
  return s;
}

Scene disks_2d(bool long_size)
{
  Scene s;
  s.name = "dimension 2: disks poured onto a floor, e = 0.7";
  // The width is no whole number of diameters: a bottom row that closes on itself around the
  // periodic box is a rigid ring, which the guards cannot bring to rest
  // (HardCases.DISABLED_JammedRingOfDisksStaysBounded, doc/hard_cases.md).
  const int n = long_size ? 40 : 20, layers = long_size ? 10 : 5;
  const double a = 1.2, side = n * a + 0.3, yb = 5.0, top = yb + layers * a + 5.0;
  s.dimension = 2;
  s.header = {"units lj", "dimension 2", "atom_style sphere", "atom_modify map array",
              "boundary p f p"};
  s.atoms = {line("region box block 0 %.17g 0 %.17g -0.5 0.5 units box", side, top),
             "create_box 1 box",
             line("lattice sq %.17g origin 0.5 0.5 0.0", 1.0 / (a * a)),
             line("region block block 0 %.17g %.17g %.17g -0.5 0.5 units box", side, yb,
                  yb + layers * a - 1e-9),
             "create_atoms 1 region block",
             "set type 1 diameter 1.0",
             "set type 1 mass 1.0",
             "velocity all create 0.05 87287 loop geom"};
  s.fixes = dynamics("restitution 0.7 wall ylo 0.7 wall yhi 0.7", 0.01);
  s.fixes.insert(s.fixes.end(), {"fix g all gravity 1.0 vector 0 -1 0", "fix 2d all enforce2d"});
  s.g = 1.0;
  s.gaxis = 1;
  s.steps = 2000;
  s.chunk = long_size ? 1000 : 500;
  s.pour = true;
  return s;
}

Scene mpi_pile(bool long_size)
{
  Scene s = pour(0.5, false);
  s.name = "pile (e = 0.5) from one data file";
  const int n = long_size ? 12 : 6, layers = 4;
  s.atoms = block_on_floor(n, layers, 1.2, 5.0, 5.0 + layers * 1.2 + 5.0);
  s.atoms.insert(s.atoms.end(), {"set type 1 diameter 1.0", "set type 1 mass 1.0",
                                 "velocity all create 0.05 87287 loop geom"});
  s.fixes = dynamics("restitution 0.5 wall zlo 0.5 wall zhi 0.5", 0.01);
  s.fixes.push_back("fix g all gravity 1.0 vector 0 0 -1");
  s.prepare = {"run 1000"};    // settles into a pile (t = 10) before the data file is written
  s.steps = 200;
  s.chunk = long_size ? 1000 : 100;
  return s;
}

Scene mpi_fluid(bool long_size)
{
  Scene s = crystal("fcc", 0.45, false);
  s.name = "dense fluid (packing fraction 0.45) from one data file";
  const int n = long_size ? 8 : 4;
  s.atoms[1] = line("region box block 0 %d 0 %d 0 %d", n, n, n);
  s.prepare = {"run 200"};    // melts the lattice
  s.steps = 200;
  s.chunk = long_size ? 1000 : 100;
  return s;
}

// --- micro scenes: placed anew before every step --------------------------------------------

namespace {

  struct Vec {
    double x, y, z;
  };
  Vec operator+(Vec a, Vec b)
  {
    return {a.x + b.x, a.y + b.y, a.z + b.z};
  }
  Vec operator*(double s, Vec a)
  {
    return {s * a.x, s * a.y, s * a.z};
  }
  double dot(Vec a, Vec b)
  {
    return a.x * b.x + a.y * b.y + a.z * b.z;
  }

  // m^3 sites of spacing a in a periodic box; `roles` atoms per site, created anywhere (they are
  // placed before the first step); unit spheres of unit mass, elastic.
  Scene micro(int m, double a, int roles, const std::string &fix_hs, double dt)
  {
    Scene s;
    const double side = m * a;
    s.header = {"units lj", "atom_style sphere", "atom_modify map array", "boundary p p p"};
    s.atoms = {line("region box block 0 %.17g 0 %.17g 0 %.17g units box", side, side, side),
               "create_box 1 box",
               line("create_atoms 1 random %d 20261125 NULL", m * m * m * roles),
               "set type 1 diameter 1.0", "set type 1 mass 1.0"};
    s.fixes = dynamics(fix_hs, dt);
    return s;
  }

  // Placement of one step: site j's role r is taken by atom r P + (j + r c) mod P in step c, so
  // that no two atoms meet again in the same roles (two atoms whose latest events were their
  // collision with each other are not tested again before another event).
  struct Layout {
    int m;
    double a;
    int roles;
    long sites() const { return (long) m * m * m; }
    long atom(long j, int r, long c) const { return r * sites() + (j + r * c) % sites(); }
    Vec site(long j) const
    {
      return {a * (j % m + 0.5), a * ((j / m) % m + 0.5), a * (j / ((long) m * m) + 0.5)};
    }
  };

  void put(std::vector<double> &x, std::vector<double> &v, long i, Vec p, Vec u, double side)
  {
    const double q[3] = {p.x, p.y, p.z};
    for (int d = 0; d < 3; ++d) x[3 * i + d] = q[d] - side * std::floor(q[d] / side);
    v[3 * i] = u.x;
    v[3 * i + 1] = u.y;
    v[3 * i + 2] = u.z;
  }

  Vec get(const std::vector<double> &v, long i)
  {
    return {v[3 * i], v[3 * i + 1], v[3 * i + 2]};
  }

  double norm(Vec a)
  {
    return std::sqrt(dot(a, a));
  }

  // A random unit vector u and a unit vector w perpendicular to it.
  void directions(std::mt19937_64 &rng, Vec &u, Vec &w)
  {
    std::normal_distribution<double> nd(0.0, 1.0);
    u = {nd(rng), nd(rng), nd(rng)};
    u = (1.0 / norm(u)) * u;
    const Vec e = std::fabs(u.x) < 0.5 ? Vec{1, 0, 0} : Vec{0, 1, 0};
    w = {u.y * e.z - u.z * e.y, u.z * e.x - u.x * e.z, u.x * e.y - u.y * e.x};
    w = (1.0 / norm(w)) * w;
  }

  // Distance of p from q, nearest image.
  double dist(Vec p, Vec q, double side)
  {
    double d[3] = {p.x - q.x, p.y - q.y, p.z - q.z};
    for (double &c : d) c -= side * std::round(c / side);
    return std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  }

  std::string fail(long c, long j, const char *what, double value)
  {
    return line("step %ld, site %ld: %s (%.17g)", c, j, what, value);
  }

}    // namespace

Scene grazing(bool long_size)
{
  const Layout L{long_size ? 10 : 4, 5.0, 2};
  // B moves 2.8 at most in the step of 2 time units: reach 3.
  Scene s = micro(L.m, L.a, L.roles, "reach 3.0", 2.0);
  s.name = "grazing: impact parameter contact -/+ 1e-12, new each step";
  s.steps = long_size ? 1 : 12;
  s.chunk = 1;
  struct Course {
    Vec u, vb;
    double b;
    bool hit;
  };
  auto plan = std::make_shared<std::vector<Course>>(L.sites());
  s.place = [L, plan](long c, std::vector<double> &x, std::vector<double> &v) {
    std::mt19937_64 rng(1000 + c);
    std::uniform_real_distribution<double> speed(1.0, 1.4);
    for (long j = 0; j < L.sites(); ++j) {
      Vec u, w;
      directions(rng, u, w);
      Course &k = (*plan)[j];
      k.hit = (j + c) % 4 != 3;
      k.b = k.hit ? 1.0 - 1e-12 : 1.0 + 1e-12;
      k.u = u;
      k.vb = speed(rng) * u;
      const Vec sj = L.site(j);
      put(x, v, L.atom(j, 0, c), sj, {0, 0, 0}, L.m * L.a);
      put(x, v, L.atom(j, 1, c), sj + (-1.5) * u + k.b * w, k.vb, L.m * L.a);
    }
  };
  s.verify = [L, plan](long c, const std::vector<double> &, const std::vector<double> &v,
                       double collisions) -> std::string {
    long hits = 0;
    for (long j = 0; j < L.sites(); ++j) {
      const Course &k = (*plan)[j];
      const Vec va = get(v, L.atom(j, 0, c)), vb = get(v, L.atom(j, 1, c));
      if (!k.hit) {
        if (norm(va) != 0.0 || norm(vb + (-1.0) * k.vb) != 0.0)
          return fail(c, j, "a pair that misses by 1e-12 changed its velocities", norm(va));
        continue;
      }
      ++hits;
      // The normal at contact makes sqrt(1 - b^2) with the course: A leaves with that share of
      // B's speed (1.4e-6), momentum and energy are kept.
      const double expect = norm(k.vb) * std::sqrt(1.0 - k.b * k.b);
      // (2e-2: the placed coordinates carry round-off of some 1e-14, a percent of 1 - b.)
      if (!(std::fabs(norm(va) / expect - 1.0) < 2e-2))
        return fail(c, j, "grazing: speed of the sphere hit / expected - 1", norm(va) / expect - 1);
      if (!(norm(va + vb + (-1.0) * k.vb) < 1e-14))
        return fail(c, j, "grazing: momentum changed by", norm(va + vb + (-1.0) * k.vb));
      if (!(std::fabs(dot(va, va) + dot(vb, vb) - dot(k.vb, k.vb)) < 1e-14))
        return fail(c, j, "grazing: kinetic energy changed by",
                    dot(va, va) + dot(vb, vb) - dot(k.vb, k.vb));
    }
    if (collisions != (double) hits) return fail(c, -1, "collisions in the step", collisions);
    return "";
  };
  return s;
}

Scene touching(bool long_size)
{
  const Layout L{long_size ? 10 : 4, 6.0, 3};
  Scene s = micro(L.m, L.a, L.roles, "reach 1.5", 1.0);
  s.name = "touching starts: in contact, 1e-10 overlapped, rows of 3 in contact; new each step";
  s.steps = long_size ? 1 : 12;
  s.chunk = 1;
  struct Start {
    int kind;    // 0 touching approaching, 1 touching receding, 2 row of three, 3 overlapped
    Vec u, va, vb;
  };
  auto plan = std::make_shared<std::vector<Start>>(L.sites());
  s.place = [L, plan](long c, std::vector<double> &x, std::vector<double> &v) {
    std::mt19937_64 rng(2000 + c);
    std::uniform_real_distribution<double> speed(0.5, 1.0);
    const double side = L.m * L.a;
    for (long j = 0; j < L.sites(); ++j) {
      Vec u, w;
      directions(rng, u, w);
      Start &k = (*plan)[j];
      k.kind = (int) ((j + c) % 4);
      k.u = u;
      const Vec sj = L.site(j);
      const long a = L.atom(j, 0, c), b = L.atom(j, 1, c), c3 = L.atom(j, 2, c);
      k.va = {0, 0, 0};
      k.vb = speed(rng) * u;
      if (k.kind == 1) k.vb = (-1.0) * k.vb;
      if (k.kind == 3) k.va = (-speed(rng)) * u;
      const double sep = k.kind == 3 ? 1.0 - 1e-10 : 1.0;
      put(x, v, a, sj, k.va, side);
      put(x, v, b, sj + (-sep) * u, k.vb, side);
      // The third sphere: in contact ahead of A (row of three) or a spectator at rest.
      put(x, v, c3, k.kind == 2 ? sj + u : sj + 2.0 * w, {0, 0, 0}, side);
    }
  };
  s.verify = [L, plan](long c, const std::vector<double> &, const std::vector<double> &v,
                       double collisions) -> std::string {
    long expected = 0, rows = 0;
    for (long j = 0; j < L.sites(); ++j) {
      const Start &k = (*plan)[j];
      if (k.kind == 2) ++rows;
      const Vec va = get(v, L.atom(j, 0, c)), vb = get(v, L.atom(j, 1, c)),
                vc = get(v, L.atom(j, 2, c));
      const double tol = 1e-13;
      if (k.kind == 1) {
        if (norm(va) != 0.0 || norm(vb + (-1.0) * k.vb) != 0.0 || norm(vc) != 0.0)
          return fail(c, j, "a receding pair in contact changed its velocities", norm(va));
      } else if (k.kind == 2) {
        expected += 2;
        if (!(norm(va) < tol && norm(vb) < tol && norm(vc + (-1.0) * k.vb) < tol))
          return fail(c, j, "row of three in contact: not a cradle, last sphere off by",
                      norm(vc + (-1.0) * k.vb));
      } else {
        expected += 1;
        if (!(norm(va + (-1.0) * k.vb) < tol && norm(vb + (-1.0) * k.va) < tol))
          return fail(c, j, "pair in contact: velocities not exchanged, off by",
                      norm(va + (-1.0) * k.vb));
        if (norm(vc) != 0.0) return fail(c, j, "the spectator moved", norm(vc));
      }
    }
    // A row of three in contact may add a collision at round-off speed (1e-16) after the two:
    // its partners' residual velocities are that small, and so is the approach threshold.
    if (collisions < (double) expected || collisions > (double) (expected + rows))
      return fail(c, -1, "collisions in the step", collisions);
    return "";
  };
  return s;
}

Scene crossing(bool long_size)
{
  constexpr int targets = 5;
  constexpr double gap = 0.6, speed = 5.0;    // 5 diameters per step of 1 time unit
  // The row spans -1.6 ... 8.4 along u (and the radius) before and after the step: it is
  // centred on its site, 12.5 from the next.
  constexpr double mid = 3.4;
  const Layout L{long_size ? 6 : 3, 12.5, targets + 1};
  Scene s = micro(L.m, L.a, L.roles, "reach 5.5", 1.0);
  s.name = "a sphere crossing 5 diameters per step into a row of 5 (gaps 0.6), new each step";
  s.steps = long_size ? 1 : 10;
  s.chunk = 1;
  auto dirs = std::make_shared<std::vector<Vec>>(L.sites());
  s.place = [L, dirs](long c, std::vector<double> &x, std::vector<double> &v) {
    std::mt19937_64 rng(3000 + c);
    const double side = L.m * L.a;
    for (long j = 0; j < L.sites(); ++j) {
      Vec u, w;
      directions(rng, u, w);
      (*dirs)[j] = u;
      const Vec sj = L.site(j);
      put(x, v, L.atom(j, 0, c), sj + (-(1.0 + gap) - mid) * u, speed * u, side);
      for (int i = 0; i < targets; ++i)
        put(x, v, L.atom(j, 1 + i, c), sj + (i * (1.0 + gap) - mid) * u, {0, 0, 0}, side);
    }
  };
  s.verify = [L, dirs](long c, const std::vector<double> &x, const std::vector<double> &v,
                       double collisions) -> std::string {
    const double side = L.m * L.a, tol = 1e-12;
    for (long j = 0; j < L.sites(); ++j) {
      const Vec u = (*dirs)[j], sj = L.site(j);
      // Each sphere stops where it hits the next one; the last leaves at the full speed and
      // moves for the rest of the step, (1 - 5 gap / speed) of it.
      for (int i = 0; i <= targets; ++i) {
        const long id = L.atom(j, i, c);
        const Vec vi = get(v, id), xi = get(x, id);
        const bool last = i == targets;
        const Vec vexp = last ? speed * u : Vec{0, 0, 0};
        const double along =
            last ? (targets - 1) * (1.0 + gap) + speed * (1.0 - targets * gap / speed)
                 : (i - 1) * (1.0 + gap) + gap;
        if (!(norm(vi + (-1.0) * vexp) < tol))
          return fail(c, j, "crossing: velocity off by", norm(vi + (-1.0) * vexp));
        const Vec at = sj + (along - mid) * u;
        if (!(dist(xi, at, side) < tol))
          return fail(c, j, "crossing: position off by", dist(xi, at, side));
      }
    }
    if (collisions != (double) (targets * L.sites()))
      return fail(c, -1, "collisions in the step", collisions);
    return "";
  };
  return s;
}

}    // namespace hsgpu_hard
