/* HARDSPHERE_GPU: the physics core evaluated on the device, see core_device_check.h.

   Compiled like the CUDA collision backend (--fmad=false, no fast math), so that what this
   checks is what the backend computes. */
#include "core_device_check.h"

#include "cuda_check.cuh"

namespace HSGPU {
namespace GPU {

  namespace {

    // Launch contract: 1-D grid of 1-D blocks, any shape; thread k evaluates case k < n.
    // cases[n] and out[n] in device memory, tables[core_tables_size(ntypes)] in device memory.
    __global__ void evaluate_cases_kernel(const CoreCase *__restrict__ cases, int n,
                                          const double *__restrict__ tables, int ntypes,
                                          CoreResult *__restrict__ out)
    {
      const int k = blockIdx.x * blockDim.x + threadIdx.x;
      if (k >= n) return;
      CoreResult r;
      evaluate_core_case(cases[k], tables, ntypes, r);
      out[k] = r;
    }

  }    // namespace

  void run_core_cases_on_device(int device, const CoreCase *cases, int n, const double *tables,
                                int ntypes, CoreResult *out)
  {
    if (n <= 0) return;
    cuda_check(cudaSetDevice(device), "cudaSetDevice");
    const size_t ne = (size_t) core_tables_size(ntypes);
    DeviceBuffer dcases, depair, dout;
    try {
      dcases.reserve(n * sizeof(CoreCase), "cudaMalloc(core cases)");
      depair.reserve(ne * sizeof(double), "cudaMalloc(restitution and friction tables)");
      dout.reserve(n * sizeof(CoreResult), "cudaMalloc(core results)");
      cuda_check(cudaMemcpy(dcases.ptr, cases, n * sizeof(CoreCase), cudaMemcpyHostToDevice),
                 "cudaMemcpy(core cases)");
      cuda_check(cudaMemcpy(depair.ptr, tables, ne * sizeof(double), cudaMemcpyHostToDevice),
                 "cudaMemcpy(restitution and friction tables)");
      const int block = 64;
      (void) cudaGetLastError();    // the launch check below sees this launch's error only
      evaluate_cases_kernel<<<(n + block - 1) / block, block>>>(
          dcases.as<CoreCase>(), n, depair.as<double>(), ntypes, dout.as<CoreResult>());
      cuda_check(cudaGetLastError(), "evaluate_cases_kernel launch");
      cuda_check(cudaMemcpy(out, dout.ptr, n * sizeof(CoreResult), cudaMemcpyDeviceToHost),
                 "evaluate_cases_kernel (copy back)");
    } catch (...) {
      dcases.release();
      depair.release();
      dout.release();
      throw;
    }
    dcases.release();
    depair.release();
    dout.release();
  }

}    // namespace GPU
}    // namespace HSGPU
