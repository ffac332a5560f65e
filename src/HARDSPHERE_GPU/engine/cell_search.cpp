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
    // Points in cell order, contiguous (x, y, z, radius), so that a cell's points are read
    // in one sweep.
    order.resize(n);
    sorted.resize((size_t) 4 * n);
    {
      std::vector<int> fill(start.begin(), start.end() - 1);
      for (int i = 0; i < n; ++i) {
        const int k = fill[cell_of[i]]++;
        order[k] = i;
        for (int d = 0; d < 3; ++d) sorted[(size_t) 4 * k + d] = x[3 * i + d];
        sorted[(size_t) 4 * k + 3] = rad[i];
      }
    }
    for (int i = 0; i < nsearch; ++i) {
      const long ci[3] = {coord(i, 0), coord(i, 1), coord(i, 2)};
      const double xi[3] = {x[3 * i], x[3 * i + 1], x[3 * i + 2]};
      const double ri = rad[i] + extra;
      for (long cz = std::max(0L, ci[2] - 1); cz <= std::min(ncell[2] - 1, ci[2] + 1); ++cz)
        for (long cy = std::max(0L, ci[1] - 1); cy <= std::min(ncell[1] - 1, ci[1] + 1); ++cy) {
          const long row = (cz * ncell[1] + cy) * ncell[0];
          const int lo = start[row + std::max(0L, ci[0] - 1)];
          const int hi = start[row + std::min(ncell[0] - 1, ci[0] + 1) + 1];
          for (int k = lo; k < hi; ++k) {
            const double *q = &sorted[(size_t) 4 * k];
            const double dx = xi[0] - q[0], dy = xi[1] - q[1], dz = xi[2] - q[2];
            const double range = ri + q[3];
            if (dx * dx + dy * dy + dz * dz <= range * range) {
              const int j = order[k];
              if (j <= i) continue;
              pairs.push_back(i);
              pairs.push_back(j);
            }
          }
        }
    }
  }

}    // namespace Collide
}    // namespace HSGPU
