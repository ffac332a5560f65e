/* HARDSPHERE_GPU collision engine: a whole step of one rank kept on a backend (the device-
   resident step of the CUDA backend).

   The step driver (window_driver.h) takes the candidate pairs from its caller and hands the
   backend one window's groups at a time, so every window crosses the host-device link twice.
   A resident step gets the bodies and their step bounds once and does the rest where they
   are: the candidate search (a cell list, nearest image in a periodic box), the windows
   (window_chooser.h, the driver's choice; with adaptive windows the CUDA step aims at smaller
   largest groups by default), the groups (connected components
   of each window's edges), their events, each window's check (a pair not joined that could
   have touched is joined and the window resolved again from its start), and the step's check
   (a body that moved further than its step bound).  The bodies come back once, at the end.

   Exact or nothing.  A step it carries out gives the step driver's positions, velocities and
   event counts bit for bit, and its window statistics with the same windows (the same core
   functions, compiled without
   FMA contraction; event times depend only on the two bodies' states, never on the group or
   the window).  Only the tally's sums of energy lost and virial are added in another order
   (over groups by a tree rather than one by one): they agree to rounding.  Where the step is
   not one it can finish alone it declines it, leaving the bodies as given, and the caller
   resolves the step its own way from the same input:
   - overlap:   a pair or a sphere and a wall overlap at the start points (the caller reports
                or pushes them);
   - excursion: a pair that was not a candidate could have touched (a body moved further
                than its step bound, and the two together at least the pair's gap), or a body
                moved further than the reach (the caller raises bounds, or stops); run_atoms()
                first does such a step again itself, up to three times, with the bounds of the
                bodies that moved too far raised (report.redone);
   - capped:    the step needs more than p.maxevents events (the caller's cap decides which);
   - small_box: a periodic length holds fewer than three search cells.

   Only one rank's bodies with no foreign nodes (on several ranks the caller gathers them all on
   one rank, or uses the driver).  No LAMMPS, MPI or CUDA here. */
#ifndef HSGPU_ENGINE_RESIDENT_STEP_H
#define HSGPU_ENGINE_RESIDENT_STEP_H

#include "window_driver.h"

#include "core/verlet_motion.h"

#include <memory>
#include <vector>

namespace HSGPU {
namespace Collide {

  /// The box: lower corner, lengths, periodic flags.
  struct ResidentBox {
    double lo[3];
    double prd[3];
    int periodic[3];
    /// Pairs closer than (1 - overlap_tol) x contact, and spheres that far inside a wall,
    /// overlap.
    double overlap_tol;
    /// A body that moves further than this in the step declines it (the caller's limit).
    double reach;
  };

  enum class ResidentOutcome { done = 0, overlap, excursion, capped, small_box };

  /// How run_atoms() gets x and v.  Between two steps LAMMPS's integrator (fix nve or
  /// nve/sphere of every atom) moves the atoms by verlet_between_steps() (core/verlet_motion.h)
  /// with the step's f: where nothing else touched x or v (the caller knows), the step can move
  /// the copies it kept from its last step the same way instead of copying the caller's up.
  ///   copy:    x and v copied up (as always before);
  ///   check:   copied up, and compared with the kept copies so moved, both ways of rounding
  ///            (ResidentReport::motion_miss); the step itself uses what came up;
  ///   predict: the kept copies so moved are the step's x and v; nothing copied up.
  ///   advance: x and v as given (the caller's arrays, or the step's shared buffers) are
  ///            LAMMPS's at the forces of the step before (its post_force(), before fix nve's
  ///            final_integrate()); the step moves them as predict moves the kept copies
  ///            (StepMotion without wrap: LAMMPS wraps atoms only after the step) and uses
  ///            them.  Needs no kept copies: for FixHardSphere's gathered step of several
  ///            ranks, whose x and v come from every rank (and with results or shared inputs).
  /// check and predict fall back to copy where the step kept no copies of these arrays (its
  /// last run_atoms() not done, or not with keep, other arrays or another atom count, or
  /// forget_host_arrays() since).
  enum class MotionUse { copy, check, predict, advance };
  struct KeptMotion {
    MotionUse use = MotionUse::copy;
    bool keep = false;     // keep copies of x and v as this step leaves them, for the next
    bool fused = false;    // predict: fused multiply-adds (core/verlet_motion.h)
    StepMotion move;       // what LAMMPS did to the atoms since the last step
  };

