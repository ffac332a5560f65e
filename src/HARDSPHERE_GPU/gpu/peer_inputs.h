/* HARDSPHERE_GPU: the other side of ResidentStep::share_inputs() (engine/resident_step.h).

   fix hardsphere's gathered step of several ranks runs on rank 0's device; on one node each
   other rank copies its atoms' x, v and f straight into that device's buffers (CUDA IPC)
   instead of sending them to rank 0's host through MPI.  PeerInputs opens the buffers named by
   rank 0's handles on this process's device and copies into them.

   Plain C++: no CUDA types.  Built from peer_inputs.cu with CUDA; without, from
   collision_backend_none.cpp, where every call throws (the caller then gathers through MPI). */
#ifndef HSGPU_GPU_PEER_INPUTS_H
#define HSGPU_GPU_PEER_INPUTS_H

#include <cstddef>
#include <vector>

namespace HSGPU {
namespace GPU {

  class PeerInputs {
   public:
    /// On CUDA device `device` (this process's); throws HSGPU::GPU::Error where it cannot.
    explicit PeerInputs(int device);
    ~PeerInputs();
    PeerInputs(const PeerInputs &) = delete;
    PeerInputs &operator=(const PeerInputs &) = delete;

    /// Opens the buffers of `handles` (ResidentStep::share_inputs()'s bytes) unless they are
    /// the ones open now; throws where the driver refuses.
    void open(const std::vector<char> &handles);
    /// Copies count atoms' x, v and f (3 doubles each) into atoms [first, first + count) of the
    /// open buffers and waits.  The host arrays are page-locked in place and kept so until
    /// forget_host_arrays() or they move.
    /// room: atoms the arrays x, v, f hold (at least count), page-locked once.
    void put(long first, long count, const double *x, const double *v, const double *f,
             long room);
    /// Copies count atoms' angular velocities (3 each) into the open buffer of them (rough
    /// spheres: handles with omega) and waits.
    void put_spin(long first, long count, const double *omega);
    /// Copies count atoms' times of last collision, radii, masses, types and IDs (id_bytes
    /// each) into atoms [first, first + count) of the open buffers and waits (pageable copies:
    /// these move only after atoms moved in a rank's arrays).
    void put_statics(long first, long count, const double *tlast, const double *radius,
                     const double *rmass, const int *type, const void *id, int id_bytes);
    /// Copies count atoms' IDs (id_bytes each) into atoms [first, first + count) of the open
    /// ID buffer and waits (ResidentStep::put_ids()).
    void put_ids(long first, long count, const void *id, int id_bytes);
    /// Opens the buffers of `handles` (ResidentStep::share_results()'s bytes: the results of
    /// the gathering device's step, every atom's tlast, and for rough spheres the results'
    /// angular velocities) unless they are open now.
    void open_results(const std::vector<char> &handles);
    /// Copies `bytes` bytes from byte `offset` of open result buffer k (0: the results, 1:
    /// tlast, 2: the results' angular velocities) into host memory `out`, and waits.
    void get_result(int k, size_t offset, size_t bytes, void *out);
    /// Copies atoms [first, first + count) of the open buffers' x, v and tlast (the gathering
    /// device's step end state: ResidentStep::get_atoms()) into x, v (3 doubles each) and tlast
    /// here, and waits.
    void get_atoms(long first, long count, double *x, double *v, double *tlast);
    /// The host arrays given to put() may move or be freed.
    void forget_host_arrays();

   private:
    struct Impl;
    Impl *impl;
  };

}    // namespace GPU
}    // namespace HSGPU

#endif
