/* ----------------------------------------------------------------------------------
   HARDSPHERE_GPU: fix hardsphere, see fix_hardsphere.h and doc/fix_hardsphere.md.

   This file: the command's arguments, the checks, per-atom state and its migration and
   restart, forward communication, output.  fix_hardsphere_step.cpp: the step itself.

   Output vector (f_ID[1] ... f_ID[NVECTOR]); new entries are appended, never renumbered:
     1 collisions last step (ext)        8 groups of 2+ atoms, last step (ext)
     2 collisions in total (ext)         9 time windows of the last step
     3 wall collisions in total (ext)   10 steps redone in total
     4 kinetic energy lost (ext)        11 atoms in groups spanning ranks, last step (ext)
     5 most events in one step          12 seconds in the candidate search, in total
     6 events in total (ext)            13 seconds resolving, in total
     7 largest group, last step         14 overlaps pushed apart, in total (ext)
                                        15 groups merged after a missed contact, in total
                                        16 gathers of groups spanning ranks, last step
                                        17 CUDA device of rank 0's collision backend, -1: CPU
                                        18 steps carried out whole on the device, in total
                                        19 steps the device handed back to the host, in total
                                        20 seconds in the fix's whole step, in total
                                        21 candidate pairs, last step (ext)
                                        22 ghost cutoff raised during runs, in total
                                        23 largest step reach the ghost atoms cover now
                                        24 the fix's MPI collectives, last step
                                        25 the fix's ghost updates, last step
                                        26 bytes the fix's communication brought, last
                                           step, summed over the ranks (ext)
                                        27 groups spanning ranks resolved where they lie
                                           (no gather), last step (ext)
                                        28 windows resolved by the old path (every spanning
                                           group gathered), last step
                                        29 atoms gathered (of those in 11), last step (ext)
                                        30 gathers (of 16) with the neighbouring ranks only,
                                           last step
                                        31 messages to neighbouring ranks, last step,
                                           summed over the ranks (ext)
                                        32 rounds of the gathers of 30 passing entries on,
                                           last step
                                        33 passes gathered again from every rank after
                                           those rounds, last step
                                        34 1 where the last step's planned windows were
                                           done again with a reduction per window
------------------------------------------------------------------------------------- */

#include "fix_hardsphere.h"

#include "atom.h"
#include "comm.h"
#include "domain.h"
#include "error.h"
#include "force.h"
#include "group.h"
#include "memory.h"
#include "modify.h"
#include "neighbor.h"
#include "pair.h"
#include "update.h"
#include "utils.h"

#include "fix_nh_sphere.h"
#include "fix_nve_sphere.h"

#include "fix_hardsphere_exchange.h"
#include "gpu/collision_backend_cuda.h"
#include "gpu/peer_inputs.h"
#include "gpu/resident_step_cuda.h"
#include "step_ahead.h"
#include "gpu/device_info.cuh"
#include "gpu_device_choice.h"
#include "lmp_compat.h"

#include <algorithm>
#include <exception>

#include <cmath>
#include <cstdlib>
#include <cstring>

using namespace LAMMPS_NS;
using namespace FixConst;

namespace {

const char *const FACES[HSGPU::Collide::NFACES] = {"xlo", "xhi", "ylo", "yhi", "zlo", "zhi"};
constexpr int NVECTOR = 34;
constexpr int DEFAULT_MAXPUSH = 1000;    // overlap push passes before giving up
constexpr int RESTART_FORMAT = 2;        // global restart data: -format, count, values

/* An on/off environment variable (a number, 0 off; `dflt` where it is not set), the same on
   every rank: off where any rank has it off. */
bool env_switch(LAMMPS *lmp, const char *name, bool dflt)
{
  const char *e = std::getenv(name);
  int on = (e ? utils::inumeric(FLERR, e, false, lmp) != 0 : dflt) ? 1 : 0;
  MPI_Allreduce(MPI_IN_PLACE, &on, 1, MPI_INT, MPI_MIN, lmp->world);
  return on != 0;
}

double friction_arg(const char *arg, LAMMPS *lmp)
{
  const double mu = utils::numeric(FLERR, arg, false, lmp);
  if (!(mu >= 0.0) || !std::isfinite(mu))
    lmp->error->all(FLERR, "Fix hardsphere: friction coefficient mu must be >= 0, got {}", arg);
  return mu;
}

double beta_arg(const char *arg, LAMMPS *lmp)
{
  const double b = utils::numeric(FLERR, arg, false, lmp);
  if (!(b >= -1.0 && b <= 1.0))
    lmp->error->all(FLERR,
                    "Fix hardsphere: tangential restitution beta0 must be between -1 and 1, got {}",
                    arg);
  return b;
}

/* The protected moment-of-inertia factor of LAMMPS's sphere integrators (0.4, or 0.5 with
   their 'disc' keyword), read through a pointer to member formed in a derived class (these
   classes are never instantiated). */
struct NVESpherePeek : FixNVESphere {
  static double inertia_of(Fix *f)
  {
    return static_cast<FixNVESphere *>(f)->*(&NVESpherePeek::inertia);
  }
};
struct NHSpherePeek : FixNHSphere {
  static double inertia_of(Fix *f)
  {
    return static_cast<FixNHSphere *>(f)->*(&NHSpherePeek::inertia);
  }
};

double restitution_arg(const char *arg, LAMMPS *lmp)
{
  const double e = utils::numeric(FLERR, arg, false, lmp);
  if (e < 0.0 || e > 1.0)
    lmp->error->all(FLERR, "Fix hardsphere: restitution must be between 0 and 1, got {}", arg);
  return e;
}

}    // namespace

