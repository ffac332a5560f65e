/* HARDSPHERE_GPU collision engine: the candidate search, see cell_search.h. */
#include "cell_search.h"

#include <algorithm>
#include <cmath>

namespace HSGPU {
namespace Collide {

  namespace {

    // Points with radii above this share of the rest's radii go to the class of large ones,
    // which holds at most one in LARGE_SHARE of the points.
    constexpr int LARGE_SHARE = 32;
    // Split only where the largest radius exceeds SPLIT_RATIO times the small class's largest
    // (the cells of the small class are then at most half as wide as one class's would be).
    constexpr double SPLIT_RATIO = 2.0;
    // The small class takes the radii up to this factor above the quantile, so that the many
    // points just above it (a spread of speeds) stay in it.
    constexpr double SMALL_SLACK = 1.25;

  }    // namespace

  void CellSearch::Grid::build(const double *x, const double *rad, const std::vector<int> &mem,
                               const double *blo, const double *bhi, double w)
  {
    const int m = (int) mem.size();
    // Cells at least as wide as the longest pair range, so that the 27 cells around a point's
    // cell hold all its partners; at most about 2 m cells (a dilute gas in a large box gets
    // wider cells rather than an empty grid).
    if (!(w > 0.0)) w = 1.0;
    double len[3];
    for (int d = 0; d < 3; ++d) {
      lo[d] = blo[d];
      len[d] = std::max(bhi[d] - blo[d], 0.0);
    }
    const double limit = 2.0 * m + 27.0;
    for (;;) {
      double total = 1.0;
      for (int d = 0; d < 3; ++d) {
        ncell[d] = std::max(1L, (long) std::floor(len[d] / w));
        total *= (double) ncell[d];
      }
      if (total <= limit) break;
      w *= 1.26;
    }
    width = w;
    for (int d = 0; d < 3; ++d) inv[d] = ncell[d] / std::max(len[d], 1e-300);
    const long nc = cells();
    start.assign(nc + 1, 0);
    fill.resize(m);
    for (int k = 0; k < m; ++k) {
      const double *p = &x[3 * (size_t) mem[k]];
      fill[k] = (int) ((coord(p[2], 2) * ncell[1] + coord(p[1], 1)) * ncell[0] + coord(p[0], 0));
      start[fill[k] + 1]++;
    }
    for (long c = 0; c < nc; ++c) start[c + 1] += start[c];
    // Points in cell order, contiguous (x, y, z, radius), so that a cell's points are read
    // in one sweep.
    order.resize(m);
    sorted.resize((size_t) 4 * m);
    std::vector<int> next(start.begin(), start.end() - 1);
    for (int k = 0; k < m; ++k) {
      const int i = mem[k];
      const int s = next[fill[k]]++;
      order[s] = i;
      for (int d = 0; d < 3; ++d) sorted[(size_t) 4 * s + d] = x[3 * (size_t) i + d];
      sorted[(size_t) 4 * s + 3] = rad[i];
    }
  }

  long CellSearch::Grid::coord(double p, int d) const
  {
    const double c = (p - lo[d]) * inv[d];
    if (!(c > 0.0)) return 0;    // also NaN
    if (!(c < (double) ncell[d])) return ncell[d] - 1;
    return (long) c;
  }

  void CellSearch::Grid::pairs(int nsearch, double extra, std::vector<int> &out) const
  {
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
            for (long y = std::max(0L, cy - 1); y <= std::min(ny - 1, cy + 1); ++y)
              add_row(y, cz + 1);
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
                  out.push_back(std::min(i, j));
                  out.push_back(std::max(i, j));
                }
              }
            };
            scan(ki + 1, own_end);
            for (int r = 0; r < nr; ++r) scan(rlo[r], rhi[r]);
          }
        }
  }

  void CellSearch::Grid::box(const double *p, double range, std::vector<int> &out) const
  {
    if (start.empty()) return;
    long c0[3], c1[3];
    for (int d = 0; d < 3; ++d) {
      c0[d] = coord(p[d] - range, d);
      c1[d] = coord(p[d] + range, d);
    }
    for (long cz = c0[2]; cz <= c1[2]; ++cz)
      for (long cy = c0[1]; cy <= c1[1]; ++cy) {
        const long row = (cz * ncell[1] + cy) * ncell[0];
        for (int k = start[row + c0[0]]; k < start[row + c1[0] + 1]; ++k) out.push_back(order[k]);
      }
  }

  void CellSearch::find(const double *x, const double *rad, int n, int nsearch, double rmax,
                        double extra, std::vector<int> &pairs)
  {
    nbig = 0;
    pos.assign(x, x + 3 * (size_t) std::max(n, 0));
    members.clear();
    large.clear();
    if (n <= 0 || nsearch <= 0) {
      small = Grid();
      return;
    }
    double lo[3], hi[3];
    for (int d = 0; d < 3; ++d) lo[d] = hi[d] = x[d];
    for (int i = 1; i < n; ++i)
      for (int d = 0; d < 3; ++d) {
        lo[d] = std::min(lo[d], x[3 * i + d]);
        hi[d] = std::max(hi[d], x[3 * i + d]);
      }

    // The small class: radii up to SMALL_SLACK times the (1 - 1/LARGE_SHARE) quantile, where
    // the largest radius is more than SPLIT_RATIO times that.
    double tsmall = rmax;
    if (n >= 2 * LARGE_SHARE) {
      tmp.assign(rad, rad + n);
      const int k = n - 1 - n / LARGE_SHARE;
      std::nth_element(tmp.begin(), tmp.begin() + k, tmp.end());
      const double t = SMALL_SLACK * tmp[k];
      if (t > 0.0 && rmax > SPLIT_RATIO * t) tsmall = t;
    }
    for (int i = 0; i < n; ++i) (rad[i] <= tsmall ? members : large).push_back(i);
    nbig = (int) large.size();
    if (nbig == 0) tsmall = rmax;

    small.build(x, rad, members, lo, hi, 2.0 * tsmall + extra);
    small.pairs(nsearch, extra, pairs);
    if (nbig == 0) return;

    // Large points among themselves, in cells of their own.
    big.build(x, rad, large, lo, hi, 2.0 * rmax + extra);
    big.pairs(nsearch, extra, pairs);
    // Each large point against the small points in the cells within its own range.
    std::vector<int> &near = tmp_idx;
    for (int b : large) {
      const double *pb = &x[3 * (size_t) b];
      const double rb = rad[b] + extra;
      near.clear();
      small.box(pb, rb + tsmall, near);
      for (int k : near) {
        if (b >= nsearch && k >= nsearch) continue;
        const double *q = &x[3 * (size_t) k];
        const double dx = pb[0] - q[0], dy = pb[1] - q[1], dz = pb[2] - q[2];
        const double range = rb + rad[k];
        if (dx * dx + dy * dy + dz * dz <= range * range) {
          pairs.push_back(std::min(b, k));
          pairs.push_back(std::max(b, k));
        }
      }
    }
  }

  void CellSearch::within(int i, double range, std::vector<int> &out) const
  {
    const double *p = &pos[3 * (size_t) i];
    small.box(p, range, out);
    if (nbig > 0) big.box(p, range, out);
  }

  void CellSearch::neighbors(int i, std::vector<int> &out) const
  {
    within(i, small.width, out);
  }

}    // namespace Collide
}    // namespace HSGPU
