/* ----------------------------------------------------------------------------------
   HARDSPHERE_GPU: pair_style gravity, see pair_gravity.h and doc/pair_gravity.md
------------------------------------------------------------------------------------- */

#include "pair_gravity.h"

#include "atom.h"
#include "atom_gather.h"
#include "comm.h"
#include "compute.h"
#include "domain.h"
#include "error.h"
#include "force.h"
#include "memory.h"
#include "modify.h"
#include "neighbor.h"
#include "update.h"
#include "utils.h"

#include "core/gravity_pair.h"
#include "gpu/device_info.cuh"
#include "gpu/gravity_engine.h"
#include "gpu_device_choice.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

using namespace LAMMPS_NS;

PairGravity::PairGravity(LAMMPS *lmp) :
    Pair(lmp), gravity_g(0.0), softening_eps(0.0), cutoff(0.0), gather(nullptr), gpu_requested(0),
    precision((int) HSGPU::GPU::Precision::Mixed), device_request(-1), engine(nullptr),
    t_gather(0.0), t_upload(0.0), t_kernel(0.0), t_total(0.0), ncalls(0), ncalls_once(0),
    ncalls_overlap(0), ncalls_peer(0), peer_sources(false),
    timing(false), timing_all(false)
{
  single_enable = 0;
  restartinfo = 1;
  one_coeff = 1;
  manybody_flag = 0;
  // Forces come from all atoms, not from ghosts: the f.r virial would be wrong.
  no_virial_fdotr_compute = 1;
  gather = new AtomGather(lmp, "gravity");
  const char *t = std::getenv("HSGPU_TIMING");
  timing = t && *t && strcmp(t, "0") != 0;
  timing_all = timing && strcmp(t, "all") == 0;
}

PairGravity::~PairGravity()
{
  if (timing && timing_all && ncalls > 0)
    printf("Pair gravity timing on rank %d over %ld calls (s/call): total %.4g, gather %.4g, "
           "device transfers+launch %.4g, kernels %.4g; pairs once in %ld calls; gather "
           "overlapped with the kernels in %ld calls, from the other ranks' devices in %ld\n",
           comm->me, ncalls, t_total / ncalls, t_gather / ncalls, t_upload / ncalls,
           t_kernel / ncalls, ncalls_once, ncalls_overlap, ncalls_peer);
  else if (timing && comm->me == 0 && ncalls > 0)
    utils::logmesg(lmp,
                   "Pair gravity timing on rank 0 over {} calls (s/call): total {:.4g}, gather "
                   "{:.4g}, device transfers+launch {:.4g}, kernels {:.4g}; pairs once in {} "
                   "calls; gather overlapped with the kernels in {} calls, from the other ranks' "
                   "devices in {}\n",
                   ncalls, t_total / ncalls, t_gather / ncalls, t_upload / ncalls,
                   t_kernel / ncalls, ncalls_once, ncalls_overlap, ncalls_peer);
  delete gather;
  delete engine;
  if (allocated) {
    memory->destroy(setflag);
    memory->destroy(cutsq);
  }
}

void PairGravity::allocate()
{
  allocated = 1;
  const int n = atom->ntypes;
  memory->create(setflag, n + 1, n + 1, "pair:setflag");
  memory->create(cutsq, n + 1, n + 1, "pair:cutsq");
  for (int i = 1; i <= n; i++)
    for (int j = i; j <= n; j++) setflag[i][j] = 0;
}

