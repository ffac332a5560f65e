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
    // Half stencil: each cell against itself (later points only) and its 13 neighbours that
    // follow it in (z, y, x) order, so that every pair of points is tested once.  In the
    // sorted order these are five contiguous ranges: the rest of the cell with the next cell
    // of its row, the three cells of the next row, and three rows of three in the next layer.
    // Pairs of two points that are not searched from (ghosts) are dropped.
    const long nx = ncell[0], ny = ncell[1], nz = ncell[2];
    for (long cz = 0; cz < nz; ++cz)
      for (long cy = 0; cy < ny; ++cy)
        for (long cx = 0; cx < nx; ++cx) {
          const long c = (cz * ny + cy) * nx + cx;
          const long xlo = std::max(0L, cx - 1), xhi = std::min(nx - 1, cx + 1);
          int rlo[5], rhi[5], nr = 0;
          auto add_row = [&](long y, long z) {
            const long row = (z * ny + y) * nx;
            rlo[nr] = start[row + xlo];
            rhi[nr] = start[row + xhi + 1];
            ++nr;
          };
          if (cy + 1 < ny) add_row(cy + 1, cz);
          if (cz + 1 < nz)
            for (long y = std::max(0L, cy - 1); y <= std::min(ny - 1, cy + 1); ++y) add_row(y, cz + 1);
          const int own_end = start[(cz * ny + cy) * nx + xhi + 1];
          for (int ki = start[c]; ki < start[c + 1]; ++ki) {
            const int i = order[ki];
            const double *pi = &sorted[(size_t) 4 * ki];
            const double ri = pi[3] + extra;
            auto scan = [&](int lo, int hi) {
              for (int k = lo; k < hi; ++k) {
                const double *q = &sorted[(size_t) 4 * k];
                const double dx = pi[0] - q[0], dy = pi[1] - q[1], dz = pi[2] - q[2];
                const double range = ri + q[3];
                if (dx * dx + dy * dy + dz * dz <= range * range) {
                  const int j = order[k];
                  if (i >= nsearch && j >= nsearch) continue;
                  pairs.push_back(std::min(i, j));
                  pairs.push_back(std::max(i, j));
                }
              }
            };
            scan(ki + 1, own_end);
            for (int r = 0; r < nr; ++r) scan(rlo[r], rhi[r]);
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
