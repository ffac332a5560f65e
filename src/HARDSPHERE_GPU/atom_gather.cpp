/* ----------------------------------------------------------------------------------
   HARDSPHERE_GPU: AtomGather, see atom_gather.h
------------------------------------------------------------------------------------- */

#include "atom_gather.h"

#include "atom.h"
#include "comm.h"
#include "domain.h"
#include "error.h"

#include <algorithm>
#include <cstring>
#include <mpi.h>

using namespace LAMMPS_NS;

static constexpr int NPACK = 5;    // tag, x, y, z, mass

AtomGather::AtomGather(LAMMPS *lmp, const char *style_name) :
    Pointers(lmp), ntotal(0), changed_masses(true), style(style_name)
{
  std::memset(&box, 0, sizeof(box));
}

void AtomGather::gather()
{
  const int nlocal = atom->nlocal;
  const int nprocs = comm->nprocs;
  double **xx = atom->x;
  const tagint *tag = atom->tag;
  const double *rmass = atom->rmass;
  const double *pmass = atom->mass;
  const int *type = atom->type;

  for (int d = 0; d < 3; ++d) {
    box.lo[d] = domain->boxlo[d];
    box.prd[d] = domain->prd[d];
  }
  box.periodic[0] = domain->xperiodic;
  box.periodic[1] = domain->yperiodic;
  box.periodic[2] = domain->zperiodic;

  sendbuf.resize((size_t) NPACK * nlocal);
  for (int i = 0; i < nlocal; ++i) {
    double *b = &sendbuf[(size_t) NPACK * i];
    b[0] = (double) tag[i];
    for (int d = 0; d < 3; ++d) {
      double c = xx[i][d];
      if (box.periodic[d]) c = HSGPU::Gravity::wrap_coordinate(c, box.lo[d], box.prd[d]);
      b[1 + d] = c;
    }
    b[4] = rmass ? rmass[i] : pmass[type[i]];
  }

  counts.resize(nprocs);
  displs.resize(nprocs);
  int nsend = NPACK * nlocal;
  MPI_Allgather(&nsend, 1, MPI_INT, counts.data(), 1, MPI_INT, world);
  long total = 0;
  for (int p = 0; p < nprocs; ++p) {
    displs[p] = (int) total;
    total += counts[p];
  }
  if (total > 2147483647L)
    error->all(FLERR, "Pair style {}: too many atoms for the all-pairs gather", style);
  recvbuf.resize(total);
  MPI_Allgatherv(sendbuf.data(), nsend, MPI_DOUBLE, recvbuf.data(), counts.data(), displs.data(),
                 MPI_DOUBLE, world);

  const long n = total / NPACK;
  const bool resized = (n != ntotal);
  ntotal = n;
  x.resize(3 * n);
  if (resized) mass.assign(n, 0.0);

  // Atom-ID order: direct placement when IDs are exactly 1..n, a sort otherwise.
  double maxtag = 0.0;
  for (long k = 0; k < n; ++k) maxtag = std::max(maxtag, recvbuf[NPACK * k]);
  const bool direct = (maxtag == (double) n);
  order.resize(n);
  if (direct) {
    for (long k = 0; k < n; ++k) order[(long) recvbuf[NPACK * k] - 1] = k;
  } else {
    for (long k = 0; k < n; ++k) order[k] = k;
    std::sort(order.begin(), order.end(),
              [this](long a, long b) { return recvbuf[NPACK * a] < recvbuf[NPACK * b]; });
    tags_sorted.resize(n);
    for (long s = 0; s < n; ++s) tags_sorted[s] = recvbuf[NPACK * order[s]];
  }

  changed_masses = resized;
  for (long s = 0; s < n; ++s) {
    const double *b = &recvbuf[NPACK * order[s]];
    x[3 * s] = b[1];
    x[3 * s + 1] = b[2];
    x[3 * s + 2] = b[3];
    if (!(b[4] > 0.0))
      error->all(FLERR, "Pair style {} requires positive masses: atom {} has mass {}", style,
                 (tagint) b[0], b[4]);
    if (mass[s] != b[4]) changed_masses = true;
    mass[s] = b[4];
  }

  index.resize(nlocal);
  for (int i = 0; i < nlocal; ++i) {
    if (direct) {
      index[i] = (long) tag[i] - 1;
    } else {
      auto it = std::lower_bound(tags_sorted.begin(), tags_sorted.end(), (double) tag[i]);
      index[i] = (long) (it - tags_sorted.begin());
    }
  }
}