/* pair_style gravity G eps [cutoff rc] */
void PairGravity::settings(int narg, char **arg)
{
  if (narg < 2)
    error->all(FLERR, "Illegal pair_style gravity command: expected G and eps, got {} argument(s)",
               narg);
  gravity_g = utils::numeric(FLERR, arg[0], false, lmp);
  softening_eps = utils::numeric(FLERR, arg[1], false, lmp);
  if (!(gravity_g > 0.0) || !std::isfinite(gravity_g))
    error->all(FLERR, "Illegal pair_style gravity command: G must be > 0 and finite, got {}",
               arg[0]);
  if (!(softening_eps >= 0.0) || !std::isfinite(softening_eps))
    error->all(FLERR, "Illegal pair_style gravity command: eps must be >= 0 and finite, got {}",
               arg[1]);
  // The sums use eps^2: one that underflows to 0 would silently mean no softening.
  if (softening_eps > 0.0 && !std::isnormal(softening_eps * softening_eps))
    error->all(FLERR,
               "Illegal pair_style gravity command: eps {} has a square that {} in double "
               "precision; use 0 for no softening, or eps between {:.4g} and {:.4g}",
               arg[1], softening_eps < 1.0 ? "underflows" : "overflows", std::sqrt(DBL_MIN),
               std::sqrt(DBL_MAX));
  cutoff = 0.0;
  gpu_requested = 0;
  precision = (int) HSGPU::GPU::Precision::Mixed;
  device_request = -1;
  int iarg = 2;
  while (iarg < narg) {
    if (strcmp(arg[iarg], "cutoff") == 0) {
      if (iarg + 2 > narg)
        error->all(FLERR, "Illegal pair_style gravity command: cutoff needs a value");
      cutoff = utils::numeric(FLERR, arg[iarg + 1], false, lmp);
      if (!(cutoff > 0.0) || !std::isfinite(cutoff))
        error->all(FLERR,
                   "Illegal pair_style gravity command: cutoff must be > 0 and finite, "
                   "got {}",
                   arg[iarg + 1]);
      // The sums compare r^2 with rc^2, and rc^2 = 0 means no cutoff: a cutoff whose square
      // underflows would silently become none.
      if (!std::isnormal(cutoff * cutoff))
        error->all(FLERR,
                   "Illegal pair_style gravity command: cutoff {} has a square that {} in "
                   "double precision; give a cutoff between {:.4g} and {:.4g}, or none",
                   arg[iarg + 1], cutoff < 1.0 ? "underflows" : "overflows", std::sqrt(DBL_MIN),
                   std::sqrt(DBL_MAX));
      iarg += 2;
    } else if (strcmp(arg[iarg], "gpu") == 0) {
      if (iarg + 2 > narg)
        error->all(FLERR, "Illegal pair_style gravity command: gpu needs yes or no");
      const std::string v = arg[iarg + 1];
      if (v == "yes" || v == "on" || v == "true" || v == "1")
        gpu_requested = 1;
      else if (v == "no" || v == "off" || v == "false" || v == "0")
        gpu_requested = 0;
      else
        error->all(FLERR, "Illegal pair_style gravity command: gpu must be yes or no, not {}", v);
      iarg += 2;
    } else if (strcmp(arg[iarg], "precision") == 0) {
      if (iarg + 2 > narg)
        error->all(FLERR,
                   "Illegal pair_style gravity command: precision needs single, mixed or double");
      if (strcmp(arg[iarg + 1], "single") == 0)
        precision = (int) HSGPU::GPU::Precision::Single;
      else if (strcmp(arg[iarg + 1], "mixed") == 0)
        precision = (int) HSGPU::GPU::Precision::Mixed;
      else if (strcmp(arg[iarg + 1], "double") == 0)
        precision = (int) HSGPU::GPU::Precision::Double;
      else
        error->all(FLERR, "Illegal pair_style gravity command: unknown precision {}",
                   arg[iarg + 1]);
      iarg += 2;
    } else if (strcmp(arg[iarg], "device") == 0) {
      if (iarg + 2 > narg)
        error->all(FLERR, "Illegal pair_style gravity command: device needs auto or a number");
      if (strcmp(arg[iarg + 1], "auto") == 0) {
        device_request = -1;
      } else {
        device_request = utils::inumeric(FLERR, arg[iarg + 1], false, lmp);
        if (device_request < 0)
          error->all(FLERR, "Illegal pair_style gravity command: device must be auto or >= 0");
      }
      iarg += 2;
    } else {
      error->all(FLERR, "Illegal pair_style gravity command: unknown keyword {}", arg[iarg]);
    }
  }
}

