/* ----------------------------------------------------------------------------------
   HARDSPHERE_GPU: fix hardsphere, the step (see fix_hardsphere.h).

   post_integrate():
     1. each atom's displacement bound for the step (twice its own drift |v| dt, at least a
        floor of half the fastest atom's drift and bow, at most the step's reach); where the
        fastest atom may move further than the reach, the step's reach is all that the ghost
        atoms cover (ghost_reach());
     2. forward communication of the owners' positions and velocities to the ghosts;
     3. bodies for the owned atoms (start points X0 = x - vh dt), candidate pairs whose start
        points are within their two radii plus their two bounds (the fix's own cell search
        over owned and ghost atoms, nearest image), overlap check (error or push);
     4. the step driver (engine/window_driver.h) resolves the step in time windows, each
        split into groups that cannot influence each other; groups that reach a ghost owned
        by another rank are gathered from all ranks and resolved identically on every rank.
        With 'order serial': the seed paper's global loop (Hawick and Playne 2011, see
        README) over all of this rank's bodies (several ranks: over all bodies, gathered);
     5. check that no pair outside the candidates could have touched (an atom moved further
        than its bound and, with its partner, at least their gap); if one could, raise those
        atoms' bounds and redo the step; an atom that moved further than the ghosts cover
        stops the run, naming the reach to set;
     6. positions and half-step velocities back to the atoms, counters, virial; on steps
        where LAMMPS asks for per-atom virials (update->vflag_atom, set by Integrate::ev_set
        before post_integrate) also those: half of each pair collision's r (x) dp to each of
        its two atoms, all of a wall collision's to its atom, each rank to its own atoms.
        Such steps run on the host (not the device-resident step, and with the CPU backend
        in place of the CUDA one), which gives the same trajectories bit for bit;
     7. where the next step at the atoms' present speeds would move one further than half of
        what the ghosts cover: a reneighboring at the end of this step, at which the ghost
        cutoff is raised (plan_ghost_raise(), pre_exchange()).
------------------------------------------------------------------------------------- */

#include "fix_hardsphere.h"

#include "atom.h"
#include "comm.h"
#include "domain.h"
#include "error.h"
#include "force.h"
#include "group.h"
#include "memory.h"
#include "neighbor.h"
#include "update.h"
#include "utils.h"

#include "core/collision_step.h"
#include "lmp_compat.h"
#include "fix_hardsphere_exchange.h"
#include "gpu/peer_inputs.h"
#include "mpi_allgather.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <exception>
#include <mpi.h>
#include <new>

using namespace LAMMPS_NS;
using HSGPU::Collide::Body;
using HSGPU::Collide::Edge;
using HSGPU::Collide::Params;
using HSGPU::Collide::Tally;

namespace {

constexpr double OVERLAP_TOL = 1e-9;    // pairs closer than (1 - tol) x contact overlap
// overlap push moves a pair to this much beyond contact (relative): a margin well above the
// overlap criterion lets the relaxation end in a few passes rather than creep up to it.
constexpr double PUSH_MARGIN = 1e-6;
// How far inside a fixed boundary a push leaves an atom's centre, as a fraction of the box
// length: well clear of the round-off that decides which side of the face an atom is on.
constexpr double PUSH_INSET = 1e-9;
constexpr int NSTATE = 15;    // doubles per body in the boundary exchange (3 more with friction)

// Seconds of MPI_Wtime() since t, and t moved to now (the run summary's parts).
double lap(double &t)
{
  const double now = MPI_Wtime();
  const double s = now - t;
  t = now;
  return s;
}

// Lexicographic order of overlap reports: lower atom ID first, walls (negative) first.
bool before(double a1, double b1, double a2, double b2)
{
  return a1 < a2 || (a1 == a2 && b1 < b2);
}

}    // namespace

Params FixHardSphere::step_params() const
{
  Params p;
  p.dt = update->dt;
  p.tc = current_tc();
  p.vmin = vmin;
  p.vmin_atc = vmin_auto ? HSGPU::Collide::VMIN_AUTO_ATC : 0.0;
  p.tcslow = tc_slow;
  p.walls = walls;
  for (int f = 0; f < HSGPU::Collide::NFACES; ++f)
    p.walls.pos[f] = (f & 1) ? domain->boxhi[f / 2] : domain->boxlo[f / 2];
  p.ntypes = atom->ntypes;
  p.epair = epair.data();
  p.maxevents = (long) maxevents;
  p.friction = 0;
  if (friction_on)
    p.friction =
        friction_guard ? HSGPU::Collide::FRICTION_GUARDED : HSGPU::Collide::FRICTION_WALTON;
  p.inertia = inertia;
  p.fpair = fpair.data();
  return p;
}

/* The owners' state to the ghosts, with each atom's displacement bound for the step: twice
   its drift over the step, at least bound_floor (or what a failed check of this step raised
   it to), at most the reach the ghosts cover. */
void FixHardSphere::forward_state(double drift_dt)
{
  const int nlocal = atom->nlocal;
  if (gdata.size() < (size_t) NFWD * atom->nmax) gdata.resize((size_t) NFWD * atom->nmax);
  if (sboost.size() < (size_t) nlocal) sboost.resize(nlocal, 0.0);
  double **x = atom->x, **v = atom->v;
  const double *radius = atom->radius;
  for (int i = 0; i < nlocal; ++i) {
    double *g = &gdata[(size_t) NFWD * i];
    for (int d = 0; d < 3; ++d) {
      g[d] = x[i][d];
      g[3 + d] = v[i][d];
    }
    g[6] = radius[i];
    g[7] = comm->me;
    g[8] = i;
    g[9] = step_bound(i, drift_dt);
  }
  const double t0 = MPI_Wtime();
  HsgpuCompat::forward_comm(comm, this);
  comm_step.seconds += MPI_Wtime() - t0;
  // Ghosts whose owner is another rank: their values came in a message.
  remote_ghosts = 0;
  const int nall = nlocal + atom->nghost;
  for (int j = nlocal; j < nall; ++j)
    if ((int) gdata[(size_t) NFWD * j + 7] != comm->me) ++remote_ghosts;
  count_halo(NFWD);
}

/* MPI_Allreduce over the world, counted in the step's communication. */
void FixHardSphere::allreduce(const void *in, void *out, int n, MPI_Datatype type, MPI_Op op)
{
  const double t0 = MPI_Wtime();
  MPI_Allreduce(const_cast<void *>(in), out, n, type, op, world);
  comm_step.seconds += MPI_Wtime() - t0;
  int size = 0;
  MPI_Type_size(type, &size);
  count_collective((double) n * size);
}

/* A collective operation of the step carrying `bytes` to this rank (none on one rank). */
void FixHardSphere::count_collective(double bytes)
{
  if (comm->nprocs == 1) return;
  comm_step.collectives += 1.0;
  comm_step.bytes += bytes;
}

/* A ghost update of nval values per atom (none on one rank): the ghosts of atoms owned by
   other ranks received theirs. */
void FixHardSphere::count_halo(int nval)
{
  if (comm->nprocs == 1) return;
  comm_step.halos += 1.0;
  comm_step.bytes += (double) remote_ghosts * nval * sizeof(double);
}

/* Point-to-point messages of the step (gathers to the neighbouring ranks): n of them received
   here, with their bytes. */
void FixHardSphere::count_messages(double n, double bytes)
{
  comm_step.messages += n;
  comm_step.bytes += bytes;
}

/* Atom i's displacement bound for the step: twice its drift, at least bound_floor (or what a
   failed check of this step raised it to), at most the reach. */
double FixHardSphere::step_bound(int i, double drift_dt) const
{
  return HSGPU::Collide::drift_bound(atom->v[i], drift_dt, bound_floor, sboost[i], reach);
}

/* The step's checks on the fastest atom (radius growth, drift within the reach the ghost
   atoms cover) and the floor of every atom's step bound. */
void FixHardSphere::step_budget()
{
  const int nlocal = atom->nlocal;
  const int *mask = atom->mask;
  double **v = atom->v, **f = atom->f;
  const double ftm2v = force->ftm2v;
  double loc[3] = {0.0, 0.0, 0.0}, glob[3];
  for (int i = 0; i < nlocal; ++i) {
    if (!(mask[i] & groupbit)) continue;
    loc[0] = std::max(loc[0], HSGPU::Collide::speed2(v[i]));
    loc[1] = std::max(loc[1], HSGPU::Collide::accel_magnitude(f[i], ftm2v, atom->rmass[i]));
    loc[2] = std::max(loc[2], atom->radius[i]);
  }
  allreduce(loc, glob, 3, MPI_DOUBLE, MPI_MAX);
  check_budget(glob[0], glob[1], glob[2]);
}

/* The checks of step_budget() on the maxima over the group's atoms (found on the host, or by
   the resident step on the device): largest squared speed, acceleration and radius.  Sets the
   step's reach: reach_base, or, where the fastest atom may move further, all that the ghost
   atoms cover (ghost_reach()); whether the atoms stayed within it is the step's own check
   (step_exact(): an atom rattling fast in a narrow gap moves far less than its speed says). */
void FixHardSphere::check_budget(double vmax2, double amax, double rmax_seen)
{
  if (rmax_seen > rmax * (1.0 + 1e-12))
    error->all(FLERR,
               "Fix hardsphere: an atom's radius grew to {} during the run; the neighbor "
               "list was set up for a largest radius of {} (start a new run after changing radii)",
               rmax_seen, rmax);
  const double dt = update->dt;
  const double least = HSGPU::Collide::step_least(vmax2, amax, dt);
  reach = least > reach_base ? std::max(reach_base, ghost_reach()) : reach_base;
  step_vmax2 = vmax2;
  step_amax = amax;
  // Every atom's step bound is at least half the fastest drift: an atom at rest that is hit
  // moves about as far as what hit it, and a bound of zero would make the step's check fail
  // (and the step be redone) each time.
  bound_floor = 0.5 * least;
}

/* The largest reach that a periodic box allows: a pair must be found through one periodic
   image only, so every periodic length must exceed twice 2 rmax + 2 reach. */
double FixHardSphere::periodic_reach() const
{
  double most = 1e300;
  for (int d = 0; d < domain->dimension; ++d)
    if (domain->periodicity[d]) most = std::min(most, (0.25 - 1e-12) * domain->prd[d] - rmax);
  return most;
}

/* The largest reach the ghost atoms cover now (the same on every rank): an owned atom's
   partners lie within 2 rmax + 2 reach of it at the step start, and every atom has moved less
   than half the neighbor skin since the ghosts were made (LAMMPS's distance check), so
   2 rmax + 2 reach + skin must fit within the communication cutoff; at most periodic_reach(). */
double FixHardSphere::ghost_reach() const
{
  double cut = 1e300;
  for (int d = 0; d < domain->dimension; ++d) cut = std::min(cut, comm->cutghost[d]);
  return std::min(periodic_reach(), 0.5 * (cut - neighbor->skin - 2.0 * rmax));
}

