/* HARDSPHERE_GPU collision engine: the candidate search.  Pairs of spheres whose centres are
   within their radius sum plus a margin, found with a cell list built anew for every call
   (O(n) work and memory), so that the search follows each step's own displacement budget
   rather than a cutoff fixed at setup.

   No LAMMPS, MPI or CUDA here. */
#ifndef HSGPU_ENGINE_CELL_SEARCH_H
#define HSGPU_ENGINE_CELL_SEARCH_H

#include <vector>

namespace HSGPU {
namespace Collide {

  class CellSearch {
   public:
    /// Points 0 .. n-1 at x (3 each) with radii rad; the first nsearch of them are searched
    /// from.  Appends to `pairs` every (i, j) with i < nsearch, i < j < n and
    /// |x_i - x_j| <= rad_i + rad_j + extra (plain distance: periodic images must be among
    /// the points), each once.  rmax bounds every radius.
    void find(const double *x, const double *rad, int n, int nsearch, double rmax, double extra,
              std::vector<int> &pairs);

    /// Cells of the last call (for reports).
    long cells() const { return ncell[0] * ncell[1] * ncell[2]; }
    /// Width of the last call's cells: every point within this distance of point i is among
    /// neighbors(i).
    double cell_width() const { return width_used; }
    /// Appends to `out` the points of the last call in the 27 cells around point i's.
    void neighbors(int i, std::vector<int> &out) const;

   private:
    long ncell[3] = {1, 1, 1};
    double width_used = 0.0;
    std::vector<int> cell_of, start, order;
    std::vector<double> sorted;
  };

}    // namespace Collide
}    // namespace HSGPU

#endif