FixHardSphere::FixHardSphere(LAMMPS *lmp, int narg, char **arg) :
    Fix(lmp, narg, arg), serial_order(0), neighbour_exchange(1), spanning_gather(1),
    nwindows_user(0), tc_user(-1.0),
    vmin(0.0), vmin_auto(1), tc_slow(1),
    maxevents_user(-1), maxevents_warn(0), overlap_push(0), maxpush(DEFAULT_MAXPUSH),
    reach_user(-1.0), gpu_requested(0), device_request(-1), gpu_gather(1), backend_device(-1), friction_on(0),
    disc_user(0), friction_guard(1), inertia(0.4), rmax(0.0),
    reach_base(0.0), reach(0.0), reach_raise(0.0), list_cut(0.0), raise_drift(0.0), step_vmax2(0.0),
    step_amax(0.0), vend2(0.0), maxevents(0), tlast(nullptr), n_step(0.0), n_total(0.0),
    n_wall(0.0), ke_total(0.0), max_events(0.0), events_total(0.0), n_redo(0.0), last_largest(0.0),
    last_groups(0.0), last_windows(0.0), last_boundary(0.0), last_gathers(0.0), last_spanning(0.0),
    last_fallbacks(0.0), last_gathered(0.0), last_neighbour(0.0), last_forwards(0.0),
    last_round_fails(0.0), last_step_redos(0.0), t_search(0.0),
    t_resolve(0.0), t_step(0.0), n_repair(0.0), n_resident(0.0), n_declined(0.0),
    last_candidates(0.0), n_ghost_raise(0.0), bound_floor(0.0), exchange(nullptr), fwd_nval(0),
    n_push(0.0)
{
  for (double &o : ovl) o = 0.0;
  ovl_depth = 0.0;
  // The collision virial of the last step; kept across runs and in restart files, so that
  // the first thermo line of a run shows the full pressure.
  for (double &w : virial) w = 0.0;
  vector_flag = 1;
  size_vector = NVECTOR;
  global_freq = 1;
  extvector = -1;
  extlist = new int[NVECTOR]{1, 1, 1, 1, 0, 1, 0, 1, 0, 0, 1, 0, 0,
                             1, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 1, 0, 1, 0, 1, 0, 0, 0};
  virial_global_flag = 1;
  virial_peratom_flag = 1;    // on the steps LAMMPS asks for it (compute stress/atom)
  thermo_virial = 1;
  vatom_step = -1;
  maxexchange = 7;    // tlast and, on a step with per-atom virial, its 6 values
  restart_global = 1;
  restart_peratom = 1;
  create_attribute = 1;
  // The step driver sends whole bodies to the ghosts and back (Exchange::to_foreign,
  // to_owner).
  comm_forward = std::max(NFWD, HSGPU::Collide::Exchange::MAX_VALUES);
  comm_reverse = HSGPU::Collide::Exchange::MAX_VALUES;
  dynamic_group_allow = 0;
  // The fix may ask for a reneighboring (next_reneighbor) to raise the ghost cutoff when the
  // atoms' moves approach what it covers (pre_exchange()).
  force_reneighbor = 1;
  next_reneighbor = -1;

  if (!atom->radius_flag || !atom->rmass_flag)
    error->all(FLERR, "Fix hardsphere requires atom style sphere (per-atom radius and rmass)");
  if (!atom->tag_enable) error->all(FLERR, "Fix hardsphere requires atom IDs");

  parse(narg, arg);
  if (friction_on && !atom->omega_flag)
    error->all(FLERR, "Fix hardsphere: friction needs per-atom angular velocities (atom style "
                      "sphere, omega); this atom style has none");
  exchange = new LammpsExchange(this);

  grow_arrays(atom->nmax);
  atom->add_callback(Atom::GROW);
  atom->add_callback(Atom::RESTART);
  for (int i = 0; i < atom->nlocal; ++i) tlast[i] = NEVER_COLLIDED;
}

FixHardSphere::~FixHardSphere()
{
  if (copymode) return;
  atom->delete_callback(id, Atom::GROW);
  atom->delete_callback(id, Atom::RESTART);
  ahead.reset();       // waits for a step run ahead (it uses `resident`)
  resident.reset();    // lets go of the atom arrays it keeps page-locked
  peer.reset();        // the same
  memory->destroy(tlast);
  delete exchange;
  delete[] extlist;
}

/* fix ID group hardsphere [restitution e] [restitution/pair I J e] [wall face e] ...
   [order parallel|serial] [tc t|auto] [tc/slow yes|no] [vmin v|auto]
   [maxevents N error|warn]
   [overlap error|push] [maxpush N] [reach d] [gpu yes|no] [device auto|N]
   [friction mu beta0] [friction/pair I J mu beta0] [wall/friction face mu beta0]
   [friction/guard elastic|none] [disc] */
