/* HARDSPHERE_GPU collision engine: the candidate search, see cell_search.h. */
#include "cell_search.h"

#include <algorithm>
#include <cmath>
#include <numeric>

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

    // Relative allowance for rounding in the boxes of Grid::pairs(): the distance test and the
    // cell coordinates round within a few units in the last place of the coordinates (about
    // 1e-16 relative); this is far above that and far below any pair range.
    constexpr double ROUNDING = 1e-12;

    // Cells are this many times narrower along x than the longest pair range: a point's rows
    // (contiguous runs of cells along x) then end closer to its own box, with fewer points
    // tested, and there are no more rows than with cubic cells.
    constexpr int X_SPLIT = 4;

  }    // namespace

  void CellSearch::Grid::build(const double *x, const double *rad, const std::vector<int> &mem,
                               const double *blo, const double *bhi, double w, int searched_below)
  {
    const int m = (int) mem.size();
    nsearch = searched_below;
    // Cells at least as wide as the longest pair range along y and z (X_SPLIT times narrower
    // along x), so that a point's partners lie in the rows of the cells next to its own; at
    // most about 2 m cells (a dilute gas in a large box gets wider cells rather than an empty
    // grid).
    if (!(w > 0.0)) w = 1.0;
    double len[3], span = w;
    for (int d = 0; d < 3; ++d) {
      lo[d] = blo[d];
      len[d] = std::max(bhi[d] - blo[d], 0.0);
      span = std::max(span, std::max(std::fabs(blo[d]), std::fabs(bhi[d])));
    }
    const double limit = 2.0 * m + 27.0;
    for (;;) {
      double total = 1.0;
      for (int d = 0; d < 3; ++d) {
        ncell[d] = std::max(1L, (long) std::floor(len[d] / (d == 0 ? w / X_SPLIT : w)));
        total *= (double) ncell[d];
      }
      if (total <= limit) break;
      w *= 1.26;
    }
    width = w;
    pad = ROUNDING * (span + w);
    for (int d = 0; d < 3; ++d) inv[d] = ncell[d] / std::max(len[d], 1e-300);
    const long nc = cells();
    // Counting sort by cell, stable: in each cell the searched points (lower indices, as
    // members come in increasing order) precede the others.  sstart counts the searched ones.
    start.assign(nc + 1, 0);
    sstart.assign(nc + 1, 0);
    fill.resize(m);
    double rlargest = 0.0;
    for (int k = 0; k < m; ++k) {
      const int i = mem[k];
      const double *p = &x[3 * (size_t) i];
      const int c = (int) ((coord(p[2], 2) * ncell[1] + coord(p[1], 1)) * ncell[0] + coord(p[0], 0));
      fill[k] = c;
      start[c + 1]++;
      sstart[c + 1] += i < nsearch;
      rlargest = std::max(rlargest, rad[i]);
    }
    rmax = rlargest;
    for (long c = 0; c < nc; ++c) {
      start[c + 1] += start[c];
      sstart[c + 1] += sstart[c];
    }
    // Points in cell order, contiguous (x, y, z, radius), so that a cell's points are read
    // in one sweep.
    order.resize(m);
    sorted.resize((size_t) 4 * m);
    next.assign(start.begin(), start.end() - 1);
    for (int k = 0; k < m; ++k) {
      const int i = mem[k];
      const int s = next[fill[k]]++;
      order[s] = i;
      double *to = &sorted[(size_t) 4 * s];
      for (int d = 0; d < 3; ++d) to[d] = x[3 * (size_t) i + d];
      to[3] = rad[i];
    }
    // The searched points alone, in the same order: a filtered copy, in one sweep that writes
    // every point and keeps the searched ones by advancing its count (one slot more, for the
    // last write when a ghost comes last).
    const int ns = sstart[nc];
    all_searched = ns == m;
    if (all_searched) return;
    sorder.resize((size_t) ns + 1);
    ssorted.resize((size_t) 4 * (ns + 1));
    for (int k = 0, t = 0; k < m; ++k) {
      sorder[t] = order[k];
      for (int d = 0; d < 4; ++d) ssorted[(size_t) 4 * t + d] = sorted[(size_t) 4 * k + d];
      t += order[k] < nsearch;
    }
  }

  namespace {

    /// The points in [lo, hi) of a sorted (x, y, z, radius) array within (r_i + r_j) + extra of
    /// the point (xi, yi, zi, ri): their positions are appended to hit at nh, which is
    /// returned.  No branch on the outcome (most tests fail, unpredictably): each position is
    /// written, and kept by advancing nh.
    inline int scan(const double *sorted, int lo, int hi, double xi, double yi, double zi,
                    double ri, double extra, int *hit, int nh)
    {
      for (int k = lo; k < hi; ++k) {
        const double *q = sorted + 4 * (size_t) k;
        const double dx = xi - q[0], dy = yi - q[1], dz = zi - q[2];
        // (r_i + r_j) + extra: the same bits whichever of the two is searched from.
        const double range = (ri + q[3]) + extra;
        hit[nh] = k;
        nh += dx * dx + dy * dy + dz * dz <= range * range;
      }
      return nh;
    }

  }    // namespace

  void CellSearch::Grid::pairs(double extra, std::vector<int> &out)
  {
    // Half stencil: each point against the later points of its cell and the points of the
    // cells that follow it in (z, y, x) order, so that every pair of points is tested once.
    // The cells tested are those within the point's own box (its radius plus the largest
    // one, plus extra): a small point looks at fewer cells than the largest pair range would
    // ask for.  In the sorted order they are contiguous rows: the rest of the point's row,
    // the rows above it in its layer, and the rows of the layers above.  A point that is not
    // searched from (a ghost) looks at the searched points alone (the copy without ghosts),
    // so that pairs of two ghosts are never tested; the searched points of its own cell
    // precede it and are not looked at again.
    const long nx = ncell[0], ny = ncell[1], nz = ncell[2];
    const double *S = sorted.data();
    const int *O = order.data(), *st = start.data();
    hits.resize(order.size());
    int *H = hits.data();
    for (long cz = 0; cz < nz; ++cz)
      for (long cy = 0; cy < ny; ++cy)
        for (long cx = 0; cx < nx; ++cx) {
          const long c = (cz * ny + cy) * nx + cx;
          for (int ki = st[c]; ki < st[c + 1]; ++ki) {
            const int i = O[ki];
            const double xi = S[4 * (size_t) ki], yi = S[4 * (size_t) ki + 1],
                         zi = S[4 * (size_t) ki + 2], ri = S[4 * (size_t) ki + 3];
            // The point's box: every partner lies within it, with room for the rounding of
            // the distance test and of the cell coordinates.
            const double reach = (ri + rmax) + extra + pad;
            const long x0 = coord(xi - reach, 0), x1 = coord(xi + reach, 0);
            const long y0 = coord(yi - reach, 1), y1 = coord(yi + reach, 1);
            const long z1 = coord(zi + reach, 2);
            const bool searched = all_searched || i < nsearch;
            const double *P = searched ? S : ssorted.data();
            const int *Q = searched ? O : sorder.data(), *T = searched ? st : sstart.data();
            int nh = scan(P, searched ? ki + 1 : T[c + 1], T[(cz * ny + cy) * nx + x1 + 1], xi, yi,
                          zi, ri, extra, H, 0);
            for (long y = cy + 1; y <= y1; ++y) {
              const long row = (cz * ny + y) * nx;
              nh = scan(P, T[row + x0], T[row + x1 + 1], xi, yi, zi, ri, extra, H, nh);
            }
            for (long z = cz + 1; z <= z1; ++z)
              for (long y = y0; y <= y1; ++y) {
                const long row = (z * ny + y) * nx;
                nh = scan(P, T[row + x0], T[row + x1 + 1], xi, yi, zi, ri, extra, H, nh);
              }
            for (int h = 0; h < nh; ++h) {
              const int j = Q[H[h]];
              out.push_back(std::min(i, j));
              out.push_back(std::max(i, j));
            }
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
    double lo[3], hi[3], rmin = rad[0];
    bounding_box(x, n, lo, hi);
    bool within_rmax = true;    // every radius is at most rmax (none is NaN)
    for (int i = 0; i < n; ++i) {
      rmin = std::min(rmin, rad[i]);
      within_rmax &= rad[i] <= rmax;
    }

    // The small class: radii up to SMALL_SLACK times the (1 - 1/LARGE_SHARE) quantile, where
    // the largest radius is more than SPLIT_RATIO times that.  The quantile is at least the
    // smallest radius: where the largest is within SPLIT_RATIO SMALL_SLACK of that (the same
    // rounding as the test below), there is one class and no quantile to find.
    double tsmall = rmax;
    if (n >= 2 * LARGE_SHARE && !(rmax <= SPLIT_RATIO * (SMALL_SLACK * rmin))) {
      tmp.assign(rad, rad + n);
      const int k = n - 1 - n / LARGE_SHARE;
      std::nth_element(tmp.begin(), tmp.begin() + k, tmp.end());
      const double t = SMALL_SLACK * tmp[k];
      if (t > 0.0 && rmax > SPLIT_RATIO * t) tsmall = t;
    }
    if (tsmall == rmax && within_rmax) {    // one class: every point, without a test each
      members.resize(n);
      std::iota(members.begin(), members.end(), 0);
    } else {
      for (int i = 0; i < n; ++i) (rad[i] <= tsmall ? members : large).push_back(i);
    }
    nbig = (int) large.size();
    if (nbig == 0) tsmall = rmax;

    small.build(x, rad, members, lo, hi, 2.0 * tsmall + extra, nsearch);
    small.pairs(extra, pairs);
    if (nbig == 0) return;

    // Large points among themselves, in cells of their own.
    big.build(x, rad, large, lo, hi, 2.0 * rmax + extra, nsearch);
    big.pairs(extra, pairs);
    // Each large point against the small points in the cells within its own range.
    std::vector<int> &near = tmp_idx;
    for (int b : large) {
      const double *pb = &x[3 * (size_t) b];
      near.clear();
      small.box(pb, (rad[b] + tsmall) + extra + small.pad, near);
      for (int k : near) {
        if (b >= nsearch && k >= nsearch) continue;
        const double *q = &x[3 * (size_t) k];
        const double dx = pb[0] - q[0], dy = pb[1] - q[1], dz = pb[2] - q[2];
        const double range = (rad[b] + rad[k]) + extra;
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