/* pair_coeff * * : all pairs interact; the style takes no per-type parameters */
void PairGravity::coeff(int narg, char **arg)
{
  if (narg != 2)
    error->all(FLERR, "Incorrect args for pair coefficients: pair style gravity takes only "
                      "'pair_coeff * *'");
  if (!allocated) allocate();
  const int n = atom->ntypes;
  int ilo, ihi, jlo, jhi;
  utils::bounds(FLERR, arg[0], 1, n, ilo, ihi, error);
  utils::bounds(FLERR, arg[1], 1, n, jlo, jhi, error);
  for (int i = 1; i <= n; i++)
    for (int j = i; j <= n; j++) setflag[i][j] = 1;
}

void PairGravity::init_style()
{
  if (!atom->tag_enable) error->all(FLERR, "Pair style gravity requires atom IDs");
  if (domain->triclinic) error->all(FLERR, "Pair style gravity requires an orthogonal box");
  if (atom->natoms > 2147483647L / 5)
    error->all(FLERR, "Pair style gravity supports at most {} atoms", 2147483647L / 5);
  if (!atom->rmass_flag) {
    for (int t = 1; t <= atom->ntypes; ++t)
      if (!atom->mass_setflag[t] || !(atom->mass[t] > 0.0))
        error->all(FLERR, "Pair style gravity requires a positive mass for atom type {}", t);
  }
  // No neighbor list: every rank sums over the gathered copy of all atoms.  compute
  // pair/local walks a neighbor list, which holds none of this style's pairs (its range is
  // 1e-10), and there is no single(): it would list nothing, silently.
  if (force->pair == this)
    for (int c = 0; c < modify->ncompute; ++c)
      if (utils::strmatch(modify->compute[c]->style, "^pair/local"))
        error->all(FLERR,
                   "Pair style gravity does not support compute pair/local (compute {}): it "
                   "sums over all pairs without a neighbor list and has no single() function",
                   modify->compute[c]->id);
  choose_sort_bins();
  setup_gpu();
}

/* LAMMPS sorts the atoms in bins of half the neighbor cutoff unless a bin size was given
   (atom_modify sort).  This style's range is negligible, so that is half the skin, and in a
   large box the bins run into the billions: LAMMPS stops with "Too many atom sorting bins" or
   allocates gigabytes for them (a slab of 1e6 spheres 512 x 512 x 36 wide: 2.8e9 bins).  As
   LAMMPS's GPU package picks its own bin size, where this style is the pair style, sorting is
   on, no size was given and the default would make more than 8 bins per local atom (and more
   than 1e6) on some rank, the bin size becomes the edge of a cell that holds one atom on
   average on the rank whose atoms are sparsest (one value for all ranks). */
void PairGravity::choose_sort_bins()
{
  if (force->pair != this || atom->sortfreq <= 0 || atom->userbinsize > 0.0) return;
  const int dim = domain->dimension;
  const double half = 0.5 * (neighbor->skin + init_one(1, 1));
  double bins = 1.0, vol = 1.0;
  for (int d = 0; d < dim; ++d) {
    const double len = domain->subhi[d] - domain->sublo[d];
    bins *= std::max(1.0, std::floor(len / half));
    vol *= len;
  }
  const double n = std::max(1, atom->nlocal);
  double mine[2] = {bins > std::max(8.0 * n, 1.0e6) ? 1.0 : 0.0, std::pow(vol / n, 1.0 / dim)};
  double all[2];
  MPI_Allreduce(mine, all, 2, MPI_DOUBLE, MPI_MAX, world);
  if (all[0] == 0.0 || !(all[1] > half)) return;
  atom->userbinsize = all[1];
  if (comm->me == 0)
    utils::logmesg(lmp,
                   "Pair gravity: atom sorting bin size set to {:.6g} (half the neighbor cutoff, "
                   "{:.6g}, would make more than 8 bins per atom; atom_modify sort sets it)\n",
                   all[1], half);
}