void FixHardSphere::parse(int narg, char **arg)
{
  const int ntypes = atom->ntypes;
  double eglobal = 1.0;
  struct PairE {
    int ilo, ihi, jlo, jhi;
    double e;
  };
  std::vector<PairE> pairs;
  double muglobal = 0.0, betaglobal = -1.0;
  std::vector<PairE> fpairs;    // e holds mu, fbeta beta0
  std::vector<double> fbeta;
  int wall_friction[HSGPU::Collide::NFACES];
  for (int f = 0; f < HSGPU::Collide::NFACES; ++f) {
    walls.on[f] = 0;
    walls.pos[f] = 0.0;
    walls.e[f] = 1.0;
    walls.mu[f] = 0.0;
    walls.beta[f] = -1.0;
    wall_friction[f] = 0;
  }
  auto face_arg = [&](const char *a) {
    for (int f = 0; f < HSGPU::Collide::NFACES; ++f)
      if (strcmp(a, FACES[f]) == 0) return f;
    error->all(FLERR, "Fix hardsphere: unknown wall face {} (use xlo xhi ylo yhi zlo zhi)", a);
    return -1;
  };

  int iarg = 3;
  auto need = [&](int n, const char *kw) {
    if (iarg + n >= narg) error->all(FLERR, "Fix hardsphere: keyword {} needs {} value(s)", kw, n);
  };
  // A keyword whose one value is yes or no: 1 or 0, and iarg past it.
  auto yes_no = [&](const char *kw) {
    need(1, kw);
    const char *value = arg[iarg + 1];
    iarg += 2;
    if (strcmp(value, "yes") == 0) return 1;
    if (strcmp(value, "no") != 0)
      error->all(FLERR, "Fix hardsphere: {} must be yes or no, got {}", kw, value);
    return 0;
  };
  while (iarg < narg) {
    const char *kw = arg[iarg];
    if (strcmp(kw, "restitution") == 0) {
      need(1, kw);
      eglobal = restitution_arg(arg[iarg + 1], lmp);
      iarg += 2;
    } else if (strcmp(kw, "restitution/pair") == 0) {
      need(3, kw);
      PairE p;
      utils::bounds(FLERR, arg[iarg + 1], 1, ntypes, p.ilo, p.ihi, error);
      utils::bounds(FLERR, arg[iarg + 2], 1, ntypes, p.jlo, p.jhi, error);
      p.e = restitution_arg(arg[iarg + 3], lmp);
      pairs.push_back(p);
      iarg += 4;
    } else if (strcmp(kw, "wall") == 0) {
      need(2, kw);
      int face = -1;
      for (int f = 0; f < HSGPU::Collide::NFACES; ++f)
        if (strcmp(arg[iarg + 1], FACES[f]) == 0) face = f;
      if (face < 0)
        error->all(FLERR, "Fix hardsphere: unknown wall face {} (use xlo xhi ylo yhi zlo zhi)",
                   arg[iarg + 1]);
      walls.on[face] = 1;
      walls.e[face] = restitution_arg(arg[iarg + 2], lmp);
      iarg += 3;
    } else if (strcmp(kw, "friction") == 0) {
      need(2, kw);
      muglobal = friction_arg(arg[iarg + 1], lmp);
      betaglobal = beta_arg(arg[iarg + 2], lmp);
      iarg += 3;
    } else if (strcmp(kw, "friction/pair") == 0) {
      need(4, kw);
      PairE p;
      utils::bounds(FLERR, arg[iarg + 1], 1, ntypes, p.ilo, p.ihi, error);
      utils::bounds(FLERR, arg[iarg + 2], 1, ntypes, p.jlo, p.jhi, error);
      p.e = friction_arg(arg[iarg + 3], lmp);
      fpairs.push_back(p);
      fbeta.push_back(beta_arg(arg[iarg + 4], lmp));
      iarg += 5;
    } else if (strcmp(kw, "wall/friction") == 0) {
      need(3, kw);
      const int face = face_arg(arg[iarg + 1]);
      walls.mu[face] = friction_arg(arg[iarg + 2], lmp);
      walls.beta[face] = beta_arg(arg[iarg + 3], lmp);
      wall_friction[face] = 1;
      iarg += 4;
    } else if (strcmp(kw, "friction/guard") == 0) {
      need(1, kw);
      if (strcmp(arg[iarg + 1], "elastic") == 0)
        friction_guard = 1;
      else if (strcmp(arg[iarg + 1], "none") == 0)
        friction_guard = 0;
      else
        error->all(FLERR, "Fix hardsphere: friction/guard must be elastic or none, got {}",
                   arg[iarg + 1]);
      iarg += 2;
    } else if (strcmp(kw, "disc") == 0) {
      disc_user = 1;
      iarg += 1;
    } else if (strcmp(kw, "order") == 0) {
      need(1, kw);
      if (strcmp(arg[iarg + 1], "parallel") == 0)
        serial_order = 0;
      else if (strcmp(arg[iarg + 1], "serial") == 0)
        serial_order = 1;
      else
        error->all(FLERR, "Fix hardsphere: order must be parallel or serial, got {}",
                   arg[iarg + 1]);
      iarg += 2;
    } else if (strcmp(kw, "spanning") == 0) {
      need(1, kw);
      if (strcmp(arg[iarg + 1], "view") == 0)
        spanning_gather = 0;
      else if (strcmp(arg[iarg + 1], "gather") == 0)
        spanning_gather = 1;
      else
        error->all(FLERR, "Fix hardsphere: spanning must be view or gather, got {}", arg[iarg + 1]);
      iarg += 2;
    } else if (strcmp(kw, "windows") == 0) {
      need(1, kw);
      if (strcmp(arg[iarg + 1], "auto") == 0) {
        nwindows_user = 0;
      } else {
        nwindows_user = utils::inumeric(FLERR, arg[iarg + 1], false, lmp);
        if (nwindows_user < 1)
          error->all(FLERR, "Fix hardsphere: windows must be auto or a number >= 1, got {}",
                     arg[iarg + 1]);
      }
      iarg += 2;
    } else if (strcmp(kw, "tc") == 0) {
      need(1, kw);
      if (strcmp(arg[iarg + 1], "auto") == 0) {
        tc_user = -1.0;
      } else {
        tc_user = utils::numeric(FLERR, arg[iarg + 1], false, lmp);
        if (tc_user < 0.0) error->all(FLERR, "Fix hardsphere: tc must be >= 0 or auto");
      }
      iarg += 2;
    } else if (strcmp(kw, "tc/slow") == 0) {
      tc_slow = yes_no(kw);
    } else if (strcmp(kw, "vmin") == 0) {
      need(1, kw);
      if (strcmp(arg[iarg + 1], "auto") == 0) {
        vmin_auto = 1;
        vmin = 0.0;
      } else {
        vmin_auto = 0;
        vmin = utils::numeric(FLERR, arg[iarg + 1], false, lmp);
        if (vmin < 0.0) error->all(FLERR, "Fix hardsphere: vmin must be >= 0 or auto");
      }
      iarg += 2;
    } else if (strcmp(kw, "maxevents") == 0) {
      need(2, kw);
      maxevents_user = utils::bnumeric(FLERR, arg[iarg + 1], false, lmp);
      if (maxevents_user < 1) error->all(FLERR, "Fix hardsphere: maxevents must be >= 1");
      if (strcmp(arg[iarg + 2], "error") == 0)
        maxevents_warn = 0;
      else if (strcmp(arg[iarg + 2], "warn") == 0)
        maxevents_warn = 1;
      else
        error->all(FLERR, "Fix hardsphere: maxevents takes N error|warn, got {}", arg[iarg + 2]);
      iarg += 3;
    } else if (strcmp(kw, "overlap") == 0) {
      need(1, kw);
      if (strcmp(arg[iarg + 1], "error") == 0)
        overlap_push = 0;
      else if (strcmp(arg[iarg + 1], "push") == 0)
        overlap_push = 1;
      else
        error->all(FLERR, "Fix hardsphere: overlap must be error or push, got {}", arg[iarg + 1]);
      iarg += 2;
    } else if (strcmp(kw, "maxpush") == 0) {
      need(1, kw);
      maxpush = utils::inumeric(FLERR, arg[iarg + 1], false, lmp);
      if (maxpush < 1) error->all(FLERR, "Fix hardsphere: maxpush must be >= 1");
      iarg += 2;
    } else if (strcmp(kw, "gpu") == 0) {
      gpu_requested = yes_no(kw);
    } else if (strcmp(kw, "gpu/gather") == 0) {
      gpu_gather = yes_no(kw);
    } else if (strcmp(kw, "gpu/keep") == 0) {
      gpu_keep = yes_no(kw);
    } else if (strcmp(kw, "device") == 0) {
      need(1, kw);
      if (strcmp(arg[iarg + 1], "auto") == 0) {
        device_request = -1;
      } else {
        device_request = utils::inumeric(FLERR, arg[iarg + 1], false, lmp);
        if (device_request < 0) error->all(FLERR, "Fix hardsphere: device must be auto or >= 0");
      }
      iarg += 2;
    } else if (strcmp(kw, "reach") == 0) {
      need(1, kw);
      reach_user = utils::numeric(FLERR, arg[iarg + 1], false, lmp);
      if (reach_user <= 0.0) error->all(FLERR, "Fix hardsphere: reach must be > 0");
      iarg += 2;
    } else {
      error->all(FLERR, "Fix hardsphere: unknown keyword {}", kw);
    }
  }

  epair.assign((size_t) (ntypes + 1) * (ntypes + 1), eglobal);
  for (const PairE &p : pairs)
    for (int i = p.ilo; i <= p.ihi; ++i)
      for (int j = p.jlo; j <= p.jhi; ++j) {
        epair[(size_t) i * (ntypes + 1) + j] = p.e;
        epair[(size_t) j * (ntypes + 1) + i] = p.e;
      }

  fpair.assign((size_t) 2 * (ntypes + 1) * (ntypes + 1), 0.0);
  for (size_t k = 0; k < fpair.size(); k += 2) {
    fpair[k] = muglobal;
    fpair[k + 1] = betaglobal;
  }
  for (size_t q = 0; q < fpairs.size(); ++q)
    for (int i = fpairs[q].ilo; i <= fpairs[q].ihi; ++i)
      for (int j = fpairs[q].jlo; j <= fpairs[q].jhi; ++j)
        for (size_t at : {(size_t) i * (ntypes + 1) + j, (size_t) j * (ntypes + 1) + i}) {
          fpair[2 * at] = fpairs[q].e;
          fpair[2 * at + 1] = fbeta[q];
        }
  friction_on = 0;
  for (int i = 1; i <= ntypes; ++i)
    for (int j = 1; j <= ntypes; ++j)
      if (fpair[2 * ((size_t) i * (ntypes + 1) + j)] > 0.0) friction_on = 1;
  for (int f = 0; f < HSGPU::Collide::NFACES; ++f) {
    if (wall_friction[f] && !walls.on[f])
      error->all(FLERR, "Fix hardsphere: wall/friction {} needs a wall on that face (keyword wall)",
                 FACES[f]);
    if (walls.mu[f] > 0.0) friction_on = 1;
  }
  if (disc_user && domain->dimension != 2)
    error->all(FLERR, "Fix hardsphere: disc requires a 2d simulation");
  if (disc_user && !friction_on)
    error->all(FLERR, "Fix hardsphere: disc sets the moment of inertia of friction; no friction "
                      "(friction, friction/pair or wall/friction with mu > 0) is set");
}

