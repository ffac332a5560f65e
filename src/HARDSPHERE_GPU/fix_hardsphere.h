/* -*- c++ -*- ------------------------------------------------------------------
   HARDSPHERE_GPU: fix hardsphere, hard-core collisions resolved inside each timestep.

     fix ID group-ID hardsphere keyword value ...

   After the integrator's first half kick and drift (post_integrate) the fix finds the
   collisions of the step on the atoms' paths, carries them out in time order (rolling each
   pair back to its contact time, applying the impulse, moving it on) and hands the integrator
   positions and half-step velocities free of overlaps.  The physics lives in core/, the step
   driver (time windows, groups, redo) and its backends in engine/; this class is the LAMMPS
   adapter: it gathers the atoms, finds the candidate pairs, talks to the other ranks for the
   driver and does LAMMPS's bookkeeping.  See doc/fix_hardsphere.md.
------------------------------------------------------------------------------------- */
#ifndef LMP_HSGPU_FIX_HARDSPHERE_H
#define LMP_HSGPU_FIX_HARDSPHERE_H

#include "fix.h"

#include "core/event_order.h"
#include "core/trajectory.h"
#include "engine/cell_search.h"
#include "engine/collision_backend.h"
#include "engine/resident_step.h"
#include "engine/window_driver.h"

#include <memory>
#include <string>
#include <vector>

namespace HSGPU {
namespace GPU {
  class PeerInputs;
}
}    // namespace HSGPU
class StepAhead;

namespace LAMMPS_NS {

class FixHardSphere : public Fix {
 public:
  FixHardSphere(class LAMMPS *, int, char **);
  ~FixHardSphere() override;
  int setmask() override;
  void init() override;
  void setup(int) override;
  void setup_pre_neighbor() override;
  void pre_exchange() override;
  void post_run() override;
  void post_integrate() override;
  void post_force(int) override;
  void end_of_step() override;
  double compute_vector(int) override;

  void write_restart(FILE *) override;
  void restart(char *) override;
  void grow_arrays(int) override;
  void copy_arrays(int, int, int) override;
  void set_arrays(int) override;
  int pack_exchange(int, double *) override;
  int unpack_exchange(int, double *) override;
  int pack_restart(int, double *) override;
  void unpack_restart(int, int) override;
  int size_restart(int) override;
  int maxsize_restart() override;
  int pack_forward_comm(int, int *, double *, int, int *) override;
  int pack_reverse_comm(int, int, double *) override;
  void unpack_reverse_comm(int, int *, double *) override;
  void unpack_forward_comm(int, int, double *) override;
  double memory_usage() override;

 protected:
  // LAMMPS's Domain::boundary code of a fixed ('f') face (0 periodic, 2 and 3 shrink-wrapped).
  static constexpr int FIXED_FACE = 1;
  // tlast of an atom that never collided.
  static constexpr double NEVER_COLLIDED = -1.0e30;
  // --- settings -------------------------------------------------------------------------
  std::vector<double> epair;    // restitution of type pairs, (ntypes + 1)^2
  HSGPU::Collide::Walls walls;
  int serial_order;         // 1: the seed paper's global loop, 0: time windows and groups
  int neighbour_exchange;    // 1: gathers' messages with the neighbouring ranks only (3+ ranks)
  int spanning_gather;      // 1: groups spanning ranks always gathered (default), 0: resolved
                            // in the view (spanning view)
  int nwindows_user;        // windows per step, 0: adaptive
  double tc_user;           // TC-model time, < 0: auto (dt / 2)
  double vmin;              // elastic threshold on |v_n|
  int vmin_auto;            // 1: the threshold is VMIN_AUTO_ATC |a| tc (vmin auto)
  int tc_slow;              // 1: the TC model applies only to slow collisions
  bigint maxevents_user;    // cap on events per step, < 0: auto
  int maxevents_warn;       // 1: warn when capped, 0: error
  int overlap_push;         // 1: push overlapping pairs apart, 0: error
  int maxpush;              // overlap push: relaxation passes before giving up
  double reach_user;        // largest distance an atom may move per step, <= 0: auto
  int gpu_requested;        // gpu yes: the CUDA collision backend where a device is usable
  int device_request;       // CUDA device to use, < 0: auto (node-local rank)
  int gpu_gather;           // gpu/gather: 1 (default) several ranks gather their atoms on rank
                            // 0 each step, whose device runs the whole step; 0 each rank's
                            // device resolves the groups its host driver hands it
  int backend_device;       // device of the current backend, -1: the CPU backend
  // Rough spheres: friction mu and tangential restitution beta0 of type pairs, 2 per pair
  // ((ntypes + 1)^2 pairs); walls.mu and walls.beta for the walls.
  std::vector<double> fpair;
  int friction_on;            // 1: some pair or wall has mu > 0 (else smooth spheres)
  int disc_user;              // 1: 'disc' given (moment of inertia 0.5 m r^2)
  int friction_guard;         // 1: guarded collisions are tangentially elastic too
  double inertia;             // moment of inertia / (m r^2) of this run (init())

