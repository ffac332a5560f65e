/* HARDSPHERE_GPU: fix hardsphere's gpu/keep: the device step's own copies of x and v.

   One rank running whole steps on the device copies every atom's x and v up at each step
   (48 bytes per atom, about 1 ms at N = 1e6).  Between two of its steps LAMMPS changes them
   only through the integrator, fix nve or nve/sphere (core/verlet_motion.h), where no other fix
   touches them; the device then moves the copies it kept from its last step the same way and
   gets LAMMPS's values to the bit (ResidentAtoms::motion, engine/resident_step.h).

   When that holds, known at init() from the fixes defined (motion_fixes_known()):
     - one rank (or the gathered step of several, below), group all, smooth spheres, one fix nve or nve/sphere of group all, and every
       other fix one of a list that never changes x or v of an atom present (output, forces,
       insertion of new atoms);
     - the device's copies are of these atoms in this order: the last step was done there and
       since then no atom moved in the arrays, arrived, left or was created and no run started
       (resident_same: the device copies of tlast, radius, ... are current too).
   A reneighboring (neighbor->ncalls changed) wrapped atoms into the periodic box: the device
   wraps its copies the same way (Domain::pbc(), core/verlet_motion.h) before moving them; the
   box does not change within a run (fixes that change it are not on the list; the shrink-wrapped
   faces have no periodic wrap).  The integrator's rounding (with or without
   fused multiply-adds: how LAMMPS was compiled) is found on each run's first step with kept
   copies, which copies x and v up and compares both ways; if neither gives LAMMPS's bits the
   run copies them every step, with a WARNING.  After every MOTION_AUDIT steps moved on the
   device the next such step checks again; a check that fails then stops the run with an ERROR:
   something this list calls harmless changed x or v.

   On several ranks with the gathered device step (gpu/gather yes) the same fixes let the
   gathered step run ahead from x, v and f sent at post_force() (fix_hardsphere_ahead.cpp,
   MotionUse::advance); the rounding is then found and checked on every rank's host
   (motion_snapshot(), motion_check_gathered()). */
#include "fix_hardsphere.h"

#include "atom.h"
#include "comm.h"
#include "domain.h"
#include "error.h"
#include "force.h"
#include "modify.h"
#include "neighbor.h"
#include "update.h"
#include "utils.h"

#include "lmp_compat.h"

#include <algorithm>
#include <cstring>
#include <mpi.h>

using namespace LAMMPS_NS;

namespace {

// Fix styles whose hooks never change x or v of an atom already present: they add forces
// (which the device gets as f), write output, store values, or insert new atoms (a new atom
// count or order makes the device copy everything again).
const char *const HARMLESS_FIXES[] = {
    "gravity",     "addforce",    "setforce",     "aveforce",     "viscous",
    "spring",      "spring/self", "efield",       "wall/lj93",    "wall/lj126",
    "wall/lj1043", "wall/harmonic", "wall/morse", "wall/colloid", "wall/table",
    "print",       "ave/time",    "ave/atom",     "ave/chunk",    "ave/histo",
    "ave/histo/weight", "ave/correlate", "ave/correlate/long", "vector", "store/state",
    "halt",        "pour",        "deposit",      "property/atom"};

bool harmless(const char *style)
{
  // LAMMPS's own internal fixes that store per-atom or global values (compute msd, ...).
  if (utils::strmatch(style, "^STORE")) return true;
  for (const char *h : HARMLESS_FIXES)
    if (strcmp(style, h) == 0) return true;
  return false;
}

}    // namespace

/* Whether LAMMPS changes x and v between two whole device steps only by fix nve or fix
   nve/sphere of every atom; else false with the reason in `why`. */