int FixHardSphere::setmask()
{
  // POST_FORCE, END_OF_STEP: the next step run ahead on the device (fix_hardsphere_ahead.cpp).
  return POST_INTEGRATE | PRE_NEIGHBOR | PRE_EXCHANGE | POST_FORCE | END_OF_STEP;
}

double FixHardSphere::current_tc() const
{
  return tc_user >= 0.0 ? tc_user : 0.5 * update->dt;
}

void FixHardSphere::init()
{
  if (utils::strmatch(update->integrate_style, "^respa"))
    error->all(FLERR, "Fix hardsphere does not support run_style respa");
  if (domain->triclinic) error->all(FLERR, "Fix hardsphere requires an orthogonal box");
  if (comm->nprocs > 1 && !comm->ghost_velocity)
    error->all(FLERR, "Fix hardsphere requires 'comm_modify vel yes' when running on more "
                      "than one MPI rank");
  if (neighbor->every != 1 || neighbor->delay != 0)
    error->all(FLERR, "Fix hardsphere requires 'neigh_modify every 1 delay 0' (it relies on "
                      "the neighbor list covering every step's moves)");
  if ((bigint) epair.size() != (bigint) (atom->ntypes + 1) * (atom->ntypes + 1) ||
      (bigint) fpair.size() != (bigint) 2 * (atom->ntypes + 1) * (atom->ntypes + 1))
    error->all(FLERR, "Fix hardsphere: the number of atom types changed; define the fix again");
  // Fixes that change radius, mass or type of atoms in place (fix adapt and adapt/fep on any
  // step; atom/swap, mol/swap and sgcmc swap types): those arrays go to the device every step.
  sizes_vary = false;
  for (int i = 0; i < modify->nfix; ++i)
    if (utils::strmatch(modify->fix[i]->style, "^adapt") ||
        utils::strmatch(modify->fix[i]->style, "swap") ||
        utils::strmatch(modify->fix[i]->style, "^sgcmc"))
      sizes_vary = true;
  // Collisions are found forward in time within each step, and their virial is the impulses
  // divided by the timestep: a zero, negative or non-finite timestep has no meaning for them.
  // Checked for runs only (minimization does not invoke the fix; write_restart and write_data
  // call init() too).
  if (update->whichflag == 1 && !(update->dt > 0.0 && std::isfinite(update->dt)))
    error->all(FLERR,
               "Fix hardsphere requires a positive timestep, got {} (collisions are resolved "
               "forward in time within each step, and their virial is the impulses divided by "
               "the timestep)",
               update->dt);
  check_other_fixes();
  forces_none = no_force_styles();

  // Friction turns spin into translation through the moment of inertia k m r^2: k follows the
  // integrator that moves these atoms' omega (fix nve/sphere and the nvt, npt, nph/sphere
  // styles: 0.4, or 0.5 with their 'disc'), or 'disc' here where none of those is defined.
  inertia = 0.4;
  if (friction_on) {
    const double k = integrator_inertia();
    if (disc_user && k > 0.0 && k != 0.5)
      error->all(FLERR,
                 "Fix hardsphere: 'disc' (moment of inertia 0.5 m r^2) but the integrator of its "
                 "atoms uses {} m r^2 (add 'disc' to the integrator, or remove it here)",
                 k);
    inertia = disc_user ? 0.5 : (k > 0.0 ? k : 0.4);
  }

  for (int f = 0; f < HSGPU::Collide::NFACES; ++f) {
    if (!walls.on[f]) continue;
    const int d = f / 2, side = f % 2;
    if (domain->periodicity[d])
      error->all(FLERR, "Fix hardsphere: wall {} is on a periodic face of the box", FACES[f]);
    if (domain->boundary[d][side] != FIXED_FACE)
      error->all(FLERR, "Fix hardsphere: wall {} needs a fixed boundary ('f') on that face",
                 FACES[f]);
  }

  // Largest radius in the group, and masses.
  const int nlocal = atom->nlocal;
  double rlocal = 0.0;
  int bad = 0;
  for (int i = 0; i < nlocal; ++i)
    if (atom->mask[i] & groupbit) {
      rlocal = std::max(rlocal, atom->radius[i]);
      if (!(atom->rmass[i] > 0.0)) bad = 1;
    }
  MPI_Allreduce(&rlocal, &rmax, 1, MPI_DOUBLE, MPI_MAX, world);
  rmax = std::max(rmax, inserted_radius());
  int anybad = 0;
  MPI_Allreduce(&bad, &anybad, 1, MPI_INT, MPI_MAX, world);
  if (anybad) error->all(FLERR, "Fix hardsphere requires positive masses (rmass) for its atoms");
  // An empty group is allowed: the fix has nothing to do until atoms join it (atoms inserted
  // by fix pour or fix deposit are covered by their largest radius, above).
  if (!(rmax > 0.0) && group->count(igroup) > 0)
    error->all(FLERR, "Fix hardsphere: no atom of group {} has a radius > 0", group->names[igroup]);

  reach_base = reach_user > 0.0 ? reach_user : rmax;
  reach = reach_base;
  reach_raise = 0.0;
  next_reneighbor = -1;
  list_cut = 2.0 * rmax + 2.0 * reach;
  for (int d = 0; d < domain->dimension; ++d)
    if (domain->periodicity[d] && 2.0 * list_cut >= domain->prd[d])
      error->all(FLERR,
                 "Fix hardsphere: the periodic box length {} along {} must exceed twice the "
                 "collision range 2*max radius + 2*reach = {}",
                 domain->prd[d], "xyz"[d], list_cut);

  // Ghost atoms must reach as far as the candidate search: 2 rmax + 2 reach, plus the skin
  // that atoms may move between reneighborings.  Raised here (once, with a line in the log)
  // when the communication cutoff is shorter; a larger user setting is kept.  The reach
  // covered is at least twice the fastest atom's drift of a step at its current speed (as far
  // as a periodic box allows), so that a run does not start on ghosts its first steps outgrow.
  if (comm->mode != Comm::SINGLE)
    error->all(FLERR, "Fix hardsphere requires comm_modify mode single (in mode multi the ghost "
                      "cutoff of each atom type follows the pair cutoffs, not the range of the "
                      "fix's collisions)");
  double vloc = 0.0, vmax2 = 0.0;
  for (int i = 0; i < nlocal; ++i)
    if (atom->mask[i] & groupbit) vloc = std::max(vloc, HSGPU::Collide::speed2(atom->v[i]));
  MPI_Allreduce(&vloc, &vmax2, 1, MPI_DOUBLE, MPI_MAX, world);
  const double drift = update->dt > 0.0 ? std::sqrt(vmax2) * update->dt : 0.0;
  const double covered = std::max(reach_base, std::min(2.0 * drift, periodic_reach()));
  double ghost = comm->cutghostuser;
  if (force->pair && force->pair->cutforce > 0.0)
    ghost = std::max(ghost, force->pair->cutforce + neighbor->skin);
  const double need = 2.0 * rmax + 2.0 * covered + neighbor->skin;
  if (ghost < need) {
    comm->cutghostuser = need;
    if (comm->me == 0)
      utils::logmesg(lmp,
                     "Fix hardsphere: communication cutoff raised to {:.8g} (2*max radius {:.8g} "
                     "+ 2*reach {:.8g} + neighbor skin {:.8g})\n",
                     need, 2.0 * rmax, 2.0 * covered, neighbor->skin);
  }

  maxevents = maxevents_user > 0 ? maxevents_user : 1000 + 100 * atom->natoms;
  wsettings = HSGPU::Collide::WindowSettings();
  wsettings.nwindows = nwindows_user;
  // Tuning aid: HSGPU_SPANNING_WIDE=1, every boundary atom to every neighbouring rank of the
  // spanning groups at a gather (WindowSettings::gather_wide; no result bit depends on it).
  wsettings.gather_wide = std::getenv("HSGPU_SPANNING_WIDE") != nullptr;
  // The gathers' messages go to the neighbouring ranks only, one to each (no consensus
  // over all ranks); HSGPU_NEIGHBOUR_EXCHANGE=0 makes them the messages with a non-blocking
  // barrier instead (for comparison; no result bit depends on it).  The same on all ranks.
  neighbour_exchange = env_switch(lmp, "HSGPU_NEIGHBOUR_EXCHANGE", true) ? 1 : 0;
  exchange->forget_neighbours();
  // The rounds of a gather to the neighbouring ranks passing entries on: a fixed number, with
  // no reduction (WindowSettings::fixed_rounds); HSGPU_FIXED_ROUNDS=n sets how many, 0 the
  // rounds decided by a reduction each, as before (for comparison; no result bit depends on
  // it).  The same on all ranks, since the reductions must match.
  if (const char *e = std::getenv("HSGPU_FIXED_ROUNDS")) {
    wsettings.fixed_rounds = utils::inumeric(FLERR, e, false, lmp);
    if (wsettings.fixed_rounds < 0)
      error->all(FLERR, "Fix hardsphere: HSGPU_FIXED_ROUNDS must be >= 0");
  }
  MPI_Allreduce(MPI_IN_PLACE, &wsettings.fixed_rounds, 1, MPI_INT, MPI_MIN, world);
  // Two passes of every window's check, the first with no reduction
  // (WindowSettings::two_passes, on by default); HSGPU_TWO_PASSES=0 makes a reduction after
  // every pass, as before (for comparison).  The same on all ranks.  No result bit depends
  // on it.
  wsettings.two_passes = env_switch(lmp, "HSGPU_TWO_PASSES", wsettings.two_passes);
  // Planned windows, whose checks ride in the step's one reduction after them
  // (WindowSettings::step_checks, on by default); HSGPU_STEP_CHECKS=0 makes a reduction per
  // window length tried and per window's check, as before (for comparison).  The same on all
  // ranks.  No result bit depends on it.
  wsettings.step_checks = env_switch(lmp, "HSGPU_STEP_CHECKS", wsettings.step_checks);
  // The foreign atoms' start points of each step's first window formed from the step's own
  // ghost update (WindowSettings::start_from_step, on by default); HSGPU_START_FROM_STEP=0
  // gives them a ghost update of their own, as every later window start (for comparison);
  // HSGPU_START_CHECK=1 makes both and compares them (a test aid; the run's summary says how
  // many differed).  The same on all ranks.  No result bit depends on them.
  wsettings.start_from_step = env_switch(lmp, "HSGPU_START_FROM_STEP", wsettings.start_from_step);
  wsettings.start_check = env_switch(lmp, "HSGPU_START_CHECK", wsettings.start_check);
  // With planned windows, the foreign atoms' later start points and each pass's excursions by
  // messages to the neighbouring ranks holding only the atoms they need
  // (WindowSettings::sparse_foreign, on by default); HSGPU_SPARSE_FOREIGN=0 makes them ghost
  // updates, as before (for comparison).  The same on all ranks.  No result bit depends on it.
  wsettings.sparse_foreign = env_switch(lmp, "HSGPU_SPARSE_FOREIGN", wsettings.sparse_foreign);
  // HSGPU_SPARSE_DROP=1: rank 0 leaves an atom out of its first such message of each step, and
  // the step is done again (a test aid for that way back).
  wsettings.sparse_drop = env_switch(lmp, "HSGPU_SPARSE_DROP", wsettings.sparse_drop);
  // Should planned windows do a step again, its bodies are made again from the atoms (which
  // change only after the step; post_integrate() made them at x - v dt), rather than kept in a
  // copy at every step's start.
  driver.step_source([this](std::vector<HSGPU::Collide::Body> &out) {
    gather_bodies(update->dt);
    if (&out != &bodies) out = bodies;
  });
  // Tuning aid: HSGPU_EDGE_FACTOR and HSGPU_EDGE_HOPS set the window bounds of the atoms next to
  // another rank's (WindowSettings::edge_factor, edge_hops; no result bit depends on them).
  if (const char *e = std::getenv("HSGPU_EDGE_FACTOR"))
    wsettings.edge_factor = utils::numeric(FLERR, e, false, lmp);
  if (const char *e = std::getenv("HSGPU_EDGE_HOPS"))
    wsettings.edge_hops = utils::inumeric(FLERR, e, false, lmp);
  // Tuning aids: HSGPU_TARGET_GROUP, the largest group a window aims at (default max(256, N /
  // 128)), and HSGPU_SPAN_TARGET, that of the part of a group spanning ranks that one rank
  // sees (default 256; 0: the same as any group's).  No result bit depends on them.
  if (const char *e = std::getenv("HSGPU_TARGET_GROUP"))
    wsettings.target_group = utils::bnumeric(FLERR, e, false, lmp);
  if (const char *e = std::getenv("HSGPU_SPAN_TARGET"))
    wsettings.span_target = utils::bnumeric(FLERR, e, false, lmp);
  if (wsettings.target_group < 0 || wsettings.span_target < 0)
    error->all(FLERR, "Fix hardsphere: HSGPU_TARGET_GROUP and HSGPU_SPAN_TARGET must be >= 0");
  if (wsettings.edge_factor <= 0.0 || wsettings.edge_hops < 0)
    error->all(FLERR, "Fix hardsphere: HSGPU_EDGE_FACTOR must be > 0 and HSGPU_EDGE_HOPS >= 0");
  if (nwindows_user == 1) {
    // One window per step: nothing is split, so it joins every candidate pair (its groups are
    // the connected components of the step's candidates), and where bounds are used (the
    // view's windows, the device) it takes the step's own.  The window bounds of shorter
    // windows (1.5 |v|, a quarter of the fastest) would leave candidates out and make the
    // window repair its one large group, which costs the whole window again (the falling
    // column of in.column at dt = 0.05: 19 repairs in 20 steps).  No result bit depends on
    // which pairs a window joins.
    wsettings.join_all = true;
    wsettings.bound_factor = HSGPU::Collide::STEP_BOUND_FACTOR;
    wsettings.floor_fraction = HSGPU::Collide::STEP_FLOOR_FRACTION;
  }
  setup_backend();
  // gpu/keep and the step run ahead (after setup_backend(): gather_step).
  motion_known = motion_fixes_known(motion_why);
  ahead_at_post_force = last_post_force();
}

