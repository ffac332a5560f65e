/* HARDSPHERE_GPU: the all-pairs gravity engine on one CUDA device.

   Owns the device buffers (allocated once, grown when N grows), uploads positions every
   call but masses and target lists only when they change, runs the kernels of
   gravity_kernels.cuh and returns double-precision results.  The implementation is behind a
   pointer: this header includes no CUDA, LAMMPS or MPI header.  Every CUDA failure is thrown
   as HSGPU::GPU::Error carrying CUDA's message. */
#ifndef HSGPU_GPU_GRAVITY_ENGINE_H
#define HSGPU_GPU_GRAVITY_ENGINE_H

#include "gpu_error.h"
#include "gravity_types.h"

#include <string>

namespace HSGPU {
namespace GPU {

  class GravityEngine {
   public:
    explicit GravityEngine(int device);
    ~GravityEngine();
    GravityEngine(const GravityEngine &) = delete;
    GravityEngine &operator=(const GravityEngine &) = delete;

    int device() const;
    std::string device_name() const;
    /// Multiprocessors of the device (what the automatic launch shape is sized for).
    int num_sms() const;

    /// n sources: positions x (3n, mapped into the periodic cell) and masses m (n).  Masses
    /// are uploaded only when masses_changed is true or n changed.
    void set_sources(long n, const double *x, const double *m, bool masses_changed);

    /// ntgt targets given by their source indices; uploaded only when the list changed.
    void set_targets(long ntgt, const long *index);

    /// Forces f (3 per target) and, with a.energy_virial, per-target half energies e and
    /// half virials v (6 per target).  shape.splits <= 0 lets the engine choose the shape;
    /// when the pairs-once kernel runs, a given shape's ilp (2, 4 or 8) is its ILP.
    void compute(Precision p, const GravityArgs &a, double *f, double *e, double *v,
                 GravityShape shape = GravityShape{0, 0, 0});

    /// Kernel time of the last compute() in milliseconds (CUDA events).
    float last_kernel_ms() const;
    /// Whether the last compute() evaluated each pair once (GravityArgs::pairs_once).
    bool last_pairs_once() const;

   private:
    struct Impl;
    Impl *impl;
    void launch_pairs_once(Precision p, const GravityArgs &a, int ilp);
  };

}    // namespace GPU
}    // namespace HSGPU

#endif
