/* ----------------------------------------------------------------------------------
   HARDSPHERE_GPU: fix hardsphere, the device step of several ranks (see fix_hardsphere.h).

   With `gpu yes` on several MPI ranks and `gpu/gather yes` (the default), each step every rank
   sends its atoms of the group (LAMMPS's arrays with group all, else its group's atoms packed)
   to rank 0: positions, velocities, forces (and angular velocities of rough spheres) every
   step, times of last collision, radii, masses, types and IDs only where some rank's atoms
   moved in its arrays since the last such step.  Where all ranks share one node they copy
   them straight into rank 0's device (CUDA IPC, share_inputs()), else MPI_Gatherv takes them
   to rank 0's host.  Rank 0's device runs the whole step over all of them as on one rank
   (ResidentStep::run_atoms), and the atoms that had events go back to their ranks (position,
   velocity, spin, and every atom's time of last collision): each rank reads its own from rank
   0's device on one node (results_shared()), else they come by MPI_Scatterv and every rank
   shifts its other atoms' times of last collision to the step end itself (results_mpi()).
   Event times depend only on the two atoms' states, so the result is one rank's bit for bit,
   whatever order the atoms arrive in.  Where the device hands the step back, every rank
   resolves it the host way from the same start (its arrays are untouched until the results
   come).  With gpu/keep the first half (gathered_send()) may run at post_force() of the step
   before and rank 0's device step on a thread of its own until this step takes it
   (fix_hardsphere_ahead.cpp).
------------------------------------------------------------------------------------- */

#include "fix_hardsphere.h"

#include "atom.h"
#include "comm.h"
#include "error.h"
#include "force.h"
#include "neighbor.h"
#include "update.h"
#include "utils.h"

#include "gpu/peer_inputs.h"

#include <algorithm>
#include <climits>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <stdexcept>
#include <mpi.h>

using namespace LAMMPS_NS;
using HSGPU::Collide::Tally;

/* Each rank's x, v and f (nlocal atoms of src) into rank 0's device buffers for the step of
   all n atoms, and with `statics` their tlast, radius, rmass, type and id too, where every
   rank can open them (ResidentStep::share_inputs(), GPU::PeerInputs: CUDA IPC, ranks of one
   node).  Returns whether they are there; false on every rank where any rank could not (the
   atoms then go through MPI, and so for the rest of the run, with a note in the log).
   HSGPU_GATHER_MPI in the environment: never tried. */
bool FixHardSphere::share_inputs(long n, int nlocal, const Source &src, bool statics,
                                 bool no_forces, bool xv, bool ids_only)
{
  if (!gath.ipc) return false;
  const int me = comm->me;
  const double t_h = MPI_Wtime();
  // Rank 0's handles to everyone (a fixed size: three CUDA IPC handles, or none).
  int ok = 1;
  std::vector<char> &h = gath.handles;
  int hbytes = 0;
  if (me == 0) {
    try {
      ok = resident->share_inputs(n, (int) sizeof(tagint), friction_on, h) ? 1 : 0;
    } catch (std::exception &) {
      ok = 0;
    }
    hbytes = ok ? (int) h.size() : 0;
    gath.t_part[5] += MPI_Wtime() - t_h;
  }
  MPI_Bcast(&hbytes, 1, MPI_INT, 0, world);
  if (hbytes > 0) {
    h.resize(hbytes);
    MPI_Bcast(h.data(), hbytes, MPI_CHAR, 0, world);
  }
  count_collective(sizeof(int) + hbytes);
  ok = hbytes > 0;
  // Each rank's own atoms, at its offset (the ranks' atoms in rank order).
  const long first = gath.displ[me];
  const double t0 = MPI_Wtime();
  gath.t_part[0] += t0 - t_h;
  gath.t_handles_most = std::max(gath.t_handles_most, t0 - t_h);
  if (ok) {
    try {
      const int idb = (int) sizeof(tagint);
      if (me == 0) {
        resident->put_inputs(first, nlocal, xv ? src.x : nullptr, xv ? src.v : nullptr,
                             no_forces ? nullptr : src.f, src.room);
        if (friction_on) resident->put_spin(first, nlocal, src.omega);
        if (ids_only)
          resident->put_ids(first, nlocal, src.id, idb);
        else if (statics)
          resident->put_statics(first, nlocal, src.tlast, src.radius, src.rmass, src.type, src.id,
                                idb);
      } else {
        if (!peer) throw std::runtime_error("no device for the gathered step's inputs");
        peer->open(h);
        peer->put(first, nlocal, xv ? src.x : nullptr, xv ? src.v : nullptr,
                  no_forces ? nullptr : src.f, src.room);
        if (friction_on) peer->put_spin(first, nlocal, src.omega);
        if (ids_only)
          peer->put_ids(first, nlocal, src.id, idb);
        else if (statics)
          peer->put_statics(first, nlocal, src.tlast, src.radius, src.rmass, src.type, src.id,
                            idb);
      }
    } catch (std::exception &e) {
      ok = 0;
      gath.why = e.what();
    }
  }
  // Also the barrier after which rank 0's device holds every rank's atoms.
  const double t1 = MPI_Wtime();
  int all = 0;
  MPI_Allreduce(&ok, &all, 1, MPI_INT, MPI_MIN, world);
  count_collective(sizeof(int));
  gath.t_put += t1 - t0;
  gath.t_wait += MPI_Wtime() - t1;
  if (all) return true;
  gath.ipc = false;
  const int first_bad = first_failed(ok);
  if (first_bad == me && me != 0)
    utils::logmesg(lmp,
                   "Fix hardsphere: rank {} cannot copy its atoms to rank 0's device ({}); "
                   "they go through rank 0's host (MPI) for the rest of the run\n",
                   me, gath.why);
  if (me == 0 && first_bad == 0)
    utils::logmesg(lmp,
                   "Fix hardsphere: rank 0's device does not share its buffers{}{}; the "
                   "atoms go through rank 0's host (MPI) for the rest of the run\n",
                   gath.why.empty() ? "" : ": ", gath.why);
  return false;
}