/* One CUDA device per rank: the one the user named, or the node-local rank modulo the
   number of devices (gpu_device_choice.h).  Without a usable device the CPU path runs, with a
   message. */
void PairGravity::setup_gpu()
{
  if (!gpu_requested) {
    delete engine;
    engine = nullptr;
    return;
  }
  const int device = hsgpu_choose_device(lmp, world, device_request, "Pair gravity");
  if (device < 0) {
    delete engine;
    engine = nullptr;
    return;
  }
  if (!engine || engine->device() != device) {
    delete engine;
    engine = nullptr;
    try {
      engine = new HSGPU::GPU::GravityEngine(device);
    } catch (std::exception &e) {
      error->one(FLERR, "Pair gravity: cannot use CUDA device {}: {}", device, e.what());
    }
  }
  // Several ranks of one node read each other's positions from their devices (CUDA IPC)
  // instead of gathering them on every host; HSGPU_GATHER_MPI=1 keeps the host's gather.
  peer_sources =
      comm->nprocs > 1 && !std::getenv("HSGPU_GATHER_MPI") && hsgpu_one_node(world);
  if (comm->me == 0 && comm->nprocs > 1)
    utils::logmesg(lmp, "Pair gravity: {}\n",
                   peer_sources ? "each rank copies the other ranks' positions from their "
                                  "devices (one node, CUDA IPC)"
                                : "the positions of all ranks are gathered through MPI");
  if (comm->me == 0) {
    static const char *names[] = {"single", "mixed", "double"};
    utils::logmesg(lmp, "Pair gravity: CUDA path, precision {}, rank 0 on device {} ({})\n",
                   names[precision], device, HSGPU::GPU::device_description(device));
    const bool open = !domain->xperiodic && !domain->yperiodic && !domain->zperiodic;
    if (force->newton_pair && comm->nprocs == 1 && open && cutoff <= 0.0)
      utils::logmesg(lmp,
                     "Pair gravity: newton on, one rank, open box, no cutoff: each pair "
                     "evaluated once on force-only steps with {} or more atoms\n",
                     HSGPU::GPU::PAIRS_ONCE_MIN_N);
  }
}

double PairGravity::init_one(int, int)
{
  // The all-pairs sum needs no ghost atoms.  A zero range would make LAMMPS warn at every
  // reneighboring that no ghosts are made; a negligible one leaves ghosts within the skin.
  return 1.0e-10;
}

void PairGravity::compute(int eflag, int vflag)
{
  ev_init(eflag, vflag);
  const double t0 = timing ? MPI_Wtime() : 0.0;
  // The CPU path sums in atom-ID order (results independent of the decomposition); the GPU
  // path takes the atoms in the order they arrive.
  gather->id_order = (engine == nullptr);
  const int nlocal = atom->nlocal;
  double t_gathered = 0.0;
  if (engine && comm->nprocs > 1) {
    compute_gpu_overlapped(nlocal, t_gathered);
  } else {
    gather->gather();
    t_gathered = timing ? MPI_Wtime() - t0 : 0.0;
    if (engine)
      compute_gpu(nlocal);
    else
      compute_cpu(nlocal);
  }
  check_forces(nlocal);
  tally(nlocal);
  if (timing) {
    t_gather += t_gathered;
    t_total += MPI_Wtime() - t0;
    ++ncalls;
  }
}

