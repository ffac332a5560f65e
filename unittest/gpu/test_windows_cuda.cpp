// The time-window driver on the CUDA backend: the same window cases as the CPU test
// (unittest/core/test_contact_order.cpp, common/collision_world.h), every fixed and adaptive
// window setting, bit for bit equal to the serial loop.  Skipped where no device is present.
#include "common/collision_world.h"
#include "gpu/collision_backend_cuda.h"
#include "gpu/device_info.cuh"

#include <gtest/gtest.h>

using namespace hsgpu_test;

TEST(WindowDriverCuda, EqualsSerialBitwise)
{
  if (HSGPU::GPU::device_count() == 0) GTEST_SKIP() << "no CUDA device";
  std::unique_ptr<CollisionBackend> gpu = make_cuda_backend(0);
  ASSERT_TRUE(gpu);
  check_windows_equal_serial(gpu.get());
}