/* The step on rank 0's device over every rank's atoms.  Returns 2 where the device did it (the
   atoms' arrays hold the results), else 0 with nothing changed. */
int FixHardSphere::step_gathered(Tally &mine, Tally &all)
{
  // gpu/keep: the check of the integrator's rounding set up at the last post_force(), and the
  // step run ahead from there (fix_hardsphere_ahead.cpp).
  if (mcheck.pending) motion_check_gathered();
  // Rank 0's device holds this step's end state again only where it does the step
  // (gathered_finish(); a step on the host, with per-atom virial, moves the atoms without it).
  gath.state_kept = false;
  if (next.pending) {
    const int taken = take_ahead_gathered(mine, all);
    if (taken >= 0) return taken;
  }
  // Per rank: whether its arrays hold what the last gathered step left there (with another
  // group never: its atoms are packed anew every step).
  const bool unchanged = igroup == 0 && resident_same && !sizes_vary;
  resident_same = false;
  if (!resident_usable()) return 0;
  GatheredSend s;
  gathered_send(s, unchanged);
  mine = Tally();
  GatheredResult r = {};
  if (comm->me == 0) {
    HSGPU::Collide::ResidentReport report;
    const HSGPU::Collide::ResidentAtoms a = gathered_atoms(s);
    try {
      resident->run_atoms(a, resident_box(), step_params(), wsettings, mine, report);
    } catch (std::exception &e) {
      error->one(FLERR,
                 "Fix hardsphere: CUDA device {} (the step of all {} atoms of the ranks, "
                 "gpu/gather yes): {}; with gpu/gather no each rank's device takes only the "
                 "groups of its own atoms",
                 backend_device, s.n, e.what());
    }
    r = gathered_result(report, mine);
  }
  return gathered_finish(s, r, all);
}

/* The first half of the gathered step: every rank's atoms (x, v, f, and where some rank's atoms
   moved in its arrays since the last such step also tlast, radius, rmass, type, id) to rank 0's
   device, or its host.  unchanged: this rank's arrays hold what the last gathered step left. */