void PairGravity::compute_cpu(int nlocal)
{
  HSGPU::Gravity::Params p;
  p.G = gravity_g;
  p.eps2 = softening_eps * softening_eps;
  p.cutsq = cutoff * cutoff;
  double **f = atom->f;
  sums.resize(nlocal);
  const double *gx = gather->x.data();
  const double *gm = gather->mass.data();
  const long *gidx = gather->index.data();
  const long n = gather->ntotal;
  const HSGPU::Gravity::Box box = gather->box;

#if defined(_OPENMP)
#pragma omp parallel for num_threads(comm->nthreads) schedule(static)
#endif
  for (int i = 0; i < nlocal; ++i) {
    const long gi = gidx[i];
    HSGPU::Gravity::Accum a;
    HSGPU::Gravity::sum_on_target(gx + 3 * gi, gm[gi], gi, gx, gm, n, box, p, a);
    f[i][0] += a.f[0];
    f[i][1] += a.f[1];
    f[i][2] += a.f[2];
    sums[i].e = a.e;
    for (int k = 0; k < 6; ++k) sums[i].v[k] = a.v[k];
  }
}

// The engine's arguments for this step (the box of the last gather) and room for its results.
void PairGravity::gpu_args(int nlocal, HSGPU::GPU::GravityArgs &a)
{
  a.G = gravity_g;
  a.eps2 = softening_eps * softening_eps;
  a.cutsq = cutoff * cutoff;
  for (int d = 0; d < 3; ++d) {
    a.lo[d] = gather->box.lo[d];
    a.prd[d] = gather->box.prd[d];
    a.periodic[d] = gather->box.periodic[d];
  }
  a.energy_virial = (eflag_either || vflag_either);
  // newton on (the LAMMPS default): on one rank, where every atom is a target, each pair may
  // be evaluated once for both atoms; the engine does so on force-only steps where it is
  // faster (doc/pair_gravity.md).
  a.pairs_once = force->newton_pair ? 1 : 0;
  gpu_f.resize(3 * (size_t) nlocal);
  gpu_e.resize(a.energy_virial ? nlocal : 0);
  gpu_v.resize(a.energy_virial ? 6 * (size_t) nlocal : 0);
}

void PairGravity::add_gpu_results(int nlocal, bool energy_virial)
{
  double **f = atom->f;
  sums.resize(nlocal);
  for (int i = 0; i < nlocal; ++i) {
    f[i][0] += gpu_f[3 * i];
    f[i][1] += gpu_f[3 * i + 1];
    f[i][2] += gpu_f[3 * i + 2];
    if (energy_virial) {
      sums[i].e = gpu_e[i];
      for (int k = 0; k < 6; ++k) sums[i].v[k] = gpu_v[6 * i + k];
    }
  }
}

void PairGravity::compute_gpu(int nlocal)
{
  HSGPU::GPU::GravityArgs a;
  gpu_args(nlocal, a);
  try {
    const double t0 = timing ? MPI_Wtime() : 0.0;
    engine->set_sources(gather->ntotal, gather->x.data(), gather->mass.data(),
                        gather->changed_masses);
    engine->set_targets(nlocal, gather->index.data());
    engine->compute((HSGPU::GPU::Precision) precision, a, gpu_f.data(), gpu_e.data(), gpu_v.data());
    if (timing) {
      ncalls_once += engine->last_pairs_once() ? 1 : 0;
      const double k = 1e-3 * engine->last_kernel_ms();
      t_kernel += k;
      t_upload += MPI_Wtime() - t0 - k;
    }
  } catch (std::exception &e) {
    error->one(FLERR, "Pair gravity on CUDA device {}: {}", engine->device(), e.what());
  }
  add_gpu_results(nlocal, a.energy_virial);
}

/* Several ranks: the device starts on the sums over the rank's own atoms (known before the
   gather) and the gather of the other ranks' positions, most of the bytes, runs meanwhile;
   then the sums over the other atoms.  Collective, as gather() is. */
