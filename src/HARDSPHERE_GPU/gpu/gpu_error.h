/* HARDSPHERE_GPU: the exception every GPU driver function throws when CUDA fails (or when the
   package was built without CUDA).  Plain C++: callers catch it without seeing any CUDA type;
   cuda_check.cuh turns a CUDA status into one, with CUDA's error name and message. */
#ifndef HSGPU_GPU_GPU_ERROR_H
#define HSGPU_GPU_GPU_ERROR_H

#include <stdexcept>
#include <string>

namespace HSGPU {
namespace GPU {

  class Error : public std::runtime_error {
   public:
    explicit Error(const std::string &what) : std::runtime_error(what) {}
  };

}    // namespace GPU
}    // namespace HSGPU

#endif