void FixHardSphere::gathered_send(GatheredSend &s, bool unchanged, bool keep_xv)
{
  const int np = comm->nprocs, me = comm->me;
  s = GatheredSend();
  s.whole = igroup == 0;
  // The atoms this rank sends: LAMMPS's arrays with group all, else its group's atoms packed
  // (gath.lidx: their indices here).
  const Source src = gathered_source();
  const int nlocal = src.n;
  s.nlocal = nlocal;
  int head[2] = {nlocal, unchanged ? 1 : 0};
  gath.head.resize(2 * (size_t) np);
  MPI_Allgather(head, 2, MPI_INT, gath.head.data(), 2, MPI_INT, world);
  count_collective(2.0 * sizeof(int) * (np - 1));
  bool same = true;
  long n = 0;
  for (int p = 0; p < np; ++p) {
    same = same && gath.head[2 * p + 1];
    n += gath.head[2 * p];
  }
  if (3 * n + 3 > INT_MAX)
    error->all(FLERR,
               "Fix hardsphere: {} atoms are too many to gather on one rank for the device step "
               "(at most {}); use gpu/gather no",
               n, INT_MAX / 3 - 1);
  const double t_start = MPI_Wtime();
  // Rank 0's arrays grow (every rank keeps their size, so all send everything that step); the
  // device step lets go of the old arrays before they move.
  if (n > gath.all.room) {
    same = false;
    if (me == 0) resident->forget_host_arrays();
    gath.all.grow(n, me == 0);
  }
  gath.displ.resize(np);
  gath.vcount.resize(np);
  gath.vdispl.resize(np);
  for (int p = 0, off = 0; p < np; ++p) {
    gath.displ[p] = off;
    off += gath.head[2 * p];
  }
  // One array of `per` values per atom, from every rank to rank 0.
  auto gather = [&](void *mine_, int per, MPI_Datatype type, void *all_) {
    if (me == 0)
      for (int p = 0; p < np; ++p) {
        gath.vcount[p] = per * gath.head[2 * p];
        gath.vdispl[p] = per * gath.displ[p];
      }
    MPI_Gatherv(mine_, per * nlocal, type, all_, gath.vcount.data(), gath.vdispl.data(), type, 0,
                world);
    int size = 0;
    MPI_Type_size(type, &size);
    if (me == 0) s.moved += (double) size * per * (n - nlocal);
  };
  // No force styles (the same on every rank): f stays where it is after the run's first step
  // found it zero, as on one rank.
  const bool no_forces = forces_none && forces_checked;
  // x, v and f straight into rank 0's device where every rank can reach it (one node, CUDA
  // IPC): each rank copies its own atoms there, all at once; else through rank 0's host.
  // keep_xv (a step run ahead): where no rank's atoms moved in its arrays and rank 0's device
  // kept the last step's end state (results_whole()), x and v stay there; the device wraps
  // them into the box where LAMMPS reneighbored since (gathered_motion()).
  // Where atoms moved between ranks or in their arrays but none arrived or left, the ranks
  // send their atoms' IDs instead, and the device finds each atom's kept state by its ID
  // (ResidentAtoms::reordered; where an ID is new to it, the step is not taken).
  // (gath.state_kept: the last step was done on the device with group all and smooth spheres,
  // state_back().)
  const bool reordered = keep_xv && !same && gath.state_kept && n == gath.n_kept && !sizes_vary;
  const bool xv_kept = keep_xv && (same || reordered) && gath.state_kept;
  const bool shared = share_inputs(n, nlocal, src, !same, no_forces, !xv_kept, reordered);
  s.xv_kept = xv_kept && shared;
  s.reordered = reordered && shared;
  if (!shared) {
    gather(src.x, 3, MPI_DOUBLE, gath.all.x.data());
    gather(src.v, 3, MPI_DOUBLE, gath.all.v.data());
    if (!no_forces) gather(src.f, 3, MPI_DOUBLE, gath.all.f.data());
    if (friction_on) gather(src.omega, 3, MPI_DOUBLE, gath.all.omega.data());
  }
  // The rest only where some rank's atoms moved in its arrays (the device keeps its copies),
  // and with the copies above already in place.
  if (!same && !shared) {
    gather(src.tlast, 1, MPI_DOUBLE, gath.all.tlast.data());
    gather(src.radius, 1, MPI_DOUBLE, gath.all.radius.data());
    gather(src.rmass, 1, MPI_DOUBLE, gath.all.rmass.data());
    gather(src.type, 1, MPI_INT, gath.all.type.data());
    gather(src.id, 1, MPI_LMP_TAGINT, gath.all.id.data());
  }
  s.n = n;
  s.same = same;
  s.shared = shared;
  s.no_forces = no_forces;
  s.t_gather = MPI_Wtime() - t_start;
}

