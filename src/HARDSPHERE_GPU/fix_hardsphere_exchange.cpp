/* HARDSPHERE_GPU: fix hardsphere's Exchange, see fix_hardsphere_exchange.h. */
#include "fix_hardsphere_exchange.h"

#include "fix_hardsphere.h"

#include "atom.h"
#include "comm.h"
#include "error.h"

#include "lmp_compat.h"
#include "mpi_allgather.h"

#include <algorithm>
#include <array>
#include <mpi.h>

using namespace LAMMPS_NS;

namespace {
/* max_sum()'s reduction over doubles: the first value counts the maxima that follow it (the
   same on every rank); the rest are summed. */
void max_then_sum_op(void *in, void *inout, int *len, MPI_Datatype *)
{
  const double *a = static_cast<const double *>(in);
  double *b = static_cast<double *>(inout);
  const int nm = (int) a[0];
  for (int k = 1; k < *len; ++k) b[k] = k <= nm ? std::max(a[k], b[k]) : a[k] + b[k];
}
}    // namespace

LammpsExchange::LammpsExchange(FixHardSphere *fix) :
    fix(fix), p2p(MPI_COMM_NULL), max_then_sum(MPI_OP_NULL)
{
  MPI_Comm_dup(fix->world, &p2p);
  MPI_Op_create(&max_then_sum_op, 1, &max_then_sum);
}

LammpsExchange::~LammpsExchange()
{
  if (max_then_sum != MPI_OP_NULL) MPI_Op_free(&max_then_sum);
  if (p2p != MPI_COMM_NULL) MPI_Comm_free(&p2p);
}

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
  const double t0 = MPI_Wtime();
  HsgpuCompat::forward_comm(fix->comm, fix);
  fix->comm_step.seconds += MPI_Wtime() - t0;
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
  const double t0 = MPI_Wtime();
  HsgpuCompat::reverse_comm(fix->comm, fix);
  fix->comm_step.seconds += MPI_Wtime() - t0;
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
  const double t0 = MPI_Wtime();
  const bool fits = HSGPU::allgather_doubles(fix->world, send, recv, counts, displs);
  fix->comm_step.seconds += MPI_Wtime() - t0;
  if (!fits) fix->error->all(FLERR, "Fix hardsphere: too many atoms in groups that span ranks");
  mine = displs[fix->comm->me];
  // Two collectives: the counts, then the other ranks' values.
  fix->count_collective((double) (fix->comm->nprocs - 1) * sizeof(int));
  fix->count_collective((double) (recv.size() - send.size()) * sizeof(double));
}

/* Messages to chosen ranks with no count exchanged beforehand (the non-blocking consensus of
   Hoefler, Siebert and Lumsdaine, 2010): synchronous sends to the destinations; incoming
   messages are taken as they are probed; once this rank's sends are all received, it enters a
   non-blocking barrier, and when every rank has entered it, no message is left in flight.
   Costs one barrier (counted as a collective) and the messages (counted, with their bytes). */
bool LammpsExchange::to_ranks(const std::vector<int> &dest,
                              const std::vector<std::vector<double>> &send,
                              std::vector<double> &recv)
{
  // Consecutive calls use different tags, so that a message of the next call (sent by a rank
  // whose barrier has completed) is never taken by a rank still probing in this one.
  const int TAG = 7411 + (int) (++p2p_calls & 1);
  const double t0 = MPI_Wtime();
  const int nd = (int) dest.size();
  std::vector<MPI_Request> sreq(nd, MPI_REQUEST_NULL);
  for (int k = 0; k < nd; ++k) {
    if (send[k].size() > 2147483647UL)
      fix->error->one(FLERR, "Fix hardsphere: too many atoms in groups that span ranks");
    MPI_Issend(send[k].data(), (int) send[k].size(), MPI_DOUBLE, dest[k], TAG, p2p, &sreq[k]);
  }
  // The messages side by side in `inbox` (kept between calls), (source, offset, length) each.
  std::vector<std::array<long, 3>> &got = inbox_parts;
  got.clear();
  size_t used = 0;
  MPI_Request barrier = MPI_REQUEST_NULL;
  bool in_barrier = false;
  while (true) {
    int flag = 0;
    MPI_Status st;
    MPI_Iprobe(MPI_ANY_SOURCE, TAG, p2p, &flag, &st);
    if (flag) {
      int count = 0;
      MPI_Get_count(&st, MPI_DOUBLE, &count);
      if (inbox.size() < used + (size_t) count) inbox.resize(used + (size_t) count);
      got.push_back({(long) st.MPI_SOURCE, (long) used, (long) count});
      MPI_Recv(inbox.data() + used, count, MPI_DOUBLE, st.MPI_SOURCE, TAG, p2p,
               MPI_STATUS_IGNORE);
      used += (size_t) count;
      continue;
    }
    int done = 0;
    if (!in_barrier) {
      MPI_Testall(nd, sreq.data(), &done, MPI_STATUSES_IGNORE);
      if (done) {
        MPI_Ibarrier(p2p, &barrier);
        in_barrier = true;
      }
    } else {
      MPI_Test(&barrier, &done, MPI_STATUS_IGNORE);
      if (done) break;
    }
  }
  fix->comm_step.seconds += MPI_Wtime() - t0;
  // In the order of the sources (each sends one message per call).
  std::sort(got.begin(), got.end(),
            [](const std::array<long, 3> &a, const std::array<long, 3> &b) { return a[0] < b[0]; });
  recv.clear();
  double bytes = 0.0;
  for (const auto &g : got) {
    recv.insert(recv.end(), inbox.begin() + g[1], inbox.begin() + g[1] + g[2]);
    bytes += (double) g[2] * sizeof(double);
  }
  fix->count_messages((double) got.size(), bytes);
  fix->count_collective(0.0);
  return true;
}