/* After a step: `drift` is how far the fastest atom would move in the next step at its
   current speed.  Where that comes within half of what the ghost atoms cover, the fix asks
   LAMMPS to reneighbor at the end of this step and raises the ghost cutoff there
   (pre_exchange()), to twice that drift and at least 1.5 times the present reach, as far as a
   periodic box allows.  Decided from quantities summed over the ranks: the same on all. */
void FixHardSphere::plan_ghost_raise(double drift)
{
  const double cap = ghost_reach();
  if (!(drift > 0.5 * cap)) return;
  const double target = std::min(periodic_reach(), std::max(2.0 * drift, 1.5 * cap));
  if (!(target > cap)) return;    // a periodic box allows no more: the steps check themselves
  reach_raise = target;
  raise_drift = drift;
  next_reneighbor = update->ntimestep;
}

/* At a reneighboring the fix asked for: the ghost cutoff raised to cover reach_raise (the
   communication and neighbor bins set up again, as LAMMPS does when the box changes), before
   the atoms are exchanged and the ghosts made. */
void FixHardSphere::pre_exchange()
{
  if (!(reach_raise > 0.0) || update->ntimestep != next_reneighbor) return;
  const double need = 2.0 * rmax + 2.0 * reach_raise + neighbor->skin;
  if (comm->cutghostuser < need) {
    comm->cutghostuser = need;
    comm->setup();
    if (neighbor->style) neighbor->setup_bins();
    n_ghost_raise += 1.0;
    if (comm->me == 0)
      utils::logmesg(lmp,
                     "Fix hardsphere: communication cutoff raised to {:.8g} at step {} (atoms "
                     "move up to {:.6g} per step; 2*max radius {:.8g} + 2*reach {:.8g} + neighbor "
                     "skin {:.8g})\n",
                     need, update->ntimestep, raise_drift, 2.0 * rmax, 2.0 * reach_raise,
                     neighbor->skin);
  }
  reach_raise = 0.0;
  next_reneighbor = -1;
}

/* Stops the run: an atom moved `moved` in this step, more than the ghost atoms cover; the
   message says what to set. */
void FixHardSphere::reach_error(double moved, const char *what)
{
  const double most = periodic_reach();
  if (moved > most) {
    int dim = 0;
    for (int d = 0; d < domain->dimension; ++d)
      if (domain->periodicity[d] &&
          (!domain->periodicity[dim] || domain->prd[d] < domain->prd[dim]))
        dim = d;
    error->all(FLERR,
               "Fix hardsphere: {} {:.6g} in one step (step {}), more than the periodic box "
               "length {:.6g} along {} lets the fix cover ({:.6g}: twice 2*max radius + 2*reach "
               "must stay below the box length): reduce the timestep",
               what, moved, update->ntimestep, domain->prd[dim], "xyz"[dim], most);
  }
  double cut = 1e300;
  for (int d = 0; d < domain->dimension; ++d) cut = std::min(cut, comm->cutghost[d]);
  error->all(FLERR,
             "Fix hardsphere: {} {:.6g} in one step (step {}), more than the {:.6g} its ghost "
             "atoms cover (communication cutoff {:.6g}); the fix raises the ghost cutoff as moves "
             "approach it, but this one came within a step: set the fix's 'reach' to at least "
             "{:.6g} (or 'comm_modify cutoff' to at least {:.6g}), or reduce the timestep",
             what, moved, update->ntimestep, ghost_reach(), cut, moved,
             2.0 * rmax + 2.0 * moved + neighbor->skin);
}

/* The bodies of the group's owned atoms at their start points x - v drift_dt.  Returns true
   when a sphere is this close to a wall that the exact overlap test must run. */
bool FixHardSphere::gather_bodies(double drift_dt)
{
  const int nlocal = atom->nlocal;
  double **x = atom->x, **v = atom->v, **f = atom->f;
  const int *mask = atom->mask, *type = atom->type;
  const tagint *tag = atom->tag;
  const double *radius = atom->radius, *rmass = atom->rmass;
  const double ftm2v = force->ftm2v;

  body_of.assign(nlocal, -1);
  int nb = 0;
  for (int i = 0; i < nlocal; ++i)
    if (mask[i] & groupbit) body_of[i] = nb++;
  // Capacity with slack, as atoms migrate between ranks every step.
  if (bodies.capacity() < (size_t) nb) bodies.reserve(nb + nb / 8 + 64);
  bodies.resize(nb);
  // A sphere this close to a wall is tested exactly for overlap below.
  bool near_wall = false;
  for (int i = 0; i < nlocal; ++i) {
    if (body_of[i] < 0) continue;
    // Made in place (a body made on the stack and assigned is copied 16 bytes at a time over
    // its 8-byte stores just made, a store-forwarding stall per body).
    Body &b = *::new (&bodies[body_of[i]])
        Body(HSGPU::Collide::start_body(x[i], v[i], f[i], radius[i], rmass[i], tlast[i],
                                        (long) tag[i], type[i], i, drift_dt, ftm2v));
    if (friction_on)
      for (int d = 0; d < 3; ++d) b.omega[d] = atom->omega[i][d];
    for (int fc = 0; fc < HSGPU::Collide::NFACES; ++fc)
      if (walls.on[fc]) {
        const int d = fc / 2;
        const double pos = (fc & 1) ? domain->boxhi[d] : domain->boxlo[d];
        const double s = HSGPU::Collide::face_sign(fc);
        if (s * (b.X0[d] - pos) < b.radius * (1.0 + 1e-6)) near_wall = true;
      }
  }
  return near_wall;
}

/* Bodies, foreign nodes, edges; overlaps are counted (and, with overlap push, the pushes
   that separate them collected in push_dx).  Returns the number of overlaps found here. */
