/* -*- c++ -*- ------------------------------------------------------------------
   HARDSPHERE_GPU: every rank's copy of all positions and masses.

   The all-pairs styles let each rank compute the interactions of its own atoms with every
   atom of the system.  AtomGather collects the positions (mapped into the periodic cell)
   and masses of all atoms on all ranks.  In atom-ID order (id_order true, the CPU path) the
   order of the sums and hence the results do not depend on how the domain is decomposed.
   In rank order (id_order false, the GPU path, whose sums depend on the launch shape anyway)
   the positions are received straight into place: no reordering pass over all N atoms on
   every rank and step (at N = 1048576 on 4 GPUs the gather fell from 16 to 10 ms per call).
------------------------------------------------------------------------------------- */
#ifndef LMP_HSGPU_ATOM_GATHER_H
#define LMP_HSGPU_ATOM_GATHER_H

#include "pointers.h"

#include "core/gravity_pair.h"

#include <vector>

namespace LAMMPS_NS {

class AtomGather : protected Pointers {
 public:
  AtomGather(class LAMMPS *, const char *style);

  // Collective: gather owned atoms of all ranks.  Stops with an error naming the atom if
  // a mass is not positive.  Ranks may differ in id_order.  gather() is prepare() then
  // exchange(): in rank order (id_order false on every rank) the rank's own atoms are known
  // between the two (own_first(), own_x(), own_mass(), ntotal, index), so that work on them
  // can start before the exchange, which moves most of the bytes.
  void gather();
  void prepare();
  void exchange();
  long own_first() const { return own_start; }
  const double *own_x() const { return own_xp; }       // 3 per owned atom, wrapped
  const double *own_mass() const { return own_mp; }    // 1 per owned atom
  bool masses_travel() const { return any_changed != 0; }    // this gather changes masses
  // After prepare(): where each rank's atoms start in the rank-ordered arrays, and how many.
  void rank_ranges(std::vector<long> &first, std::vector<long> &count) const
  {
    first.resize(counts.size());
    count.resize(counts.size());
    for (size_t p = 0; p < counts.size(); ++p) {
      first[p] = displs[p] / npack;
      count[p] = counts[p] / npack;
    }
  }

  bool id_order = true;    // order x and mass by atom ID (else by rank, as received)

  long ntotal;                 // atoms in the system
  std::vector<double> x;       // 3*ntotal positions in atom-ID (or rank) order, wrapped
  std::vector<double> mass;    // ntotal masses
  std::vector<long> index;     // index[i] for owned atom i: its place in x and mass
  HSGPU::Gravity::Box box;     // orthogonal box with its periodic flags
  bool changed_masses;         // true when masses differ from the previous gather

  // In atom-ID order: the ID of the atom at place s of x and mass.
  tagint id_at(long s) const { return direct ? (tagint) (s + 1) : (tagint) tags_sorted[s]; }

 private:
  const char *style;
  std::vector<double> sendbuf, recvbuf;
  std::vector<double> own_xbuf, own_mbuf;    // the own atoms where sendbuf also holds IDs
  long own_start = 0;
  const double *own_xp = nullptr, *own_mp = nullptr;
  int any_changed = 1, npack = 0;            // from prepare() for exchange()
  std::vector<int> counts, displs;
  std::vector<long> order;
  bool direct = false;          // atom IDs are exactly 1..ntotal
  bool last_id_order = true;    // the order of the previous gather
  std::vector<double> tags_sorted;
  std::vector<tagint> last_tag;     // owned atoms' IDs and masses at the previous gather:
  std::vector<double> last_mass;    // masses travel only when these change on some rank
};

}    // namespace LAMMPS_NS

#endif
