/* ----------------------------------------------------------------------------------
   HARDSPHERE_GPU: pair_style gravity, see pair_gravity.h and doc/pair_gravity.md
------------------------------------------------------------------------------------- */

#include "pair_gravity.h"

#include "atom.h"
#include "atom_gather.h"
#include "comm.h"
#include "domain.h"
#include "error.h"
#include "force.h"
#include "memory.h"
#include "utils.h"

#include "core/gravity_pair.h"
#include "gpu/device_info.cuh"
#include "gpu/gravity_engine.h"
#include "gpu_device_choice.h"

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

using namespace LAMMPS_NS;

PairGravity::PairGravity(LAMMPS *lmp) :
    Pair(lmp), gravity_g(0.0), softening_eps(0.0), cutoff(0.0), gather(nullptr), gpu_requested(0),
    precision((int) HSGPU::GPU::Precision::Mixed), device_request(-1), engine(nullptr),
    t_gather(0.0), t_upload(0.0), t_kernel(0.0), t_total(0.0), ncalls(0), ncalls_once(0),
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
           "device transfers+launch %.4g, kernels %.4g; pairs once in %ld calls\n",
           comm->me, ncalls, t_total / ncalls, t_gather / ncalls, t_upload / ncalls,
           t_kernel / ncalls, ncalls_once);
  else if (timing && comm->me == 0 && ncalls > 0)
    utils::logmesg(lmp,
                   "Pair gravity timing on rank 0 over {} calls (s/call): total {:.4g}, gather "
                   "{:.4g}, device transfers+launch {:.4g}, kernels {:.4g}; pairs once in {} "
                   "calls\n",
                   ncalls, t_total / ncalls, t_gather / ncalls, t_upload / ncalls,
                   t_kernel / ncalls, ncalls_once);
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
  if (gravity_g <= 0.0) error->all(FLERR, "Illegal pair_style gravity command: G must be > 0");
  if (softening_eps < 0.0)
    error->all(FLERR, "Illegal pair_style gravity command: eps must be >= 0");
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
      if (cutoff <= 0.0)
        error->all(FLERR, "Illegal pair_style gravity command: cutoff must be > 0");
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
  // No neighbor list: every rank sums over the gathered copy of all atoms.
  setup_gpu();
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
  gather->gather();
  const double t1 = timing ? MPI_Wtime() : 0.0;
  const int nlocal = atom->nlocal;
  if (engine)
    compute_gpu(nlocal);
  else
    compute_cpu(nlocal);
  tally(nlocal);
  if (timing) {
    const double t2 = MPI_Wtime();
    t_gather += t1 - t0;
    t_total += t2 - t0;
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

void PairGravity::compute_gpu(int nlocal)
{
  HSGPU::GPU::GravityArgs a;
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
  double **f = atom->f;
  sums.resize(nlocal);
  for (int i = 0; i < nlocal; ++i) {
    f[i][0] += gpu_f[3 * i];
    f[i][1] += gpu_f[3 * i + 1];
    f[i][2] += gpu_f[3 * i + 2];
    if (a.energy_virial) {
      sums[i].e = gpu_e[i];
      for (int k = 0; k < 6; ++k) sums[i].v[k] = gpu_v[6 * i + k];
    }
  }
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
