// GPU presence and description (label GPU): skipped, not passed, where no GPU is usable.
#include "gpu/device_info.cuh"

#include <gtest/gtest.h>

TEST(GpuDevice, DescribesEveryDevice)
{
  if (!HSGPU::GPU::compiled_with_cuda()) GTEST_SKIP() << "built without CUDA";
  const int n = HSGPU::GPU::device_count();
  if (n == 0) GTEST_SKIP() << "no CUDA device on this machine";
  for (int id = 0; id < n; ++id) {
    const std::string d = HSGPU::GPU::device_description(id);
    std::printf("[ DEVICE   ] %d: %s\n", id, d.c_str());
    EXPECT_NE(d.find("sm_"), std::string::npos) << d;
  }
}

TEST(GpuDevice, NoDeviceMeansZero)
{
  // Holds on every machine: the count is never negative and the call never throws.
  EXPECT_GE(HSGPU::GPU::device_count(), 0);
}
