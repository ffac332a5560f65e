/* HARDSPHERE_GPU collision engine: the CUDA backend, resident step and peer inputs for a build
   without CUDA, see collision_backend_cuda.h, resident_step_cuda.h and peer_inputs.h.  Asking
   for one throws, so callers fall back to the CPU backend (or to MPI). */
#include "collision_backend_cuda.h"
#include "peer_inputs.h"
#include "resident_step_cuda.h"

#include "gpu_error.h"

namespace HSGPU {
namespace Collide {

  std::unique_ptr<CollisionBackend> make_cuda_backend(int)
  {
    throw GPU::Error("built without CUDA");
  }

  std::unique_ptr<ResidentStep> make_cuda_resident_step(int)
  {
    throw GPU::Error("built without CUDA");
  }

  bool cuda_backend_available()
  {
    return false;
  }

}    // namespace Collide

namespace GPU {

  struct PeerInputs::Impl {};

  PeerInputs::PeerInputs(int) : impl(nullptr)
  {
    throw Error("built without CUDA");
  }
  PeerInputs::~PeerInputs() = default;
  void PeerInputs::open(const std::vector<char> &)
  {
    throw Error("built without CUDA");
  }
  void PeerInputs::put(long, long, const double *, const double *, const double *, long)
  {
    throw Error("built without CUDA");
  }
  void PeerInputs::put_statics(long, long, const double *, const double *, const double *,
                               const int *, const void *, int)
  {
    throw Error("built without CUDA");
  }
  void PeerInputs::put_spin(long, long, const double *)
  {
    throw Error("built without CUDA");
  }
  void PeerInputs::open_results(const std::vector<char> &)
  {
    throw Error("built without CUDA");
  }
  void PeerInputs::get_result(int, size_t, size_t, void *)
  {
    throw Error("built without CUDA");
  }
  void PeerInputs::put_ids(long, long, const void *, int)
  {
    throw Error("built without CUDA");
  }
  void PeerInputs::get_atoms(long, long, double *, double *, double *)
  {
    throw Error("built without CUDA");
  }
  void PeerInputs::forget_host_arrays() {}

}    // namespace GPU
}    // namespace HSGPU