  // --- derived in init() ----------------------------------------------------------------
  double rmax;           // largest radius in the group
  double reach_base;     // the reach of an ordinary step: reach_user, else rmax
  double reach;          // this step's reach: reach_base, or up to ghost_reach() when needed
  double reach_raise;    // > 0: raise the ghost cutoff to cover this reach at the
                         // reneighboring of step next_reneighbor (pre_exchange())
  double list_cut;       // candidate range (without skin) of an ordinary step: 2 rmax + 2 reach
  double raise_drift;    // the drift that asked for reach_raise (for the log)
  double step_vmax2, step_amax;    // the step budget's maxima (all ranks)
  double vend2;                    // largest squared end speed of this rank's atoms with events
  bigint maxevents;

  // --- per-atom state ---------------------------------------------------------------------
  double *tlast;    // time of the atom's last collision relative to the end of the last step

  // --- output -----------------------------------------------------------------------------
  double n_step;             // collisions (pair) this step
  double n_total;            // pair collisions in total
  double n_wall;             // wall collisions in total
  double ke_total;           // kinetic energy removed in total (energy units)
  double max_events;         // most events any step needed
  double events_total;       // events in total
  double n_redo;             // steps redone (larger displacement budget, or a window's check)
  double last_largest;       // most atoms resolved together in one window, last step
  double last_groups;        // groups of two or more atoms resolved, last step (all windows)
  double last_windows;       // time windows of the last step
  double last_boundary;      // atoms in groups that spanned ranks, last step (all windows)
  double last_gathers;       // gathers of the groups that span ranks, last step
  double last_spanning;      // groups spanning ranks resolved where they lie, last step
  double last_fallbacks;     // windows resolved by the old path, last step
  double last_gathered;      // atoms gathered (of those in spanning groups), last step
  double last_neighbour;     // of the gathers, those with the neighbouring ranks only, last step
  double last_forwards;      // rounds of those gathers passing entries on, last step
  double last_round_fails;   // passes gathered again from every rank after them, last step
  double last_step_redos;    // 1: the last step's planned windows were done again
  double t_search;           // seconds spent in the candidate search, in total
  double t_resolve;          // seconds spent resolving, in total
  double t_step;             // seconds spent in the fix's step (post_integrate), in total
  double n_repair;           // groups merged and resolved again after a missed contact, in total
  double n_resident;         // steps carried out whole on the device, in total
  double n_declined;         // steps the device handed back to the host, in total
  double last_candidates;    // candidate pairs of the last step on this rank
  double n_ghost_raise;      // ghost cutoff raised during runs, in total
  // The fix's own MPI communication during a step (none on one rank): collective operations
  // (the same count on every rank), ghost updates (LAMMPS forward communications), and the
  // bytes this rank received (the other ranks' shares of the collectives, and the ghost
  // updates' values for ghosts of atoms owned by other ranks).
  struct CommCount {
    double collectives = 0.0, halos = 0.0, bytes = 0.0;
    double messages = 0.0;    // point-to-point messages received (gathers to neighbours)
    double seconds = 0.0;     // in those operations, waiting for the other ranks included
  };
  CommCount comm_step;      // this step so far
  CommCount comm_last;      // the last step
  int remote_ghosts = 0;    // ghosts of atoms owned by another rank (set by forward_state())
  struct RunSummary {       // this run, for the line post_run() logs
    bigint steps = 0;
    double pairs = 0.0, events = 0.0, largest = 0.0, windows = 0.0, groups = 0.0;
    double largest_sum = 0.0;    // the steps' largest groups added up (post_run()'s warning)
    double boundary = 0.0, gathers = 0.0, repairs = 0.0, redos = 0.0;
    double spanning = 0.0, fallbacks = 0.0, gathered = 0.0, neighbour = 0.0;
    double t_search = 0.0, t_resolve = 0.0, t_step = 0.0;
    double t_search_steps = 0.0;    // of t_search, the steps' own (not the setup's)
    double t_prepare = 0.0;         // the steps' ghost update, search and overlap check
    double t_windows = 0.0;         // the steps' windows with the step check after them
    // ... of which after the windows: the atoms' step ends, the tallies' reduction, and the
    // step check's ghost update, search and reduction
    double t_ends = 0.0, t_tallies = 0.0, t_check_ghosts = 0.0, t_check_search = 0.0;
    double t_check_reduce = 0.0;
    double t_first = 0.0;       // seconds of the run's first step (allocations, page-locking)
    bigint resident = 0;        // steps carried out on the device
    double t_transfer = 0.0;    // seconds copying bodies to the device and back
    double bytes_up = 0.0;      // bytes of atom arrays copied to the device (whole steps)
    double t_gather = 0.0;      // gpu/gather: seconds moving the atoms to rank 0 and back
    double t_back = 0.0;        // gpu/gather: of those, sending the results back
    double collectives = 0.0, halos = 0.0, bytes = 0.0;    // communication (this rank's)
    double messages = 0.0;
    double t_comm = 0.0;    // seconds in the communication above (waits for other ranks too)
    double forwards = 0.0;  // rounds of gathers passing entries on (WindowStats::forwards)
    double round_fails = 0.0;    // passes gathered again after them (WindowStats::round_fails)
    double step_redos = 0.0;     // steps of planned windows done again (WindowStats::step_redos)
    double start_checked = 0.0, start_differ = 0.0;    // WindowStats::start_checked, _differ
    bigint declined[5] = {0, 0, 0, 0, 0};                  // steps handed back, by ResidentOutcome
    bigint moved = 0, checked = 0;    // device steps with x, v moved there, or checked (gpu/keep)
    bigint ahead = 0, dropped = 0;    // steps run ahead during LAMMPS's integration, dropped
    bigint xv_kept = 0;    // gathered steps run ahead with x and v kept on rank 0's device
    bigint reordered = 0;  // of them with the atoms found there by ID
    double t_ahead_wait = 0.0;    // seconds the steps run ahead were waited for (with the
                                  // ranks' agreement to take them, on several ranks)
  } run_sum;

