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
    width_used = width;
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
    // Searched points visited cell by cell, so that neighbouring rows stay in cache.
    for (long cz = 0; cz < ncell[2]; ++cz)
      for (long cy = 0; cy < ncell[1]; ++cy)
        for (long cx = 0; cx < ncell[0]; ++cx) {
          const long c = (cz * ncell[1] + cy) * ncell[0] + cx;
          for (int ki = start[c]; ki < start[c + 1]; ++ki) {
            const int i = order[ki];
            if (i >= nsearch) continue;
            const double *pi = &sorted[(size_t) 4 * ki];
            const double ri = pi[3] + extra;
            for (long nz = std::max(0L, cz - 1); nz <= std::min(ncell[2] - 1, cz + 1); ++nz)
              for (long ny = std::max(0L, cy - 1); ny <= std::min(ncell[1] - 1, cy + 1); ++ny) {
                const long row = (nz * ncell[1] + ny) * ncell[0];
                const int lo = start[row + std::max(0L, cx - 1)];
                const int hi = start[row + std::min(ncell[0] - 1, cx + 1) + 1];
                for (int k = lo; k < hi; ++k) {
                  const double *q = &sorted[(size_t) 4 * k];
                  const double dx = pi[0] - q[0], dy = pi[1] - q[1], dz = pi[2] - q[2];
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
  }

  void CellSearch::neighbors(int i, std::vector<int> &out) const
  {
    const long c = cell_of[i];
    const long cx = c % ncell[0], cy = (c / ncell[0]) % ncell[1], cz = c / (ncell[0] * ncell[1]);
    for (long nz = std::max(0L, cz - 1); nz <= std::min(ncell[2] - 1, cz + 1); ++nz)
      for (long ny = std::max(0L, cy - 1); ny <= std::min(ncell[1] - 1, cy + 1); ++ny) {
        const long row = (nz * ncell[1] + ny) * ncell[0];
        const int lo = start[row + std::max(0L, cx - 1)];
        const int hi = start[row + std::min(ncell[0] - 1, cx + 1) + 1];
        for (int k = lo; k < hi; ++k) out.push_back(order[k]);
      }
  }

}    // namespace Collide
}    // namespace HSGPU
