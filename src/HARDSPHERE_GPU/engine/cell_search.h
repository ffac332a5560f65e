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

   private:
    long ncell[3] = {1, 1, 1};
    std::vector<int> cell_of, start, order;
    std::vector<double> sorted;
  };

}    // namespace Collide
}    // namespace HSGPU

#endif