void PairGravity::compute_gpu_overlapped(int nlocal, double &t_gathered)
{
  const double t0 = MPI_Wtime();
  gather->prepare();
  const double t1 = MPI_Wtime();
  HSGPU::GPU::GravityArgs a;
  gpu_args(nlocal, a);
  a.pairs_once = 0;    // not every atom is a target here
  const auto prec = (HSGPU::GPU::Precision) precision;
  try {
    engine->set_targets(nlocal, gather->index.data());
    engine->begin_own(prec, a, gather->ntotal, gather->own_first(), nlocal, gather->own_x(),
                      gather->own_mass(), gather->masses_travel());
  } catch (std::exception &e) {
    error->one(FLERR, "Pair gravity on CUDA device {}: {}", engine->device(), e.what());
  }
  const double t2 = MPI_Wtime();
  const bool peers = peer_sources && sources_from_peers();
  if (!peers) gather->exchange();
  const double t3 = MPI_Wtime();
  try {
    if (peers)
      engine->finish_from_peers(rank_first, rank_count, gpu_f.data(), gpu_e.data(), gpu_v.data());
    else
      engine->finish_rest(gather->x.data(), gather->mass.data(), gpu_f.data(), gpu_e.data(),
                          gpu_v.data());
  } catch (std::exception &e) {
    error->one(FLERR, "Pair gravity on CUDA device {}: {}", engine->device(), e.what());
  }
  const double t4 = MPI_Wtime();
  if (timing && peers) ++ncalls_peer;
  t_gathered = (t1 - t0) + (t3 - t2);
  if (timing) {
    ++ncalls_overlap;
    const double k = 1e-3 * engine->last_kernel_ms();
    t_kernel += k;
    t_upload += std::max(0.0, t4 - t1 - k);
  }
  add_gpu_results(nlocal, a.energy_virial);
}

/* Ranks of one node: instead of the host's gather, every rank's device buffers of positions
   and masses are opened by the others (CUDA IPC), which copy the other ranks' atoms from
   there (GravityEngine::finish_from_peers()).  Collective; false on every rank where some rank
   could not (the host's gather then takes over for the rest of the run, with a log line). */
bool PairGravity::sources_from_peers()
{
  int ok = 1;
  try {
    ok = engine->share_sources(peer_mine) ? 1 : 0;
  } catch (std::exception &) {
    ok = 0;
  }
  int all = 0;
  MPI_Allreduce(&ok, &all, 1, MPI_INT, MPI_MIN, world);
  std::string why = "a device would not share its buffers";
  if (all) {
    // Every rank's own positions are on its device now (share_sources() waited for them).
    peer_all.resize(peer_mine.size() * comm->nprocs);
    MPI_Allgather(peer_mine.data(), (int) peer_mine.size(), MPI_CHAR, peer_all.data(),
                  (int) peer_mine.size(), MPI_CHAR, world);
    try {
      engine->open_peers(peer_all, comm->me);
    } catch (std::exception &e) {
      ok = 0;
      why = e.what();
    }
    MPI_Allreduce(&ok, &all, 1, MPI_INT, MPI_MIN, world);
  }
  if (all) {
    gather->rank_ranges(rank_first, rank_count);
    return true;
  }
  peer_sources = false;
  int who = ok ? comm->nprocs : comm->me, first_bad = 0;
  MPI_Allreduce(&who, &first_bad, 1, MPI_INT, MPI_MIN, world);
  if (comm->me == first_bad)
    utils::logmesg(lmp,
                   "Pair gravity: rank {} cannot read the other ranks' positions from their "
                   "devices ({}); they are gathered through MPI for the rest of the run\n",
                   comm->me, why);
  return false;
}

/* Collective: stops with an error that names the problem where the forces cannot be right.
   A non-finite force: two atoms at one point without softening, or an overflow.  A force that
   alone moves an atom by more than the box length in one step (along a periodic or fixed
   direction, where LAMMPS would then lose the atom): G far too large for the masses and
   distances, or the timestep far too long.  O(N) per step and one reduction of two values. */
