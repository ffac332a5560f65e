# HARDSPHERE_GPU: the CUDA collision backend and the device check of the physics core.
# Included from src/HARDSPHERE_GPU/CMakeLists.txt after the hsgpu_gpu target.
#
# hsgpu_collide_gpu is compiled for bitwise agreement with the CPU backend, not for speed:
# nvcc with --fmad=false and without --use_fast_math (which hsgpu_gpu's gravity kernels use),
# the host compiler with -ffp-contract=off.  Without CUDA it holds the stubs that throw.

set(_hsgpu_collide_dir ${CMAKE_CURRENT_LIST_DIR})
if(HSGPU_HAVE_CUDA)
  set(_hsgpu_collide_sources ${_hsgpu_collide_dir}/core_device_check.cu
      ${_hsgpu_collide_dir}/collision_backend_cuda.cu ${_hsgpu_collide_dir}/resident_step_cuda.cu
      ${_hsgpu_collide_dir}/peer_inputs.cu)
else()
  set(_hsgpu_collide_sources ${_hsgpu_collide_dir}/core_device_check_none.cpp
      ${_hsgpu_collide_dir}/collision_backend_none.cpp)
endif()

add_library(hsgpu_collide_gpu STATIC ${_hsgpu_collide_sources})
target_link_libraries(hsgpu_collide_gpu PUBLIC hsgpu_core hsgpu_gpu)
target_compile_options(hsgpu_collide_gpu PRIVATE
  $<$<COMPILE_LANGUAGE:CXX>:${HSGPU_WARNING_FLAGS} -ffp-contract=off>
  $<$<COMPILE_LANGUAGE:CUDA>:--fmad=false -Xcompiler=-Wall,-Wextra,-ffp-contract=off -lineinfo>)
if(HSGPU_HAVE_CUDA)
  set_target_properties(hsgpu_collide_gpu PROPERTIES CUDA_RUNTIME_LIBRARY Static)
endif()