  // --- per-step work ----------------------------------------------------------------------
  // Forwarded per atom: owner's x (3), v (3), radius, owner rank, owner's local index, the
  // atom's displacement bound for the step (pairs are candidates within the sum of bounds).
  static constexpr int NFWD = 10;
  std::vector<double> gdata;    // forwarded per-atom data, NFWD per owned and ghost atom
  std::vector<int> body_of;     // local atom -> body index, -1 when none
  std::vector<HSGPU::Collide::Body> bodies;
  std::vector<HSGPU::Collide::Edge> edges, iedges;
  std::vector<HSGPU::Collide::Edge> isorted;    // build(): iedges sorted by j
  std::vector<int> icount;                       // build(): the counting sort's offsets
  std::vector<char> near_body;    // build(): the body is in a pair close enough to overlap
  std::vector<int> foreign_of;        // ghost - nlocal -> foreign node, -1 when none
  std::vector<tagint> foreign_tag;    // foreign node -> atom ID
  struct ForeignEdge {
    int body, node, ghost;    // owned body, foreign node, a ghost index of it
    double shift[3];          // image shift of x_body - x_node
  };
  std::vector<ForeignEdge> fedges;
  std::vector<int> foreign_ghost;    // foreign node -> one ghost index of it
  std::vector<HSGPU::Collide::ForeignEdge> efedges;
  std::vector<HSGPU::Collide::ForeignNode> fnodes;
  // Per foreign node: its owner's start point X0 and velocity from the step's ghost update
  // (WindowDriver::foreign_start())
  std::vector<double> fstart;
  // Candidate pairs of two foreign nodes (window_driver.h's view; several ranks, parallel
  // order): i, j foreign nodes, the lower ID first; and the partner counts that tell which
  // foreign nodes have all their partners here.
  std::vector<HSGPU::Collide::Edge> ffedges;
  std::vector<double> fdeg_local, fdeg;
  std::vector<int> fdeg_here;
  std::vector<double> spos, srad, sraw, sbound;    // the candidate search's points
  std::vector<double> sboost;        // per owned atom: a bound raised by a step's check
  double bound_floor;                // least step bound of any atom: half the fastest drift
  std::vector<double> bexc, fexc;    // per body / foreign node: excursion in the step
  std::vector<tagint> sid;
  std::vector<int> sidx, sbody, snode, spairs;
  std::vector<double> sreach;
  HSGPU::Collide::CellSearch search;
  HSGPU::Collide::WindowDriver driver;
  HSGPU::Collide::WindowSettings wsettings;
  std::unique_ptr<HSGPU::Collide::CollisionBackend> backend;
  // Steps with per-atom virial where `backend` is the CUDA one (it cannot tally them).
  std::unique_ptr<HSGPU::Collide::CollisionBackend> cpu_backend;
  // Per-atom virial of the step, 6 per body (r (x) dp summed, before the 1/(dt ftm2v)); for
  // order serial per lbodies and gbodies entry.  Only on steps that LAMMPS asks for it.
  std::vector<double> bvir, lvir, gvir;
  bigint vatom_step;    // step whose per-atom virial vatom holds, -1: none
  // The CUDA backend's device-resident step (one rank; on several, rank 0 with gather_step), else
  // null.
  std::unique_ptr<HSGPU::Collide::ResidentStep> resident;
  // The resident step's device copies of tlast, radius, rmass, type and id are current: the
  // last step was done there whole, and since then no atom moved in the arrays, arrived or
  // was created (copy_arrays(), unpack_exchange(), set_arrays()), no run started and the host
  // did no step (ResidentAtoms::same_atoms).
  bool resident_same = false;
  // A fix that changes radius, mass or type in place (fix adapt, type swaps): those arrays go
  // to the device every step.
  bool sizes_vary = false;
  // No style sets forces (no pair, bond, angle, dihedral, improper or kspace style and no fix
  // with a force hook): f is zero on every step, and the device step does not copy it up.
  // Checked against the atoms' f on the first device step of each run (forces_seen()).
  bool forces_none = false;
  bool forces_checked = false;    // this run's first device step found f zero
  bool no_force_styles() const;
  void forces_seen(double amax);
  // gpu/keep (fix_hardsphere_motion.cpp): between device steps the device moves its own copies
  // of x and v as LAMMPS's integrator moves the atoms, instead of receiving them
  // (ResidentAtoms::motion), where one rank runs the whole step and nothing but fix nve or
  // nve/sphere of every atom changes x or v (motion_fixes_known(), at init); checked against
  // the copied arrays on the run's first such step and after every MOTION_AUDIT moved steps.
  int gpu_keep = 1;
  enum MotionWay { MOTION_UNKNOWN = -1, MOTION_PLAIN = 0, MOTION_FUSED = 1, MOTION_OFF = 2 };
  bool motion_known = false;           // the fixes allow it (init())
  std::string motion_why;              // else why not, for the run's log
  int motion_way = MOTION_UNKNOWN;     // the integrator's rounding, as this run's check found it
  bigint motion_builds = -1;           // neighbor->ncalls at the last device step
  static constexpr int MOTION_AUDIT = 100;    // steps moved on the device between checks
  int motion_unchecked = 0;            // steps moved on the device since the last check
  bool motion_fixes_known(std::string &why) const;
  HSGPU::Collide::KeptMotion kept_motion(bool same) const;
  void motion_seen(const HSGPU::Collide::ResidentReport &report);
  std::string motion_summary() const;
  // The next step run ahead on the device while LAMMPS integrates (fix_hardsphere_ahead.cpp):
  // started at end_of_step() where that step can move x and v on the device, taken by the
  // next post_integrate() (or dropped, where something changed in between).
  // The gathered step of several ranks (fix_hardsphere_gathered.cpp): what its first half
  // (the atoms to rank 0) leaves for its second (the result back), which runs in the same
  // post_integrate(), or in the next one where the step runs ahead.
  struct GatheredSend {
    long n = 0;               // atoms of all ranks
    int nlocal = 0;           // of this rank
    bool whole = true;        // group all: LAMMPS's arrays, else the group's atoms packed
    bool same = false;        // no rank's atoms moved in its arrays since the last such step
    bool shared = false;      // in rank 0's device buffers (CUDA IPC), else its host's
    bool no_forces = false;   // f not sent (zero)
    bool xv_kept = false;     // x and v not sent: rank 0's device kept the last step's
    bool reordered = false;   // and found by the IDs sent instead of tlast, radius, ...
    double t_gather = 0.0;    // seconds sending
    double moved = 0.0;       // bytes this rank received
  };
  // What rank 0 sends every rank after its step: the outcome, the tally and the report's
  // figures.  One broadcast of doubles (the counts are far below 2^53).
  struct GatheredResult {
    double outcome, pair, wall, rest, events, capped, ke_lost;
    double vmax2, amax, rmax, vend2, candidates, redone;
    double t_search, t_resolve, t_upload, t_download, bytes_up;
    double largest_group, groups, windows, repairs;
  };
  void gathered_send(GatheredSend &s, bool unchanged, bool keep_xv = false);
  HSGPU::Collide::ResidentAtoms gathered_atoms(const GatheredSend &s);
  GatheredResult gathered_result(const HSGPU::Collide::ResidentReport &report,
                                 const HSGPU::Collide::Tally &mine) const;
  int gathered_finish(const GatheredSend &s, GatheredResult r, HSGPU::Collide::Tally &all);
  // gpu/keep on several ranks: each rank's x, v and f at post_force() of the step before a
  // check (motion_snapshot()), compared at the next post_integrate() with what fix nve made
  // of them (motion_check_gathered()).
  struct MotionCheck {
    bool pending = false;
    bigint step = -1;
    int n = -1;
    const double *x = nullptr, *v = nullptr;    // LAMMPS's arrays then
    std::vector<double> x0, v0, f0;             // f0 empty: no forces
  } mcheck;
  HSGPU::Collide::StepMotion gathered_motion(bool wrap, bool half = false) const;
  void motion_snapshot();
  void motion_check_gathered();
  std::unique_ptr<StepAhead> ahead;
  struct Ahead {
    bool pending = false;
    // Several ranks (run_ahead_gathered()): something changed under it on this rank after it
    // started (its arrays grew); the step is dropped on every rank when it is due.
    bool spoiled = false;
    int nlocal = -1;    // this rank's atoms and arrays when it started (several ranks)
    const double *x = nullptr, *v = nullptr, *f = nullptr, *tlast = nullptr;
    bigint step = -1;      // the step it is
    bigint builds = -1;    // neighbor->ncalls when it started
    double dt = 0.0;
    HSGPU::Collide::ResidentAtoms atoms{};
    HSGPU::Collide::ResidentBox box{};
    HSGPU::Collide::Params params{};
    HSGPU::Collide::Tally tally;
    HSGPU::Collide::ResidentReport report;
    GatheredSend send;    // several ranks: the first half of the gathered step
  } next;
  // This fix's post_force() comes after every other fix's (the forces are final there): the
  // step runs ahead from there, else from end_of_step().
  bool ahead_at_post_force = false;
  bool last_post_force() const;
  void run_ahead();
  int take_ahead(HSGPU::Collide::Tally &mine, HSGPU::Collide::Tally &all);
  void drop_ahead();
  void forget_ahead();
  void spoil_ahead();
  void start_ahead(bool here, double t_start);
  void run_ahead_gathered();
  int take_ahead_gathered(HSGPU::Collide::Tally &mine, HSGPU::Collide::Tally &all);
  // gpu yes on several ranks with gpu/gather yes: each step's atoms (of the group) gathered on
  // rank 0, whose `resident` step runs it (step_gathered(); the same on every rank).
  bool gather_step = false;
  // Rank 0's copies of all atoms for that step, in rank order (grown, never shrunk: the device
  // step keeps them page-locked where they lie).
  // Some atoms' per-atom arrays (n atoms): LAMMPS's own, or copies for the gathered step.
  struct Source {
    int n = 0;
    long room = 0;    // atoms x, v and f hold (LAMMPS's nmax, or the packed arrays' room)
    double *x = nullptr, *v = nullptr, *f = nullptr, *omega = nullptr, *tlast = nullptr;
    double *radius = nullptr, *rmass = nullptr;
    int *type = nullptr;
    tagint *id = nullptr;
  };
  // Per-atom arrays of the gathered step, grown only.
  struct AtomArrays {
    std::vector<double> x, v, f, omega, tlast, radius, rmass;
    std::vector<int> type;
    std::vector<tagint> id;
    long room = 0;    // atoms the arrays hold (or would, where not allocated)
    /// Room for n atoms: the room grows (with an eighth to spare) and, where `allocate`, the
    /// arrays with it (their owner has let go of the old ones where they were too short).
    void grow(long n, bool allocate);
    /// The first n atoms' arrays (omega only with `spin`).
    Source view(int n, bool spin);
  };
  struct Gathered {
    std::vector<int> head;             // per rank: atoms, and whether its arrays are unchanged
    std::vector<int> displ;            // per rank: offset of its atoms
    std::vector<int> vcount, vdispl;   // the same times values per atom, for one transfer
    AtomArrays all;                    // every rank's atoms (allocated on rank 0)
    std::vector<HSGPU::Collide::ResidentResult> results;    // the atoms with events (rank 0)
    std::vector<double> rspin;                              // and their spins (rough spheres)
    std::vector<double> send, recv;                         // the results, by rank
    bool ipc_results = true;      // each rank reads its results from rank 0's device
    bool ipc_whole = true;        // each rank reads its atoms' end state from there
    bool state_kept = false;      // the last step's end state is in rank 0's device buffers
    bigint builds = -1;           // neighbor->ncalls at the end of the last step
    long n_kept = -1;             // and its atoms
    std::vector<char> rhandles;   // rank 0's device copies of the results
    std::vector<int> span;        // per rank: its first result and how many (rank 0)
    std::vector<HSGPU::Collide::ResidentResult> rres;    // this rank's results, read there
    std::vector<double> rtlast;                          // and its atoms' tlast
    std::vector<double> rrspin;                          // and its results' spins
    bool ipc = true;              // x, v, f straight to rank 0's device (share_inputs())
    std::vector<char> handles;    // rank 0's device buffers for them
    std::string why;              // why a rank could not
    double t_put = 0.0, t_wait = 0.0;    // this run: seconds copying them, and waiting for all
    // This run, seconds: rank 0's buffer handles to the ranks; its results' handles and counts
    // to them; reading them; the reduction after; writing them into the atoms' arrays; of the
    // first, rank 0's own part (its device's handles).
    double t_part[6] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
    double t_handles_most = 0.0;    // the longest of the first in one step
    // With a group other than all: this rank's group atoms (indices here) and their arrays.
    std::vector<int> lidx;
    AtomArrays packed;
  } gath;
  /// LAMMPS's own arrays of this rank's atoms.
  Source atom_source() const;
  /// What this rank sends to the gathered step.
  Source gathered_source();
  // The gathered step's x, v and f copied from this rank (not rank 0) to rank 0's device.
  std::unique_ptr<HSGPU::GPU::PeerInputs> peer;
  class LammpsExchange *exchange;
  int fwd_nval;                     // forward communication: 0 the state (NFWD), else xfwd's nval
  std::vector<double> xfwd;         // per-atom values for the driver's to_foreign
  std::vector<char> in_boundary;    // body is in a component that touches a foreign node
  std::vector<HSGPU::Collide::Body> lbodies, gbodies;
  std::vector<HSGPU::Collide::Edge> ledges, gedges;
  std::vector<int> lindex;        // body -> index in lbodies, -1 when boundary
  std::vector<int> gmine;         // global body -> my body index, -1 when not mine
  std::vector<double> push_dx;    // overlap push per owned atom
  double ovl[5];                  // first overlap found: flag, id, id or wall, dist, s
  double ovl_depth;               // deepest overlap found, relative to its contact distance
  double n_push;                  // overlaps pushed apart in total
  HSGPU::Collide::Resolver resolver;
  HSGPU::Collide::UnionFind uf;

