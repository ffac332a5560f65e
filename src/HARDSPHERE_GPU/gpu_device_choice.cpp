/* ----------------------------------------------------------------------------------
   HARDSPHERE_GPU: choice of a CUDA device per rank, see gpu_device_choice.h
------------------------------------------------------------------------------------- */

#include "gpu_device_choice.h"

#include "error.h"
#include "lammps.h"

#include "gpu/device_info.cuh"

using namespace LAMMPS_NS;

int LAMMPS_NS::hsgpu_choose_device(LAMMPS *lmp, MPI_Comm world, int requested, const char *style)
{
  int me = 0;
  MPI_Comm_rank(world, &me);
  // Every rank or none: a mix of GPU and CPU ranks would be slow and, for some styles, not
  // give the same bits on every rank.
  const int ndev = HSGPU::GPU::device_count();
  int ok = (ndev > 0) ? 1 : 0, all_ok = 0;
  MPI_Allreduce(&ok, &all_ok, 1, MPI_INT, MPI_MIN, world);
  if (!all_ok) {
    if (me == 0)
      lmp->error->warning(FLERR, "{}: gpu yes, but {}; using the CPU path", style,
                          HSGPU::GPU::compiled_with_cuda()
                              ? "no CUDA device is usable on every rank"
                              : "the plugin was built without CUDA");
    return -1;
  }
  int device = requested;
  if (device < 0) {
    // Ranks that share a node (and its devices) spread over them in node-local rank order.
    MPI_Comm node;
    MPI_Comm_split_type(world, MPI_COMM_TYPE_SHARED, me, MPI_INFO_NULL, &node);
    int node_rank = 0;
    MPI_Comm_rank(node, &node_rank);
    MPI_Comm_free(&node);
    device = node_rank % ndev;
  }
  if (device >= ndev)
    lmp->error->one(FLERR, "{}: device {} requested but this node has {} CUDA device(s)", style,
                    device, ndev);
  return device;
}

bool LAMMPS_NS::hsgpu_one_node(MPI_Comm world)
{
  MPI_Comm node;
  MPI_Comm_split_type(world, MPI_COMM_TYPE_SHARED, 0, MPI_INFO_NULL, &node);
  int size = 0, nprocs = 0;
  MPI_Comm_size(node, &size);
  MPI_Comm_size(world, &nprocs);
  MPI_Comm_free(&node);
  int all = 0, mine = size == nprocs ? 1 : 0;
  MPI_Allreduce(&mine, &all, 1, MPI_INT, MPI_MIN, world);
  return all == 1;
}