int FixHardSphere::build(double drift_dt, bool collect_pushes)
{
  const int nlocal = atom->nlocal, nall = nlocal + atom->nghost;
  const int me = comm->me;
  double **x = atom->x;
  const double t_start = MPI_Wtime();
  const int *mask = atom->mask;
  const tagint *tag = atom->tag;
  const double *rmass = atom->rmass;
  const int periodic[3] = {domain->xperiodic, domain->yperiodic, domain->zperiodic};
  const double *prd = domain->prd;
  const bool near_wall = gather_bodies(drift_dt);
  const int nb = (int) bodies.size();

  // Ghosts of atoms owned by other ranks: one foreign node per atom ID.
  foreign_of.assign(nall - nlocal, -1);
  foreign_tag.clear();
  {
    std::vector<std::pair<tagint, int>> ft;
    for (int j = nlocal; j < nall; ++j)
      if ((mask[j] & groupbit) && (int) gdata[(size_t) NFWD * j + 7] != me)
        ft.emplace_back(tag[j], j);
    std::sort(ft.begin(), ft.end());
    foreign_ghost.clear();
    fnodes.clear();
    for (size_t k = 0; k < ft.size(); ++k) {
      if (k == 0 || ft[k].first != ft[k - 1].first) {
        foreign_tag.push_back(ft[k].first);
        foreign_ghost.push_back(ft[k].second);
        fnodes.push_back({(long) ft[k].first, gdata[(size_t) NFWD * ft[k].second + 6]});
        fnodes.back().owner = (int) gdata[(size_t) NFWD * ft[k].second + 7];
      }
      foreign_of[ft[k].second - nlocal] = (int) foreign_tag.size() - 1;
    }
    // Each node's owner's start point and velocity, as its body has them (start_body()).
    fstart.resize((size_t) 6 * fnodes.size());
    for (size_t f = 0; f < fnodes.size(); ++f) {
      const double *g = &gdata[(size_t) NFWD * foreign_ghost[f]];
      HSGPU::Collide::start_point(g, g + 3, drift_dt, &fstart[6 * f]);
      for (int d = 0; d < 3; ++d) fstart[6 * f + 3 + d] = g[3 + d];
    }
  }

  // Candidate pairs from the cell search over owned and ghost atoms of the group, at their
  // start points; ghosts at their owners' start points moved to the ghost's periodic image
  // (the stale ghost coordinates only tell which image).
  // Per search point: its start point (raw owner coordinates, for the canonical nearest-image
  // separation), radius, ID, body (own atom or an image of one) or foreign node.
  const size_t npmax = (size_t) nb + (size_t) (nall - nlocal);
  for (std::vector<double> *w : {&spos, &sraw})
    if (w->size() < 3 * npmax) w->resize(3 * npmax);
  for (std::vector<double> *w : {&srad, &sbound})
    if (w->size() < npmax) w->resize(npmax);
  for (std::vector<int> *w : {&sbody, &snode, &sidx})
    if (w->size() < npmax) w->resize(npmax);
  if (sid.size() < npmax) sid.resize(npmax);
  size_t np = 0;
  for (int b = 0; b < nb; ++b, ++np) {
    const Body &bd = bodies[b];
    for (int d = 0; d < 3; ++d) spos[3 * np + d] = sraw[3 * np + d] = bd.X0[d];
    srad[np] = bd.radius;
    sbound[np] = gdata[(size_t) NFWD * bd.owner + 9];
    sid[np] = (tagint) bd.id;
    sbody[np] = b;
    snode[np] = -1;
    sidx[np] = bd.owner;
  }
  // On several ranks in the parallel order the pairs between ghosts are wanted too: the step
  // driver resolves a group that spans ranks where all its bodies and pairs are seen.
  const bool view = comm->nprocs > 1 && !serial_order && !spanning_gather;
  // Ghosts too far from every owned body to pair with one are left out: a pair is a candidate
  // within its radii and two step bounds, and the step's check looks within the radii and two
  // excursions, each at most what the ghosts cover (ghost_reach()).  The ghost shell follows
  // the largest sphere; a small ghost needs only its own share of it (diameters 1 and 10).
  // The bodies' box, from their search points just filled.
  double blo[3], bhi[3], rown = 0.0;
  HSGPU::Collide::bounding_box(spos.data(), nb, blo, bhi);
  for (int b = 0; b < nb; ++b) rown = std::max(rown, srad[b]);
  const double keep = rown + 2.0 * ghost_reach();
  for (int j = nlocal; j < nall && nb > 0; ++j) {
    if (!(mask[j] & groupbit)) continue;
    const double *g = &gdata[(size_t) NFWD * j];
    const int bj = (int) g[7] == me ? body_of[(int) g[8]] : -1;
    const int node = bj < 0 ? foreign_of[j - nlocal] : -1;
    if (bj < 0 && node < 0) continue;
    double out2 = 0.0;
    HSGPU::Collide::start_point(g, g + 3, drift_dt, &sraw[3 * np]);
    for (int d = 0; d < 3; ++d) {
      const double p = sraw[3 * np + d];
      spos[3 * np + d] = periodic[d] ? p + std::nearbyint((x[j][d] - p) / prd[d]) * prd[d] : p;
      const double e =
          std::max(std::max(blo[d] - spos[3 * np + d], spos[3 * np + d] - bhi[d]), 0.0);
      out2 += e * e;
    }
    const double range = (g[6] + keep) * (1.0 + 1e-9);
    if (out2 > range * range) continue;
    srad[np] = g[6];
    sbound[np] = g[9];
    sid[np] = tag[j];
    sbody[np] = bj;
    snode[np] = node;
    sidx[np] = j;
    ++np;
  }
  spos.resize(3 * np);
  sraw.resize(3 * np);
  for (std::vector<double> *w : {&srad, &sbound}) w->resize(np);
  for (std::vector<int> *w : {&sbody, &snode, &sidx}) w->resize(np);
  sid.resize(np);
  // Candidates: pairs within their radii plus their bounds (the search's radii are r + bound,
  // with a margin for the search's own rounding; the exact test follows).
  spairs.clear();
  {
    sreach.resize(np);
    double rm = 0.0;
    for (size_t k = 0; k < np; ++k) {
      sreach[k] = srad[k] + sbound[k];
      rm = std::max(rm, sreach[k]);
    }
    search.find(spos.data(), sreach.data(), (int) np, view ? (int) np : nb, rm, 1e-9 * rm, spairs);
  }

  edges.clear();
  fedges.clear();
  iedges.clear();
  ffedges.clear();
  bool maybe_overlap = false;
  near_body.assign(nb, 0);
  for (size_t k = 0; k < spairs.size(); k += 2) {
    int a = spairs[k], c = spairs[k + 1];    // a < c: a is one of my bodies or a ghost
    if (sid[a] == sid[c]) continue;          // an atom and its own image
    if (sbody[a] < 0) {
      if (sbody[c] < 0) {
        // Two foreign nodes: a pair of the view only (their owners test it for overlaps).
        const bool swap = sid[c] < sid[a];
        const int lo = swap ? c : a, hi = swap ? a : c;
        double r[3], sh[3];
        HSGPU::Collide::nearest_image_separation(&sraw[3 * (size_t) lo], &sraw[3 * (size_t) hi],
                                                 prd, periodic, r, sh);
        const double range = (srad[lo] + srad[hi]) + (sbound[lo] + sbound[hi]);
        if (r[0] * r[0] + r[1] * r[1] + r[2] * r[2] > range * range) continue;
        Edge &e = ffedges.emplace_back();
        e.i = snode[lo];
        e.j = snode[hi];
        for (int d = 0; d < 3; ++d) e.shift[d] = sh[d];
        continue;
      }
      std::swap(a, c);    // a body (or an image of one) first
    } else if (a >= nb && sbody[c] >= 0) {
      continue;    // two images of my atoms: the pair is found from the atom itself
    }
    const int bi = sbody[a], bj = sbody[c], node = snode[c];
    // Canonical orientation: the lower ID first, its separation computed that way round.
    const bool swap = sid[c] < sid[a];
    const int lo = swap ? c : a, hi = swap ? a : c;
    double r[3], sh[3];
    HSGPU::Collide::nearest_image_separation(&sraw[3 * (size_t) lo], &sraw[3 * (size_t) hi], prd,
                                             periodic, r, sh);
    const double range = (srad[lo] + srad[hi]) + (sbound[lo] + sbound[hi]);
    const double d2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
    if (d2 > range * range) continue;
    // Could be an overlap (the exact test below runs only if some pair is this close, and
    // only on the pairs of bodies in such a pair).
    const double near = (srad[lo] + srad[hi]) * (1.0 + 1e-6);
    if (d2 < near * near) {
      maybe_overlap = true;
      near_body[bi] = 1;
      if (bj >= 0) near_body[bj] = 1;
    }
    // Filled in place: an edge built on the stack and copied is read back in 16-byte pieces
    // over its 4- and 8-byte stores, which stalls the copy until those stores complete.
    if (bj >= 0) {
      Edge &e = (c >= nb || a >= nb ? iedges : edges).emplace_back();
      e.i = swap ? bj : bi;
      e.j = swap ? bi : bj;
      for (int d = 0; d < 3; ++d) e.shift[d] = sh[d];
    } else {
      ForeignEdge &fe = fedges.emplace_back();
      fe.body = bi;
      fe.node = node;
      fe.ghost = sidx[c];
      for (int d = 0; d < 3; ++d) fe.shift[d] = swap ? -sh[d] : sh[d];
    }
  }
  // A pair of my atoms found through periodic images appears once per image held here: keep
  // one.  Pairs found directly appear once, and never also through an image (init() keeps
  // periodic lengths above twice the candidate range).  They are put in (i, j) order by two
  // stable counting passes, by j and then by i (linear in the edges and bodies, where a
  // comparison sort stalls on its unpredictable comparisons); the copies of a pair are alike
  // (the same bodies, orientation and image shift), so the first of each is kept.
  if (!iedges.empty()) {
    auto counting_pass = [&](int Edge::*key, const std::vector<Edge> &from, std::vector<Edge> &to) {
      icount.assign((size_t) nb + 1, 0);
      for (const Edge &e : from) ++icount[e.*key + 1];
      for (int b = 0; b < nb; ++b) icount[b + 1] += icount[b];
      to.resize(from.size());
      for (const Edge &e : from) to[icount[e.*key]++] = e;
    };
    counting_pass(&Edge::j, iedges, isorted);
    counting_pass(&Edge::i, isorted, iedges);
    for (size_t k = 0; k < iedges.size(); ++k)
      if (k == 0 || iedges[k].i != iedges[k - 1].i || iedges[k].j != iedges[k - 1].j)
        edges.push_back(iedges[k]);
  }
  std::sort(fedges.begin(), fedges.end(), [](const ForeignEdge &a, const ForeignEdge &b) {
    return a.body < b.body || (a.body == b.body && a.node < b.node);
  });
  fedges.erase(std::unique(fedges.begin(), fedges.end(),
                           [](const ForeignEdge &a, const ForeignEdge &b) {
                             return a.body == b.body && a.node == b.node;
                           }),
               fedges.end());
  efedges.resize(fedges.size());
  for (size_t k = 0; k < fedges.size(); ++k) {
    efedges[k].body = fedges[k].body;
    efedges[k].node = fedges[k].node;
    for (int d = 0; d < 3; ++d) efedges[k].shift[d] = fedges[k].shift[d];
  }
  if (view) view_completeness();

  // Overlaps: pairs closer than contact, spheres inside a wall.
  int found = 0;
  ovl[0] = 0.0;
  if (collect_pushes) push_dx.assign((size_t) 3 * nlocal, 0.0);
  ovl_depth = 0.0;
  // counted: a pair of atoms on two ranks is counted by the rank of the lower ID only.
  auto note = [&](double a, double b, double dist, double s, bool counted) {
    if (counted) ++found;
    ovl_depth = std::max(ovl_depth, 1.0 - dist / s);
    if (ovl[0] == 0.0 || before(a, b, ovl[1], ovl[2])) {
      ovl[0] = 1.0;
      ovl[1] = a;
      ovl[2] = b;
      ovl[3] = dist;
      ovl[4] = s;
    }
  };
  auto pair_overlap = [&](const Body &bi, const double *X0j, double rj, double mj, tagint tj,
                          int bj) {
    double r[3], sh[3];
    HSGPU::Collide::nearest_image_separation(bi.X0, X0j, prd, periodic, r, sh);
    const double s = bi.radius + rj;
    const double d2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
    const double lim = s * (1.0 - OVERLAP_TOL);
    if (!(d2 < lim * lim)) return;
    const double dist = std::sqrt(d2);
    note((double) std::min((tagint) bi.id, tj), (double) std::max((tagint) bi.id, tj), dist, s,
         bj >= 0 || (tagint) bi.id < tj);
    if (!collect_pushes) return;
    // Mass-weighted push along the line of centres to just beyond contact: the centre of
    // mass stays put.  Two centres at one point part along x, the lower ID upwards (on
    // both ranks when the pair spans two).
    double n[3] = {(tagint) bi.id < tj ? 1.0 : -1.0, 0.0, 0.0};
    if (dist > 0.0)
      for (int d = 0; d < 3; ++d) n[d] = r[d] / dist;
    const double delta = s * (1.0 + PUSH_MARGIN) - dist;
    const double wi = mj / (bi.mass + mj), wj = bi.mass / (bi.mass + mj);
    for (int d = 0; d < 3; ++d) {
      push_dx[(size_t) 3 * bi.owner + d] += wi * delta * n[d];
      if (bj >= 0) push_dx[(size_t) 3 * bodies[bj].owner + d] -= wj * delta * n[d];
    }
  };
  // A pair closer than contact was found close above (the same start points and separation),
  // so the pairs of bodies in no close pair are passed over (a dense fluid has close pairs in
  // every step; reading both bodies of every pair cost more than the rest of the test).  The
  // order of the pairs tested, and so of the sums in push_dx, is kept.
  if (maybe_overlap) {
    for (const Edge &e : edges)
      if (near_body[e.i] && near_body[e.j])
        pair_overlap(bodies[e.i], bodies[e.j].X0, bodies[e.j].radius, bodies[e.j].mass,
                     (tagint) bodies[e.j].id, e.j);
    for (const ForeignEdge &fe : fedges) {
      if (!near_body[fe.body]) continue;
      const double *g = &gdata[(size_t) NFWD * fe.ghost];
      double X0j[3];
      HSGPU::Collide::start_point(g, g + 3, drift_dt, X0j);
      pair_overlap(bodies[fe.body], X0j, g[6], rmass[fe.ghost], foreign_tag[fe.node], -1);
    }
  }
  for (size_t k = 0; near_wall && k < bodies.size(); ++k)
    for (int fc = 0; fc < HSGPU::Collide::NFACES; ++fc) {
      const Body &b = bodies[k];
      if (!walls.on[fc]) continue;
      const int d = fc / 2;
      const double s = HSGPU::Collide::face_sign(fc);
      const double pos = (fc & 1) ? domain->boxhi[d] : domain->boxlo[d];
      const double gap = s * (b.X0[d] - pos) - b.radius;
      if (!(gap < -OVERLAP_TOL * b.radius)) continue;
      note((double) b.id, (double) (-1 - fc), s * (b.X0[d] - pos), b.radius, true);
      if (collect_pushes) push_dx[(size_t) 3 * b.owner + d] += s * (-gap + PUSH_MARGIN * b.radius);
    }
  // Candidate pairs (a pair with a foreign atom is seen from both of its ranks).
  last_candidates = (double) edges.size() + 0.5 * (double) fedges.size();
  t_search += MPI_Wtime() - t_start;
  return found;
}

/* Stops with an error naming the overlap with the lowest atom IDs over all ranks; after
   npush passes of overlap push, also how many overlaps were left and how deep. */