  void parse(int narg, char **arg);
  void check_other_fixes();
  double inserted_radius();
  double integrator_inertia();
  double current_tc() const;
  HSGPU::Collide::Params step_params() const;
  void forward_state(double drift_dt);
  void allreduce(const void *in, void *out, int n, MPI_Datatype type, MPI_Op op);
  void count_collective(double bytes);
  void count_halo(int nval);
  void count_messages(double n, double bytes);
  void step_budget();
  void check_budget(double vmax2, double amax, double rmax_seen);
  double ghost_reach() const;
  double periodic_reach() const;
  void plan_ghost_raise(double drift);
  void reach_error(double moved, const char *what);
  /// This step can go to the device-resident step: one rank, or several with the atoms
  /// gathered on rank 0 (gather_step), and no per-atom virial asked for.
  bool resident_usable() const;
  double step_bound(int i, double drift_dt) const;
  bool gather_bodies(double drift_dt);
  int build(double drift_dt, bool collect_pushes);
  int step_resident(HSGPU::Collide::Tally &mine, HSGPU::Collide::Tally &all);
  int step_gathered(HSGPU::Collide::Tally &mine, HSGPU::Collide::Tally &all);
  bool share_inputs(long n, int nlocal, const Source &src, bool statics, bool no_forces,
                    bool xv = true, bool ids_only = false);
  void results_mpi(int nlocal, bool whole, double &moved);
  bool results_shared(int nlocal, bool whole, double &moved);
  bool state_back(const GatheredSend &s) const;
  bool results_whole(int nlocal);
  bool results_read(int ok);
  int first_failed(int ok) const;
  HSGPU::Collide::ResidentBox resident_box() const;
  HSGPU::Collide::ResidentAtoms resident_atoms(const Source &s, bool same) const;
  void count_resident(const HSGPU::Collide::ResidentReport &report);
  void atoms_stepped(const HSGPU::Collide::ResidentReport &report);
  int resident_outcome(const HSGPU::Collide::ResidentReport &report,
                       const HSGPU::Collide::Tally &mine, HSGPU::Collide::Tally &all, bool whole);
  void report_overlap(int npush, int left);
  void prepare(double drift_dt);
  int overlap_pass(double drift_dt, int pass, double &moved);
  void setup_backend();
  bool step_exact(const double *figures = nullptr);
  void exact_figures(double *loc);
  void log_rank_parts();
  void view_completeness();
  void classify();
  void gather_boundary();
  void resolve(HSGPU::Collide::Tally &mine, HSGPU::Collide::Tally &all);
  void sum_tallies(const HSGPU::Collide::Tally &mine, int capped, HSGPU::Collide::Tally &all,
                   double *figures = nullptr);
  void step_serial(HSGPU::Collide::Tally &mine, HSGPU::Collide::Tally &all);
  void step_windows(HSGPU::Collide::Tally &mine, HSGPU::Collide::Tally &all);
  void apply_results(double dt, bool in_bodies);
  void apply_virial(double dt, bool in_bodies);
  void virial_init(int vflag);

  friend class LammpsExchange;
};

}    // namespace LAMMPS_NS

#endif
