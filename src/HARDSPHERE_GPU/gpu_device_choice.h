/* -*- c++ -*- ------------------------------------------------------------------
   HARDSPHERE_GPU: which CUDA device a rank uses, for the styles that offer "gpu yes".

   The policy, the same for every style: each rank takes the device the user named, or else
   its node-local rank modulo the number of devices on its node.  Where any rank has no usable
   device (or the plugin was built without CUDA) every rank runs the CPU path and rank 0 warns;
   a named device that the node does not have is an error.
------------------------------------------------------------------------------------- */
#ifndef LMP_HSGPU_GPU_DEVICE_CHOICE_H
#define LMP_HSGPU_GPU_DEVICE_CHOICE_H

#include <mpi.h>

namespace LAMMPS_NS {

class LAMMPS;

/// The CUDA device this rank of `world` uses, or -1: fall back to the CPU path on every rank
/// (rank 0 has warned).  `requested` < 0 picks from the node-local rank.  `style` starts the
/// messages, e.g. "Pair gravity".  Collective over `world`.
int hsgpu_choose_device(LAMMPS *lmp, MPI_Comm world, int requested, const char *style);

/// Whether all ranks of `world` share one node's memory (MPI's shared-memory split), where
/// processes can open each other's device buffers (CUDA IPC).  Collective over `world`.
bool hsgpu_one_node(MPI_Comm world);

}    // namespace LAMMPS_NS

#endif