/* Rank 0: the gathered step's atoms, as gathered_send() left them. */
HSGPU::Collide::ResidentAtoms FixHardSphere::gathered_atoms(const GatheredSend &s)
{
  HSGPU::Collide::ResidentAtoms a = resident_atoms(gath.all.view((int) s.n, friction_on), s.same);
  a.inputs_shared = s.shared;
  a.zero_forces = s.no_forces;
  a.statics_shared = s.shared && !s.same;
  a.reordered = s.reordered;
  a.spin_shared = s.shared && friction_on;
  a.results = &gath.results;    // the atoms with events listed, to go back to their ranks
  a.result_spin = &gath.rspin;
  // Group all, one node, smooth spheres: every rank reads its atoms' end state whole from
  // rank 0's device (results_whole()), which keeps it there.
  a.motion.keep = state_back(s);
  return a;
}

/* Rank 0: what it sends every rank after its step. */
FixHardSphere::GatheredResult FixHardSphere::gathered_result(
    const HSGPU::Collide::ResidentReport &report, const Tally &mine) const
{
  return {(double) report.outcome,
          (double) mine.pair,
          (double) mine.wall,
          (double) mine.rest,
          (double) mine.events,
          (double) mine.capped,
          mine.ke_lost,
          report.vmax2,
          report.amax,
          report.rmax,
          report.vend2,
          (double) report.candidates,
          (double) report.redone,
          report.t_search,
          report.t_resolve,
          report.t_upload,
          report.t_download,
          (double) report.bytes_up,
          (double) report.stats.largest_group,
          (double) report.stats.groups,
          (double) report.stats.windows,
          (double) report.stats.repairs};
}

/* The second half: rank 0's result r to every rank, the results back into the atoms' arrays,
   the counters.  Returns 2 where the device did the step, else 0 with nothing changed. */
int FixHardSphere::gathered_finish(const GatheredSend &s, GatheredResult r, Tally &all)
{
  MPI_Bcast(&r, (int) (sizeof(r) / sizeof(double)), MPI_DOUBLE, 0, world);
  count_collective(sizeof(r));
  double moved = s.moved;    // bytes this rank received
  HSGPU::Collide::ResidentReport report;
  report.outcome = (HSGPU::Collide::ResidentOutcome)(int) r.outcome;
  report.vend2 = r.vend2;
  report.candidates = (long) r.candidates;
  report.redone = (int) r.redone;
  report.t_search = r.t_search + s.t_gather;    // the gather counts as the step's upload
  report.t_resolve = r.t_resolve;
  report.t_upload = r.t_upload;
  report.t_download = r.t_download;
  report.bytes_up = (long) r.bytes_up;
  report.stats.largest_group = (long) r.largest_group;
  report.stats.groups = (long) r.groups;
  report.stats.windows = (long) r.windows;
  report.stats.repairs = (long) r.repairs;
  if (forces_none && !forces_checked) forces_seen(r.amax);
  // The budget's checks on every rank, and bound_floor for the host should the device decline.
  check_budget(r.vmax2, r.amax, r.rmax);
  if (report.outcome == HSGPU::Collide::ResidentOutcome::done) {
    // The results back to their ranks: per atom with events its index there, position,
    // velocity, time of last collision (and spin); every other atom's time of last collision
    // is shifted to the step end here, as the device did (max(t - dt, never)).
    const double t0 = MPI_Wtime();
    if (!(state_back(s) && results_whole(s.nlocal)) &&
        !(s.shared && gath.ipc_results && results_shared(s.nlocal, s.whole, moved)))
      results_mpi(s.nlocal, s.whole, moved);
    report.t_resolve += MPI_Wtime() - t0;
    run_sum.t_gather += MPI_Wtime() - t0;
    run_sum.t_back += MPI_Wtime() - t0;
  }
  run_sum.t_gather += s.t_gather;
  // The gathers and scatters as one collective, with the bytes this rank received.
  count_collective(moved);
  count_resident(report);
  if (report.outcome != HSGPU::Collide::ResidentOutcome::done) return 0;
  // Counts for every rank; the virial and energy of the step stay with rank 0's `mine` (LAMMPS
  // sums the fix's virial over the ranks).
  all = Tally();
  all.pair = (long) r.pair;
  all.wall = (long) r.wall;
  all.rest = (long) r.rest;
  all.events = (long) r.events;
  all.capped = (int) r.capped;
  all.ke_lost = r.ke_lost;
  resident_same = s.whole;
  gath.state_kept = state_back(s);
  gath.n_kept = s.n;
  gath.builds = neighbor->ncalls;
  vend2 = report.vend2;
  return 2;
}

