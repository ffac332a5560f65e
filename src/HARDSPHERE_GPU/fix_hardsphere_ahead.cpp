/* HARDSPHERE_GPU: fix hardsphere's device step run ahead, during LAMMPS's integration.

   With gpu/keep the device moves its own copies of x and v between steps as LAMMPS does
   (fix_hardsphere_motion.cpp); on such a step it reads nothing of the atoms' arrays but f,
   and f is final once the forces of the step before are.  So from there (this fix's
   post_force() of step N where no other fix's comes after it, else its end_of_step()) the fix
   can run the device step of N+1 on a host thread of its own (StepAhead) while LAMMPS
   integrates (fix nve/sphere's final and initial halves over every atom, on one core) and
   writes its output, and post_integrate() of N+1 only waits for it and has its results written into
   x, v and tlast (ResidentAtoms::defer_writes: nothing of the atoms' arrays is written
   before).  The step is the same step, from the same inputs: every result bit is as before.

   Only where step N+1 would move x and v on the device anyway (one rank, group all, the
   integrator's rounding known, no check due, the device's copies current, forces known: not
   the run's first steps), and not after a run's last step.  post_integrate() takes it only
   where nothing it assumed changed in between (the step, the timestep, the reneighborings,
   the atom arrays, a step on the host or with per-atom virial); else it drops it, with the
   device's kept copies (which ran ahead with it), and does the step as before.
   On several ranks the gathered step runs ahead in its own way (below).
   HSGPU_RESIDENT_AHEAD=0 (tuning aid) never runs a step ahead. */
#include "fix_hardsphere.h"

#include "atom.h"
#include "comm.h"
#include "domain.h"
#include "error.h"
#include "force.h"
#include "modify.h"
#include "neighbor.h"
#include "update.h"

#include "step_ahead.h"

#include <cstdlib>
#include <cstring>
#include <mpi.h>

using namespace LAMMPS_NS;

/* Whether no other fix's post_force() comes after this one's (LAMMPS calls them in the order
   the fixes were defined): then f is final there, after the pair, bond, kspace styles and the
   force fixes, and stays so through fix nve's final_integrate() and the output of the step. */
bool FixHardSphere::last_post_force() const
{
  bool after = false;
  for (int f = 0; f < modify->nfix; ++f) {
    if (modify->fix[f] == this)
      after = true;
    else if (after && (modify->fmask[f] & FixConst::POST_FORCE))
      return false;
  }
  return after;
}

/* The next step starts where the forces of this one are final: at this fix's post_force()
   where it is the last, else at end_of_step(). */
void FixHardSphere::post_force(int)
{
  if (ahead_at_post_force) run_ahead();
}

void FixHardSphere::end_of_step()
{
  if (!ahead_at_post_force) run_ahead();
}

namespace {

bool ahead_off()
{
  static const bool off = [] {
    const char *e = std::getenv("HSGPU_RESIDENT_AHEAD");
    return e && std::strcmp(e, "0") == 0;
  }();
  return off;
}

}    // namespace

/* Starts step N+1 on the device (see above) where it can run ahead. */
void FixHardSphere::run_ahead()
{
  if (next.pending) drop_ahead();    // (not taken: a step without post_integrate)
  if (comm->nprocs > 1) {
    run_ahead_gathered();
    return;
  }
  if (ahead_off() || !resident || igroup != 0 || gather_step) return;
  if (update->ntimestep >= update->laststep) return;    // no next step in this run
  if (!(resident_same && !sizes_vary) || (forces_none && !forces_checked)) return;
  const HSGPU::Collide::KeptMotion m = kept_motion(true);
  if (m.use != HSGPU::Collide::MotionUse::predict) return;
  const double t_start = MPI_Wtime();
  next.pending = true;
  next.step = update->ntimestep + 1;
  next.builds = neighbor->ncalls;
  next.dt = update->dt;
  next.atoms = resident_atoms(atom_source(), true);
  next.atoms.zero_forces = forces_none && forces_checked;
  next.atoms.motion = m;
  next.atoms.defer_writes = true;
  start_ahead(true, t_start);
}

/* The device step of next.atoms started on this rank's thread (where `here`), and the step
   counted as run ahead, its time since t_start as the fix's. */