void FixHardSphere::report_overlap(int npush, int left)
{
  std::vector<double> all((size_t) 5 * comm->nprocs);
  MPI_Allgather(ovl, 5, MPI_DOUBLE, all.data(), 5, MPI_DOUBLE, world);
  double depth = 0.0;
  allreduce(&ovl_depth, &depth, 1, MPI_DOUBLE, MPI_MAX);
  int best = -1;
  for (int p = 0; p < comm->nprocs; ++p) {
    const double *o = &all[(size_t) 5 * p];
    if (o[0] == 0.0) continue;
    if (best < 0 || before(o[1], o[2], all[(size_t) 5 * best + 1], all[(size_t) 5 * best + 2]))
      best = p;
  }
  const double *o = &all[(size_t) 5 * best];
  const std::string after =
      npush > 0 ? fmt::format(" after {} passes of 'overlap push' ({} overlaps left, the deepest "
                              "{:.3g} of its contact distance; raise 'maxpush' or start from a "
                              "looser configuration)",
                              npush, left, depth)
                : std::string();
  if (o[2] < 0) {
    const int fc = -1 - (int) o[2];
    const char *names[6] = {"xlo", "xhi", "ylo", "yhi", "zlo", "zhi"};
    error->all(FLERR,
               "Fix hardsphere: atom {} overlaps wall {} at step {}: its centre is {:.10g} from "
               "the wall, its radius {:.10g}{}",
               (tagint) o[1], names[fc], update->ntimestep, o[3], o[4], after);
  }
  error->all(FLERR,
             "Fix hardsphere: atoms {} and {} overlap at step {}: centre distance {:.10g}, "
             "contact distance {:.10g}{}",
             (tagint) o[1], (tagint) o[2], update->ntimestep, o[3], o[4],
             overlap_push ? after : " (use the fix's 'overlap push' to push overlaps apart)");
}

/* One pass over the overlaps at the start points (x - v drift_dt): forward state, bodies and
   candidate pairs built anew.  Returns 0 when no overlap is left.  Otherwise stops with an
   error (overlap error, or maxpush passes done) or pushes the overlaps apart, counts them in
   n_push and returns their number, with `moved` the largest push of an atom (all ranks). */
