/* -*- c++ -*- ------------------------------------------------------------------
   HARDSPHERE_GPU: pair_style gravity, all-pairs softened Newtonian gravity.

     pair_style gravity G eps [cutoff rc] [gpu yes|no] [precision single|mixed|double]
                              [device auto|N]
     pair_coeff * *

   Every pair of atoms interacts once, through the nearest periodic image.  Each rank gathers
   all positions and masses (AtomGather) and computes the forces on its own atoms, on the CPU
   or on one CUDA device per rank (HSGPU::GPU::GravityEngine).
------------------------------------------------------------------------------------- */
#ifndef LMP_HSGPU_PAIR_GRAVITY_H
#define LMP_HSGPU_PAIR_GRAVITY_H

#include "pair.h"

#include <vector>

namespace HSGPU {
namespace GPU {
  class GravityEngine;
  struct GravityArgs;
}
}    // namespace HSGPU

namespace LAMMPS_NS {

class AtomGather;

class PairGravity : public Pair {
 public:
  PairGravity(class LAMMPS *);
  ~PairGravity() override;

  void compute(int, int) override;
  void settings(int, char **) override;
  void coeff(int, char **) override;
  void init_style() override;
  double init_one(int, int) override;
  void write_restart(FILE *) override;
  void read_restart(FILE *) override;
  void write_restart_settings(FILE *) override;
  void read_restart_settings(FILE *) override;

  double gconst() const { return gravity_g; }
  double softening() const { return softening_eps; }
  bool on_gpu() const { return engine != nullptr; }

 protected:
  double gravity_g;        // gravitational constant in the input's units
  double softening_eps;    // Plummer softening length (0 = none)
  double cutoff;           // interaction cutoff (0 = none)
  AtomGather *gather;
  int gpu_requested;                    // gpu yes
  int precision;                        // HSGPU::GPU::Precision as int
  int device_request;                   // -1: pick from the node-local rank
  HSGPU::GPU::GravityEngine *engine;    // null: CPU path
  std::vector<double> gpu_f, gpu_e, gpu_v;
  // HSGPU_TIMING=1 in the environment: seconds spent per phase, printed by rank 0 at the end;
  // HSGPU_TIMING=all: printed by every rank
  double t_gather, t_upload, t_kernel, t_total;
  long ncalls, ncalls_once;    // calls, and calls that evaluated each pair once
  long ncalls_overlap;         // calls with the gather overlapped with the kernels
  long ncalls_peer;            // calls with the positions copied from the other ranks' devices
  bool peer_sources;           // several ranks of one node: no host gather (CUDA IPC)
  std::vector<char> peer_mine, peer_all;    // handles of this and of every rank's buffers
  std::vector<long> rank_first, rank_count;
  bool timing, timing_all;

  struct TargetSums {
    double e;
    double v[6];
  };
  std::vector<TargetSums> sums;

  void allocate();
  void compute_cpu(int nlocal);
  void compute_gpu(int nlocal);
  void compute_gpu_overlapped(int nlocal, double &t_gathered);
  bool sources_from_peers();
  void gpu_args(int nlocal, HSGPU::GPU::GravityArgs &a);
  void add_gpu_results(int nlocal, bool energy_virial);
  void setup_gpu();
  void choose_sort_bins();
  void tally(int nlocal);
  void check_forces(int nlocal);
  void report_nonfinite(int nlocal);
};

}    // namespace LAMMPS_NS

#endif