  /// What a resident step did besides the tally.
  struct ResidentReport {
    ResidentOutcome outcome = ResidentOutcome::done;
    WindowStats stats;
    long candidates = 0;        // candidate pairs of the step
    long changed = 0;           // bodies that had events (the ones copied back)
    int redone = 0;             // times the step was done again on the device (run_atoms)
    double t_search = 0.0;      // seconds: upload and candidate search
    double t_resolve = 0.0;     // seconds: windows, checks and download
    double t_upload = 0.0;      // seconds of t_search copying the bodies to the device
    double t_download = 0.0;    // seconds of t_resolve copying them back
    // run_atoms(): the step budget's maxima over the atoms (FixHardSphere::step_budget), found
    // on the device: squared speed, acceleration |f| ftm2v / m, radius.
    double vmax2 = 0.0, amax = 0.0, rmax = 0.0;
    // run_atoms() on `done`: the largest squared half-step speed of the atoms at the step's
    // end (after its collisions), for the fix's look ahead at the next step's moves
    // (FixHardSphere::plan_ghost_raise()); 0 where the step does not find it (the fix then
    // looks ahead from vmax2, the speeds at the step's start).
    double vend2 = 0.0;
    long bytes_up = 0;    // run_atoms(): bytes copied to the device for the step
    // run_atoms(): how the step got x and v (ResidentAtoms::motion; copy where it kept no
    // copies to move), and on a check the atoms whose kept copies, moved by the integrator's
    // arithmetic, differ from the caller's x or v in any bit: plain rounding x, v, then fused
    // multiply-adds x, v (core/verlet_motion.h); -1 where not checked.
    MotionUse motion = MotionUse::copy;
    long long motion_miss[4] = {-1, -1, -1, -1};
  };

  /// The end of the step of an atom that had events (ResidentAtoms::results): its index in
  /// the caller's arrays, end-of-step position and velocity.
  struct ResidentResult {
    int index;
    double x[3], v[3];
  };

  /// A caller's per-atom arrays, when every atom is a body (ResidentStep::run_atoms): the
  /// bodies are built and the results written on the device, so that only these arrays and
  /// the atoms that had events cross the link.
  struct ResidentAtoms {
    int n;
    // The arrays are read and written where they lie; the step may keep them page-locked until
    // forget_host_arrays().
    double *x;          // 3 per atom: the drift's end point x0 + v dt (in; out: step end)
    double *v;          // 3 per atom: half-step velocities (in; out)
    double *tlast;      // time of the last collision relative to the step start (in); out:
                        // relative to the step end, max(t - dt, never), for every atom
    const double *f;    // 3 per atom: forces
    const double *radius, *rmass;
    const int *type;
    const void *id;    // atom IDs, id_bytes (4 or 8) each
    int id_bytes;
    double *omega = nullptr;    // 3 per atom: angular velocities (in; out for the atoms that
                                // had events), rough spheres (Params::friction) only; else null
    double ftm2v;          // acceleration = f ftm2v / rmass
    double bound_floor;    // step bound: min(max(2 |v| dt, bound_floor), reach); negative: the
                           // step's own, half of step_least() of the atoms' maxima (the report's)
    double reach;
    double never;    // the least time of last collision (an atom that never collided)
    // Where given: x, v and omega are left as they were, and the atoms that had events are
    // listed here instead, in increasing index (with their angular velocities, 3 each, in
    // result_spin for rough spheres); tlast is written for every atom as always.  For a
    // caller that sends them on (FixHardSphere's step of several ranks on rank 0's device).
    std::vector<ResidentResult> *results = nullptr;
    std::vector<double> *result_spin = nullptr;
    // x, v and f are in the step's own buffers already (share_inputs(), put there by the
    // processes that hold the atoms, and put_inputs()): x, v and f here are not read.
    bool inputs_shared = false;
    // The same for tlast, radius, rmass, type and id (put_statics() and the processes'
    // GPU::PeerInputs::put_statics()): not read here; tlast is still written back.
    bool statics_shared = false;
    // The same for omega (put_spin(), GPU::PeerInputs::put_spin()).
    bool spin_shared = false;
    // The caller vouches that tlast, radius, rmass, type and id hold what they held at the end
    // of the last run_atoms() that returned `done` (same atoms in the same order, nothing
    // written to them since): the step may then keep its device copies instead of copying
    // them up again.  False is always safe.
    bool same_atoms = false;
    // The caller vouches that f is zero for every atom (no style sets forces: FixHardSphere::
    // forces_none): f is not read or copied up, the device uses zeros.
    bool zero_forces = false;
    // The gathered step of several ranks after LAMMPS moved atoms between ranks or in their
    // arrays (FixHardSphere, a step run ahead): the shared buffers hold this step's f and, in
    // the slot of the IDs, the atoms' IDs in their new order (put_ids()); their x, v, tlast,
    // radius, rmass and type are the last step's end state (KeptMotion::keep, listed results),
    // which the step finds by ID before it moves x and v (MotionUse::advance with wrap).
    // Where an ID was not among the last step's, or the step has no such state, it returns
    // at once with ResidentReport::motion copy and nothing done, its kept state gone (the
    // caller sends everything again).  Only with inputs_shared and statics_shared.
    bool reordered = false;
    // How x and v get to the step (KeptMotion); check and predict only with x, v, f of the
    // caller's (not inputs_shared, not results) and no omega; advance with any of those but
    // omega.
    KeptMotion motion;
    // The caller's x, v, omega and tlast are not written until deliver_atoms(), which writes
    // the results there, and x and v are not read: the step can then run while LAMMPS still
    // integrates the atoms (FixHardSphere::run_ahead()).  Only with MotionUse::predict: where
    // the step has no copies to move, it returns at once with ResidentReport::motion copy and
    // nothing done.  Not with results.
    bool defer_writes = false;
  };

