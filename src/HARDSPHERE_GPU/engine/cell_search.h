/* HARDSPHERE_GPU collision engine: the candidate search.  Pairs of spheres whose centres are
   within their radius sum plus a margin, found with a cell list built anew for every call
   (O(n) work and memory), so that the search follows each step's own displacement budget
   rather than a cutoff fixed at setup.

   Within the half stencil of its cell, each point tests only the cells that its own box
   reaches (its radius plus the largest, plus the margin), and a point that is not searched
   from (a ghost) only the searched points: pairs of two ghosts are never tested.  Cells are
   as wide as the longest pair range along y and z and a quarter of that along x: a point's
   cells form a few rows along x (contiguous in memory) that end close to its own box.

   Mixed sizes: where a few points have radii far above the rest (diameters 1 and 10), cells as
   wide as the largest pair range would hold hundreds of small points each.  The points are
   then split in two classes: the small ones get cells sized for them, the large ones (at most
   about n/32 of them) cells of their own, and each large point is searched against the small
   cells within its own range.  Every pair is still found once.

   No LAMMPS, MPI or CUDA here. */
#ifndef HSGPU_ENGINE_CELL_SEARCH_H
#define HSGPU_ENGINE_CELL_SEARCH_H

#include <cstddef>
#include <vector>

namespace HSGPU {
namespace Collide {

  /// The bounding box of the points 0 .. n-1 at x (3 each); lo = 1e300, hi = -1e300 for
  /// n = 0.  Kept in scalars: arrays indexed by the dimension were kept in memory by the
  /// compiler, a store and a reload per point and dimension.
  inline void bounding_box(const double *x, int n, double *lo, double *hi)
  {
    double lx = 1e300, ly = 1e300, lz = 1e300, hx = -1e300, hy = -1e300, hz = -1e300;
    for (int i = 0; i < n; ++i) {
      const double *p = &x[3 * (std::size_t) i];
      lx = p[0] < lx ? p[0] : lx;
      ly = p[1] < ly ? p[1] : ly;
      lz = p[2] < lz ? p[2] : lz;
      hx = p[0] > hx ? p[0] : hx;
      hy = p[1] > hy ? p[1] : hy;
      hz = p[2] > hz ? p[2] : hz;
    }
    lo[0] = lx, lo[1] = ly, lo[2] = lz;
    hi[0] = hx, hi[1] = hy, hi[2] = hz;
  }

  class CellSearch {
   public:
    /// Points 0 .. n-1 at x (3 each) with radii rad; the first nsearch of them are searched
    /// from.  Appends to `pairs` every (i, j) with i < nsearch, i < j < n and
    /// |x_i - x_j| <= rad_i + rad_j + extra (plain distance: periodic images must be among
    /// the points), each once.  rmax bounds every radius.  The test is
    /// dx^2 + dy^2 + dz^2 <= ((rad_i + rad_j) + extra)^2 in double precision, the same bits
    /// whichever point of a pair is searched from.
    void find(const double *x, const double *rad, int n, int nsearch, double rmax, double extra,
              std::vector<int> &pairs);

    /// Cells of the last call (both classes; for reports).
    long cells() const { return small.cells() + (nbig > 0 ? big.cells() : 0); }
    /// Points of the last call in the class of large radii (0: one class).
    int large_points() const { return nbig; }
    /// Width of the last call's cells of the small class: every point within this distance of
    /// point i is among neighbors(i).
    double cell_width() const { return small.width; }
    /// Appends to `out` the points of the last call in the cells within one cell width of
    /// point i (in each class's cells).
    void neighbors(int i, std::vector<int> &out) const;
    /// Appends to `out` the points of the last call in the cells that overlap the cube of
    /// half-edge `range` around point i: every point within `range` of it, and others.
    void within(int i, double range, std::vector<int> &out) const;

   private:
    /// A cell list of some of the points (members), over a box given by the caller.
    struct Grid {
      double lo[3] = {0.0, 0.0, 0.0}, inv[3] = {1.0, 1.0, 1.0};
      double width = 0.0;
      double rmax = 0.0;    // the largest radius among the members
      double pad = 0.0;     // allowance for rounding in the boxes of pairs()
      long ncell[3] = {1, 1, 1};
      int nsearch = 0;             // members below this index are searched from
      bool all_searched = true;    // no member is at or above nsearch (no copy below)
      std::vector<int> start, order;    // order: point indices in cell order
      std::vector<double> sorted;       // x, y, z, radius per member, in cell order
      // The searched members alone, in the same cells and order (where some are not).
      std::vector<int> sstart, sorder;
      std::vector<double> ssorted;
      std::vector<int> fill, next, hits;    // scratch of build() and pairs()

      long cells() const { return ncell[0] * ncell[1] * ncell[2]; }
      /// Cells at least `width` wide along y and z, a quarter of that along x (coarsened to
      /// about 2 m cells at most) over [lo, hi];
      /// members below index searched_below are searched from.
      void build(const double *x, const double *rad, const std::vector<int> &members,
                 const double *blo, const double *bhi, double width, int searched_below);
      /// Cell of coordinate p along d, clamped to the grid (a NaN goes to cell 0).  Defined
      /// here to be inlined: the plugin is position-independent, and an out-of-line member
      /// is called through the PLT (several calls per point in pairs()).
      long coord(double p, int d) const
      {
        const double c = (p - lo[d]) * inv[d];
        if (!(c > 0.0)) return 0;    // also NaN
        if (!(c < (double) ncell[d])) return ncell[d] - 1;
        return (long) c;
      }
      /// Pairs of members with at least one searched (half stencil), within
      /// (rad_i + rad_j) + extra.
      void pairs(double extra, std::vector<int> &out);
      /// Members in the cells overlapping [p - range, p + range].
      void box(const double *p, double range, std::vector<int> &out) const;
    };

    Grid small, big;
    int nbig = 0;
    std::vector<double> pos;            // the last call's points
    std::vector<int> members, large;    // point indices of the two classes
    std::vector<double> tmp;
    std::vector<int> tmp_idx;
  };

}    // namespace Collide
}    // namespace HSGPU

#endif
