/* -*- c++ -*- ------------------------------------------------------------------
   HARDSPHERE_GPU: gather every rank's doubles on every rank, in rank order.

   Shared by the all-pairs gather (AtomGather) and fix hardsphere's exchange of components
   that span ranks.  displs[p] is where rank p's data starts in recv.  Returns false, with
   nothing gathered, when the total does not fit MPI's int counts; the caller names the error.
------------------------------------------------------------------------------------- */
#ifndef LMP_HSGPU_MPI_ALLGATHER_H
#define LMP_HSGPU_MPI_ALLGATHER_H

#include <mpi.h>

#include <vector>

namespace HSGPU {

/* The first half of allgather_doubles: every rank's count (counts) and start (displs) and
   the total, or -1 where it does not fit MPI's int counts. */
inline long allgather_layout(MPI_Comm comm, int nsend, std::vector<int> &counts,
                             std::vector<int> &displs)
{
  int nprocs = 1;
  MPI_Comm_size(comm, &nprocs);
  counts.resize(nprocs);
  displs.resize(nprocs);
  MPI_Allgather(&nsend, 1, MPI_INT, counts.data(), 1, MPI_INT, comm);
  long total = 0;
  for (int p = 0; p < nprocs; ++p) {
    displs[p] = (int) total;
    total += counts[p];
  }
  return total > 2147483647L ? -1 : total;
}

inline bool allgather_doubles(MPI_Comm comm, const std::vector<double> &send,
                              std::vector<double> &recv, std::vector<int> &counts,
                              std::vector<int> &displs)
{
  const int nsend = (int) send.size();
  const long total = allgather_layout(comm, nsend, counts, displs);
  if (total < 0) return false;
  recv.resize(total);
  MPI_Allgatherv(send.data(), nsend, MPI_DOUBLE, recv.data(), counts.data(), displs.data(),
                 MPI_DOUBLE, comm);
  return true;
}

}    // namespace HSGPU

#endif
