/* HARDSPHERE_GPU driver interface to the all-pairs gravity kernels.

   Plain functions over raw device pointers, sizes and launch shapes; the kernels live in
   gravity_kernels.cu, which includes nothing from LAMMPS or MPI.  Every function returns the
   CUDA status of its launches (cudaGetLastError after each launch).

   Data on the device:
     x      3n doubles, positions already mapped into the periodic cell (as on the host)
     m      n doubles, masses (uploaded only when they change)
     src    packed sources in the precision's format (pack_sources fills it):
              Single: float4 (x - lo, m)            16 B per source
              Mixed:  float4 hi + float4 lo         32 B per source, x - lo = hi + lo exactly
                                                      to about 2^-48 relative
              Double: double4 (x - lo, m)           32 B per source
     tidx   ntgt ints: the source index of each target (the atoms this rank owns)
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

  /// Launch shape that keeps all multiprocessors busy for ntgt targets and nsrc sources.
  GravityShape choose_shape(Precision p, long ntgt, long nsrc, int num_sms);

  /// Bytes of scratch space compute_gravity needs for this shape (split partial sums).
  size_t scratch_bytes(Precision p, const GravityShape &s, long ntgt, bool energy_virial);

  /// Pack positions and masses into src (and src_lo for Mixed, else unused).
  cudaError_t pack_sources(Precision p, const double *x, const double *m, long n,
                           const GravityArgs &a, void *src, void *src_lo, cudaStream_t st);

  /// All-pairs sum for ntgt targets over nsrc sources, leaving out each target's own index.
  /// f: 3*ntgt doubles; e: ntgt, v: 6*ntgt doubles (only with a.energy_virial).
  cudaError_t compute_gravity(Precision p, const GravityShape &s, const void *src,
                              const void *src_lo, long nsrc, const int *tidx, long ntgt,
                              const double *m, const GravityArgs &a, void *scratch, double *f,
                              double *e, double *v, cudaStream_t st);

  /// The plain reference kernel used as the benchmark baseline: one body per thread, 256-body
  /// shared-memory tiles, fp32 with rsqrtf, no periodic images, forces only.
  /// pos: float4 (x, y, z, m) for n bodies; acc: float4 per body (acceleration / G).
  cudaError_t reference_nbody(const void *pos, long n, float eps2, void *acc, cudaStream_t st);

}    // namespace GPU
}    // namespace HSGPU

#endif