  class ResidentStep {
   public:
    virtual ~ResidentStep() = default;
    /// Order serial: the step's events one globally earliest at a time (the seed paper's loop,
    /// core/event_order.h) instead of windows and groups; the same result, and the report
    /// counts one window of one group of all bodies, as the host's serial order does.
    void set_serial(bool on) { serial = on; }
    /// The caller's arrays given to run_atoms() may move or be freed (LAMMPS grows its
    /// per-atom arrays, a run ends): the step lets go of any hold it keeps on them (the CUDA
    /// step page-locks them in place between steps).
    virtual void forget_host_arrays() {}
    /// The gathered step of several ranks on one node: reserves the step's buffers of x, v, f,
    /// tlast, radius, rmass, type and id (id_bytes each), with `spin` also omega, for n atoms
    /// and writes handles to them, which other processes of the node can open (GPU::PeerInputs) to copy their atoms'
    /// arrays in place, into `handles` (opaque bytes, the same while the buffers stay where
    /// they are).  False where the step has no such buffers (the host's reference step) or the
    /// device refuses; then nothing changed.
    virtual bool share_inputs(long n, int id_bytes, bool spin, std::vector<char> &handles)
    {
      (void) n;
      (void) id_bytes;
      (void) spin;
      handles.clear();
      return false;
    }
    /// After a run_atoms() with ResidentAtoms::results that returned `done`: handles to the
    /// step's device copies of those results (ResidentResult each, in the listed order) and of
    /// every atom's tlast, with `spin` also of the results' angular velocities (3 each), which
    /// other processes of the node can open (GPU::PeerInputs::open_results()) to read their
    /// atoms' results in place.  They stay valid until the next
    /// share_inputs(), put_inputs(), put_statics() or run_atoms().  False where the step has no
    /// such copies; then `handles` is empty.
    virtual bool share_results(bool spin, std::vector<char> &handles)
    {
      (void) spin;
      handles.clear();
      return false;
    }
    /// After a run_atoms() with ResidentAtoms::results and KeptMotion::keep that returned
    /// `done`: copies atoms [first, first + count) of the step's end state (x and v: every
    /// atom's, the results written in; tlast) into x, v (3 each) and tlast here, and waits;
    /// other processes of the node read the same from the buffers of share_inputs()
    /// (GPU::PeerInputs::get_atoms()).  Valid until the next put_inputs(), put_statics() or
    /// run_atoms().  False where the step has no such state (the host's reference step).
    virtual bool get_atoms(long first, long count, double *x, double *v, double *tlast)
    {
      (void) first;
      (void) count;
      (void) x;
      (void) v;
      (void) tlast;
      return false;
    }
    /// Copies count atoms' angular velocities (3 each) from this process into atoms [first,
    /// first + count) of the omega buffer of share_inputs() with spin, and waits.
    virtual void put_spin(long first, long count, const double *omega)
    {
      (void) first;
      (void) count;
      (void) omega;
    }
    /// Copies count atoms' tlast, radius, rmass, type and id from this process into atoms
    /// [first, first + count) of the buffers of share_inputs(), and waits for the copy.
    virtual void put_statics(long first, long count, const double *tlast, const double *radius,
                             const double *rmass, const int *type, const void *id, int id_bytes)
    {
      (void) first;
      (void) count;
      (void) tlast;
      (void) radius;
      (void) rmass;
      (void) type;
      (void) id;
      (void) id_bytes;
    }
    /// Copies count atoms' IDs (id_bytes each) from this process into atoms [first, first +
    /// count) of the ID buffer of share_inputs(), and waits (ResidentAtoms::reordered).
    virtual void put_ids(long first, long count, const void *id, int id_bytes)
    {
      (void) first;
      (void) count;
      (void) id;
      (void) id_bytes;
    }
    /// Copies count atoms' x, v and f (3 each) from this process into atoms [first, first +
    /// count) of the buffers of share_inputs(), and waits for the copy.  room: atoms the
    /// arrays x, v, f hold (at least count; the CUDA step page-locks that much once).
    virtual void put_inputs(long first, long count, const double *x, const double *v,
                            const double *f, long room)
    {
      (void) first;
      (void) count;
      (void) room;
      (void) x;
      (void) v;
      (void) f;
    }
    /// The step of the atoms in `a` (start points x - v dt), as run() over the bodies built
    /// from them, with the step bounds of ResidentAtoms.  On `done` x and v of the atoms that
    /// had events are those at the step end, the others' are as given, every atom's tlast is
    /// relative to the step end, and `tally` holds the events; otherwise the arrays are as
    /// given.  The report's budget maxima are filled in either way.
    virtual void run_atoms(const ResidentAtoms &a, const ResidentBox &box, const Params &p,
                           const WindowSettings &s, Tally &tally, ResidentReport &report) = 0;
    /// After a run_atoms() with ResidentAtoms::defer_writes that returned `done`: writes its
    /// results into the arrays it was given (x, v and omega of the atoms that had events, every
    /// atom's tlast) and waits.  Nothing where none is pending; forget_host_arrays() drops a
    /// pending one (and the copies the step keeps, which ran ahead with it).
    virtual void deliver_atoms() = 0;
    /// The step of bodies[0 .. n) (states at the step start, x = X0, tref = 0) with their step
    /// bounds: pairs whose start points are within r_i + r_j + bound_i + bound_j (nearest
    /// image) are the candidates.  On `done` the bodies that had events hold their states at
    /// the step end (the others' drift lines did not change: they are as given) and `tally`
    /// this step's events; otherwise both are as given.
    virtual void run(Body *bodies, const double *bound, int n, const ResidentBox &box,
                     const Params &p, const WindowSettings &s, Tally &tally,
                     ResidentReport &report) = 0;