void FixHardSphere::AtomArrays::grow(long n, bool allocate)
{
  if (n <= room) return;
  room = n + n / 8 + 64;
  if (!allocate) return;
  for (std::vector<double> *w : {&x, &v, &f, &omega}) w->resize(3 * (size_t) room);
  for (std::vector<double> *w : {&tlast, &radius, &rmass}) w->resize(room);
  type.resize(room);
  id.resize(room);
}

FixHardSphere::Source FixHardSphere::AtomArrays::view(int n, bool spin)
{
  Source s;
  s.n = n;
  s.room = (long) x.size() / 3;
  s.x = x.data();
  s.v = v.data();
  s.f = f.data();
  s.omega = spin ? omega.data() : nullptr;
  s.tlast = tlast.data();
  s.radius = radius.data();
  s.rmass = rmass.data();
  s.type = type.data();
  s.id = id.data();
  return s;
}

/* The results of rank 0's step back to their ranks through MPI: per atom with events its index
   there, position, velocity, time of last collision (and spin); every other atom's time of
   last collision is shifted to the step end here, as the device did (max(t - dt, never)). */
void FixHardSphere::results_mpi(int nlocal, bool whole, double &moved)
{
  const int np = comm->nprocs, me = comm->me;
  const int per = friction_on ? 11 : 8;
  if (me == 0) {
    std::fill(gath.vcount.begin(), gath.vcount.end(), 0);
    gath.send.resize((size_t) per * gath.results.size());
    double *out = gath.send.data();
    int p = 0;
    for (size_t k = 0; k < gath.results.size(); ++k, out += per) {
      const HSGPU::Collide::ResidentResult &res = gath.results[k];
      while (p + 1 < np && res.index >= gath.displ[p + 1]) ++p;    // increasing indices
      gath.vcount[p] += per;
      out[0] = (double) (res.index - gath.displ[p]);
      for (int d = 0; d < 3; ++d) {
        out[1 + d] = res.x[d];
        out[4 + d] = res.v[d];
      }
      out[7] = gath.all.tlast[res.index];
      if (friction_on)
        for (int d = 0; d < 3; ++d) out[8 + d] = gath.rspin[3 * k + d];
    }
    for (int q = 0, off = 0; q < np; ++q) {
      gath.vdispl[q] = off;
      off += gath.vcount[q];
    }
  }
  int nrecv = 0;
  MPI_Scatter(gath.vcount.data(), 1, MPI_INT, &nrecv, 1, MPI_INT, 0, world);
  gath.recv.resize(nrecv);
  MPI_Scatterv(gath.send.data(), gath.vcount.data(), gath.vdispl.data(), MPI_DOUBLE,
               gath.recv.data(), nrecv, MPI_DOUBLE, 0, world);
  if (me != 0) moved += sizeof(int) + (double) sizeof(double) * nrecv;
  const double dt = update->dt;
  // Into LAMMPS's arrays (the k-th atom sent is atom k, or gath.lidx[k] with a group).
  double **x = atom->x, **v = atom->v;
  auto local = [&](int k) { return whole ? k : gath.lidx[k]; };
  for (int k = 0; k < nlocal; ++k) {
    const int i = local(k);
    tlast[i] = std::max(tlast[i] - dt, NEVER_COLLIDED);
  }
  for (const double *in = gath.recv.data(); in < gath.recv.data() + nrecv; in += per) {
    const int i = local((int) in[0]);
    for (int d = 0; d < 3; ++d) {
      x[i][d] = in[1 + d];
      v[i][d] = in[4 + d];
    }
    tlast[i] = in[7];
    if (friction_on)
      for (int d = 0; d < 3; ++d) atom->omega[i][d] = in[8 + d];
  }
}

/* The same, each rank reading its atoms' results and times of last collision straight from
   rank 0's device (CUDA IPC, where share_inputs() copied the atoms there this step): rank 0
   sends each rank where its results start and how many there are.  Returns false on every
   rank, with nothing changed, where some rank could not; the results then go through MPI
   (results_mpi()), and so for the rest of the run. */