bool FixHardSphere::motion_fixes_known(std::string &why) const
{
  why.clear();
  if (!gpu_keep) {
    why = "gpu/keep no";
    return false;
  }
  if (comm->nprocs > 1 && !gather_step) {
    why = "several ranks without the gathered device step";
    return false;
  }
  if (igroup != 0) {
    why = "the fix's group is not all";
    return false;
  }
  if (friction_on) {
    why = "rough spheres (the angular velocities go up every step)";
    return false;
  }
  int integrators = 0;
  for (int f = 0; f < modify->nfix; ++f) {
    const Fix *other = modify->fix[f];
    if (other == this) continue;
    if (strcmp(other->style, "nve") == 0 || strcmp(other->style, "nve/sphere") == 0) {
      ++integrators;
      if (other->igroup != 0) {
        why = fmt::format("fix {} ({}) does not act on group all", other->id, other->style);
        return false;
      }
      continue;
    }
    if (!harmless(other->style)) {
      why = fmt::format("fix {} ({}) may change x or v", other->id, other->style);
      return false;
    }
  }
  if (integrators != 1) {
    why = integrators ? "more than one fix nve or nve/sphere" : "no fix nve or nve/sphere";
    return false;
  }
  return true;
}

/* How this step's x and v get to the device; same: the device's copies are of these atoms
   (resident_same). */
HSGPU::Collide::KeptMotion FixHardSphere::kept_motion(bool same) const
{
  using HSGPU::Collide::MotionUse;
  HSGPU::Collide::KeptMotion m;
  m.keep = motion_known && motion_way != MOTION_OFF;
  if (!m.keep || !same) return m;    // copy (and keep the copies for the next step)
  m.move.dtf = 0.5 * update->dt * force->ftm2v;    // as fix nve's init()
  m.move.dtv = update->dt;
  // A reneighboring since the last step wrapped atoms into the periodic box (Domain::pbc()).
  m.move.wrap = neighbor->ncalls != motion_builds;
  for (int d = 0; d < 3; ++d) {
    m.move.lo[d] = domain->boxlo[d];
    m.move.hi[d] = domain->boxhi[d];
    m.move.prd[d] = domain->prd[d];
    m.move.periodic[d] = domain->periodicity[d];
  }
  if (motion_way == MOTION_UNKNOWN || motion_unchecked >= MOTION_AUDIT) {
    m.use = MotionUse::check;
  } else {
    m.use = MotionUse::predict;
    m.fused = motion_way == MOTION_FUSED;
  }
  return m;
}

/* After a whole device step: what its check found (run_atoms()'s report). */
void FixHardSphere::motion_seen(const HSGPU::Collide::ResidentReport &report)
{
  using HSGPU::Collide::MotionUse;
  motion_builds = neighbor->ncalls;
  if (report.motion == MotionUse::predict) {
    run_sum.moved++;
    motion_unchecked++;
  }
  if (report.motion != MotionUse::check) return;
  run_sum.checked++;
  motion_unchecked = 0;
  const long long *miss = report.motion_miss;
  // Whether each way of rounding gives LAMMPS's bits for every atom.
  const bool plain = miss[0] == 0 && miss[1] == 0, fused = miss[2] == 0 && miss[3] == 0;
  if (motion_way == MOTION_UNKNOWN) {
    // Settled where exactly one way fits (both fit where every product was exact, at rest
    // for instance: the next step checks again).
    if (!plain && !fused) {
      motion_way = MOTION_OFF;
      if (comm->me == 0)
        error->warning(FLERR,
                       "Fix hardsphere: step {}: x and v of {} atoms differ from what fix nve "
                       "makes of the last step's on the device; copying them to the device every "
                       "step of this run",
                       update->ntimestep, std::min(std::max(miss[0], miss[1]), std::max(miss[2], miss[3])));
    } else if (plain != fused) {
      motion_way = plain ? MOTION_PLAIN : MOTION_FUSED;
    }
    return;
  }
  if (motion_way == MOTION_OFF || (motion_way == MOTION_FUSED ? fused : plain)) return;
  const long long bad = motion_way == MOTION_FUSED ? std::max(miss[2], miss[3])
                                                   : std::max(miss[0], miss[1]);
  error->all(FLERR,
             "Fix hardsphere: step {}: the device's copies of x and v, moved as fix nve moves "
             "the atoms, differ from LAMMPS's for {} atoms: a fix or command changed them in "
             "a way the device step does not follow (use 'gpu/keep no', and report it)",
             update->ntimestep, bad);
}

/* Several ranks, at post_force() of the step before a check (fix_hardsphere_ahead.cpp): this
   rank's x, v and f as they are now, for motion_check_gathered(). */