/* Two fix hardsphere acting on one atom would each resolve its collisions with its own
   partners and then find the other's results overlapping: stop with an error that names the
   fixes and the atom (the lowest ID they share).  Fixes on disjoint groups are allowed (their
   atoms pass through each other). */
void FixHardSphere::check_other_fixes()
{
  for (int f = 0; f < modify->nfix; ++f) {
    const Fix *other = modify->fix[f];
    if (other == this || strcmp(other->style, style) != 0) continue;
    const int both = groupbit | other->groupbit;
    tagint shared = MAXTAGINT, least = MAXTAGINT;
    for (int i = 0; i < atom->nlocal; ++i)
      if ((atom->mask[i] & both) == both) shared = std::min(shared, atom->tag[i]);
    MPI_Allreduce(&shared, &least, 1, MPI_LMP_TAGINT, MPI_MIN, world);
    if (least != MAXTAGINT || other->igroup == igroup)
      error->all(FLERR,
                 "Fix hardsphere: fixes {} (group {}) and {} (group {}) both act on {}; use one "
                 "fix hardsphere for all the spheres that collide with each other",
                 id, group->names[igroup], other->id, group->names[other->igroup],
                 least != MAXTAGINT ? fmt::format("atom {}", least)
                                    : std::string("the same group"));
  }
}

