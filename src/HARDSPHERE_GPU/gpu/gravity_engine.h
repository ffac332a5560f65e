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
#include <vector>

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

    /// Several MPI ranks, the sums in two parts so that the gather of the other ranks'
    /// positions can run while the device sums over the rank's own atoms.  The n sources of
    /// the system hold this rank's atoms at [first, first + n_own); the targets (set_targets
    /// first) must lie there.  begin_own() uploads the own positions x_own (3 n_own, wrapped
    /// as for set_sources) and, where masses_changed or n changed, the own masses m_own, and
    /// starts the sums over the own sources; it returns at once.  finish_rest() uploads the
    /// other sources from the whole arrays x (3n) and m (n; the own range is not read),
    /// sums over them and returns the results as compute() does.  The sums are those of
    /// compute() in another order (equal to round-off).  Not with pairs_once.
    void begin_own(Precision p, const GravityArgs &a, long n, long first, long n_own,
                   const double *x_own, const double *m_own, bool masses_changed);
    void finish_rest(const double *x, const double *m, double *f, double *e, double *v);

    /// The same without the host's gather, for ranks of one node (CUDA IPC): after
    /// begin_own(), share_sources() waits until the own sources are on the device and writes
    /// handles to this engine's positions and masses (a fixed size, the same while they stay
    /// where they are); false where the device refuses.  Once every rank got there,
    /// open_peers() opens the other ranks' buffers (`all`: every rank's handles in rank order;
    /// kept open while unchanged; throws where it cannot), and finish_from_peers() copies rank
    /// q's sources [first[q], first[q] + count[q]) from its device (and their masses where
    /// begin_own() was told they changed), sums over them and returns the results as
    /// finish_rest() does.  Rank q's own sources must stay as they are until every rank has
    /// returned from finish_from_peers().
    bool share_sources(std::vector<char> &handles);
    void open_peers(const std::vector<char> &all, int me);
    void finish_from_peers(const std::vector<long> &first, const std::vector<long> &count,
                           double *f, double *e, double *v);

    /// Kernel time of the last compute() in milliseconds (CUDA events); after finish_rest(),
    /// from the start of the own sums to the end, waits for the other sources included.
    float last_kernel_ms() const;
    /// Whether the last compute() evaluated each pair once (GravityArgs::pairs_once).
    bool last_pairs_once() const;

   private:
    struct Impl;
    Impl *impl;
    void launch_pairs_once(Precision p, const GravityArgs &a, int ilp);
    void fetch_results(bool energy_virial, double *f, double *e, double *v);
    void sum_rest(double *f, double *e, double *v);
  };

}    // namespace GPU
}    // namespace HSGPU

#endif
