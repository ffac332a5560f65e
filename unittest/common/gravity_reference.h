/* Long-double direct sum for softened Newtonian gravity, written independently of the
   package's core: the nearest periodic image is found by trying the images -1, 0, +1 along
   each periodic direction. */
#ifndef HSGPU_TEST_GRAVITY_REFERENCE_H
#define HSGPU_TEST_GRAVITY_REFERENCE_H

#include <cmath>
#include <vector>

namespace hsgpu_test {

struct GravityReference {
  std::vector<long double> f;    // 3 per atom
  std::vector<long double> e;    // per-atom energy (half of each pair's)
  long double pe = 0;
  long double virial[6] = {0, 0, 0, 0, 0, 0};    // xx yy zz xy xz yz, summed over pairs
};

inline long double nearest_image_ref(long double d, double prd, int periodic)
{
  if (!periodic) return d;
  long double best = d;
  for (int k = -2; k <= 2; ++k) {
    const long double c = d + k * (long double) prd;
    if (std::fabs(c) < std::fabs(best)) best = c;
  }
  return best;
}

inline GravityReference gravity_reference(const std::vector<double> &x,
                                          const std::vector<double> &m, double G, double eps,
                                          double cut, const double prd[3], const int periodic[3])
{
  const size_t n = m.size();
  GravityReference r;
  r.f.assign(3 * n, 0.0L);
  r.e.assign(n, 0.0L);
  for (size_t i = 0; i < n; ++i)
    for (size_t j = i + 1; j < n; ++j) {
      long double d[3];
      long double r2 = 0;
      for (int k = 0; k < 3; ++k) {
        d[k] = nearest_image_ref((long double) x[3 * i + k] - x[3 * j + k], prd[k], periodic[k]);
        r2 += d[k] * d[k];
      }
      if (cut > 0 && r2 > (long double) cut * cut) continue;
      const long double s = std::sqrt(r2 + (long double) eps * eps);
      const long double gmm = (long double) G * m[i] * m[j];
      const long double u = -gmm / s;
      const long double fp = -gmm / (s * s * s);
      for (int k = 0; k < 3; ++k) {
        r.f[3 * i + k] += fp * d[k];
        r.f[3 * j + k] -= fp * d[k];
      }
      r.e[i] += 0.5L * u;
      r.e[j] += 0.5L * u;
      r.pe += u;
      r.virial[0] += d[0] * fp * d[0];
      r.virial[1] += d[1] * fp * d[1];
      r.virial[2] += d[2] * fp * d[2];
      r.virial[3] += d[0] * fp * d[1];
      r.virial[4] += d[0] * fp * d[2];
      r.virial[5] += d[1] * fp * d[2];
    }
  return r;
}

}    // namespace hsgpu_test

#endif