void LammpsExchange::find_neighbours(const std::vector<HSGPU::Collide::ForeignNode> &fnodes,
                                     long stamp)
{
  if (nbr_ready && stamp == nbr_stamp) return;
  const int me = fix->comm->me;
  std::vector<int> owners;
  for (const auto &f : fnodes)
    if (f.owner >= 0 && f.owner != me) owners.push_back(f.owner);
  std::sort(owners.begin(), owners.end());
  owners.erase(std::unique(owners.begin(), owners.end()), owners.end());
  // Each owner learns that this rank holds ghosts of its atoms.
  const std::vector<std::vector<double>> hello(owners.size(), std::vector<double>(1, (double) me));
  std::vector<double> got;
  to_ranks(owners, hello, got);
  for (double r : got) owners.push_back((int) r);
  std::sort(owners.begin(), owners.end());
  owners.erase(std::unique(owners.begin(), owners.end()), owners.end());
  nbrs.swap(owners);
  nbr_stamp = stamp;
  nbr_ready = true;
}

const std::vector<int> *LammpsExchange::neighbours() const
{
  return nbr_ready ? &nbrs : nullptr;
}

/* One message to every neighbouring rank (empty where dest does not name it) and one from
   each: the receives are matched by source, so no count and no consensus is exchanged. */
void LammpsExchange::to_neighbours(const std::vector<int> &dest,
                                   const std::vector<std::vector<double>> &send,
                                   std::vector<double> &recv)
{
  const int TAG = 7421;
  const double t0 = MPI_Wtime();
  const int nn = (int) nbrs.size();
  nbr_msg.assign(nn, -1);
  for (size_t k = 0; k < dest.size(); ++k) {
    const auto it = std::lower_bound(nbrs.begin(), nbrs.end(), dest[k]);
    if (it == nbrs.end() || *it != dest[k])
      fix->error->one(FLERR, "Fix hardsphere: internal error: a message for rank {}, which is "
                             "not a neighbouring rank of rank {}", dest[k], fix->comm->me);
    if (send[k].size() > 2147483647UL)
      fix->error->one(FLERR, "Fix hardsphere: too many atoms in groups that span ranks");
    nbr_msg[it - nbrs.begin()] = (int) k;
  }
  static double nothing = 0.0;    // the buffer of an empty message
  nbr_req.assign(nn, MPI_REQUEST_NULL);
  for (int q = 0; q < nn; ++q) {
    const int k = nbr_msg[q];
    const int n = k >= 0 ? (int) send[k].size() : 0;
    MPI_Isend(n > 0 ? send[k].data() : &nothing, n, MPI_DOUBLE, nbrs[q], TAG, p2p, &nbr_req[q]);
  }
  recv.clear();
  double bytes = 0.0;
  for (int q = 0; q < nn; ++q) {
    MPI_Status st;
    MPI_Probe(nbrs[q], TAG, p2p, &st);
    int count = 0;
    MPI_Get_count(&st, MPI_DOUBLE, &count);
    const size_t at = recv.size();
    recv.resize(at + (size_t) count);
    MPI_Recv(count > 0 ? recv.data() + at : &nothing, count, MPI_DOUBLE, nbrs[q], TAG, p2p,
             MPI_STATUS_IGNORE);
    bytes += (double) count * sizeof(double);
  }
  MPI_Waitall(nn, nbr_req.data(), MPI_STATUSES_IGNORE);
  fix->comm_step.seconds += MPI_Wtime() - t0;
  fix->count_messages((double) nn, bytes);
}

void LammpsExchange::max(double *v, int n)
{
  fix->allreduce(MPI_IN_PLACE, v, n, MPI_DOUBLE, MPI_MAX);
}

void LammpsExchange::sum(long *v, int n)
{
  fix->allreduce(MPI_IN_PLACE, v, n, MPI_LONG, MPI_SUM);
}

/* One reduction: the count of maxima, the maxima, then the sums, as doubles (exact below
   2^53). */
template <class Sum> void LammpsExchange::max_then_sum_of(double *mx, int nm, Sum *sm, int ns)
{
  msbuf.assign(1 + nm + ns, 0.0);
  msbuf[0] = nm;
  for (int k = 0; k < nm; ++k) msbuf[1 + k] = mx[k];
  for (int k = 0; k < ns; ++k) msbuf[1 + nm + k] = (double) sm[k];
  fix->allreduce(MPI_IN_PLACE, msbuf.data(), 1 + nm + ns, MPI_DOUBLE, max_then_sum);
  for (int k = 0; k < nm; ++k) mx[k] = msbuf[1 + k];
  for (int k = 0; k < ns; ++k) sm[k] = (Sum) msbuf[1 + nm + k];
}

void LammpsExchange::max_sum(double *mx, int nm, long *sm, int ns)
{
  max_then_sum_of(mx, nm, sm, ns);
}

void LammpsExchange::max_sum(double *mx, int nm, double *sm, int ns)
{
  max_then_sum_of(mx, nm, sm, ns);
}