void PairGravity::check_forces(int nlocal)
{
  double **f = atom->f;
  const double *rmass = atom->rmass, *pmass = atom->mass;
  const int *type = atom->type;
  const double dt = update->dt;
  const bool dynamics = update->whichflag == 1 && dt > 0.0;
  bool bounded[3];
  for (int d = 0; d < 3; ++d)
    bounded[d] = dynamics && (domain->boundary[d][0] <= 1 || domain->boundary[d][1] <= 1);
  double loc[2] = {0.0, 0.0};    // any non-finite force, largest step / box length
  int worst = -1, worst_dim = 0;
  for (int i = 0; i < nlocal; ++i) {
    if (!std::isfinite(f[i][0]) || !std::isfinite(f[i][1]) || !std::isfinite(f[i][2])) {
      loc[0] = 1.0;
      continue;
    }
    const double scale = 0.5 * dt * dt * force->ftm2v / (rmass ? rmass[i] : pmass[type[i]]);
    for (int d = 0; d < 3; ++d) {
      if (!bounded[d]) continue;
      const double ratio = std::fabs(f[i][d]) * scale / domain->prd[d];
      if (ratio > loc[1]) {
        loc[1] = ratio;
        worst = i;
        worst_dim = d;
      }
    }
  }
  double glob[2];
  MPI_Allreduce(loc, glob, 2, MPI_DOUBLE, MPI_MAX, world);
  if (glob[0] > 0.0) report_nonfinite(nlocal);
  if (!(glob[1] > 1.0)) return;

  // The atom with the largest step: its owner sends what the message says.
  struct {
    double ratio;
    int rank;
  } in = {loc[1], comm->me}, out;
  MPI_Allreduce(&in, &out, 1, MPI_DOUBLE_INT, MPI_MAXLOC, world);
  double info[4] = {0.0, 0.0, 0.0, 0.0};    // ID, direction, |F_d|, step
  if (comm->me == out.rank) {
    info[0] = (double) atom->tag[worst];
    info[1] = worst_dim;
    info[2] = std::fabs(f[worst][worst_dim]);
    info[3] = loc[1] * domain->prd[worst_dim];
  }
  MPI_Bcast(info, 4, MPI_DOUBLE, out.rank, world);
  const int d = (int) info[1];
  error->all(FLERR,
             "Pair style gravity: the force on atom {} at step {} ({:.6g} along {}) moves it "
             "{:.6g} in one timestep, more than the box length {:.6g}: atoms would be lost. G = "
             "{:.6g} is far too large for these masses and distances, or the timestep {:.6g} far "
             "too long{}",
             (tagint) info[0], update->ntimestep, info[2], "xyz"[d], info[3], domain -> prd[d],
             gravity_g, dt, softening_eps > 0.0 ? "" : " (or close atoms need eps > 0)");
}

/* Collective, after a non-finite force: stops with an error naming the atom with the lowest ID
   whose force is not finite and its nearest atom (from an atom-ID-ordered gather, whatever
   the path). */
void PairGravity::report_nonfinite(int nlocal)
{
  double **f = atom->f;
  tagint mine = MAXTAGINT, bad = MAXTAGINT;
  for (int i = 0; i < nlocal; ++i)
    if (!std::isfinite(f[i][0]) || !std::isfinite(f[i][1]) || !std::isfinite(f[i][2]))
      mine = std::min(mine, atom->tag[i]);
  MPI_Allreduce(&mine, &bad, 1, MPI_LMP_TAGINT, MPI_MIN, world);
  gather->id_order = true;
  gather->gather();
  const long n = gather->ntotal;
  const double *gx = gather->x.data();
  const HSGPU::Gravity::Box &box = gather->box;
  long sb = 0;
  while (sb < n - 1 && gather->id_at(sb) != bad) ++sb;
  long near = -1;
  double r2min = 0.0;
  for (long j = 0; j < n; ++j) {
    if (j == sb) continue;
    double r2 = 0.0;
    for (int d = 0; d < 3; ++d) {
      const double dd = HSGPU::Gravity::nearest_image(gx[3 * sb + d] - gx[3 * j + d], box.prd[d],
                                                      box.periodic[d]);
      r2 += dd * dd;
    }
    if (near < 0 || r2 < r2min) {
      near = j;
      r2min = r2;
    }
  }
  if (near >= 0 && r2min == 0.0 && softening_eps == 0.0)
    error->all(FLERR,
               "Pair style gravity: atoms {} and {} are at the same position ({:.10g}, {:.10g}, "
               "{:.10g}) at step {} with eps = 0 (no softening): their force and energy are "
               "infinite. Use eps > 0, or move the atoms apart",
               std::min(bad, gather->id_at(near)), std::max(bad, gather->id_at(near)), gx[3 * sb],
               gx[3 * sb + 1], gx[3 * sb + 2], update->ntimestep);
  if (near >= 0)
    error->all(FLERR,
               "Pair style gravity: the force on atom {} is not finite at step {}: its nearest "
               "atom {} is {:.6g} away, G = {:.6g}, eps = {:.6g}; the pair terms overflow double "
               "precision",
               bad, update->ntimestep, gather->id_at(near), std::sqrt(r2min), gravity_g,
               softening_eps);
  error->all(FLERR, "Pair style gravity: the force on atom {} is not finite at step {}", bad,
             update->ntimestep);
}

