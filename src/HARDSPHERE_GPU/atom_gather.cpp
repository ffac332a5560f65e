/* ----------------------------------------------------------------------------------
   HARDSPHERE_GPU: AtomGather, see atom_gather.h
------------------------------------------------------------------------------------- */

#include "atom_gather.h"

#include "atom.h"
#include "comm.h"
#include "domain.h"
#include "error.h"
#include "mpi_allgather.h"

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
  prepare();
  exchange();
}

void AtomGather::prepare()
{
  const int nlocal = atom->nlocal;
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

  // Masses (and IDs' order) rarely change: send them only when some rank's owned set did.
  int local_changed = (nlocal != (int) last_tag.size() || id_order != last_id_order) ? 1 : 0;
  last_id_order = id_order;
  for (int i = 0; !local_changed && i < nlocal; ++i) {
    const double mi = rmass ? rmass[i] : pmass[type[i]];
    local_changed = (tag[i] != last_tag[i] || mi != last_mass[i]) ? 1 : 0;
  }
  any_changed = 0;
  MPI_Allreduce(&local_changed, &any_changed, 1, MPI_INT, MPI_MAX, world);
  if (ntotal == 0) any_changed = 1;
  // Unchanged: the same atoms in the same places on every rank, so the receive layout and
  // the atom-ID order of the last full gather still hold and positions travel alone.
  npack = any_changed ? NPACK : 3;
  const int off = any_changed ? 1 : 0;
  if (local_changed) {
    last_tag.resize(nlocal);
    last_mass.resize(nlocal);
    for (int i = 0; i < nlocal; ++i) {
      last_tag[i] = tag[i];
      last_mass[i] = rmass ? rmass[i] : pmass[type[i]];
    }
  }

  sendbuf.resize((size_t) npack * nlocal);
  for (int i = 0; i < nlocal; ++i) {
    double *b = &sendbuf[(size_t) npack * i];
    if (any_changed) b[0] = (double) tag[i];
    for (int d = 0; d < 3; ++d) {
      double c = xx[i][d];
      if (box.periodic[d]) c = HSGPU::Gravity::wrap_coordinate(c, box.lo[d], box.prd[d]);
      b[off + d] = c;
    }
    if (any_changed) b[4] = rmass ? rmass[i] : pmass[type[i]];
  }

  const long total = HSGPU::allgather_layout(world, npack * nlocal, counts, displs);
  if (total < 0) error->all(FLERR, "Pair style {}: too many atoms for the all-pairs gather", style);
  ntotal = total / npack;
  own_start = displs[comm->me] / npack;
  if (!any_changed) {
    own_xp = sendbuf.data();
    own_mp = (mass.size() == (size_t) ntotal) ? mass.data() + own_start : nullptr;
  } else {
    own_xbuf.resize(3 * (size_t) nlocal);
    own_mbuf.resize(nlocal);
    for (int i = 0; i < nlocal; ++i) {
      for (int d = 0; d < 3; ++d) own_xbuf[3 * i + d] = sendbuf[(size_t) npack * i + 1 + d];
      own_mbuf[i] = sendbuf[(size_t) npack * i + 4];
    }
    own_xp = own_xbuf.data();
    own_mp = own_mbuf.data();
  }
  if (!id_order) {
    index.resize(nlocal);
    for (int i = 0; i < nlocal; ++i) index[i] = own_start + i;
  }
}

void AtomGather::exchange()
{
  const int nlocal = atom->nlocal;
  const tagint *tag = atom->tag;
  // Rank order, positions only: receive straight into x.
  std::vector<double> &recv = (!id_order && !any_changed) ? x : recvbuf;
  recv.resize((size_t) npack * ntotal);
  MPI_Allgatherv(sendbuf.data(), npack * nlocal, MPI_DOUBLE, recv.data(), counts.data(),
                 displs.data(), MPI_DOUBLE, world);

  const long n = ntotal;
  if (!any_changed) {
    changed_masses = false;
    if (!id_order) return;    // x is filled; index[] is unchanged
    x.resize(3 * n);
    for (long s = 0; s < n; ++s) {
      const double *b = &recvbuf[3 * order[s]];
      x[3 * s] = b[0];
      x[3 * s + 1] = b[1];
      x[3 * s + 2] = b[2];
    }
    return;    // index[] is unchanged too
  }
  x.resize(3 * n);
  mass.resize(n);

  order.resize(n);
  if (!id_order) {
    for (long k = 0; k < n; ++k) order[k] = k;
  } else {
    // Atom-ID order: direct placement when IDs are exactly 1..n, a sort otherwise.
    double maxtag = 0.0;
    for (long k = 0; k < n; ++k) maxtag = std::max(maxtag, recvbuf[npack * k]);
    direct = (maxtag == (double) n);
    if (direct) {
      for (long k = 0; k < n; ++k) order[(long) recvbuf[npack * k] - 1] = k;
    } else {
      for (long k = 0; k < n; ++k) order[k] = k;
      std::sort(order.begin(), order.end(),
                [this](long a, long b) { return recvbuf[npack * a] < recvbuf[npack * b]; });
      tags_sorted.resize(n);
      for (long s = 0; s < n; ++s) tags_sorted[s] = recvbuf[npack * order[s]];
    }
  }

  changed_masses = true;
  for (long s = 0; s < n; ++s) {
    const double *b = &recvbuf[npack * order[s]];
    x[3 * s] = b[1];
    x[3 * s + 1] = b[2];
    x[3 * s + 2] = b[3];
    if (!(b[4] > 0.0))
      error->all(FLERR, "Pair style {} requires positive masses: atom {} has mass {}", style,
                 (tagint) b[0], b[4]);
    mass[s] = b[4];
  }

  if (!id_order) return;    // index[] was set by prepare()
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