   protected:
    bool serial = false;

    /// The kept copies of x and v (ResidentAtoms::motion), the same rule for every
    /// implementation.  motion_begin(): at the start of run_atoms(), how this step gets x and
    /// v: the caller's KeptMotion::use where the copies kept are of these arrays (own: the
    /// step reads the caller's x and v, not shared or listed results), else copy; until
    /// motion_done() the step keeps none.  motion_done(): a done step kept copies (keep) of
    /// a's arrays as it leaves them.  motion_forget(): none kept (forget_host_arrays()).
    MotionUse motion_begin(const ResidentAtoms &a, bool own)
    {
      if (a.motion.use == MotionUse::advance) {
        motion_kept = false;
        return MotionUse::advance;
      }
      const bool have = motion_kept && own && motion_x == a.x && motion_v == a.v && motion_n == a.n;
      motion_kept = false;
      return have ? a.motion.use : MotionUse::copy;
    }
    void motion_done(const ResidentAtoms &a, bool keep)
    {
      motion_kept = keep;
      motion_x = a.x;
      motion_v = a.v;
      motion_n = a.n;
    }
    void motion_forget() { motion_kept = false; }

   private:
    bool motion_kept = false;
    const double *motion_x = nullptr, *motion_v = nullptr;
    int motion_n = -1;
  };

  /// The host's reference implementation (engine/host_resident_step.cpp): the same contract
  /// and results, through the host's step driver, for tests where no device is present.
  std::unique_ptr<ResidentStep> make_host_resident_step();

  inline const char *resident_outcome_name(ResidentOutcome o)
  {
    switch (o) {
    case ResidentOutcome::done:
      return "done";
    case ResidentOutcome::overlap:
      return "overlap";
    case ResidentOutcome::excursion:
      return "excursion";
    case ResidentOutcome::capped:
      return "capped";
    case ResidentOutcome::small_box:
      return "small box";
    }
    return "?";
  }

}    // namespace Collide
}    // namespace HSGPU

#endif
