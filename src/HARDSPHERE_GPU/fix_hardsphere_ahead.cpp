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
   HSGPU_RESIDENT_AHEAD=0 (tuning aid) never runs a step ahead. */
#include "fix_hardsphere.h"

#include "atom.h"
#include "comm.h"
#include "error.h"
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

/* Starts step N+1 on the device (see above) where it can run ahead. */
void FixHardSphere::run_ahead()
{
  if (next.pending) drop_ahead();    // (not taken: a step without post_integrate)
  static const bool off = [] {
    const char *e = std::getenv("HSGPU_RESIDENT_AHEAD");
    return e && std::strcmp(e, "0") == 0;
  }();
  if (off || !resident || comm->nprocs != 1 || igroup != 0 || gather_step) return;
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
  next.box = resident_box();
  next.params = step_params();
  next.tally = HSGPU::Collide::Tally();
  next.report = HSGPU::Collide::ResidentReport();
  if (!ahead) ahead.reset(new StepAhead());
  ahead->start([this] {
    resident->run_atoms(next.atoms, next.box, next.params, wsettings, next.tally, next.report);
  });
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
  try {
    ahead->wait();
  } catch (std::exception &e) {
    error->one(FLERR, "Fix hardsphere: CUDA device {}: {}", backend_device, e.what());
  }
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

/* A step run ahead that will not be taken (a run ends, another starts). */
void FixHardSphere::drop_ahead()
{
  if (!next.pending) return;
  next.pending = false;
  try {
    ahead->wait();
  } catch (std::exception &) {
    // dropped anyway
  }
  forget_ahead();
}

/* A step run ahead, waited for, not taken: its results and the copies that ran ahead with it
   are let go, and the next step copies everything again. */
void FixHardSphere::forget_ahead()
{
  resident->forget_host_arrays();
  resident_same = false;
  run_sum.dropped++;
}