void FixHardSphere::start_ahead(bool here, double t_start)
{
  if (here) {
    next.box = resident_box();
    next.params = step_params();
    next.tally = HSGPU::Collide::Tally();
    next.report = HSGPU::Collide::ResidentReport();
    if (!ahead) ahead.reset(new StepAhead());
    ahead->start([this] {
      resident->run_atoms(next.atoms, next.box, next.params, wsettings, next.tally, next.report);
    });
  }
  run_sum.ahead++;
  const double spent = MPI_Wtime() - t_start;
  t_step += spent;
  run_sum.t_step += spent;
}

/* post_integrate() of the step run ahead: its result where nothing it assumed changed since
   (returns 2 where it was done on the device, 0 where it handed the step back), else -1 with
   the step dropped. */
int FixHardSphere::take_ahead(HSGPU::Collide::Tally &mine, HSGPU::Collide::Tally &all)
{
  next.pending = false;
  const double t_start = MPI_Wtime();
  try {
    ahead->wait();
  } catch (std::exception &e) {
    error->one(FLERR, "Fix hardsphere: CUDA device {}: {}", backend_device, e.what());
  }
  run_sum.t_ahead_wait += MPI_Wtime() - t_start;
  const HSGPU::Collide::ResidentAtoms &a = next.atoms;
  const bool still = next.report.motion == HSGPU::Collide::MotionUse::predict &&
      update->ntimestep == next.step && neighbor->ncalls == next.builds &&
      update->dt == next.dt && resident_usable() && resident_same && !sizes_vary &&
      atom->nlocal == a.n && a.n > 0 && atom->x[0] == a.x && atom->v[0] == a.v &&
      atom->f[0] == a.f && tlast == a.tlast;
  if (!still) {
    forget_ahead();
    return -1;
  }
  resident_same = false;
  const HSGPU::Collide::ResidentReport &report = next.report;
  mine = next.tally;
  atoms_stepped(report);
  if (report.outcome == HSGPU::Collide::ResidentOutcome::done) {
    try {
      resident->deliver_atoms();
    } catch (std::exception &e) {
      error->one(FLERR, "Fix hardsphere: CUDA device {}: {}", backend_device, e.what());
    }
  }
  return resident_outcome(report, mine, all, true);
}

/* A step run ahead that will not be taken (a run ends, another starts; on several ranks
   called by every rank at the same point). */
void FixHardSphere::drop_ahead()
{
  if (!next.pending) return;
  next.pending = false;
  try {
    if (ahead) ahead->wait();
  } catch (std::exception &) {
    // dropped anyway
  }
  forget_ahead();
}

/* A step run ahead, waited for, not taken: its results and the copies that ran ahead with it
   are let go, and the next step copies everything again. */
void FixHardSphere::forget_ahead()
{
  if (resident) resident->forget_host_arrays();
  resident_same = false;
  gath.state_kept = false;    // the device moved its state on with the step dropped
  run_sum.dropped++;
}

/* This rank's arrays change under a step run ahead (grow_arrays()): on one rank it is dropped;
   on several it is waited for here (rank 0's device step lets go of arrays next) and dropped
   on every rank where it is due (take_ahead_gathered()). */
void FixHardSphere::spoil_ahead()
{
  if (!next.pending) return;
  if (comm->nprocs == 1) {
    drop_ahead();
    return;
  }
  next.spoiled = true;
  try {
    if (ahead) ahead->wait();
  } catch (std::exception &) {
    // dropped when due
  }
}

/* --- several ranks: the gathered step run ahead ------------------------------------------

   With gpu/gather yes rank 0's device steps every rank's atoms, which it gets from them each
   step (fix_hardsphere_gathered.cpp).  Where the fixes allow gpu/keep (motion_known: group
   all, smooth spheres, fix nve or nve/sphere of all and only harmless fixes besides), every
   rank sends its x, v and f at post_force() of step N (where this fix's comes last, else at
   end_of_step(), after fix nve's first half kick)
   (with tlast, radius, ... where atoms moved in the arrays: LAMMPS exchanged and sorted them
   just before), and rank 0's device moves x and v as fix nve will (final_integrate() of N,
   initial_integrate() of N+1: MotionUse::advance) and runs step N+1 on rank 0's host thread
   while every rank integrates.  post_integrate() of N+1 takes it where nothing changed on any
   rank (one reduction), and the results go back as always.  The integrator's rounding is
   checked on the host of every rank (motion_check_gathered()) on the run's first step with
   the atoms' arrays as post_force() left them and after every MOTION_AUDIT steps run ahead;
   no step runs ahead while it is unknown, or where neither rounding fits.  All conditions are
   the same on every rank (the fixes, the counters, rank 0's broadcast results), so every
   rank takes the same branch at each collective. */