bool FixHardSphere::results_shared(int nlocal, bool whole, double &moved)
{
  using HSGPU::Collide::ResidentResult;
  const int np = comm->nprocs, me = comm->me;
  std::vector<char> &h = gath.rhandles;
  int hbytes = 0;
  const double t_h = MPI_Wtime();
  if (me == 0) {
    // Rank p's results: those with indices in [displ[p], displ[p + 1]) (increasing indices).
    gath.span.assign(2 * np, 0);
    const std::vector<ResidentResult> &res = gath.results;
    auto start = [&](int p) {
      if (p >= np) return (int) res.size();
      return (int) (std::lower_bound(res.begin(), res.end(), gath.displ[p],
                                     [](const ResidentResult &r, int i) { return r.index < i; }) -
                    res.begin());
    };
    for (int p = 0; p < np; ++p) {
      gath.span[2 * p] = start(p);
      gath.span[2 * p + 1] = start(p + 1) - gath.span[2 * p];
    }
    bool ok = false;
    try {
      ok = resident->share_results(friction_on, h);
    } catch (std::exception &) {
      ok = false;
    }
    hbytes = ok ? (int) h.size() : 0;
  }
  MPI_Bcast(&hbytes, 1, MPI_INT, 0, world);
  if (hbytes == 0) {
    gath.ipc_results = false;
    return false;
  }
  h.resize(hbytes);
  MPI_Bcast(h.data(), hbytes, MPI_CHAR, 0, world);
  int mine[2] = {0, 0};
  MPI_Scatter(gath.span.data(), 2, MPI_INT, mine, 2, MPI_INT, 0, world);
  moved += sizeof(int) + hbytes + sizeof(mine);
  const double t_r = MPI_Wtime();
  gath.t_part[1] += t_r - t_h;
  int ok = 1;
  if (me != 0) {
    try {
      if (!peer) throw std::runtime_error("no device to read the results with");
      peer->open_results(h);
      gath.rres.resize(mine[1]);
      peer->get_result(0, sizeof(ResidentResult) * (size_t) mine[0],
                       sizeof(ResidentResult) * (size_t) mine[1], gath.rres.data());
      gath.rtlast.resize(nlocal);
      peer->get_result(1, sizeof(double) * (size_t) gath.displ[me], sizeof(double) * nlocal,
                       gath.rtlast.data());
      if (friction_on) {
        gath.rrspin.resize(3 * (size_t) mine[1]);
        peer->get_result(2, 3 * sizeof(double) * (size_t) mine[0],
                         3 * sizeof(double) * (size_t) mine[1], gath.rrspin.data());
      }
    } catch (std::exception &e) {
      ok = 0;
      gath.why = e.what();
    }
  }
  gath.t_part[2] += MPI_Wtime() - t_r;
  const bool all = results_read(ok);
  const double t_w = MPI_Wtime();
  if (!all) {
    gath.ipc_results = false;
    if (first_failed(ok) == me)
      utils::logmesg(lmp,
                     "Fix hardsphere: rank {} cannot read its results from rank 0's device ({}); "
                     "they come through MPI for the rest of the run\n",
                     me, gath.why);
    return false;
  }
  const ResidentResult *res = (me == 0) ? gath.results.data() + mine[0] : gath.rres.data();
  const double *tl = (me == 0) ? gath.all.tlast.data() + gath.displ[0] : gath.rtlast.data();
  const double *w = !friction_on ? nullptr
                    : (me == 0)  ? gath.rspin.data() + 3 * (size_t) mine[0]
                                 : gath.rrspin.data();
  double **x = atom->x, **v = atom->v;
  auto local = [&](int k) { return whole ? k : gath.lidx[k]; };
  for (int k = 0; k < nlocal; ++k) tlast[local(k)] = tl[k];
  for (int k = 0; k < mine[1]; ++k) {
    const int i = local(res[k].index - gath.displ[me]);
    for (int d = 0; d < 3; ++d) {
      x[i][d] = res[k].x[d];
      v[i][d] = res[k].v[d];
    }
    if (w)
      for (int d = 0; d < 3; ++d) atom->omega[i][d] = w[3 * k + d];
  }
  gath.t_part[4] += MPI_Wtime() - t_w;
  return true;
}

