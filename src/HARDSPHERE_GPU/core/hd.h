/* HARDSPHERE_GPU: host/device function qualifier shared by the physics core.
   Core headers include nothing from LAMMPS, MPI or CUDA: nvcc sees __host__ __device__,
   the host compiler sees plain inline functions. */
#ifndef HSGPU_CORE_HD_H
#define HSGPU_CORE_HD_H

#if defined(__CUDACC__)
#define HSGPU_HD __host__ __device__ inline
#else
#define HSGPU_HD inline
#endif

#endif