/* The integrator's move from post_force() of one step to post_integrate() of the next; with
   wrap also Domain::pbc()'s wrap before it (x and v kept on the device from the end of the
   step before, which LAMMPS reneighbored since). */
HSGPU::Collide::StepMotion FixHardSphere::gathered_motion(bool wrap, bool half) const
{
  HSGPU::Collide::StepMotion m;
  m.dtf = 0.5 * update->dt * force->ftm2v;    // as fix nve's init()
  m.dtv = update->dt;
  m.wrap = wrap;
  m.kicks = half ? 1 : 2;
  for (int d = 0; d < 3; ++d) {
    m.lo[d] = domain->boxlo[d];
    m.hi[d] = domain->boxhi[d];
    m.prd[d] = domain->prd[d];
    m.periodic[d] = domain->periodicity[d];
  }
  return m;
}

void FixHardSphere::run_ahead_gathered()
{
  if (!gather_step || !motion_known || igroup != 0) return;
  if (update->ntimestep >= update->laststep) return;    // no next step in this run
  if ((forces_none && !forces_checked) || motion_way == MOTION_OFF) return;
  if (motion_way == MOTION_UNKNOWN || motion_unchecked >= MOTION_AUDIT) {
    motion_snapshot();
    return;
  }
  if (ahead_off()) return;
  const double t_start = MPI_Wtime();
  const bool unchanged = resident_same && !sizes_vary;
  resident_same = false;
  gathered_send(next.send, unchanged, true);
  if (next.send.xv_kept) run_sum.xv_kept++;
  if (next.send.reordered) run_sum.reordered++;
  next.pending = true;
  next.spoiled = false;
  next.step = update->ntimestep + 1;
  next.builds = neighbor->ncalls;
  next.dt = update->dt;
  const Source src = atom_source();
  next.nlocal = src.n;
  next.x = src.x;
  next.v = src.v;
  next.f = src.f;
  next.tlast = tlast;
  if (comm->me == 0) {
    next.atoms = gathered_atoms(next.send);
    next.atoms.motion.use = HSGPU::Collide::MotionUse::advance;
    next.atoms.motion.fused = motion_way == MOTION_FUSED;
    // From end_of_step() (another fix's post_force() comes after this one's) the x and v sent
    // have had fix nve's first half kick already; those kept on the device have not.
    next.atoms.motion.move =
        gathered_motion(next.send.xv_kept && neighbor->ncalls != gath.builds,
                        !ahead_at_post_force && !next.send.xv_kept);
  }
  start_ahead(comm->me == 0, t_start);
}

/* post_integrate() of the gathered step run ahead (on every rank): its result where nothing
   it assumed changed on any rank (2 where the device did the step, 0 where it handed it back),
   else -1 with the step dropped on every rank. */
int FixHardSphere::take_ahead_gathered(HSGPU::Collide::Tally &mine, HSGPU::Collide::Tally &all)
{
  next.pending = false;
  const double t_start = MPI_Wtime();
  const Source src = atom_source();
  if (comm->me == 0) {
    try {
      ahead->wait();
    } catch (std::exception &e) {
      error->one(FLERR, "Fix hardsphere: CUDA device {}: {}", backend_device, e.what());
    }
  }
  // Rank 0's device did the step from what the ranks sent (an ID new to it, or no state kept
  // where the ranks sent none, and it did nothing).
  const bool stepped =
      comm->me != 0 || next.report.motion == HSGPU::Collide::MotionUse::advance;
  int ok = stepped && !next.spoiled && update->ntimestep == next.step &&
      neighbor->ncalls == next.builds && update->dt == next.dt && resident_usable() &&
      src.n == next.nlocal && src.x == next.x && src.v == next.v && src.f == next.f &&
      tlast == next.tlast;
  int all_ok = 0;
  MPI_Allreduce(&ok, &all_ok, 1, MPI_INT, MPI_MIN, world);
  count_collective(sizeof(int));
  run_sum.t_ahead_wait += MPI_Wtime() - t_start;
  if (!all_ok) {
    forget_ahead();
    return -1;
  }
  resident_same = false;
  motion_unchecked++;
  mine = HSGPU::Collide::Tally();
  GatheredResult r = {};
  if (comm->me == 0) {
    mine = next.tally;
    r = gathered_result(next.report, mine);
  }
  return gathered_finish(next.send, r, all);
}
