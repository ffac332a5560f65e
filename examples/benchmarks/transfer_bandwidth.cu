// Host-device copy bandwidth, as the collision fix's device-resident step uses it: LAMMPS's
// per-atom arrays are ordinary (pageable) host memory, the fix's download buffers are pinned.
//
//   transfer_bandwidth [device] [repeats]
//
// For sizes from 256 KiB to 256 MiB: the median over `repeats` copies (CUDA events around each
// cudaMemcpyAsync, followed by a stream synchronize) of pageable and pinned memory, host to
// device and device to host, in GB/s (1e9 bytes per second); one line per size and direction.
// The step moves about 100 bytes per atom up at N atoms: the 4 MiB row is N ~ 40000, the
// 128 MiB row N ~ 1.3 million.
#include <cuda_runtime.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

namespace {

void check(cudaError_t e, const char *what)
{
  if (e == cudaSuccess) return;
  std::fprintf(stderr, "transfer_bandwidth: %s: %s\n", what, cudaGetErrorString(e));
  std::exit(1);
}

// Median of `repeats` timed copies of `bytes` from src to dst, in GB/s.
double measure(void *dst, const void *src, size_t bytes, cudaMemcpyKind kind, int repeats,
               cudaStream_t stream, cudaEvent_t a, cudaEvent_t b)
{
  std::vector<double> gbs;
  check(cudaMemcpyAsync(dst, src, bytes, kind, stream), "warm-up copy");
  check(cudaStreamSynchronize(stream), "warm-up copy");
  for (int r = 0; r < repeats; ++r) {
    check(cudaEventRecord(a, stream), "cudaEventRecord");
    check(cudaMemcpyAsync(dst, src, bytes, kind, stream), "cudaMemcpyAsync");
    check(cudaEventRecord(b, stream), "cudaEventRecord");
    check(cudaStreamSynchronize(stream), "cudaStreamSynchronize");
    float ms = 0.0f;
    check(cudaEventElapsedTime(&ms, a, b), "cudaEventElapsedTime");
    gbs.push_back((double) bytes / (1e6 * ms));
  }
  std::sort(gbs.begin(), gbs.end());
  return gbs[gbs.size() / 2];
}

}    // namespace

int main(int argc, char **argv)
{
  const int device = argc > 1 ? std::atoi(argv[1]) : 0;
  const int repeats = argc > 2 ? std::max(1, std::atoi(argv[2])) : 9;
  check(cudaSetDevice(device), "cudaSetDevice");
  cudaDeviceProp prop;
  check(cudaGetDeviceProperties(&prop, device), "cudaGetDeviceProperties");
  std::printf("# device %d: %s; median of %d copies per row (CUDA events)\n", device, prop.name,
              repeats);
  std::printf("# %10s %10s %12s %12s\n", "MiB", "direction", "pageable", "pinned");
  const size_t most = (size_t) 256 << 20;
  char *pageable = (char *) std::malloc(most);
  if (!pageable) {
    std::fprintf(stderr, "transfer_bandwidth: out of host memory\n");
    return 1;
  }
  std::memset(pageable, 1, most);
  char *pinned = nullptr, *dev = nullptr;
  check(cudaMallocHost((void **) &pinned, most), "cudaMallocHost");
  std::memset(pinned, 1, most);
  check(cudaMalloc((void **) &dev, most), "cudaMalloc");
  cudaStream_t stream;
  check(cudaStreamCreateWithFlags(&stream, cudaStreamNonBlocking), "cudaStreamCreate");
  cudaEvent_t a, b;
  check(cudaEventCreate(&a), "cudaEventCreate");
  check(cudaEventCreate(&b), "cudaEventCreate");
  for (size_t bytes = (size_t) 256 << 10; bytes <= most; bytes *= 4) {
    const double mib = (double) bytes / (1 << 20);
    const double up_pg =
        measure(dev, pageable, bytes, cudaMemcpyHostToDevice, repeats, stream, a, b);
    const double up_pn = measure(dev, pinned, bytes, cudaMemcpyHostToDevice, repeats, stream, a, b);
    const double dn_pg =
        measure(pageable, dev, bytes, cudaMemcpyDeviceToHost, repeats, stream, a, b);
    const double dn_pn = measure(pinned, dev, bytes, cudaMemcpyDeviceToHost, repeats, stream, a, b);
    std::printf("  %10.2f %10s %9.2f GB/s %6.2f GB/s\n", mib, "up", up_pg, up_pn);
    std::printf("  %10.2f %10s %9.2f GB/s %6.2f GB/s\n", mib, "down", dn_pg, dn_pn);
  }
  cudaEventDestroy(a);
  cudaEventDestroy(b);
  cudaStreamDestroy(stream);
  cudaFree(dev);
  cudaFreeHost(pinned);
  std::free(pageable);
  return 0;
}