/* Whether every rank read its results (ok on this one): one reduction, also the point after
   which rank 0's device may move on; its time counted as the reduction after the reads. */
bool FixHardSphere::results_read(int ok)
{
  const double t0 = MPI_Wtime();
  int all = 0;
  MPI_Allreduce(&ok, &all, 1, MPI_INT, MPI_MIN, world);
  count_collective(sizeof(int));
  gath.t_part[3] += MPI_Wtime() - t0;
  return all != 0;
}

/* Whether the atoms' end state goes back whole (results_whole()): group all, shared buffers
   (one node, CUDA IPC), smooth spheres, and no rank failed at it this run. */
bool FixHardSphere::state_back(const GatheredSend &s) const
{
  static const bool off = [] {
    const char *e = std::getenv("HSGPU_GATHER_WHOLE");
    return e && std::strcmp(e, "0") == 0;
  }();
  return !off && s.shared && s.whole && !friction_on && gath.ipc_whole;
}

/* The results back as the atoms' whole end state: each rank copies its atoms' x, v and tlast
   from rank 0's device straight into LAMMPS's arrays and the fix's (the atoms without events
   get their own bits back; DMA into the page-locked arrays instead of a write per changed
   atom).  Returns false on every rank where some rank could not (the device kept no state,
   or a copy failed: the results then come the other ways, which overwrite the changed atoms
   and every tlast; an unchanged atom's x and v are its own either way), and so for the rest
   of the run. */
bool FixHardSphere::results_whole(int nlocal)
{
  const int me = comm->me;
  const double t0 = MPI_Wtime();
  int ok = 1;
  try {
    if (nlocal > 0) {
      double *x = atom->x[0], *v = atom->v[0];
      if (me == 0)
        ok = resident->get_atoms(gath.displ[0], nlocal, x, v, tlast) ? 1 : 0;
      else if (peer)
        peer->get_atoms(gath.displ[me], nlocal, x, v, tlast);
      else
        ok = 0;
    }
  } catch (std::exception &e) {
    ok = 0;
    gath.why = e.what();
  }
  gath.t_part[2] += MPI_Wtime() - t0;
  if (results_read(ok)) return true;
  gath.ipc_whole = false;
  if (first_failed(ok) == me)
    utils::logmesg(lmp,
                   "Fix hardsphere: rank {} cannot read its atoms from rank 0's device{}{}{}; "
                   "the results come as a list for the rest of the run\n",
                   me, gath.why.empty() ? "" : " (", gath.why, gath.why.empty() ? "" : ")");
  return false;
}

/* Collective, after a reduction found that some rank failed (ok == 0 there): the lowest such
   rank, the one that says why in the log. */
int FixHardSphere::first_failed(int ok) const
{
  int who = ok ? comm->nprocs : comm->me, first = 0;
  MPI_Allreduce(&who, &first, 1, MPI_INT, MPI_MIN, world);
  return first;
}

/* What this rank sends to the gathered step: with group all LAMMPS's own arrays, else the
   group's atoms packed (the device steps let go of the old arrays before they grow). */
FixHardSphere::Source FixHardSphere::gathered_source()
{
  if (igroup == 0) return atom_source();
  const int nlocal = atom->nlocal, *mask = atom->mask;
  gath.lidx.clear();
  for (int i = 0; i < nlocal; ++i)
    if (mask[i] & groupbit) gath.lidx.push_back(i);
  const int n = (int) gath.lidx.size();
  AtomArrays &p = gath.packed;
  if (n > p.room) {
    if (resident) resident->forget_host_arrays();
    if (peer) peer->forget_host_arrays();
    p.grow(n, true);
  }
  for (int k = 0; k < n; ++k) {
    const int i = gath.lidx[k];
    for (int d = 0; d < 3; ++d) {
      p.x[3 * k + d] = atom->x[i][d];
      p.v[3 * k + d] = atom->v[i][d];
      p.f[3 * k + d] = atom->f[i][d];
      if (friction_on) p.omega[3 * k + d] = atom->omega[i][d];
    }
    p.tlast[k] = tlast[i];
    p.radius[k] = atom->radius[i];
    p.rmass[k] = atom->rmass[i];
    p.type[k] = atom->type[i];
    p.id[k] = atom->tag[i];
  }
  return p.view(n, friction_on);
}