/* Energy and virial tallies, summed in atom order so that results are reproducible. */
void PairGravity::tally(int nlocal)
{
  for (int i = 0; i < nlocal; ++i) {
    const TargetSums &s = sums[i];
    if (eflag_global) eng_vdwl += s.e;
    if (eflag_atom) eatom[i] += s.e;
    if (vflag_global)
      for (int k = 0; k < 6; ++k) virial[k] += s.v[k];
    if (vflag_atom)
      for (int k = 0; k < 6; ++k) vatom[i][k] += s.v[k];
  }
}

void PairGravity::write_restart(FILE *fp)
{
  write_restart_settings(fp);
}

void PairGravity::read_restart(FILE *fp)
{
  read_restart_settings(fp);
  allocate();
  const int n = atom->ntypes;
  for (int i = 1; i <= n; i++)
    for (int j = i; j <= n; j++) setflag[i][j] = 1;
}

// Restart layout version, written first so that a changed layout is recognised.
static constexpr int RESTART_VERSION = 2;

void PairGravity::write_restart_settings(FILE *fp)
{
  const int version = RESTART_VERSION;
  fwrite(&version, sizeof(int), 1, fp);
  fwrite(&gravity_g, sizeof(double), 1, fp);
  fwrite(&softening_eps, sizeof(double), 1, fp);
  fwrite(&cutoff, sizeof(double), 1, fp);
  int flags[3] = {gpu_requested, precision, device_request};
  fwrite(flags, sizeof(int), 3, fp);
}

void PairGravity::read_restart_settings(FILE *fp)
{
  if (comm->me == 0) {
    int version = 0;
    utils::sfread(FLERR, &version, sizeof(int), 1, fp, nullptr, error);
    if (version != RESTART_VERSION)
      error->one(FLERR, "Pair gravity: restart file has settings layout {}, this plugin reads {}",
                 version, RESTART_VERSION);
    utils::sfread(FLERR, &gravity_g, sizeof(double), 1, fp, nullptr, error);
    utils::sfread(FLERR, &softening_eps, sizeof(double), 1, fp, nullptr, error);
    utils::sfread(FLERR, &cutoff, sizeof(double), 1, fp, nullptr, error);
    int flags[3];
    utils::sfread(FLERR, flags, sizeof(int), 3, fp, nullptr, error);
    gpu_requested = flags[0];
    precision = flags[1];
    if (precision < 0 || precision > 2)
      error->one(FLERR, "Pair gravity: invalid precision {} in restart file", precision);
    device_request = flags[2];
  }
  MPI_Bcast(&gravity_g, 1, MPI_DOUBLE, 0, world);
  MPI_Bcast(&softening_eps, 1, MPI_DOUBLE, 0, world);
  MPI_Bcast(&cutoff, 1, MPI_DOUBLE, 0, world);
  MPI_Bcast(&gpu_requested, 1, MPI_INT, 0, world);
  MPI_Bcast(&precision, 1, MPI_INT, 0, world);
  MPI_Bcast(&device_request, 1, MPI_INT, 0, world);
}
