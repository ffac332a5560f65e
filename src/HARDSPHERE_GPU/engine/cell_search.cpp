/* HARDSPHERE_GPU collision engine: the candidate search, see cell_search.h. */
#include "cell_search.h"

#include <algorithm>
#include <cmath>

namespace HSGPU {
namespace Collide {

  void CellSearch::find(const double *x, const double *rad, int n, int nsearch, double rmax,
                        double extra, std::vector<int> &pairs)
  {
    if (n <= 0 || nsearch <= 0) return;
    double lo[3], hi[3];
    for (int d = 0; d < 3; ++d) lo[d] = hi[d] = x[d];
    for (int i = 1; i < n; ++i)
      for (int d = 0; d < 3; ++d) {
        lo[d] = std::min(lo[d], x[3 * i + d]);
        hi[d] = std::max(hi[d], x[3 * i + d]);
      }
    // Cells at least as wide as the longest pair range, so that the 27 cells around a point's
    // cell hold all its partners; at most about 2 n cells (a dilute gas in a large box gets
    // wider cells rather than an empty grid).
    double width = 2.0 * rmax + extra;
    if (!(width > 0.0)) width = 1.0;
    double len[3];
    for (int d = 0; d < 3; ++d) len[d] = std::max(hi[d] - lo[d], 0.0);
    const double limit = 2.0 * n + 27.0;
    for (;;) {
      double total = 1.0;
      for (int d = 0; d < 3; ++d) {
        ncell[d] = std::max(1L, (long) std::floor(len[d] / width));
        total *= (double) ncell[d];
      }
      if (total <= limit) break;
      width *= 1.26;
    }
    double inv[3];
    for (int d = 0; d < 3; ++d) inv[d] = ncell[d] / std::max(len[d], 1e-300);
    auto coord = [&](int i, int d) {
      long c = (long) ((x[3 * i + d] - lo[d]) * inv[d]);
      return std::min(std::max(c, 0L), ncell[d] - 1);
    };
    const long nc = ncell[0] * ncell[1] * ncell[2];
    cell_of.resize(n);
    start.assign(nc + 1, 0);
    for (int i = 0; i < n; ++i) {
      cell_of[i] = (int) ((coord(i, 2) * ncell[1] + coord(i, 1)) * ncell[0] + coord(i, 0));
      start[cell_of[i] + 1]++;
    }
    for (long c = 0; c < nc; ++c) start[c + 1] += start[c];
    order.resize(n);
    {
      std::vector<int> fill(start.begin(), start.end() - 1);
      for (int i = 0; i < n; ++i) order[fill[cell_of[i]]++] = i;
    }
    for (int i = 0; i < nsearch; ++i) {
      const long ci[3] = {coord(i, 0), coord(i, 1), coord(i, 2)};
      const double *xi = x + 3 * i;
      for (long cz = std::max(0L, ci[2] - 1); cz <= std::min(ncell[2] - 1, ci[2] + 1); ++cz)
        for (long cy = std::max(0L, ci[1] - 1); cy <= std::min(ncell[1] - 1, ci[1] + 1); ++cy)
          for (long cx = std::max(0L, ci[0] - 1); cx <= std::min(ncell[0] - 1, ci[0] + 1);
               ++cx) {
            const long c = (cz * ncell[1] + cy) * ncell[0] + cx;
            for (int k = start[c]; k < start[c + 1]; ++k) {
              const int j = order[k];
              if (j <= i) continue;
              const double dx = xi[0] - x[3 * j], dy = xi[1] - x[3 * j + 1],
                           dz = xi[2] - x[3 * j + 2];
              const double range = rad[i] + rad[j] + extra;
              if (dx * dx + dy * dy + dz * dz <= range * range) {
                pairs.push_back(i);
                pairs.push_back(j);
              }
            }
          }
    }
  }

}    // namespace Collide
}    // namespace HSGPU