/* True where nothing in the input sets forces on atoms: no pair, bond, angle, dihedral,
   improper or kspace style, and no fix with a hook in which forces are added (pre_force,
   pre_reverse, post_force and their rRESPA forms).  LAMMPS then zeroes f every step and
   nothing writes it, so a device step needs no copy of it. */
bool FixHardSphere::no_force_styles() const
{
  if (force->pair || force->bond || force->angle || force->dihedral || force->improper ||
      force->kspace)
    return false;
  const int hooks = FixConst::PRE_FORCE | FixConst::PRE_REVERSE | FixConst::POST_FORCE |
      FixConst::PRE_FORCE_RESPA | FixConst::POST_FORCE_RESPA;
  for (int f = 0; f < modify->nfix; ++f)
    if (modify->fix[f] != this && (modify->fmask[f] & hooks)) return false;
  return true;
}

/* The moment-of-inertia factor of the sphere integrators (nve/sphere, nvt/sphere, npt/sphere,
   nph/sphere and their accelerated variants, which derive from them) that act on atoms of the
   group, or -1 where none does.  Two that disagree stop with an error. */
double FixHardSphere::integrator_inertia()
{
  double k = -1.0;
  const char *by = nullptr;
  for (int f = 0; f < modify->nfix; ++f) {
    Fix *other = modify->fix[f];
    double kf;
    if (utils::strmatch(other->style, "^nve/sphere"))
      kf = NVESpherePeek::inertia_of(other);
    else if (utils::strmatch(other->style, "^n[pv][ht]/sphere"))
      kf = NHSpherePeek::inertia_of(other);
    else
      continue;
    int mine = 0, any = 0;
    for (int i = 0; i < atom->nlocal && !mine; ++i)
      if ((atom->mask[i] & groupbit) && (atom->mask[i] & other->groupbit)) mine = 1;
    MPI_Allreduce(&mine, &any, 1, MPI_INT, MPI_MAX, world);
    if (!any && other->igroup != igroup && other->igroup != 0) continue;
    if (k > 0.0 && kf != k)
      error->all(FLERR,
                 "Fix hardsphere: the integrators {} and {} of its atoms use different moments "
                 "of inertia ({} and {} m r^2); friction needs one",
                 by, other->id, k, kf);
    k = kf;
    by = other->id;
  }
  return k;
}

