/* -*- c++ -*- ------------------------------------------------------------------
   HARDSPHERE_GPU: fix hardsphere's link between the step driver and the other MPI ranks
   (engine/window_driver.h's Exchange): values of owned bodies to the ghosts that stand for
   them elsewhere (LAMMPS forward communication), gathers and reductions over the world.
------------------------------------------------------------------------------------- */
#ifndef LMP_HSGPU_FIX_HARDSPHERE_EXCHANGE_H
#define LMP_HSGPU_FIX_HARDSPHERE_EXCHANGE_H

#include "engine/window_driver.h"

namespace LAMMPS_NS {

class FixHardSphere;

class LammpsExchange : public HSGPU::Collide::Exchange {
 public:
  explicit LammpsExchange(FixHardSphere *fix) : fix(fix) {}
  int nranks() const override;
  int rank() const override;
  void to_foreign(const std::vector<double> &local, int nval,
                  std::vector<double> &foreign) override;
  void to_owner(const std::vector<double> &foreign, int nval, int nlocal,
                std::vector<double> &local) override;
  void allgather(const std::vector<double> &send, std::vector<double> &recv, long &mine) override;
  void max(double *v, int n) override;
  void sum(long *v, int n) override;

 private:
  FixHardSphere *fix;
};

}    // namespace LAMMPS_NS

#endif
