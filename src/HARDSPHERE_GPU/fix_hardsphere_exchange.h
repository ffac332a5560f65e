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
  void max(double *v, int n) override;
  void sum(long *v, int n) override;

 private:
  FixHardSphere *fix;
  MPI_Comm p2p;    // a copy of the world for to_ranks()'s messages, apart from LAMMPS's own
  long p2p_calls = 0;
  std::vector<double> inbox;                   // to_ranks(): the messages as they came
  std::vector<std::array<long, 3>> inbox_parts;    // and their (source, offset, length)
};

}    // namespace LAMMPS_NS

#endif
