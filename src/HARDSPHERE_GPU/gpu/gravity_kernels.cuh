/* HARDSPHERE_GPU driver interface to the all-pairs gravity kernels.

   Plain functions over raw device pointers, sizes and launch shapes; the kernels live in
   gravity_kernels.cu, which includes nothing from LAMMPS or MPI.  Every function returns the
   CUDA status of its launches (cudaGetLastError after each launch).

   Data on the device:
     x      3n doubles, positions already mapped into the periodic cell (as on the host)
     m      n doubles, masses (uploaded only when they change)
     src    packed sources in the precision's format (pack_sources fills it):
              Single: float4 (x - lo, m)                   16 B per source
              Mixed, Double: 4 doubles (x - lo, m)         32 B per source
     tidx   ntgt ints: the source index of each target (the atoms this rank owns)
     order  Mixed only: targets in Morton (Z-curve) order of their positions, as the source
            index (tsorted) and the result slot (slot) of each; sort_targets fills them.
   Mixed precision: each block takes the position of its first (Morton-sorted) target as its
   origin O; sources entering shared memory and the block's targets are converted to float as
   x - O, computed in double.  Nearby pairs then lie near O and keep their digits however
   large the coordinates; pair arithmetic is fp32 and each tile's fp32 sums are added into
   fp64 accumulators.
   Results per target (double): force, and with energy/virial requested its half of the pair
   energies and of the pair virial (xx yy zz xy xz yz), the split LAMMPS tallies per atom. */
#ifndef HSGPU_GPU_GRAVITY_KERNELS_CUH
#define HSGPU_GPU_GRAVITY_KERNELS_CUH

#include "gravity_types.h"

#include <cuda_runtime.h>
#include <cstddef>

namespace HSGPU {
namespace GPU {

  /// Bytes of packed sources per source for a precision.
  size_t source_bytes(Precision p);

  /// Launch shape (one that is compiled for these flags) that keeps all multiprocessors busy
  /// for ntgt targets and nsrc sources.
  GravityShape choose_shape(Precision p, const GravityArgs &a, long ntgt, long nsrc, int num_sms);

  /// Number of source ranges ("splits") choose_shape gives shape s (block and ilp set) for
  /// ntgt targets and nsrc sources: about 16 blocks per multiprocessor, at least 2 tiles each.
  int auto_splits(const GravityShape &s, long ntgt, long nsrc, int num_sms);

  /// Bytes of scratch space compute_gravity needs for this shape (split partial sums).
  size_t scratch_bytes(Precision p, const GravityShape &s, long ntgt, bool energy_virial);

  /// Pack positions and masses into src; source k is body order[k] (order null: body k).
  cudaError_t pack_sources(Precision p, const double *x, const double *m, long n,
                           const GravityArgs &a, void *src, cudaStream_t st,
                           const int *order = nullptr);

  /// Bytes of temporary storage sort_targets needs for ntgt targets.
  size_t sort_temp_bytes(long ntgt);

  /// Orders the targets along a Z curve of their positions x: writes the source index
  /// (tsorted) and the result slot (slot) of each target in that order.  keys: 2*ntgt
  /// unsigned ints of scratch; temp: sort_temp_bytes(ntgt) bytes.
  cudaError_t sort_targets(const double *x, const int *tidx, long ntgt, const GravityArgs &a,
                           unsigned *keys, int *tsorted, int *slot, void *temp, size_t temp_bytes,
                           cudaStream_t st);

  /// Sources [begin, end) of the packed array whose partial sums fill splits
  /// [split0, split0 + shape.splits) of a scratch laid out for nsplits splits
  /// (compute_partials); several ranges cover the sources when their sums are started at
  /// different times (the all-pairs gather of several MPI ranks overlapped with the kernels).
  struct SourceRange {
    long begin, end;
    int split0, nsplits;
  };

  /// Whether the kernels must test for each target's own index (the self pair is not exactly
  /// zero: energy or virial wanted, no softening, or masses up to max_mass overflow m/eps^3).
  bool needs_self_test(Precision p, const GravityArgs &a, double max_mass);

