# Tests of the CUDA collision backend (included from unittest/CMakeLists.txt):
#   test_core_device             every host-device core function on the device against the
#                                host, bit for bit (gpu; its inputs' coverage is checked on the
#                                host before the device part is skipped where there is none)
#   test_collision_backend_cuda  the CUDA backend against the CPU backend, bit for bit (gpu)
#   test_group_loop              the CUDA backend's per-group loop run on the host against the
#                                CPU backend (unit: no device needed)
# The host side of every comparison is compiled like the backends: -ffp-contract=off.
set(_hsgpu_ct_dir ${CMAKE_CURRENT_LIST_DIR})

add_executable(test_core_device ${_hsgpu_ct_dir}/test_core_device.cpp)
target_link_libraries(test_core_device PRIVATE hsgpu_collide_gpu GTest::gtest_main)
hsgpu_test_options(test_core_device)
target_compile_options(test_core_device PRIVATE -ffp-contract=off)
gtest_discover_tests(test_core_device PROPERTIES LABELS gpu
                     SKIP_REGULAR_EXPRESSION "${HSGPU_SKIP_REGEX}")

add_executable(test_collision_backend_cuda ${_hsgpu_ct_dir}/test_collision_backend_cuda.cpp)
target_link_libraries(test_collision_backend_cuda PRIVATE hsgpu_collide_gpu hsgpu_engine
                      GTest::gtest_main)
hsgpu_test_options(test_collision_backend_cuda)
target_compile_options(test_collision_backend_cuda PRIVATE -ffp-contract=off)
gtest_discover_tests(test_collision_backend_cuda PROPERTIES LABELS gpu TIMEOUT 600
                     SKIP_REGULAR_EXPRESSION "${HSGPU_SKIP_REGEX}")

add_executable(test_group_loop ${_hsgpu_ct_dir}/test_group_loop.cpp)
target_link_libraries(test_group_loop PRIVATE hsgpu_core hsgpu_engine GTest::gtest_main)
hsgpu_test_options(test_group_loop)
target_compile_options(test_group_loop PRIVATE -ffp-contract=off)
gtest_discover_tests(test_group_loop PROPERTIES LABELS unit)
