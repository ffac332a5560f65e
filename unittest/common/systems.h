/* Input lines for the test systems, shared by the LAMMPS-level tests. */
#ifndef HSGPU_TEST_SYSTEMS_H
#define HSGPU_TEST_SYSTEMS_H

#include <random>
#include <string>
#include <vector>

namespace hsgpu_test {

struct GravitySystem {
  int n = 200;
  unsigned seed = 1;
  bool sphere = true;        // atom_style sphere with per-atom masses, else atomic with type masses
  bool periodic = true;      // p p p, else f f f in a large box
  bool clustered = false;    // Gaussian cluster instead of uniform positions
  std::string pair = "pair_style gravity 1.0 0.05";
};

// Box: x in [-5,5), y in [-4,6), z in [-3,7) (10 x 10 x 10), or [-50,50)^3 when not periodic.
inline std::vector<std::string> gravity_system_lines(const GravitySystem &s)
{
  std::vector<std::string> l = {
      "units lj", std::string("atom_style ") + (s.sphere ? "sphere" : "atomic"),
      "atom_modify map array", std::string("boundary ") + (s.periodic ? "p p p" : "f f f")};
  l.push_back(s.periodic ? "region box block -5 5 -4 6 -3 7"
                         : "region box block -50 50 -50 50 -50 50");
  l.push_back("create_box 2 box");
  std::mt19937_64 rng(s.seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> g(0.0, 0.5);
  const double lo[3] = {-5, -4, -3};
  for (int i = 0; i < s.n; ++i) {
    double c[3];
    for (int d = 0; d < 3; ++d) c[d] = s.clustered ? lo[d] + 5.0 + g(rng) : lo[d] + 10.0 * u(rng);
    char buf[200];
    std::snprintf(buf, sizeof(buf), "create_atoms %d single %.17g %.17g %.17g units box",
                  1 + (i % 2), c[0], c[1], c[2]);
    l.push_back(buf);
  }
  if (s.sphere) {
    for (int i = 1; i <= s.n; ++i) {
      char buf[100];
      std::snprintf(buf, sizeof(buf), "set atom %d mass %.17g", i, 0.3 + 1.7 * u(rng));
      l.push_back(buf);
    }
  } else {
    l.push_back("mass 1 1.25");
    l.push_back("mass 2 0.5");
  }
  l.push_back(s.pair);
  l.push_back("pair_coeff * *");
  l.push_back("thermo_modify norm no");
  return l;
}

}    // namespace hsgpu_test

#endif