  /// Partial sums of the sources in r for ntgt targets (tidx: their source indices, which
  /// index src for the targets' own positions too), s.splits block rows over r; no finalize:
  /// sum_partials adds the nsplits splits afterwards.  scratch: scratch_bytes(p, s', ntgt, ev)
  /// for a shape s' of nsplits splits.
  cudaError_t compute_partials(Precision p, const GravityShape &s, const void *src,
                               const SourceRange &r, const int *tidx, long ntgt,
                               const GravityArgs &a, bool self_test, void *scratch,
                               cudaStream_t st);

  /// All-pairs sum for ntgt targets over nsrc sources, leaving out each target's own index.
  /// tidx: source index of each target; slot: where each target's results go (nullptr: in
  /// order).  f: 3*ntgt doubles; e: ntgt, v: 6*ntgt doubles (only with a.energy_virial).
  /// max_mass: the largest source mass (decides whether the self pair needs a test).
  cudaError_t compute_gravity(Precision p, const GravityShape &s, const void *src, long nsrc,
                              const int *tidx, const int *slot, long ntgt, const double *m,
                              double max_mass, const GravityArgs &a, void *scratch, double *f,
                              double *e, double *v, cudaStream_t st);

  /// Adds nparts partial sums per target in order and scales by G m (finalize of
  /// compute_gravity and compute_gravity_pairs_once): the partials of part k for target t
  /// sit at k * stride + t (3 values each, then with ev 1 and 6 more per part and target).
  /// tidx null: target t is source t.
  cudaError_t sum_partials(Precision p, const void *part, int nparts, long stride, long ntgt,
                           const int *tidx, const int *slot, const double *m, double G, bool ev,
                           double *f, double *e, double *v, cudaStream_t st);

  // ------------------------------------------------------------------ pairs once
  // With every body a target (one MPI rank), Newton's third law lets each pair be evaluated
  // once for both bodies (gravity_pairs_once.cu): about 1.4x fewer instructions per
  // interaction than the one-sided kernels.  Forces only, open box, no cutoff; everything
  // else takes compute_gravity.

  /// How the bodies are blocked: nb blocks of `group` slices of 128 * ilp bodies, the last
  /// block padded with massless bodies to npad = nb * group * 128 * ilp.
  struct PairsOnceLayout {
    int ilp;
    int group;
    int nb;
    long npad;
  };

  /// Whether compute_gravity_pairs_once handles these flags.
  bool pairs_once_supported(Precision p, const GravityArgs &a);

  /// Whether the pairs-once kernel is faster than the one-sided ones for n bodies (measured).
  bool pairs_once_pays(Precision p, long n);

  /// Layout for n bodies; ilp 2, 4 or 8 (anything else: the measured default for p and n).
  PairsOnceLayout pairs_once_layout(Precision p, long n, int ilp = 0);

  /// Bytes of packed sources (including pads) and of scratch space (partial sums)
  /// compute_gravity_pairs_once needs.
  size_t pairs_once_source_bytes(Precision p, const PairsOnceLayout &L);
  size_t pairs_once_scratch_bytes(Precision p, const PairsOnceLayout &L);

  /// Forces f (3n doubles) on all n bodies (positions x, masses m on the device) from all
  /// others, each pair evaluated once.  The bodies are packed into src in the order `order`
  /// (Mixed: the Z-curve order of sort_targets, so that blocks are compact; null: as they
  /// are), and body order[k]'s force goes to slot[k] (null: k).
  cudaError_t compute_gravity_pairs_once(Precision p, const PairsOnceLayout &L, const double *x,
                                         const double *m, long n, const int *order, const int *slot,
                                         const GravityArgs &a, void *src, void *scratch, double *f,
                                         cudaStream_t st);

  /// The plain reference kernel used as the benchmark baseline: one body per thread, 256-body
  /// shared-memory tiles, fp32 with rsqrtf, no periodic images, forces only.
  /// pos: float4 (x, y, z, m) for n bodies; acc: float4 per body (acceleration / G).
  cudaError_t reference_nbody(const void *pos, long n, float eps2, void *acc, cudaStream_t st);

}    // namespace GPU
}    // namespace HSGPU

#endif
