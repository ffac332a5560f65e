/* HARDSPHERE_GPU: GravityEngine for a build without CUDA: constructing one throws, so callers
   fall back to the CPU path with a message. */
#include "gravity_engine.h"

namespace HSGPU {
namespace GPU {

  struct GravityEngine::Impl {};

  GravityEngine::GravityEngine(int) : impl(nullptr)
  {
    throw Error("HARDSPHERE_GPU was built without CUDA");
  }
  GravityEngine::~GravityEngine() = default;
  int GravityEngine::device() const
  {
    return -1;
  }
  std::string GravityEngine::device_name() const
  {
    return "";
  }
  int GravityEngine::num_sms() const
  {
    return 0;
  }
  void GravityEngine::set_sources(long, const double *, const double *, bool) {}
  void GravityEngine::set_targets(long, const long *) {}
  void GravityEngine::compute(Precision, const GravityArgs &, double *, double *, double *,
                              GravityShape)
  {
    throw Error("HARDSPHERE_GPU was built without CUDA");
  }
  void GravityEngine::begin_own(Precision, const GravityArgs &, long, long, long, const double *,
                                const double *, bool)
  {
    throw Error("HARDSPHERE_GPU was built without CUDA");
  }
  void GravityEngine::finish_rest(const double *, const double *, double *, double *, double *)
  {
    throw Error("HARDSPHERE_GPU was built without CUDA");
  }
  bool GravityEngine::share_sources(std::vector<char> &handles)
  {
    handles.clear();
    return false;
  }
  void GravityEngine::open_peers(const std::vector<char> &, int)
  {
    throw Error("HARDSPHERE_GPU was built without CUDA");
  }
  void GravityEngine::finish_from_peers(const std::vector<long> &, const std::vector<long> &,
                                        double *, double *, double *)
  {
    throw Error("HARDSPHERE_GPU was built without CUDA");
  }
  float GravityEngine::last_kernel_ms() const
  {
    return 0.0f;
  }
  bool GravityEngine::last_pairs_once() const
  {
    return false;
  }

}    // namespace GPU
}    // namespace HSGPU