/* The largest radius of the atoms that fix pour or fix deposit will insert into the group
   during the run (their extract("radius"), as LAMMPS's granular pair styles use it), 0 when
   there is no such fix. */
double FixHardSphere::inserted_radius()
{
  double r = 0.0;
  for (int f = 0; f < modify->nfix; ++f) {
    Fix *other = modify->fix[f];
    if (!utils::strmatch(other->style, "^pour") && !utils::strmatch(other->style, "^deposit"))
      continue;
    if (!(groupbit & (1 | other->groupbit))) continue;    // its atoms are not in the group
    for (int t = 1; t <= atom->ntypes; ++t) {
      int itype = t;
      const auto *rad = (const double *) other->extract("radius", itype);
      if (rad) r = std::max(r, *rad);
    }
  }
  return r;
}

/* The collision backend: CUDA on this rank's device with 'gpu yes' (the device policy of
   gpu_device_choice.h, shared with pair gravity: where any rank has no usable device all ranks
   run the CPU backend and rank 0 warns), else the CPU one. */
void FixHardSphere::setup_backend()
{
  int device = -1;
  if (gpu_requested) device = hsgpu_choose_device(lmp, world, device_request, "Fix hardsphere");
  if (device == backend_device && backend) return;
  backend.reset();
  resident.reset();
  peer.reset();
  gather_step = false;
  // Tests (HSGPU_RESIDENT_HOST set): where gpu yes finds no device, the host's reference
  // resident step takes the device step's place, so that the code around it runs.
  const bool host_reference = device < 0 && gpu_requested && std::getenv("HSGPU_RESIDENT_HOST");
  try {
    if (device >= 0)
      backend = HSGPU::Collide::make_cuda_backend(device);
    else
      backend = HSGPU::Collide::make_cpu_backend();
    if (device >= 0 || host_reference) {
      // One rank: whole steps on the device, in either order.  Several with gpu/gather yes:
      // rank 0's device runs each step over every rank's atoms of the group
      // (step_gathered()); with gpu/gather no each rank's host driver hands its device the
      // windows' groups.
      gather_step = comm->nprocs > 1 && gpu_gather;
      if (comm->nprocs == 1 || (gather_step && comm->me == 0)) {
        if (device >= 0)
          resident = HSGPU::Collide::make_cuda_resident_step(device);
        else
          resident = HSGPU::Collide::make_host_resident_step();
        resident->set_serial(serial_order);
      }
      // The other ranks copy their atoms to rank 0's device where they can (CUDA IPC on one
      // node; else, decided at the first step, through MPI).
      gath.ipc = gather_step && !std::getenv("HSGPU_GATHER_MPI") && hsgpu_one_node(world);
      if (gath.ipc && comm->me != 0 && device >= 0) {
        try {
          peer.reset(new HSGPU::GPU::PeerInputs(device));
        } catch (std::exception &e) {
          gath.why = e.what();
        }
      }
    }
  } catch (std::exception &e) {
    error->one(FLERR, "Fix hardsphere: cannot use CUDA device {}: {}", device, e.what());
  }
  if (host_reference && comm->me == 0)
    utils::logmesg(lmp, "Fix hardsphere: HSGPU_RESIDENT_HOST: the host's reference resident "
                        "step in the device step's place{}\n",
                   gather_step ? ", each step's atoms gathered on rank 0" : "");
  backend_device = device;
  if (device >= 0 && comm->me == 0)
    utils::logmesg(lmp, "Fix hardsphere: CUDA collision backend, rank 0 on device {} ({}){}\n",
                   device, HSGPU::GPU::device_description(device),
                   gather_step ? "; each step's atoms gathered on rank 0, whose device runs the step"
                   : (serial_order && !resident) ? "; order serial runs on the host"
                                                 : "");
}

double FixHardSphere::compute_vector(int n)
{
  switch (n) {
  case 0:
    return n_step;
  case 1:
    return n_total;
  case 2:
    return n_wall;
  case 3:
    return ke_total;
  case 4:
    return max_events;
  case 5:
    return events_total;
  case 6:
    return last_largest;
  case 7:
    return last_groups;
  case 8:
    return last_windows;
  case 9:
    return n_redo;
  case 10:
    return last_boundary;
  case 11:
    return t_search;
  case 12:
    return t_resolve;
  case 13:
    return n_push;
  case 14:
    return n_repair;
  case 15:
    return last_gathers;
  case 16:
    return (double) backend_device;
  case 17:
    return n_resident;
  case 18:
    return n_declined;
  case 19:
    return t_step;
  case 20: {
    // Summed over the ranks here (compute_vector runs on every rank).
    double all = 0.0;
    MPI_Allreduce(&last_candidates, &all, 1, MPI_DOUBLE, MPI_SUM, world);
    return last_candidates < 0.0 ? -1.0 : all;
  }
  case 21:
    return n_ghost_raise;
  case 22:
    return ghost_reach();
  case 23:
    return comm_last.collectives;
  case 24:
    return comm_last.halos;
  case 25: {
    double all = 0.0;
    MPI_Allreduce(&comm_last.bytes, &all, 1, MPI_DOUBLE, MPI_SUM, world);
    return all;
  }
  case 26:
    return last_spanning;
  case 27:
    return last_fallbacks;
  case 28:
    return last_gathered;
  case 29:
    return last_neighbour;
  case 30: {
    double all = 0.0;
    MPI_Allreduce(&comm_last.messages, &all, 1, MPI_DOUBLE, MPI_SUM, world);
    return all;
  }
  case 31:
    return last_forwards;
  case 32:
    return last_round_fails;
  case 33:
    return last_step_redos;
  default:
    return 0.0;
  }
}

/* --- restart ---------------------------------------------------------------------------- */

/* Global restart data: -RESTART_FORMAT, the count of values, the values (the totals, the
   last step's pair collisions and collision virial; the other figures of the last step and the
   timers start again).  Files written before the format marker hold 7 values: n_total n_wall
   ke_total max_events events_total n_redo n_step; older files of this format 9 or 11 (no
   virial) or 17 (no count of ghost cutoff raises).  Readers take the values they know and leave the
   rest. */
void FixHardSphere::write_restart(FILE *fp)
{
  // Every rank holds its share of the virial (LAMMPS sums them): the file holds the sum.
  double vsum[6];
  MPI_Allreduce(virial, vsum, 6, MPI_DOUBLE, MPI_SUM, world);
  const double state[] = {-(double) RESTART_FORMAT,
                          18.0,
                          n_total,
                          n_wall,
                          ke_total,
                          max_events,
                          events_total,
                          n_redo,
                          n_step,
                          n_push,
                          n_repair,
                          n_resident,
                          n_declined,
                          vsum[0],
                          vsum[1],
                          vsum[2],
                          vsum[3],
                          vsum[4],
                          vsum[5],
                          n_ghost_raise};
  const int count = (int) (sizeof(state) / sizeof(double));
  if (comm->me == 0) {
    const int size = (int) sizeof(state);
    fwrite(&size, sizeof(int), 1, fp);
    fwrite(state, sizeof(double), count, fp);
  }
}

