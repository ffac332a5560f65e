/* HARDSPHERE_GPU: plain types shared by the gravity driver (gravity_kernels.cuh), the engine
   (gravity_engine.h) and the LAMMPS style.  No CUDA, LAMMPS or MPI types. */
#ifndef HSGPU_GPU_GRAVITY_TYPES_H
#define HSGPU_GPU_GRAVITY_TYPES_H

namespace HSGPU {
namespace GPU {

  /// single: fp32 throughout; mixed: fp32 pair arithmetic on positions taken relative to an
  /// origin inside each block of spatially sorted targets (computed in fp64, so large
  /// coordinates lose no digits), fp32 sums over each tile of sources added into fp64
  /// accumulators; double: fp64 throughout.
  enum class Precision { Single = 0, Mixed = 1, Double = 2 };

  /// What one all-pairs evaluation needs besides the data.
  struct GravityArgs {
    double G;
    double eps2;
    double cutsq;    // <= 0: no cutoff
    double lo[3];
    double prd[3];
    int periodic[3];
    bool energy_virial;    // also per-target energy and virial
    /// Newton's third law: when every source is a target, the engine may evaluate each pair
    /// once for both bodies (compute_gravity_pairs_once).  0: never; 1: where it is faster
    /// (N above a measured threshold); 2: wherever it is supported (benchmarks, tests).
    int pairs_once = 0;
  };

  /// GravityArgs::pairs_once = 1 takes the pairs-once kernel from this many sources on: from
  /// there it measured faster than the one-sided kernels in every precision on an H200
  /// (doc/bench_gravity_gpu.md, the ILP sweep of pairs once); below, too few block pairs fill
  /// the GPU.
  inline constexpr long PAIRS_ONCE_MIN_N = 16384;

  /// Launch shape of the tiled kernel.
  struct GravityShape {
    int block;     // threads per block = sources per shared-memory tile
    int ilp;       // targets per thread
    int splits;    // the sources are split into this many ranges, one block row each
  };

  /// The (block, ilp) shapes compiled for the force-only kernel in an open box without
  /// cutoff, the hot path; every other flag combination runs 256 x 2 (Single, Mixed) or
  /// 256 x 1 (Double).  The benchmark sweep and the tests walk this list.
  inline constexpr int HOT_SHAPES[][2] = {{128, 1}, {128, 2}, {128, 4},
                                          {256, 1}, {256, 2}, {256, 4}};
  inline constexpr int NUM_HOT_SHAPES = sizeof(HOT_SHAPES) / sizeof(HOT_SHAPES[0]);

}    // namespace GPU
}    // namespace HSGPU

#endif