int FixHardSphere::overlap_pass(double drift_dt, int pass, double &moved)
{
  moved = 0.0;
  forward_state(drift_dt);
  const int found = build(drift_dt, overlap_push && pass < maxpush);
  int any = 0;
  allreduce(&found, &any, 1, MPI_INT, MPI_SUM);
  if (!any) return 0;
  if (!overlap_push || pass >= maxpush) report_overlap(pass, any);
  double **x = atom->x;
  double m = 0.0;
  // A push never carries an atom out through a fixed boundary (LAMMPS's 'f', with or without
  // a wall of the fix there), where LAMMPS would lose it: its centre stops just inside the
  // face (a wall's own push then moves it clear of the wall), and what overlap is left is
  // pushed again in the next pass.
  double lo[3], hi[3];
  for (int d = 0; d < 3; ++d) {
    const double inset = PUSH_INSET * domain->prd[d];
    lo[d] = domain->boundary[d][0] == FIXED_FACE ? domain->boxlo[d] + inset : -HUGE_VAL;
    hi[d] = domain->boundary[d][1] == FIXED_FACE ? domain->boxhi[d] - inset : HUGE_VAL;
  }
  for (const Body &b : bodies) {
    double *u = &push_dx[(size_t) 3 * b.owner];
    for (int d = 0; d < 3; ++d) {
      const double to = x[b.owner][d] + u[d];
      if (to < lo[d] || to > hi[d]) {
        const double in = to < lo[d] ? lo[d] : hi[d];
        u[d] = in - x[b.owner][d];
        x[b.owner][d] = in;
      } else {
        x[b.owner][d] = to;
      }
    }
    m = std::max(m, u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
  }
  allreduce(&m, &moved, 1, MPI_DOUBLE, MPI_MAX);
  moved = std::sqrt(moved);
  n_push += any;
  return any;
}

/* Checks for overlaps at the start points; pushes them apart or stops.  Leaves bodies and
   edges built for the step.  (Overlaps of the starting configuration are relaxed in
   setup_pre_neighbor(), where atoms may still migrate; this catches what other fixes or a run
   without setup made.) */
void FixHardSphere::prepare(double drift_dt)
{
  double moved;
  for (int pass = 0; overlap_pass(drift_dt, pass, moved) > 0; ++pass) {}
}

/* overlap push on the starting configuration, before LAMMPS builds its neighbor lists and
   computes the forces: passes of mass-weighted pushes (a Jacobi relaxation of the overlaps)
   until none is left.  Whenever the pushes since the last exchange add up to half the neighbor
   skin, the atoms are wrapped, exchanged between ranks and their ghosts built anew (as
   Verlet::setup() does just before this), so that the ghosts keep covering the search. */
void FixHardSphere::setup_pre_neighbor()
{
  if (!overlap_push) return;    // overlap error: setup() stops at the first overlap
  bound_floor = 0.0;
  sboost.assign(atom->nlocal, 0.0);    // forward_state() extends it with zeros after exchanges
  double since = 0.0, total = 0.0, moved = 0.0;
  long pushed = 0;
  int pass = 0, migrations = 0;
  for (int any; (any = overlap_pass(0.0, pass, moved)) > 0; ++pass) {
    pushed += any;
    since += moved;
    total += moved;
    if (since > 0.5 * neighbor->skin) {
      domain->pbc();
      domain->reset_box();
      comm->setup();
      if (neighbor->style) neighbor->setup_bins();
      comm->exchange();
      comm->borders();
      since = 0.0;
      ++migrations;
    }
  }
  if (pass > 0 && comm->me == 0)
    utils::logmesg(lmp,
                   "Fix hardsphere: overlap push separated {} overlaps in {} passes (atoms moved "
                   "at most {:.4g} in all; {} exchanges of atoms between the passes)\n",
                   pushed, pass, total, migrations);
}

/* Which foreign nodes have all their candidate partners here.  Each owner counts its atom's
   partners (it finds all of them: the ghosts cover its reach); a rank that counts as many for
   the atom's foreign node among its own pairs has found every one, since every pair it finds
   is one the owner finds (the same test on the same values).  A node with a partner beyond
   the ghosts, or one left out of the search, counts fewer and is incomplete: a group that
   reaches it is gathered (window_driver.h). */
void FixHardSphere::view_completeness()
{
  std::sort(ffedges.begin(), ffedges.end(),
            [](const Edge &a, const Edge &b) { return a.i < b.i || (a.i == b.i && a.j < b.j); });
  ffedges.erase(std::unique(ffedges.begin(), ffedges.end(),
                            [](const Edge &a, const Edge &b) { return a.i == b.i && a.j == b.j; }),
                ffedges.end());
  const int nb = (int) bodies.size(), nf = (int) fnodes.size();
  fdeg_local.assign(nb, 0.0);
  for (const Edge &e : edges) {
    fdeg_local[e.i] += 1.0;
    fdeg_local[e.j] += 1.0;
  }
  for (const ForeignEdge &fe : fedges) fdeg_local[fe.body] += 1.0;
  exchange->to_foreign(fdeg_local, 1, fdeg);
  fdeg_here.assign(nf, 0);
  for (const ForeignEdge &fe : fedges) ++fdeg_here[fe.node];
  for (const Edge &e : ffedges) {
    ++fdeg_here[e.i];
    ++fdeg_here[e.j];
  }
  for (int f = 0; f < nf; ++f) fnodes[f].complete = (double) fdeg_here[f] == fdeg[f] ? 1 : 0;
}

/* Components of the edge graph (foreign nodes included): those touching a foreign node are
   boundary components.  In serial order on several ranks everything is. */
void FixHardSphere::classify()
{
  const int nb = (int) bodies.size(), nf = (int) foreign_tag.size();
  uf.reset(nb + nf);
  for (const Edge &e : edges) uf.unite(e.i, e.j);
  for (const ForeignEdge &fe : fedges) uf.unite(fe.body, nb + fe.node);
  std::vector<char> foreign_root(nb + nf, 0);
  for (int k = 0; k < nf; ++k) foreign_root[uf.find(nb + k)] = 1;
  const bool all = serial_order && comm->nprocs > 1;
  in_boundary.resize(nb);
  for (int b = 0; b < nb; ++b) in_boundary[b] = all ? 1 : foreign_root[uf.find(b)];
}

/* Boundary bodies of all ranks, with their edges, to every rank, in atom-ID order. */
void FixHardSphere::gather_boundary()
{
  const int nb = (int) bodies.size();
  const int periodic[3] = {domain->xperiodic, domain->yperiodic, domain->zperiodic};
  const double *prd = domain->prd;
  const int nstate = NSTATE + (friction_on ? 3 : 0);    // the spin follows the fixed head

  // Partners with a higher ID, per boundary body.
  std::vector<int> pstart(nb + 1, 0);
  for (const Edge &e : edges)
    if (in_boundary[e.i]) pstart[e.i + 1]++;
  for (const ForeignEdge &fe : fedges)
    if (foreign_tag[fe.node] > (tagint) bodies[fe.body].id) pstart[fe.body + 1]++;
  for (int b = 0; b < nb; ++b) pstart[b + 1] += pstart[b];
  std::vector<double> partners(pstart[nb]);
  std::vector<int> fill(pstart.begin(), pstart.end() - 1);
  for (const Edge &e : edges)
    if (in_boundary[e.i]) partners[fill[e.i]++] = (double) bodies[e.j].id;
  for (const ForeignEdge &fe : fedges)
    if (foreign_tag[fe.node] > (tagint) bodies[fe.body].id)
      partners[fill[fe.body]++] = (double) foreign_tag[fe.node];

  std::vector<double> send;
  std::vector<int> mine_sent;
  for (int b = 0; b < nb; ++b) {
    if (!in_boundary[b]) continue;
    const Body &s = bodies[b];
    const double head[NSTATE] = {
        (double) s.id, (double) s.type, s.X0[0], s.X0[1], s.X0[2],
        s.v[0],        s.v[1],          s.v[2],  s.a[0],  s.a[1],
        s.a[2],        s.radius,        s.mass,  s.tlast, (double) (pstart[b + 1] - pstart[b])};
    send.insert(send.end(), head, head + NSTATE);
    if (friction_on) send.insert(send.end(), s.omega, s.omega + 3);
    send.insert(send.end(), partners.begin() + pstart[b], partners.begin() + pstart[b + 1]);
    mine_sent.push_back(b);
  }

  std::vector<int> counts, displs;
  std::vector<double> recv;
  if (!HSGPU::allgather_doubles(world, send, recv, counts, displs))
    error->all(FLERR, "Fix hardsphere: too many atoms in components that span ranks");
  gbodies.clear();
  gedges.clear();
  gmine.clear();
  const bigint total = (bigint) recv.size();
  if (total == 0) return;

  // Entries in atom-ID order.
  std::vector<std::pair<double, bigint>> order;    // (ID, offset)
  for (bigint off = 0; off < total;) {
    order.emplace_back(recv[off], off);
    off += nstate + (bigint) recv[off + NSTATE - 1];
  }
  std::sort(order.begin(), order.end());
  const int ng = (int) order.size();
  gbodies.resize(ng);
  gmine.assign(ng, -1);
  std::vector<double> ids(ng);
  for (int k = 0; k < ng; ++k) {
    const double *h = &recv[order[k].second];
    Body &b = gbodies[k];
    std::memset(&b, 0, sizeof(b));
    b.id = (long) h[0];
    b.type = (int) h[1];
    for (int d = 0; d < 3; ++d) {
      b.X0[d] = b.x[d] = h[2 + d];
      b.v[d] = h[5 + d];
      b.a[d] = h[8 + d];
      b.rest[d] = -1;
    }
    b.radius = h[11];
    b.mass = h[12];
    b.tlast = h[13];
    if (friction_on)
      for (int d = 0; d < 3; ++d) b.omega[d] = h[NSTATE + d];
    b.owner = -1;
    ids[k] = h[0];
  }
  // Which of them are mine: my entries sit at my displacement, in the order I packed them.
  {
    bigint off = displs[comm->me];
    for (int b : mine_sent) {
      const double id = recv[off];
      const int k = (int) (std::lower_bound(ids.begin(), ids.end(), id) - ids.begin());
      gmine[k] = b;
      off += nstate + (bigint) recv[off + NSTATE - 1];
    }
  }
  for (int k = 0; k < ng; ++k) {
    const double *h = &recv[order[k].second];
    const int np = (int) h[NSTATE - 1];
    for (int q = 0; q < np; ++q) {
      const double pid = h[nstate + q];
      const auto it = std::lower_bound(ids.begin(), ids.end(), pid);
      if (it == ids.end() || *it != pid)
        error->one(FLERR, "Fix hardsphere: internal error: partner {} of atom {} was not sent",
                   (tagint) pid, (tagint) h[0]);
      Edge e;
      e.i = k;
      e.j = (int) (it - ids.begin());
      double r[3];
      HSGPU::Collide::nearest_image_separation(gbodies[e.i].X0, gbodies[e.j].X0, prd, periodic, r,
                                               e.shift);
      gedges.push_back(e);
    }
  }
}

/* Resolves the step: local components here, boundary components on every rank.  `mine` is
   this rank's share of the tallies (local plus, on rank 0, the boundary ones), `all` the sum
   over ranks.  The bodies' excursions end noted at dt (for step_exact()). */
void FixHardSphere::resolve(Tally &mine, Tally &all)
{
  const Params p = step_params();
  const int nb = (int) bodies.size();
  lbodies.clear();
  ledges.clear();
  lindex.assign(nb, -1);
  for (int b = 0; b < nb; ++b)
    if (!in_boundary[b]) {
      lindex[b] = (int) lbodies.size();
      lbodies.push_back(bodies[b]);
    }
  for (const Edge &e : edges)
    if (lindex[e.i] >= 0) {
      Edge l = e;
      l.i = lindex[e.i];
      l.j = lindex[e.j];
      ledges.push_back(l);
    }

  Tally tl, tg;
  double *lv = nullptr, *gv = nullptr;
  if (vflag_atom) {
    lvir.assign(6 * lbodies.size(), 0.0);
    lv = lvir.data();
  }
  if (serial_order)
    resolver.resolve_serial(lbodies, ledges, p, tl, lv);
  else
    resolver.resolve_components(lbodies, ledges, p, tl, lv);
  gather_boundary();
  if (vflag_atom) {
    gvir.assign(6 * gbodies.size(), 0.0);
    gv = gvir.data();
  }
  if (!gbodies.empty()) {
    if (serial_order)
      resolver.resolve_serial(gbodies, gedges, p, tg, gv);
    else
      resolver.resolve_components(gbodies, gedges, p, tg, gv);
  }

  double xe[3], ve[3];
  for (Body &b : lbodies) HSGPU::Collide::end_of_step(b, p.dt, xe, ve);
  for (Body &b : gbodies) HSGPU::Collide::end_of_step(b, p.dt, xe, ve);

  mine = tl;
  if (comm->me == 0) mine.add(tg);
  sum_tallies(mine, tl.capped | tg.capped, all);
}

/* Sums over the ranks of this rank's share of the tallies, with whether the event cap stopped
   a group on any rank (capped) and, where given, step_exact()'s figures (exact_figures(); their
   maxima come back in place): one reduction. */
void FixHardSphere::sum_tallies(const Tally &mine, int capped, Tally &all, double *figures)
{
  double mx[3] = {(double) capped, figures ? figures[0] : 0.0, figures ? figures[1] : 0.0};
  double sm[5] = {(double) mine.pair, (double) mine.wall, (double) mine.rest,
                  (double) mine.events, mine.ke_lost};
  exchange->max_sum(mx, figures ? 3 : 1, sm, 5);
  all = Tally();
  all.capped = mx[0] > 0.0 ? 1 : 0;
  all.pair = (long) sm[0];
  all.wall = (long) sm[1];
  all.rest = (long) sm[2];
  all.events = (long) sm[3];
  all.ke_lost = sm[4];
  if (figures) {
    figures[0] = mx[1];
    figures[1] = mx[2];
  }
}

/* Positions and half-step velocities of the atoms that had events, and everyone's time of
   the last collision, relative to the end of this step.  in_bodies: the results are in
   `bodies` (the windows, or a step on the device) rather than in the serial order's lists. */
void FixHardSphere::apply_results(double dt, bool in_bodies)
{
  double **x = atom->x, **v = atom->v;
  double xe[3], ve[3];
  vend2 = 0.0;
  auto put = [&](Body &b, int i) {
    if (b.nevents > 0) {
      HSGPU::Collide::end_of_step(b, dt, xe, ve);
      vend2 = std::max(vend2, ve[0] * ve[0] + ve[1] * ve[1] + ve[2] * ve[2]);
      for (int d = 0; d < 3; ++d) {
        x[i][d] = xe[d];
        v[i][d] = ve[d];
      }
      if (friction_on)
        for (int d = 0; d < 3; ++d) atom->omega[i][d] = b.omega[d];
    }
    tlast[i] = std::max(b.tlast - dt, NEVER_COLLIDED);
  };
  if (in_bodies) {
    for (Body &b : bodies) put(b, b.owner);
    return;
  }
  for (Body &b : lbodies) put(b, b.owner);
  for (size_t k = 0; k < gbodies.size(); ++k)
    if (gmine[k] >= 0) put(gbodies[k], bodies[gmine[k]].owner);
}

/* Fix::v_init, with vatom sized for every atom this rank can hold (v_init leaves it
   unallocated on a rank without atoms, and atoms may arrive with the exchange after the
   step; grow_arrays() keeps it sized from then on). */
void FixHardSphere::virial_init(int vflag)
{
  v_init(vflag);
  if (vflag_atom && atom->nmax > maxvatom) {
    maxvatom = atom->nmax;
    memory->grow(vatom, maxvatom, 6, "hardsphere:vatom");
  }
}

/* The step's per-atom virial into vatom (zeroed by v_init for every owned atom), in the
   global virial's units: each body's share of r (x) dp divided by dt ftm2v.  Bodies of
   groups that spanned ranks were resolved on every rank; each rank takes its own only. */
void FixHardSphere::apply_virial(double dt, bool in_bodies)
{
  const double scale = 1.0 / (dt * force->ftm2v);
  auto put = [&](const double *w, int i) {
    for (int k = 0; k < 6; ++k) vatom[i][k] += w[k] * scale;
  };
  if (in_bodies) {
    for (size_t b = 0; b < bodies.size(); ++b) put(&bvir[6 * b], bodies[b].owner);
    return;
  }
  for (size_t b = 0; b < lbodies.size(); ++b) put(&lvir[6 * b], lbodies[b].owner);
  for (size_t k = 0; k < gbodies.size(); ++k)
    if (gmine[k] >= 0) put(&gvir[6 * k], bodies[gmine[k]].owner);
}

void FixHardSphere::setup(int vflag)
{
  // Commands between runs may have moved the atom arrays the device step keeps page-locked,
  // or changed them.
  drop_ahead();
  if (resident) resident->forget_host_arrays();
  if (peer) peer->forget_host_arrays();
  resident_same = false;
  forces_checked = false;
  motion_way = MOTION_UNKNOWN;    // each run checks the integrator's rounding again
  motion_unchecked = 0;
  gath.state_kept = false;    // commands between runs may have changed x and v
  // The virial and the collision count are the last step's (or the restart file's): the
  // run's first thermo output shows the collisions' share of the pressure, as every later
  // one does.
  run_sum = RunSummary();
  driver.times = HSGPU::Collide::DriverTimes();
  run_sum.t_search = -t_search;
  run_sum.t_resolve = -t_resolve;
  run_sum.repairs = -n_repair;
  run_sum.redos = -n_redo;
  // Per-atom virial asked for at the run's first output: the last step's where vatom holds
  // it (kept with the atoms since, as the global virial is), else none.
  if (!(vflag_atom && vatom_step == update->ntimestep)) {
    vatom_step = -1;
    virial_init(vflag & (VIRIAL_ATOM | VIRIAL_CENTROID));
  }
  sboost.assign(atom->nlocal, 0.0);
  bound_floor = 0.0;
  // Overlaps in the starting configuration (or made since the last run).
  prepare(0.0);
}

/* After the resolution: could a pair that was not a candidate have touched?  Only if a body
   of it moved further than its bound and the two moved at least the pair's gap (at their
   start points) together.  The bodies of such pairs get their bound raised to twice their
   excursion, and the step is redone.  Returns true when the step is exact.  An atom that moved
   further than the step's reach raises it to all that the ghost atoms cover; further than
   that stops the run (reach_error()). */
/* step_exact()'s figures on this rank: loc[0] the largest excursion of a body, loc[1] 1 where
   some body moved further than its bound (bexc gets each body's excursion). */
void FixHardSphere::exact_figures(double *loc)
{
  const int nb = (int) bodies.size();
  bexc.assign(nb, 0.0);
  if (serial_order) {
    for (int b = 0; b < nb; ++b)
      if (lindex[b] >= 0) bexc[b] = std::sqrt(lbodies[lindex[b]].exc2);
    for (size_t k = 0; k < gbodies.size(); ++k)
      if (gmine[k] >= 0) bexc[gmine[k]] = std::sqrt(gbodies[k].exc2);
  } else {
    for (int b = 0; b < nb; ++b) bexc[b] = std::sqrt(bodies[b].exc2);
  }
  loc[0] = loc[1] = 0.0;
  for (int b = 0; b < nb; ++b) {
    loc[0] = std::max(loc[0], bexc[b]);
    if (bexc[b] > sbound[b]) loc[1] = 1.0;
  }
}

/* figures: exact_figures()' over all ranks where the caller reduced them already (with its
   own figures), else reduced here. */
bool FixHardSphere::step_exact(const double *figures)
{
  const int nb = (int) bodies.size();
  double glob[2];
  if (figures) {
    glob[0] = figures[0];
    glob[1] = figures[1];
  } else {
    double loc[2];
    exact_figures(loc);
    allreduce(loc, glob, 2, MPI_DOUBLE, MPI_MAX);
  }
  if (glob[0] > reach) {
    // Beyond this step's reach: all that the ghosts cover, or stop.
    const double cap = ghost_reach();
    if (glob[0] > cap) reach_error(glob[0], "an atom moved");
    reach = std::max(reach, cap);
  }
  if (glob[1] == 0.0) return true;
  double tq = MPI_Wtime();
  if (comm->nprocs > 1) exchange->to_foreign(bexc, 1, fexc);
  run_sum.t_check_ghosts += lap(tq);

  const int periodic[3] = {domain->xperiodic, domain->yperiodic, domain->zperiodic};
  const double *prd = domain->prd;
  int missed = 0;
  std::vector<int> near;
  for (int b = 0; b < nb; ++b) {
    if (!(bexc[b] > sbound[b])) continue;
    const int owner = bodies[b].owner;
    // Every point it could have touched: within 2 rmax and the two excursions.
    near.clear();
    search.within(b, bexc[b] + glob[0] + 2.0 * rmax * (1.0 + 2.0 * OVERLAP_TOL), near);
    for (int c : near) {
      if (sid[c] == sid[b]) continue;
      const double ec = sbody[c] >= 0 ? bexc[sbody[c]] : fexc[snode[c]];
      const int lo = sid[c] < sid[b] ? c : b, hi = lo == c ? b : c;
      double r[3], sh[3];
      HSGPU::Collide::nearest_image_separation(&sraw[3 * (size_t) lo], &sraw[3 * (size_t) hi], prd,
                                               periodic, r, sh);
      const double dist = std::sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
      const double contact = srad[lo] + srad[hi];
      if (dist <= contact + (sbound[lo] + sbound[hi])) continue;    // a candidate
      if (dist - contact > bexc[b] + ec + OVERLAP_TOL * contact) continue;
      sboost[owner] = std::max(sboost[owner], 2.0 * bexc[b]);
      missed = 1;
    }
  }
  run_sum.t_check_search += lap(tq);
  int any = 0;
  allreduce(&missed, &any, 1, MPI_INT, MPI_MAX);
  run_sum.t_check_reduce += lap(tq);
  return any == 0;
}

/* The seed paper's order: all of this rank's bodies (on several ranks all bodies, gathered)
   with one global event loop. */
void FixHardSphere::step_serial(Tally &mine, Tally &all)
{
  const double dt = update->dt;
  classify();
  while (true) {
    const double t0 = MPI_Wtime();
    resolve(mine, all);
    const bool exact = all.capped || step_exact();
    t_resolve += MPI_Wtime() - t0;
    if (exact) break;
    n_redo += 1.0;
    forward_state(dt);
    build(dt, false);
    classify();
  }
  last_largest = (double) group->count(igroup);
  last_groups = 1.0;
  last_windows = 1.0;
  last_boundary = comm->nprocs > 1 ? (double) atom->natoms : 0.0;
  last_gathers = comm->nprocs > 1 ? 1.0 : 0.0;
  last_spanning = last_fallbacks = last_neighbour = last_forwards = last_round_fails = 0.0;
  last_step_redos = 0.0;
  last_gathered = last_boundary;
}

/* Time windows and groups (engine/window_driver.h). */
void FixHardSphere::step_windows(Tally &mine, Tally &all)
{
  const double dt = update->dt;
  const Params p = step_params();
  HSGPU::Collide::WindowStats stats;
  // Per-atom virial: the CPU backend (the CUDA one cannot tally it; same results).
  HSGPU::Collide::CollisionBackend *be = backend.get();
  if (vflag_atom && backend_device >= 0) {
    if (!cpu_backend) cpu_backend = HSGPU::Collide::make_cpu_backend();
    be = cpu_backend.get();
  }
  // On three ranks or more the gathers of the groups that span ranks exchange with the
  // neighbouring ranks, made again after each new neighbor list (the ghosts' owners).
  if (comm->nprocs > 2 && spanning_gather && neighbour_exchange)
    exchange->find_neighbours(fnodes, (long) neighbor->ncalls);
  while (true) {
    const double t0 = MPI_Wtime();
    if (vflag_atom) bvir.assign(6 * bodies.size(), 0.0);
    driver.foreign_start(&fstart);
    driver.run(bodies, edges, efedges, fnodes, p, wsettings, *be, *exchange, mine, stats,
               vflag_atom ? bvir.data() : nullptr,
               comm->nprocs > 1 && !spanning_gather ? &ffedges : nullptr);
    if (driver.results_missing_last())
      error->one(FLERR, "Fix hardsphere: internal error: a result of a group that spans ranks, "
                        "resolved on another rank, did not arrive");
    double xe[3], ve[3];
    double tq = MPI_Wtime();
    for (Body &b : bodies) HSGPU::Collide::end_of_step(b, dt, xe, ve);
    // One reduction: the tallies, the event cap and step_exact()'s figures.
    double figures[2];
    exact_figures(figures);
    run_sum.t_ends += lap(tq);
    sum_tallies(mine, mine.capped, all, figures);
    run_sum.t_tallies += lap(tq);
    n_repair += (double) stats.repairs;
    const bool exact = all.capped || step_exact(figures);
    t_resolve += MPI_Wtime() - t0;
    if (exact) break;
    n_redo += 1.0;
    forward_state(dt);
    build(dt, false);
  }
  last_largest = (double) stats.largest_group;
  last_groups = (double) stats.groups;
  last_windows = (double) stats.windows;
  last_boundary = (double) stats.boundary_bodies;
  last_gathers = (double) stats.gathers;
  last_spanning = (double) stats.spanning;
  last_fallbacks = (double) stats.fallbacks;
  last_gathered = (double) stats.gathered;
  last_neighbour = (double) stats.neighbour;
  last_forwards = (double) stats.forwards;
  last_round_fails = (double) stats.round_fails;
  last_step_redos = (double) stats.step_redos;
  run_sum.start_checked += (double) stats.start_checked;
  run_sum.start_differ += (double) stats.start_differ;
}

bool FixHardSphere::resident_usable() const
{
  if (vflag_atom) return false;
  return comm->nprocs == 1 ? (bool) resident : gather_step;
}

/* The box and limits a resident step works in. */
HSGPU::Collide::ResidentBox FixHardSphere::resident_box() const
{
  HSGPU::Collide::ResidentBox box;
  for (int d = 0; d < 3; ++d) {
    box.lo[d] = domain->boxlo[d];
    box.prd[d] = domain->prd[d];
  }
  box.periodic[0] = domain->xperiodic;
  box.periodic[1] = domain->yperiodic;
  box.periodic[2] = domain->zperiodic;
  box.overlap_tol = OVERLAP_TOL;
  box.reach = reach;
  return box;
}

/* A resident step's view of some atoms' arrays (omega: rough spheres only, else null), the
   step budget left to the device; same: the arrays other than x, v, f and omega hold what the
   last step done there left in them (ResidentAtoms::same_atoms). */
HSGPU::Collide::ResidentAtoms FixHardSphere::resident_atoms(const Source &s, bool same) const
{
  HSGPU::Collide::ResidentAtoms a;
  a.n = s.n;
  a.x = s.x;
  a.v = s.v;
  a.f = s.f;
  a.tlast = s.tlast;
  a.radius = s.radius;
  a.rmass = s.rmass;
  a.type = s.type;
  a.id = s.id;
  a.id_bytes = (int) sizeof(tagint);
  a.ftm2v = force->ftm2v;
  a.bound_floor = -1.0;    // the device works out the step budget
  a.reach = reach;
  a.never = NEVER_COLLIDED;
  a.same_atoms = same;
  a.omega = s.omega;
  return a;
}

/* LAMMPS's own arrays of this rank's atoms (omega only for rough spheres). */
FixHardSphere::Source FixHardSphere::atom_source() const
{
  const int n = atom->nlocal;
  Source s;
  s.n = n;
  s.room = atom->nmax;
  s.x = n ? atom->x[0] : nullptr;
  s.v = n ? atom->v[0] : nullptr;
  s.f = n ? atom->f[0] : nullptr;
  s.omega = (friction_on && n) ? atom->omega[0] : nullptr;
  s.tlast = tlast;
  s.radius = atom->radius;
  s.rmass = atom->rmass;
  s.type = atom->type;
  s.id = atom->tag;
  return s;
}

/* The run's first device step with no force styles (forces_none) copied f up and found amax,
   its largest acceleration (on several ranks rank 0's gathered step's, the same number on
   every rank): zero confirms that f stays zero; anything else (a style that sets forces
   outside the hooks no_force_styles() knows) means f goes up every step. */
void FixHardSphere::forces_seen(double amax)
{
  if (amax == 0.0) {
    forces_checked = true;
    return;
  }
  forces_none = false;
  if (comm->me == 0)
    error->warning(FLERR, "Fix hardsphere: atoms have forces although no pair, bond or kspace "
                          "style or force fix is defined; copying f to the device every step");
}

/* The timers and counters of a resident step (one rank, or rank 0's gathered step as every
   rank got it); on `done` also the last step's figures. */
void FixHardSphere::count_resident(const HSGPU::Collide::ResidentReport &report)
{
  t_search += report.t_search;
  t_resolve += report.t_resolve;
  n_redo += (double) report.redone;    // steps the device did again with raised bounds
  run_sum.t_transfer += report.t_upload + report.t_download;
  run_sum.bytes_up += (double) report.bytes_up;
  if (report.outcome != HSGPU::Collide::ResidentOutcome::done) {
    n_declined += 1.0;
    run_sum.declined[(int) report.outcome]++;
    return;
  }
  last_candidates = (double) report.candidates;    // the device's search, the same pairs
  n_resident += 1.0;
  run_sum.resident++;
  n_repair += (double) report.stats.repairs;
  last_largest = (double) report.stats.largest_group;
  last_groups = (double) report.stats.groups;
  last_windows = (double) report.stats.windows;
  last_boundary = 0.0;
  last_gathers = last_spanning = last_fallbacks = last_gathered = last_neighbour = 0.0;
  last_forwards = last_round_fails = last_step_redos = 0.0;
}

/* The whole step on the device (engine/resident_step.h), where there is a resident step:
   with group all, the atoms' arrays up and the atoms that had events back (returns 2); else
   the group's bodies and step bounds up and back (returns 1, apply_results() still to do).
   Returns 0, with nothing changed, where the device hands the step back (an overlap, a
   missed contact, the event cap, a box too small for its cells): the host then resolves it
   from the same start.  On several ranks: step_gathered(). */
int FixHardSphere::step_resident(Tally &mine, Tally &all)
{
  if (comm->nprocs > 1) return step_gathered(mine, all);
  // This step run ahead during LAMMPS's integration (run_ahead()), where nothing changed.
  if (next.pending) {
    const int taken = take_ahead(mine, all);
    if (taken >= 0) return taken;
  }
  // Whatever this step does, the device's copies are current after it only where it is done
  // there whole.
  const bool same = resident_same && !sizes_vary;
  resident_same = false;
  // Per-atom virial: on the host (the device step does not tally it).
  if (!resident_usable()) return 0;
  const double dt = update->dt;
  const double t_start = MPI_Wtime();
  const HSGPU::Collide::ResidentBox box = resident_box();
  HSGPU::Collide::ResidentReport report;
  mine = Tally();
  // Group all: LAMMPS's own arrays go up and the atoms with events come back; else the
  // group's bodies, gathered here.  (post_integrate() leaves the step budget to the device
  // in the first case.)
  const bool whole = igroup == 0;
  double t_gather = 0.0;
  try {
    if (whole) {
      HSGPU::Collide::ResidentAtoms a = resident_atoms(atom_source(), same);
      // No force styles: f (zero) stays on the host after the run's first device step found
      // it zero.
      a.zero_forces = forces_none && forces_checked;
      // gpu/keep: x and v moved on the device where nothing else changed them.
      a.motion = kept_motion(same);
      resident->run_atoms(a, box, step_params(), wsettings, mine, report);
      atoms_stepped(report);
    } else {
      gather_bodies(dt);
      sboost.assign(atom->nlocal, 0.0);
      const int nb = (int) bodies.size();
      sbound.resize(nb);
      for (int b = 0; b < nb; ++b) sbound[b] = step_bound(bodies[b].owner, dt);
      t_gather = MPI_Wtime() - t_start;
      resident->run(bodies.data(), sbound.data(), nb, box, step_params(), wsettings, mine, report);
    }
  } catch (std::exception &e) {
    error->one(FLERR, "Fix hardsphere: CUDA device {}: {}", backend_device, e.what());
  }
  t_search += t_gather;
  return resident_outcome(report, mine, all, whole);
}

/* After run_atoms() over the atoms' arrays (in this step, or run ahead): what its check of x
   and v found, the forces it saw, and the budget's checks (with bound_floor for the host
   should the device decline). */
void FixHardSphere::atoms_stepped(const HSGPU::Collide::ResidentReport &report)
{
  motion_seen(report);
  if (forces_none && !forces_checked) forces_seen(report.amax);
  check_budget(report.vmax2, report.amax, report.rmax);
}

/* The end of a resident step of one rank: its counters; 0 where the device handed it back,
   else 2 with group all (the atoms' arrays hold the results: the device also shifted every
   atom's time of last collision to the end of this step) or 1 (the results in bodies). */
int FixHardSphere::resident_outcome(const HSGPU::Collide::ResidentReport &report,
                                    const HSGPU::Collide::Tally &mine, HSGPU::Collide::Tally &all,
                                    bool whole)
{
  count_resident(report);
  if (report.outcome != HSGPU::Collide::ResidentOutcome::done) return 0;
  all = mine;
  resident_same = whole;
  if (whole) vend2 = report.vend2;    // the atoms' speeds at the step end
  return whole ? 2 : 1;
}

void FixHardSphere::post_integrate()
{
  const double t_start = MPI_Wtime();
  const double search_start = t_search;
  const double dt = update->dt;
  comm_step = CommCount();
  // Per-atom virial on the steps LAMMPS asks for it (Integrate::ev_set sets vflag_atom to the
  // step before post_integrate); v_init zeroes vatom then, and sets vflag_atom.
  virial_init(update->vflag_atom == update->ntimestep ? VIRIAL_ATOM : 0);
  // The default event cap follows the atoms present (fix pour or fix deposit may have added
  // some since the run started, into a group that may have been empty then).
  if (maxevents_user <= 0) maxevents = 1000 + 100 * atom->natoms;
  // A whole step on the device (one rank with group all, or the gathered step) finds the
  // budget's maxima there.
  if (!(resident_usable() && (igroup == 0 || gather_step))) step_budget();
  Tally mine, all;
  vend2 = 0.0;
  const int on_device = step_resident(mine, all);
  if (!on_device) {
    sboost.assign(atom->nlocal, 0.0);
    double tp = MPI_Wtime();
    prepare(dt);
    run_sum.t_prepare += lap(tp);
    if (serial_order)
      step_serial(mine, all);
    else
      step_windows(mine, all);
    run_sum.t_windows += lap(tp);
  }
  if (all.capped) {
    const std::string msg = fmt::format(
        "Fix hardsphere: step {} needed more than maxevents = {} events ({} carried out); {}",
        update->ntimestep, maxevents, all.events,
        maxevents_warn ? "the rest of its collisions are not resolved"
                       : "raise maxevents, or check the guards (tc, vmin) for a collapse");
    if (maxevents_warn) {
      if (comm->me == 0) error->warning(FLERR, msg);
    } else {
      error->all(FLERR, msg);
    }
  }

  // 2: the device wrote the atoms itself (and vend2, where it finds it); 1: its results are
  // in bodies.
  if (on_device != 2) apply_results(dt, on_device == 1 || !serial_order);
  // The next step's drift at the atoms' speeds now (after a step on the device with group
  // all: as the device reports them, else at the step's start): the ghost cutoff is raised
  // ahead of it where needed.
  {
    double v2 = std::max(step_vmax2, vend2), gv2 = 0.0;
    allreduce(&v2, &gv2, 1, MPI_DOUBLE, MPI_MAX);
    plan_ghost_raise(std::sqrt(gv2) * dt + step_amax * dt * dt);
  }
  if (vflag_atom) {
    apply_virial(dt, !serial_order);
    vatom_step = update->ntimestep;
  }

  n_step = (double) all.pair;
  n_total += (double) all.pair;
  n_wall += (double) all.wall;
  ke_total += all.ke_lost * force->mvv2e;
  events_total += (double) all.events;
  max_events = std::max(max_events, (double) all.events);
  const double scale = 1.0 / (dt * force->ftm2v);
  for (int k = 0; k < 6; ++k) virial[k] = mine.virial[k] * scale;

  run_sum.steps++;
  run_sum.pairs += (double) all.pair;
  run_sum.events += (double) all.events;
  run_sum.largest = std::max(run_sum.largest, last_largest);
  run_sum.largest_sum += last_largest;
  run_sum.windows += last_windows;
  run_sum.groups += last_groups;
  run_sum.boundary += last_boundary;
  run_sum.gathers += last_gathers;
  run_sum.spanning += last_spanning;
  run_sum.fallbacks += last_fallbacks;
  run_sum.gathered += last_gathered;
  run_sum.neighbour += last_neighbour;
  run_sum.forwards += last_forwards;
  run_sum.round_fails += last_round_fails;
  run_sum.step_redos += last_step_redos;
  comm_last = comm_step;
  run_sum.collectives += comm_step.collectives;
  run_sum.halos += comm_step.halos;
  run_sum.bytes += comm_step.bytes;
  run_sum.messages += comm_step.messages;
  run_sum.t_comm += comm_step.seconds;
  const double spent = MPI_Wtime() - t_start;
  t_step += spent;
  run_sum.t_step += spent;
  run_sum.t_search_steps += t_search - search_start;
  if (run_sum.steps == 1) run_sum.t_first = spent;
}

/* Tuning aid (HSGPU_RANK_PARTS=1, several ranks): each rank's time in ms per step over the run
   on lines of its own, from rank 0: the fix's step, its communication (waits for the other ranks
   included) and the rest, its own work; the parts of the run summary (the groups spanning ranks
   with their waits, and of them the rank's packing, unpacking and resolving); the rest of the
   step ("other"), split into the step's ghost update with the overlap check, the step check
   after the windows with the step driver's reductions around them, and the rest (the step
   budget, the results written back); its atoms and ghosts; and a second line taking the step
   check and the driver's reductions apart.  The rank with the least communication is the one
   the others wait for. */
void FixHardSphere::log_rank_parts()
{
  const RunSummary &r = run_sum;
  const HSGPU::Collide::DriverTimes &dtm = driver.times;
  struct Parts {    // seconds over the run (atoms, ghosts: counts), gathered as doubles
    double step, comm, search, edges, groups, local, spanning, spanning_own, atoms, ghosts;
    double prepare, windows, before, after, ends, tallies, check_ghosts, check_search;
    double check_reduce;
  };
  constexpr int NP = sizeof(Parts) / sizeof(double);
  const Parts mine{r.t_step,
                   r.t_comm,
                   r.t_search_steps,
                   dtm.edges,
                   dtm.groups,
                   dtm.local,
                   dtm.spanning,
                   dtm.span_pack + dtm.gather_unpack + dtm.span_resolve,
                   (double) atom->nlocal,
                   (double) atom->nghost,
                   r.t_prepare,
                   r.t_windows,
                   dtm.before,
                   dtm.after,
                   r.t_ends,
                   r.t_tallies,
                   r.t_check_ghosts,
                   r.t_check_search,
                   r.t_check_reduce};
  std::vector<Parts> every(comm->me == 0 ? comm->nprocs : 0);
  MPI_Gather(&mine, NP, MPI_DOUBLE, every.data(), NP, MPI_DOUBLE, 0, world);
  if (comm->me != 0) return;
  const double per = 1e3 / (double) r.steps;    // seconds over the run -> ms per step
  for (int q = 0; q < comm->nprocs; ++q) {
    const Parts &e = every[q];
    const double parts = e.edges + e.groups + e.local + e.spanning;
    utils::logmesg(lmp,
                   "Fix hardsphere: rank {}, ms per step: step {:.4g}, communication {:.4g}, "
                   "own work {:.4g}; search {:.4g}, window lengths {:.4g}, groups {:.4g}, "
                   "local {:.4g}, spanning {:.4g} (packing, unpacking and resolving {:.4g}), "
                   "other {:.4g} (the ghost update and overlap check {:.4g}, the step check "
                   "and the windows' reductions {:.4g}, the rest {:.4g}); {:.0f} atoms, "
                   "{:.0f} ghosts\n",
                   q, per * e.step, per * e.comm, per * (e.step - e.comm), per * e.search,
                   per * e.edges, per * e.groups, per * e.local, per * e.spanning,
                   per * e.spanning_own, per * (e.step - e.search - parts),
                   per * (e.prepare - e.search), per * (e.windows - parts),
                   per * (e.step - e.prepare - e.windows), e.atoms, e.ghosts);
    utils::logmesg(lmp,
                   "Fix hardsphere: rank {}, the step check and the windows' reductions: "
                   "before the windows {:.4g}, after them {:.4g}, the atoms' step ends "
                   "{:.4g}, the tallies' reduction {:.4g}, the check's ghost update {:.4g}, "
                   "search {:.4g}, reduction {:.4g}\n",
                   q, per * e.before, per * e.after, per * e.ends, per * e.tallies,
                   per * e.check_ghosts, per * e.check_search, per * e.check_reduce);
  }
}

/* One line per run in the log: what the resolution did, for a user asking why a run is slow. */
void FixHardSphere::post_run()
{
  drop_ahead();
  const RunSummary &r = run_sum;
  if (r.steps == 0) return;
  // The bytes and messages all ranks received (every rank takes part in the sum).
  // (With them, WindowSettings::start_check's comparisons.)
  double mine[4] = {r.bytes, r.messages, r.start_checked, r.start_differ};
  double all[4] = {0.0, 0.0, 0.0, 0.0};
  if (comm->nprocs > 1) MPI_Allreduce(mine, all, 4, MPI_DOUBLE, MPI_SUM, world);
  const double bytes = all[0], messages = all[1];
  const double n = (double) r.steps;
  // Where a rank's time went, the least and the most of any rank per part, in ms per step:
  // the windows' parts, the search, the spanning groups' parts, and the communication.
  const HSGPU::Collide::DriverTimes &dtm = driver.times;
  // Then the gathered step's (several ranks, gpu/gather yes): the parts of the results' way
  // back (rank 0's buffer handles to the ranks, its results' handles and counts, reading them,
  // the reduction after, writing them into the atoms' arrays), rank 0's own part of the first,
  // its longest single step, and the time copying x, v, f to rank 0's device and waiting for
  // the other ranks there.
  constexpr int NT = 25, GPART = 13, GOWN = 18, GMOST = 19, GPUT = 20, GWAIT = 21;
  const double tmine[NT] = {dtm.edges,       dtm.groups,       dtm.local,
                            dtm.spanning,    t_search + r.t_search, dtm.span_pack,
                            dtm.span_gather, dtm.span_resolve, dtm.span_results,
                            dtm.span_join,   r.t_comm,         dtm.gather_messages,
                            dtm.gather_unpack, gath.t_part[0], gath.t_part[1],
                            gath.t_part[2],  gath.t_part[3],   gath.t_part[4],
                            gath.t_part[5],  gath.t_handles_most, gath.t_put,
                            gath.t_wait,     dtm.edges_start,  dtm.edges_reduce,
                            dtm.edges_ghosts};
  double tw[2 * NT], twx[2 * NT] = {0.0};
  for (int k = 0; k < NT; ++k) {
    tw[k] = -tmine[k];    // the least, as minus the most of the negatives
    tw[NT + k] = tmine[k];
  }
  MPI_Allreduce(tw, twx, 2 * NT, MPI_DOUBLE, MPI_MAX, world);
  auto least = [&](int k) { return -1e3 * twx[k] / n; };
  auto most = [&](int k) { return 1e3 * twx[NT + k] / n; };
  gath.t_put = gath.t_wait = gath.t_handles_most = 0.0;
  for (double &t : gath.t_part) t = 0.0;
  // One group of atoms resolved together that holds a quarter of them or more, on average over
  // the steps, on several ranks: its collisions are resolved one after another in one event
  // queue, its atoms gathered from the ranks every window (touching spheres, such as a settled
  // pile, are one group however short the window), so more ranks cannot make the run faster.
  const double natoms_fix = (comm->nprocs > 1) ? (double) group->count(igroup) : 0.0;
  if (comm->nprocs > 1) {
    // (Every rank takes part where any has the variable: a rank launched without it waits
    // for no gather that the others make.)
    int want = std::getenv("HSGPU_RANK_PARTS") ? 1 : 0;
    MPI_Allreduce(MPI_IN_PLACE, &want, 1, MPI_INT, MPI_MAX, world);
    if (want) log_rank_parts();
  }
  if (comm->me != 0) return;
  auto part = [&](int k) {
    return fmt::format("{:.3g} to {:.3g}", least(GPART + k), most(GPART + k));
  };
  if (gather_step && twx[NT + GPUT] > 0.0)
    utils::logmesg(lmp,
                   "Fix hardsphere: x, v and f copied by each rank to rank 0's device: {:.4g} s "
                   "copying and {:.4g} s waiting for the other ranks (the most of any rank); "
                   "ms per step (least to most of any rank): rank 0's buffers' handles {} (of "
                   "that rank 0's own {:.3g}; the most in one step {:.3g}), its results' "
                   "handles and counts {}, reading them {}, the reduction after {}, writing them "
                   "into the atoms' arrays {}\n",
                   twx[NT + GPUT], twx[NT + GWAIT], part(0), most(GOWN), 1e3 * twx[NT + GMOST],
                   part(1), part(2), part(3), part(4));
  utils::logmesg(lmp,
                 "Fix hardsphere ({} order, {} backend): {} steps, {:.6g} collisions and {:.6g} "
                 "events per "
                 "step; largest group {:.0f} atoms, {:.3g} windows and {:.4g} groups per step, "
                 "{:.0f} repairs, {:.0f} steps redone; {:.4g} atoms per step in groups spanning "
                 "ranks, {:.4g} such groups per step resolved where they lie, {:.3g} gathers "
                 "per step of {:.4g} atoms ({:.3g} windows per step on the old path); search "
                 "{:.4g} s, resolve {:.4g} s; the fix's step {:.4g} ms per step ({:.4g} ms after "
                 "the first)\n",
                 serial_order ? "serial" : "parallel",
                 (serial_order && !resident) ? "cpu" : backend->name(), r.steps, r.pairs / n,
                 r.events / n, r.largest, r.windows / n, r.groups / n, n_repair + r.repairs,
                 n_redo + r.redos, r.boundary / n, r.spanning / n, r.gathers / n,
                 r.gathered / n, r.fallbacks / n, t_search + r.t_search,
                 t_resolve + r.t_resolve, 1e3 * r.t_step / n,
                 r.steps > 1 ? 1e3 * (r.t_step - r.t_first) / (n - 1) : 1e3 * r.t_step);
  if (comm->nprocs > 1)
    utils::logmesg(lmp,
                   "Fix hardsphere: communication per step: {:.4g} collective operations, {:.4g} "
                   "ghost updates, {:.4g} messages to neighbouring ranks ({:.3g} gathers with "
                   "the neighbouring ranks only, {:.3g} rounds passing entries on, {:.3g} "
                   "gathered again from every rank after them), {:.4g} kB received by all {} "
                   "ranks together; {:.4g} to {:.4g} ms per step in it on a rank (waiting for "
                   "the other ranks included); {:.0f} steps of planned windows done again with a "
                   "reduction per window\n",
                   r.collectives / n, r.halos / n, messages / n, r.neighbour / n,
                   r.forwards / n, r.round_fails / n, 1e-3 * bytes / n, comm->nprocs, least(10),
                   most(10), r.step_redos);
  if (wsettings.start_check && comm->nprocs > 1)
    utils::logmesg(lmp,
                   "Fix hardsphere: start points of the steps' first windows checked: {:.0f} "
                   "candidate pairs with a foreign atom, {:.0f} of them with that atom's start "
                   "point or bound rate formed here unlike its owner's\n",
                   all[2], all[3]);
  if (most(0) + most(1) + most(2) + most(3) > 0.0) {
    utils::logmesg(lmp,
                   "Fix hardsphere: a rank's search and windows, ms per step (least to most of "
                   "any rank): search {:.4g} to {:.4g}; window lengths tried {:.4g} to {:.4g} "
                   "(of it: the windows' start points {:.4g} to {:.4g}, their ghost updates "
                   "{:.4g} to {:.4g}, reductions {:.4g} to {:.4g}; waits included), groups "
                   "{:.4g} to {:.4g}, groups resolved here {:.4g} to {:.4g}, groups spanning "
                   "ranks (gathered, resolved, results sent back; waits included) {:.4g} to "
                   "{:.4g}\n",
                   least(4), most(4), least(0), most(0), least(22), most(22), least(24),
                   most(24), least(23), most(23), least(1), most(1), least(2), most(2),
                   least(3), most(3));
  }
  if (comm->nprocs > 1 && most(0) + most(1) + most(2) + most(3) > 0.0) {
    utils::logmesg(lmp,
                   "Fix hardsphere: of the groups spanning ranks, ms per step: packing {:.4g} to "
                   "{:.4g}, the gather {:.4g} to {:.4g}, resolving {:.4g} to {:.4g}, results to "
                   "their owners {:.4g} to {:.4g}, missed pairs joined {:.4g} to {:.4g}; of the "
                   "gather: messages and reductions (waits included) {:.4g} to {:.4g}, unpacking "
                   "and grouping the entries {:.4g} to {:.4g}\n",
                   least(5), most(5), least(6), most(6), least(7), most(7), least(8), most(8),
                   least(9), most(9), least(11), most(11), least(12), most(12));
  }
  if (resident) {
    using HSGPU::Collide::ResidentOutcome;
    auto back = [&](ResidentOutcome o) { return r.declined[(int) o]; };
    utils::logmesg(lmp,
                   "Fix hardsphere: {} of {} steps carried out whole on the device{} ({:.4g} s "
                   "of the search and resolve times copying atoms to the device and back, {:.4g} "
                   "MB per step up{}); handed back to the host: {} (overlap at the start), {} (a "
                   "missed contact), {} (maxevents), {} (a periodic length shorter than three "
                   "search cells)\n",
                   r.resident, r.steps, gather_step ? " of rank 0" : "", r.t_transfer,
                   1e-6 * r.bytes_up / n,
                   gather_step ? fmt::format(", and {:.4g} s gathering the atoms of all ranks on "
                                             "rank 0 and sending the results back, {:.4g} s of "
                                             "them the results",
                                             r.t_gather, r.t_back)
                               : std::string(),
                   back(ResidentOutcome::overlap), back(ResidentOutcome::excursion),
                   back(ResidentOutcome::capped), back(ResidentOutcome::small_box));
    if ((comm->nprocs == 1 || gather_step) && igroup == 0)
      utils::logmesg(lmp, "Fix hardsphere: {}\n", motion_summary());
  }
  if (comm->nprocs > 1 && !serial_order && !gather_step && natoms_fix > 0.0 &&
      r.largest_sum / n >= 0.25 * natoms_fix)
    error->warning(FLERR,
                   fmt::format("Fix hardsphere: its largest group of atoms resolved together "
                               "held {:.0f} of its {:.0f} atoms on average over this run's {} "
                               "steps ({:.0f}%; touching spheres, such as a settled pile, are "
                               "one group): such a group's collisions are resolved one after "
                               "another, its atoms gathered from the ranks every window, so this "
                               "run cannot gain from its {} ranks and may well run faster on "
                               "fewer",
                               r.largest_sum / n, natoms_fix, r.steps,
                               100.0 * r.largest_sum / (n * natoms_fix), comm->nprocs));
}
