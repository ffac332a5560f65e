/* -*- c++ -*- ------------------------------------------------------------------
   HARDSPHERE_GPU: fix hardsphere's link between the step driver and the other MPI ranks
   (engine/window_driver.h's Exchange): values of owned bodies to the ghosts that stand for
   them elsewhere (LAMMPS forward communication), messages to chosen ranks, gathers and
   reductions over the world.
------------------------------------------------------------------------------------- */
#ifndef LMP_HSGPU_FIX_HARDSPHERE_EXCHANGE_H
#define LMP_HSGPU_FIX_HARDSPHERE_EXCHANGE_H

#include "engine/window_driver.h"

#include <mpi.h>

#include <array>
#include <vector>

namespace LAMMPS_NS {

class FixHardSphere;

class LammpsExchange : public HSGPU::Collide::Exchange {
 public:
  explicit LammpsExchange(FixHardSphere *fix);
  ~LammpsExchange() override;
  LammpsExchange(const LammpsExchange &) = delete;
  LammpsExchange &operator=(const LammpsExchange &) = delete;
  int nranks() const override;
  int rank() const override;
  void to_foreign(const std::vector<double> &local, int nval,
                  std::vector<double> &foreign) override;
  void to_owner(const std::vector<double> &foreign, int nval, int nlocal,
                std::vector<double> &local) override;
  void allgather(const std::vector<double> &send, std::vector<double> &recv, long &mine) override;
  bool to_ranks(const std::vector<int> &dest, const std::vector<std::vector<double>> &send,
                std::vector<double> &recv) override;
  const std::vector<int> *neighbours() const override;
  void to_neighbours(const std::vector<int> &dest, const std::vector<std::vector<double>> &send,
                     std::vector<double> &recv) override;
  void max(double *v, int n) override;
  void sum(long *v, int n) override;
  void max_sum(double *mx, int nm, long *sm, int ns) override;
  /// The same with sums of doubles (the fix's own figures of a step; one reduction).
  void max_sum(double *mx, int nm, double *sm, int ns);

  /// The neighbouring ranks of to_neighbours(): the owners of the foreign nodes `fnodes`,
  /// and the ranks whose foreign nodes this rank owns (one exchange with a consensus, so
  /// that the relation is symmetric).  Made again where `stamp` differs from the last call's
  /// (the number of neighbor list builds: the same on every rank, and the ghosts, whose
  /// owners these are, change only then).  Every rank calls it at the same point.
  void find_neighbours(const std::vector<HSGPU::Collide::ForeignNode> &fnodes, long stamp);
  /// No neighbouring ranks (to_neighbours() unused) until the next find_neighbours().
  void forget_neighbours() { nbr_ready = false; }

 private:
  FixHardSphere *fix;
  MPI_Comm p2p;    // a copy of the world for to_ranks()'s messages, apart from LAMMPS's own
  MPI_Op max_then_sum;    // max_sum(): the largest of the first values, the sum of the others
  std::vector<double> msbuf;
  template <class Sum> void max_then_sum_of(double *mx, int nm, Sum *sm, int ns);
  long p2p_calls = 0;
  std::vector<double> inbox;                   // to_ranks(): the messages as they came
  std::vector<std::array<long, 3>> inbox_parts;    // and their (source, offset, length)
  std::vector<int> nbrs;          // the neighbouring ranks, sorted
  std::vector<int> nbr_msg;       // to_neighbours(): per neighbour, its index in dest or -1
  std::vector<MPI_Request> nbr_req;
  bool nbr_ready = false;
  long nbr_stamp = -1;
};

}    // namespace LAMMPS_NS

#endif
