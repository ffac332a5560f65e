/* ----------------------------------------------------------------------------------
   HARDSPHERE_GPU: pair_style gravity, see pair_gravity.h and doc/pair_gravity.md
------------------------------------------------------------------------------------- */

#include "pair_gravity.h"

#include "atom.h"
#include "atom_gather.h"
#include "comm.h"
#include "domain.h"
#include "error.h"
#include "memory.h"
#include "utils.h"

#include "core/gravity_pair.h"

#include <cstring>

using namespace LAMMPS_NS;

PairGravity::PairGravity(LAMMPS *lmp) :
    Pair(lmp), gravity_g(0.0), softening_eps(0.0), cutoff(0.0), gather(nullptr)
{
  single_enable = 0;
  restartinfo = 1;
  one_coeff = 1;
  manybody_flag = 0;
  // Forces come from all atoms, not from ghosts: the f.r virial would be wrong.
  no_virial_fdotr_compute = 1;
  gather = new AtomGather(lmp, "gravity");
}

PairGravity::~PairGravity()
{
  delete gather;
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
  int iarg = 2;
  while (iarg < narg) {
    if (strcmp(arg[iarg], "cutoff") == 0) {
      if (iarg + 2 > narg)
        error->all(FLERR, "Illegal pair_style gravity command: cutoff needs a value");
      cutoff = utils::numeric(FLERR, arg[iarg + 1], false, lmp);
      if (cutoff <= 0.0)
        error->all(FLERR, "Illegal pair_style gravity command: cutoff must be > 0");
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
}

double PairGravity::init_one(int, int)
{
  // The all-pairs sum needs no ghost atoms: report no interaction range to the neighbor
  // and communication setup.
  return 0.0;
}

void PairGravity::compute(int eflag, int vflag)
{
  ev_init(eflag, vflag);
  gather->gather();
  const int nlocal = atom->nlocal;
  compute_cpu(nlocal);
  tally(nlocal);
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

void PairGravity::write_restart_settings(FILE *fp)
{
  fwrite(&gravity_g, sizeof(double), 1, fp);
  fwrite(&softening_eps, sizeof(double), 1, fp);
  fwrite(&cutoff, sizeof(double), 1, fp);
}

void PairGravity::read_restart_settings(FILE *fp)
{
  if (comm->me == 0) {
    utils::sfread(FLERR, &gravity_g, sizeof(double), 1, fp, nullptr, error);
    utils::sfread(FLERR, &softening_eps, sizeof(double), 1, fp, nullptr, error);
    utils::sfread(FLERR, &cutoff, sizeof(double), 1, fp, nullptr, error);
  }
  MPI_Bcast(&gravity_g, 1, MPI_DOUBLE, 0, world);
  MPI_Bcast(&softening_eps, 1, MPI_DOUBLE, 0, world);
  MPI_Bcast(&cutoff, 1, MPI_DOUBLE, 0, world);
}
