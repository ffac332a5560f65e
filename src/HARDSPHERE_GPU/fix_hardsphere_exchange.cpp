/* HARDSPHERE_GPU: fix hardsphere's Exchange, see fix_hardsphere_exchange.h. */
#include "fix_hardsphere_exchange.h"

#include "fix_hardsphere.h"

#include "atom.h"
#include "comm.h"
#include "error.h"

#include "lmp_compat.h"
#include "mpi_allgather.h"

#include <algorithm>
#include <mpi.h>

using namespace LAMMPS_NS;

int LammpsExchange::nranks() const
{
  return fix->comm->nprocs;
}

int LammpsExchange::rank() const
{
  return fix->comm->me;
}

/* Local body b is the owned atom bodies[b].owner; a foreign node takes the values of one of
   its ghosts, which forward communication has given its owner's values.  `local` holds the
   values of the first local.size() / nval bodies: the driver appends the foreign nodes' copies
   to the bodies while it runs. */
void LammpsExchange::to_foreign(const std::vector<double> &local, int nval,
                                std::vector<double> &foreign)
{
  Atom *atom = fix->atom;
  if (fix->xfwd.size() < (size_t) nval * atom->nmax) fix->xfwd.resize((size_t) nval * atom->nmax);
  const size_t nb = local.size() / (size_t) nval;
  for (size_t b = 0; b < nb; ++b) {
    const size_t i = (size_t) fix->bodies[b].owner;
    for (int q = 0; q < nval; ++q) fix->xfwd[nval * i + q] = local[nval * b + q];
  }
  fix->fwd_nval = nval;
  HsgpuCompat::forward_comm(fix->comm, fix);
  fix->fwd_nval = 0;
  fix->count_halo(nval);
  const size_t nf = fix->foreign_ghost.size();
  foreign.resize(nval * nf);
  for (size_t f = 0; f < nf; ++f) {
    const size_t j = (size_t) fix->foreign_ghost[f];
    for (int q = 0; q < nval; ++q) foreign[nval * f + q] = fix->xfwd[nval * j + q];
  }
}

/* A foreign node's values go into one of its ghosts (the others stay zero), and LAMMPS's
   reverse communication takes them to the owner: unpack_reverse_comm() keeps a value whose
   flag is set (several senders send the same values), rather than summing. */
void LammpsExchange::to_owner(const std::vector<double> &foreign, int nval, int nlocal,
                              std::vector<double> &local)
{
  Atom *atom = fix->atom;
  const size_t nall = (size_t) atom->nlocal + atom->nghost;
  if (fix->xfwd.size() < (size_t) nval * atom->nmax) fix->xfwd.resize((size_t) nval * atom->nmax);
  // Only the flags need clearing: unpack_reverse_comm() reads a value only under its flag.
  for (size_t i = 0; i < nall; ++i) fix->xfwd[nval * i] = 0.0;
  const size_t nf = fix->foreign_ghost.size();
  for (size_t f = 0; f < nf; ++f) {
    if (foreign[nval * f] == 0.0) continue;
    const size_t j = (size_t) fix->foreign_ghost[f];
    for (int q = 0; q < nval; ++q) fix->xfwd[nval * j + q] = foreign[nval * f + q];
  }
  fix->fwd_nval = nval;
  HsgpuCompat::reverse_comm(fix->comm, fix);
  fix->fwd_nval = 0;
  fix->count_halo(nval);
  local.resize((size_t) nval * nlocal);
  for (int b = 0; b < nlocal; ++b) {
    const size_t i = (size_t) fix->bodies[b].owner;
    for (int q = 0; q < nval; ++q) local[(size_t) nval * b + q] = fix->xfwd[nval * i + q];
  }
}

void LammpsExchange::allgather(const std::vector<double> &send, std::vector<double> &recv,
                               long &mine)
{
  std::vector<int> counts, displs;
  if (!HSGPU::allgather_doubles(fix->world, send, recv, counts, displs))
    fix->error->all(FLERR, "Fix hardsphere: too many atoms in groups that span ranks");
  mine = displs[fix->comm->me];
  // Two collectives: the counts, then the other ranks' values.
  fix->count_collective((double) (fix->comm->nprocs - 1) * sizeof(int));
  fix->count_collective((double) (recv.size() - send.size()) * sizeof(double));
}

void LammpsExchange::max(double *v, int n)
{
  fix->allreduce(MPI_IN_PLACE, v, n, MPI_DOUBLE, MPI_MAX);
}

void LammpsExchange::sum(long *v, int n)
{
  fix->allreduce(MPI_IN_PLACE, v, n, MPI_LONG, MPI_SUM);
}