void FixHardSphere::motion_snapshot()
{
  const Source src = atom_source();
  const size_t n3 = 3 * (size_t) src.n;
  mcheck.pending = true;
  mcheck.step = update->ntimestep + 1;
  mcheck.n = src.n;
  mcheck.x = src.x;
  mcheck.v = src.v;
  mcheck.x0.assign(src.x, src.x + n3);
  mcheck.v0.assign(src.v, src.v + n3);
  if (forces_none && forces_checked)
    mcheck.f0.clear();
  else
    mcheck.f0.assign(src.f, src.f + n3);
}

/* Several ranks, post_integrate() after motion_snapshot(): the atoms whose x and v, moved from
   the snapshot by the integrator's arithmetic both ways of rounding, differ from LAMMPS's now,
   summed over the ranks and judged as a device check is (motion_seen()).  Not judged where
   some rank's atoms are not those of the snapshot any more. */
void FixHardSphere::motion_check_gathered()
{
  mcheck.pending = false;
  const Source src = atom_source();
  long long miss[5] = {0, 0, 0, 0, 0};
  const bool valid = update->ntimestep == mcheck.step && src.n == mcheck.n &&
      src.x == mcheck.x && src.v == mcheck.v;
  if (valid && src.n > 0)
    HSGPU::Collide::count_motion_misses(mcheck.x0.data(), mcheck.v0.data(),
                                        mcheck.f0.empty() ? nullptr : mcheck.f0.data(),
                                        atom->rmass, src.x, src.v, src.n,
                                        gathered_motion(false, !ahead_at_post_force),
                                        miss);
  miss[4] = valid ? 0 : 1;
  long long sum[5] = {0, 0, 0, 0, 0};
  MPI_Allreduce(miss, sum, 5, MPI_LONG_LONG, MPI_SUM, world);
  count_collective(sizeof(sum));
  if (sum[4] > 0) return;
  HSGPU::Collide::ResidentReport report;
  report.motion = HSGPU::Collide::MotionUse::check;
  for (int k = 0; k < 4; ++k) report.motion_miss[k] = sum[k];
  motion_seen(report);
}

/* The run's line on gpu/keep, for post_run() (group all on one rank, or gathered on rank 0). */
std::string FixHardSphere::motion_summary() const
{
  if (!motion_known)
    return fmt::format("x and v copied to the device every step ({})", motion_why);
  // What the checks found of the integrator's rounding ("" while unknown).
  const std::string found = motion_way == MOTION_PLAIN ? "rounded as fix nve rounds them"
      : motion_way == MOTION_FUSED                     ? "fused multiply-adds as fix nve's"
      : motion_way == MOTION_OFF                       ? "not matching fix nve's"
                                                       : "";
  if (comm->nprocs > 1) {
    const std::string way = found.empty() ? "rounding not found" : found;
    return fmt::format("{} gathered steps run ahead on rank 0's device during LAMMPS's "
                       "integration ({} of them dropped), from every rank's x, v and f at the "
                       "step before's {} (on {} of them x and v kept there from the "
                       "step before, on {} of those found there by the atoms' IDs), moved there "
                       "as fix nve moves them ({}; checked against LAMMPS's on {} steps); {:.4g} "
                       "ms per step run ahead waiting for it and for the ranks to agree to take "
                       "it",
                       run_sum.ahead, run_sum.dropped,
                       ahead_at_post_force ? "post_force" : "end_of_step", run_sum.xv_kept,
                       run_sum.reordered, way, run_sum.checked,
                       run_sum.ahead ? 1e3 * run_sum.t_ahead_wait / run_sum.ahead : 0.0);
  }
  const std::string way = found.empty() ? found : found + ", ";
  return fmt::format("x and v moved on the device on {} steps ({}checked against LAMMPS's on {}); "
                     "{} steps run ahead on the device during LAMMPS's integration ({} of them "
                     "dropped), each from the step before's {}; {:.4g} ms per step run ahead "
                     "waiting for it",
                     run_sum.moved, way, run_sum.checked, run_sum.ahead, run_sum.dropped,
                     ahead_at_post_force ? "post_force" : "end_of_step",
                     run_sum.ahead ? 1e3 * run_sum.t_ahead_wait / run_sum.ahead : 0.0);
}