void FixHardSphere::restart(char *buf)
{
  const auto *state = (const double *) buf;
  const double *v = state;
  int count = 7;
  if (state[0] < 0.0) {
    count = (int) state[1];
    v = state + 2;
  }
  n_total = v[0];
  n_wall = v[1];
  ke_total = v[2];
  max_events = v[3];
  events_total = v[4];
  n_redo = v[5];
  n_step = v[6];
  if (count > 7) n_push = v[7];
  if (count > 8) n_repair = v[8];
  if (count > 10) {
    n_resident = v[9];
    n_declined = v[10];
  }
  // The last step's collision virial, on rank 0 (the ranks' shares are summed by LAMMPS).
  for (int k = 0; k < 6; ++k) virial[k] = (count > 16 && comm->me == 0) ? v[11 + k] : 0.0;
  if (count > 17) n_ghost_raise = v[17];
}

/* --- per-atom state: time of the last collision ----------------------------------------- */

void FixHardSphere::grow_arrays(int nmax)
{
  // LAMMPS has grown (moved) its per-atom arrays: the device step lets go of the old ones.
  spoil_ahead();
  if (resident) resident->forget_host_arrays();
  if (peer) peer->forget_host_arrays();
  resident_same = false;
  memory->grow(tlast, nmax, "hardsphere:tlast");
  // The per-atom virial is computed in post_integrate, before the atoms of that step are
  // exchanged and sorted: it grows, moves and migrates with them (as tlast does) while it
  // holds a step's values (vflag_atom, the same on every rank).
  if ((vatom || vflag_atom) && nmax > maxvatom) {
    maxvatom = nmax;
    memory->grow(vatom, maxvatom, 6, "hardsphere:vatom");
  }
}

/* Atoms are moved in the arrays (a sort, an atom leaving), arrive (exchange) or are created
   (fix pour, fix deposit): the device step's copies of their arrays are stale. */
void FixHardSphere::copy_arrays(int i, int j, int)
{
  resident_same = false;
  tlast[j] = tlast[i];
  if (vflag_atom)
    for (int k = 0; k < 6; ++k) vatom[j][k] = vatom[i][k];
}

void FixHardSphere::set_arrays(int i)
{
  resident_same = false;
  tlast[i] = NEVER_COLLIDED;
  if (vflag_atom && i < maxvatom)
    for (int k = 0; k < 6; ++k) vatom[i][k] = 0.0;
}

int FixHardSphere::pack_exchange(int i, double *buf)
{
  buf[0] = tlast[i];
  if (!vflag_atom) return 1;
  for (int k = 0; k < 6; ++k) buf[1 + k] = vatom[i][k];
  return 7;
}

int FixHardSphere::unpack_exchange(int nlocal, double *buf)
{
  resident_same = false;
  tlast[nlocal] = buf[0];
  if (!vflag_atom) return 1;
  for (int k = 0; k < 6; ++k) vatom[nlocal][k] = buf[1 + k];
  return 7;
}

int FixHardSphere::pack_restart(int i, double *buf)
{
  buf[0] = 2;    // count first, as every fix's per-atom restart data
  buf[1] = tlast[i];
  return 2;
}

void FixHardSphere::unpack_restart(int nlocal, int nth)
{
  double **extra = atom->extra;
  int m = 0;
  for (int k = 0; k < nth; ++k) m += static_cast<int>(extra[nlocal][m]);
  tlast[nlocal] = extra[nlocal][m + 1];
}

int FixHardSphere::size_restart(int)
{
  return 2;
}

int FixHardSphere::maxsize_restart()
{
  return 2;
}

/* --- forward communication of the owners' positions and velocities ------------------------
   Raw owner coordinates (no periodic shift): every rank then computes a pair's separation
   from the same numbers with the same (anti-symmetric) arithmetic. */

int FixHardSphere::pack_forward_comm(int n, int *list_, double *buf, int, int *)
{
  const int nv = fwd_nval > 0 ? fwd_nval : NFWD;
  const std::vector<double> &src = fwd_nval > 0 ? xfwd : gdata;
  int m = 0;
  for (int k = 0; k < n; ++k) {
    const double *g = &src[(size_t) nv * list_[k]];
    for (int q = 0; q < nv; ++q) buf[m++] = g[q];
  }
  return m;
}

/* Reverse communication (the step driver's to_owner()): values whose flag (first value) is
   set replace those held; the others are left alone. */
int FixHardSphere::pack_reverse_comm(int n, int first, double *buf)
{
  const int nv = fwd_nval;
  int m = 0;
  for (int i = first; i < first + n; ++i) {
    const double *g = &xfwd[(size_t) nv * i];
    for (int q = 0; q < nv; ++q) buf[m++] = g[q];
  }
  return m;
}

void FixHardSphere::unpack_reverse_comm(int n, int *list_, double *buf)
{
  const int nv = fwd_nval;
  int m = 0;
  for (int k = 0; k < n; ++k, m += nv) {
    if (buf[m] == 0.0) continue;
    double *g = &xfwd[(size_t) nv * list_[k]];
    for (int q = 0; q < nv; ++q) g[q] = buf[m + q];
  }
}

void FixHardSphere::unpack_forward_comm(int n, int first, double *buf)
{
  const int nv = fwd_nval > 0 ? fwd_nval : NFWD;
  std::vector<double> &dst = fwd_nval > 0 ? xfwd : gdata;
  int m = 0;
  for (int i = first; i < first + n; ++i) {
    double *g = &dst[(size_t) nv * i];
    for (int q = 0; q < nv; ++q) g[q] = buf[m++];
  }
}

double FixHardSphere::memory_usage()
{
  double bytes = (double) atom->nmax * sizeof(double);
  bytes += (double) gdata.capacity() * sizeof(double);
  bytes += (double) (bodies.capacity() + lbodies.capacity() + gbodies.capacity()) *
           sizeof(HSGPU::Collide::Body);
  bytes += (double) (edges.capacity() + ledges.capacity() + gedges.capacity()) *
           sizeof(HSGPU::Collide::Edge);
  bytes += (double) maxvatom * 6 * sizeof(double);
  bytes += (double) (bvir.capacity() + lvir.capacity() + gvir.capacity()) * sizeof(double);
  return bytes;
}
