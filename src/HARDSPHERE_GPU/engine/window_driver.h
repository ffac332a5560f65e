/* HARDSPHERE_GPU collision engine: the step driver.  Exact parallel resolution of one step's
   collisions in time windows.

   The caller gives this rank's bodies (at the step start), the candidate pairs of the step
   (every pair that can touch within the step; the caller checks the step's displacement
   budget afterwards), the foreign nodes (bodies owned by other ranks, known here through
   ghosts) with the pairs between a local body and a foreign node, and the pairs between two
   foreign nodes.  Together they are this rank's *view*.  A foreign node is *complete* when all
   its candidate partners are in the view (ForeignNode::complete; the caller compares the
   owner's count of the node's partners with its own).  The driver cuts [0, dt) into windows
   [t0, t1) and, in each:

   1. brings every foreign node's body up to date from its owner (Exchange::to_foreign; whole
      at the step's first window, what events change at the others);
   2. gives every body of the view a bound d = max(k |v|, f vmax) (t1 - t0) on how far its
      drift line will move in the window (k, f: WindowSettings; vmax the fastest drift speed of
      the step; on three ranks or more without the view, WindowSettings::edge_factor times that
      for the bodies next to another rank's, except while planned windows have given way, as in
      a settled pile) and joins the candidate pairs whose gap at t0 is
      within d_i + d_j;
   3. resolves the connected components ("groups") that hold a local body: a group of local
      bodies, or one that spans ranks and whose foreign nodes are all complete, is resolved
      here; every rank that holds a body of such a group sees the same bodies and pairs and
      gets the same result, and keeps its own bodies' results.  A rank that holds a body of a
      group that it cannot see whole flags that body to the ghosts; a rank that holds another
      body of the group and sees it whole sends the flagged bodies' results back to their
      owners (Exchange::to_owner).  A group that no rank holding a body of it sees whole is
      gathered from every rank (Exchange::allgather) and resolved identically on all of them;
   4. checks the window over the view: a candidate pair that was not joined could only have
      touched if the two drift lines together moved at least its gap (foreign nodes'
      excursions from their owners).  Where such a pair joins groups that every rank holding a
      body of them sees whole, they are merged and resolved again from the window start (a
      "repair"; repeated until no such pair is left).  Where it would join any other group, all
      ranks resolve the window again from its start as before the view: local groups here,
      every group that reaches a foreign node gathered and resolved on every rank, missed pairs
      joined to them and gathered again (fallback_window()).  No step is ever redone.

   Collectives per window: one reduction per length tried (the largest local group and the
   largest part of a group spanning ranks that one rank sees, the latter weighed against
   WindowSettings::span_target since no rank sees such a group whole; over the view, also whether
   some rank has a group it cannot see whole; without the view and with fixed windows none), one
   per pass of the check (repairs, old path; without the view the event cap rides in it, and
   whether a gather to the neighbours fell short, below; with WindowSettings::two_passes the
   first of two passes has none), and, without fixed rounds (below), one more per pass and one
   per round of a gather to the neighbours.  With planned windows (WindowSettings::step_checks:
   three ranks or more, two passes, fixed rounds, the halved bounds at the ranks' edges) none
   at all: the lengths come from the previous steps (WindowChooser::planned_end()), each
   window's last check stays on its rank, and what went wrong anywhere rides in the reduction
   after the windows; then the step is done again from its start with the reductions per
   window (run()).  Per step one reduction
   before the windows (the bodies' count and fastest speed) and one after (the figures of
   WindowStats), each of maxima and sums at once (Exchange::max_sum()).  Tallies: each group's
   once over the ranks, by the rank of its lowest-ID body among those whose owners resolve it.
   A gather goes first to the neighbouring ranks only (on more than two ranks: each boundary
   body's state to the ranks that own a foreign node of its group); a group over three ranks
   or more may reach a rank through another one only, so WindowSettings::fixed_rounds rounds
   follow (one more after each pass they left short, up to MAX_ROUNDS: every rank knows of it),
   each rank passing the entries it holds of such a group of its own on to the group's other
   neighbouring ranks (each entry once per rank), with no reduction.  Then each group is
   resolved by the rank of its lowest-ID body where that rank holds it whole, which sends the
   results to the neighbouring ranks among its other owners; an owner that is not a neighbour
   of that rank resolves the group itself where it holds it whole (the same entries, the same
   result).  A rank that cannot resolve a group of its own, or lacks a result it expects, says
   so in the check's reduction, and the window's boundary groups are resolved again from the
   window start, gathered from every rank (Exchange::allgather; every rank resolves the groups
   that hold a body of its own).  With fixed_rounds 0, rounds follow while a reduction says
   that some rank lacks a partner of a body in a group of its own (at most 3, else the gather
   from every rank), and results whose owner is not a neighbour of the resolving rank, said in
   the last round's reduction, go through Exchange::to_ranks().  The messages of the gather,
   its rounds and the results go through Exchange::to_neighbours() where the exchange has
   neighbouring ranks (one message to each, no consensus over all ranks; through
   Exchange::to_ranks() without neighbours).  After a fall-back to the gather from every rank
   the next gathers go to every rank at once for a while (a pile over many ranks is one group
   that no neighbourhood holds).

   Event times depend only on the two bodies' states (core/trajectory.h), never on the window
   or group a pair is in, and every group sees its events in the global time order restricted
   to it: the outcome is the same, bit for bit, as resolving the whole step with the global
   earliest-event loop (order serial), for any choice of windows.

   The windows are chosen by window_chooser.h (adaptive: halved while the largest group
   exceeds a target).

   No LAMMPS, MPI or CUDA here: communication goes through the Exchange interface. */
#ifndef HSGPU_ENGINE_WINDOW_DRIVER_H
#define HSGPU_ENGINE_WINDOW_DRIVER_H

#include "collision_backend.h"
#include "window_chooser.h"

#include "core/event_order.h"

#include <functional>
#include <utility>
#include <vector>

namespace HSGPU {
namespace Collide {

  /// A candidate pair of local body `body` and foreign node `node`; shift is the periodic
  /// image shift of x_body - x_node.
  struct ForeignEdge {
    int body, node;
    double shift[3];
  };

  /// A body owned by another rank, known here through a ghost atom.  complete: every
  /// candidate partner of it is known here (a local body or a foreign node, with the pair
  /// among the edges given to run()), so that a group of it can be resolved here.
  struct ForeignNode {
    long id;
    double radius;
    int complete = 0;
    int owner = -1;    // the rank that owns it (-1: not known; then no gather to neighbours)
  };

  /// What the driver needs from the ranks around it.  SingleRank below is the trivial one.
  class Exchange {
   public:
    virtual ~Exchange() = default;
    virtual int nranks() const = 0;
    virtual int rank() const = 0;
    /// Most values per body that to_foreign() and to_owner() are given (a body's whole
    /// state, with a flag and its per-atom virial for to_owner()).
    static constexpr int MAX_VALUES = 36;
    /// nval values per local body to the foreign nodes (nval per node, from their owner).
    virtual void to_foreign(const std::vector<double> &local, int nval,
                            std::vector<double> &foreign) = 0;
    /// The other way: nval values per foreign node to its owner, into nval per local body
    /// (nlocal of them).  The first value of each is a flag: nonzero where the node sends
    /// something; a local body that nobody sent to gets zeros.  Where several ranks send to
    /// one body, they send the same values.
    virtual void to_owner(const std::vector<double> &foreign, int nval, int nlocal,
                          std::vector<double> &local) = 0;
    /// Every rank's `send`, concatenated in rank order, into `recv`; `mine` is the offset of
    /// this rank's part.
    virtual void allgather(const std::vector<double> &send, std::vector<double> &recv,
                           long &mine) = 0;
    /// Point to point: send[k] to rank dest[k] (distinct ranks, not this one), and whatever
    /// the other ranks send here into recv, concatenated in the order of their ranks.  No rank
    /// needs to know beforehand who sends to it.  Returns false where the exchange has no such
    /// path (the caller then gathers from every rank).
    virtual bool to_ranks(const std::vector<int> &dest,
                          const std::vector<std::vector<double>> &send, std::vector<double> &recv)
    {
      (void) dest;
      (void) send;
      (void) recv;
      return false;
    }
    /// The ranks that to_neighbours() exchanges with (sorted, without this rank; the
    /// relation is symmetric: this rank is among each one's), or nullptr where the exchange
    /// has no such set.  It holds at least the owners of every foreign node given to run().
    virtual const std::vector<int> *neighbours() const { return nullptr; }
    /// Point to point with the neighbouring ranks only: send[k] to dest[k] (each one of
    /// neighbours()), an empty message to every other neighbour, and what each neighbour
    /// sends here into recv, concatenated in the order of their ranks.  Every rank takes
    /// part (with its own neighbours); since each rank hears from each of its neighbours,
    /// no rank waits for any other rank, and no consensus over all ranks is needed.
    virtual void to_neighbours(const std::vector<int> &dest,
                               const std::vector<std::vector<double>> &send,
                               std::vector<double> &recv)
    {
      (void) dest;
      (void) send;
      recv.clear();
    }
    virtual void max(double *v, int n) = 0;    // in place, over all ranks
    virtual void sum(long *v, int n) = 0;      // in place, over all ranks
    /// Both at once (one reduction where the exchange can; each sum below 2^53).
    virtual void max_sum(double *mx, int nm, long *sm, int ns)
    {
      max(mx, nm);
      sum(sm, ns);
    }
  };

  class SingleRank : public Exchange {
   public:
    int nranks() const override { return 1; }
    int rank() const override { return 0; }
    void to_foreign(const std::vector<double> &, int, std::vector<double> &foreign) override
    {
      foreign.clear();
    }
    void to_owner(const std::vector<double> &, int nval, int nlocal,
                  std::vector<double> &local) override
    {
      local.assign((size_t) nval * nlocal, 0.0);
    }
    void allgather(const std::vector<double> &send, std::vector<double> &recv, long &mine) override
    {
      recv = send;
      mine = 0;
    }
    void max(double *, int) override {}
    void sum(long *, int) override {}
  };

  /// What the last step did (global figures, the same on every rank).
  struct WindowStats {
    long largest_group = 0;      // most bodies resolved together in one window
    long groups = 0;             // groups with at least one event, summed over the windows
    long windows = 0;            // windows of the step (of its final pass)
    long boundary_bodies = 0;    // bodies in groups spanning ranks (each group once), summed
                                 // over the windows
    long repairs = 0;            // groups resolved again after a missed pair was joined
    long gathers = 0;            // gathers (of groups no rank sees whole; old-path windows)
    long spanning = 0;           // groups spanning ranks resolved where they lie (no gather)
    long fallbacks = 0;          // windows on the old path (every spanning group gathered)
    long gathered = 0;           // bodies gathered (of boundary_bodies), over the windows
    long neighbour = 0;          // of the gathers, those exchanged with the neighbouring ranks
                                 // only (the ranks of the foreign nodes in the groups)
    long forwards = 0;           // rounds of such gathers passing entries on to a group's
                                 // further ranks (a group over three ranks or more)
    long round_fails = 0;        // passes whose fixed rounds left some group short of its
                                 // resolver (WindowSettings::fixed_rounds): gathered again
                                 // from every rank
    long step_redos = 0;         // steps of planned windows done again with a reduction per
                                 // window (WindowSettings::step_checks): 0 or 1 per run()
    // WindowSettings::start_check, this rank's: candidate pairs with a foreign node whose
    // first-window start point and bound rate were formed here and also sent by its owner (a
    // node counted once per pair), and of them those where the two differ in some bit (never
    // expected)
    long start_checked = 0, start_differ = 0;
  };

  /// Where a rank's run() spent its time, seconds summed over the calls (wall clock; the
  /// waits for other ranks inside the exchanges included where they fall).
  struct DriverTimes {
    double edges = 0.0;       // window lengths tried: start points, bounds, pairs joined
    // ... of which: the window starts (start points, bound rates, the pairs' gaps), on
    // several ranks the foreign nodes' start points (a ghost update, waits included), and the
    // reductions of the lengths tried (waits included)
    double edges_start = 0.0, edges_ghosts = 0.0, edges_reduce = 0.0;
    double groups = 0.0;      // groups of the window taken, the view's refresh
    double local = 0.0;       // groups resolved here: events, excursions, repairs
    double spanning = 0.0;    // groups spanning ranks: gathered, resolved, results sent back,
                              // missed pairs joined
    // ... of which: packing the bodies, the gather (to the neighbours, or from every rank; the
    // groups found), resolving, results to their owners, missed pairs joined (with the
    // excursions of the bodies sent)
    double span_pack = 0.0, span_gather = 0.0, span_resolve = 0.0, span_results = 0.0;
    double span_join = 0.0;
    // ... and of the gather: its messages and reductions (waits included), and unpacking the
    // entries that came and finding their groups (the rest: choosing what goes where)
    double gather_messages = 0.0, gather_unpack = 0.0;
    // The step's set-up before the windows (the fastest speed and its reduction, the bounds at
    // the ranks' edges) and its reduction after them (waits included).
    double before = 0.0, after = 0.0;
  };

  class WindowDriver {
   public:
    /// The time of every run() so far (reset by the caller when it likes).
    DriverTimes times;
    /// Resolves the step over `bodies`.  `mine` gets the events of the groups this rank
    /// counts (see above) and, on rank 0, those of gathered groups.  The caller still checks
    /// the step's displacement budget.  foreign_pairs: candidate pairs of two foreign nodes
    /// (i, j node indices, the lower ID first).  bodies grows by the view's foreign nodes
    /// while the step runs (Exchange::to_foreign is given the local bodies' values only).
    /// body_virial (optional; the backend must support WindowWork::body_virial): 6 doubles
    /// per body, to which each body's per-atom virial of the step is added: half of every
    /// pair collision's term, all of a wall collision's, counted once whatever was resolved
    /// again (repairs, boundary gathers).  Pairs in boundary groups add to the local body
    /// only, so the sum over bodies and ranks is the sum of the ranks' `mine` virials (a
    /// result sent to an owner carries its body's per-atom virial).
    void run(std::vector<Body> &bodies, const std::vector<Edge> &edges,
             const std::vector<ForeignEdge> &fedges, const std::vector<ForeignNode> &foreign,
             const Params &p, const WindowSettings &s, CollisionBackend &backend, Exchange &ex,
             Tally &mine, WindowStats &stats, double *body_virial = nullptr,
             const std::vector<Edge> *foreign_pairs = nullptr);

    /// After run(): a result that another rank should have sent did not arrive (never
    /// expected; the caller stops with an internal error).
    bool results_missing_last() const { return results_missing; }

    /// The foreign nodes' values at the step's start from the step's own ghost update, for
    /// the next run()s (WindowSettings::start_from_step): 6 per node (run()'s `foreign`), its
    /// owner's start point X0 and drift velocity v as the owner's body has them, bit for bit;
    /// nullptr: none (a ghost update at every window start).  The caller keeps them valid.
    /// (A vector, not its data: a rank without foreign nodes has an empty one, and every
    /// rank must choose alike whether the ghost update is made.)
    void foreign_start(const std::vector<double> *x0v) { fstart = x0v; }

    /// Where the bodies at the step's start come from should planned windows do the step
    /// again: `remake` fills run()'s bodies as the caller made them for it, bit for bit (the
    /// caller's atoms do not change within run()).  Without it (empty) a copy of every body is
    /// kept at each step's start.
    void step_source(std::function<void(std::vector<Body> &)> remake)
    {
      remake_step = std::move(remake);
    }

   private:
    WindowChooser chooser;
    std::vector<char> near_edge, near_next;    // local body next to another rank's atoms
    bool edge_bounds = false;    // this run() gives those bodies smaller bounds (every rank)
    double speed_floor = 0.0;    // f vmax of this step
    long step_target = 256;      // the chooser's target of this step (largest group wanted)
    long window_seen = 0;        // window_edges(): the largest group (part) over all ranks
    // per window
    std::vector<Body> snap;       // the bodies at the window start (take_snapshot())
    // sparse_snap: snap holds only the bodies flagged in snapped (and start_exc2 every body's
    // exc2); window_start() gives any body
    bool sparse_snap = false;
    std::vector<char> snapped;
    std::vector<double> start_exc2;
    std::vector<Tally> gtally;    // tally of each local group
    std::vector<int> group_of;    // local body -> local group, -1 in a boundary group
    UnionFind merged;             // local groups merged by repairs
    std::vector<Body> sub;        // repairs: the merged groups' bodies, compacted
    std::vector<Edge> subedges;
    std::vector<int> sub_of, substart, submembers, subgroups;
    std::vector<double> bound, fstate, wstate, fexc, lexc;
    // window_edges() of one window start: each body's bound per unit of window length, each
    // edge's gap and margin at the start; start_cached while the chooser tries that window.
    std::vector<double> rate, egap, emargin;
    // ... and of the foreign edges (ranks > 1): their gaps at the start; fstate holds each
    // foreign node's start point and bound rate; wdelta the length of the window last tried.
    std::vector<double> fgap;
    double wdelta = 0.0;
    const std::vector<double> *fstart = nullptr;    // foreign_start()
    std::vector<double> fstep;         // the first window's fstate formed here (start_check)
    // The foreign nodes' values by messages to the neighbouring ranks (sparse_to_foreign(),
    // WindowSettings::sparse_foreign), lists made once per step (sf_ready): the neighbouring
    // ranks this rank sends to (sf_dest) and, for sf_dest[k], its bodies in a foreign edge with
    // a node that rank owns, in ID order (sf_body[sf_start[k] .. sf_start[k + 1])); the
    // foreign nodes of the foreign edges in the order the messages bring them (by their
    // owners' ranks, then by ID).
    bool sparse_now = false;    // this run()'s windows use them (planned windows)
    bool sparse_drop = false;   // WindowSettings::sparse_drop, until this step's first message
    bool sf_ready = false;
    std::vector<int> sf_dest, sf_start, sf_body, sf_node, sf_nbr, sf_stamp;
    std::vector<std::vector<double>> sf_send;
    std::vector<double> sf_recv;
    template <class Put>
    void sparse_to_foreign(const std::vector<Body> &bodies, int nval, Put put,
                           const std::vector<ForeignEdge> &fedges,
                           const std::vector<ForeignNode> &foreign, std::vector<double> &out,
                           Exchange &ex);
    void sparse_lists(const std::vector<Body> &bodies, const std::vector<ForeignEdge> &fedges,
                      const std::vector<ForeignNode> &foreign, Exchange &ex);
    long start_checked = 0, start_differ = 0;    // this run()'s (WindowStats)
    bool start_cached = false;
    std::vector<Edge> wedges;    // local window edges
    std::vector<char> fjoined, ljoined;
    // The candidate pairs of each local body (indices into the step's edges, ascending:
    // inc_q[inc_start[b] .. inc_start[b + 1])), made once per step where first needed
    // (inc_ready); the checks for missed pairs visit the pairs of the bodies that can have
    // one, in ascending order through the bit set qmask (all zero between uses).
    bool inc_ready = false;
    std::vector<int> inc_start, inc_q;
    std::vector<unsigned long long> qmask;
    void incidence(int nb, const std::vector<Edge> &edges);
    template <class Visit> void visit_pairs(const std::vector<int> &from, Visit visit);
    std::vector<int> qfrom;
    // ljoined: 1 for the window's own edges, 2 for those joined since (repairs, missed pairs:
    // join_pair()), jseq giving those their place in wedges; bwq, bwstart:
    // resolve_boundary()'s window edges of the boundary bodies.
    std::vector<int> jseq, bwq, bwstart;
    void join_pair(int q, const Edge &e);
    bool could_touch(const std::vector<Body> &bodies, const Edge &e) const;
    std::vector<int> fwin;    // indices of foreign edges joined in the window
    UnionFind uf;
    UnionFind gunion;    // the gathered bodies' groups
    std::vector<char> isb;    // node is the root of a boundary group
    std::vector<char> fseen;  // window_edges(): foreign node counted
    std::vector<int> gstart, gmembers, fill;
    int nlocal_groups = 0;
    // boundary groups, gathered
    std::vector<Body> gbodies;
    std::vector<Edge> gedges;
    std::vector<int> gmine, gstart2, gmembers2;
    std::vector<Tally> gtally2;
    std::vector<char> bchosen;    // local body: in a group resolve_boundary() gathers
    // the gather to the neighbouring ranks: per boundary root, the ranks of its foreign
    // nodes; per destination rank, what goes there; per gathered body, a partner missing
    std::vector<std::pair<int, int>> rootrank, sendto;    // sendto: (rank, gathered body)
    std::vector<int> ndest;
    std::vector<std::vector<double>> nsend;
    std::vector<char> gmissing;
    std::vector<size_t> gentry;    // per gathered body: its entry's offset in recv
    std::vector<std::pair<long, size_t>> gorder;    // (ID, entry offset) in ID order
    // Scratch kept between calls: resolve_boundary()'s partner lists (offsets and fill
    // positions of the higher- and lower-ID partners, the lists) and group_by_root()'s fill
    // positions.
    std::vector<int> pstart, lstart, ppos, lpos, group_pos;
    std::vector<double> bpartners, blows;
    std::vector<double> gotbuf;                      // what Exchange::to_ranks() brings
    std::vector<char> gmark;                         // roots of this rank's boundary groups
    std::vector<long> idkey;       // gathered bodies by ID (open addressing; 0: empty)
    std::vector<int> idval;
    bool virial_all = false;         // some rank tallies per-atom virials this step
    bool results_missing = false;    // a result of a group resolved elsewhere did not arrive
    bool unknown_owner = false;    // a foreign node's owner rank is not known
    long stats_neighbour = 0;
    long stats_forwards = 0;
    long stats_round_fails = 0;
    // Gathers to the neighbours with WindowSettings::fixed_rounds: this resolve_boundary()'s
    // gather was one (fixed_gather); this rank could not resolve or receive some group of its
    // own after the rounds (span_fail, told in join_missed_boundary()'s reduction); per
    // gathered entry, the neighbouring ranks it went to (by their place in neighbours()).
    int fixed_rounds = 0;     // rounds of the next gather (from the setting, grown)
    int fixed_setting = -1;   // WindowSettings::fixed_rounds that fixed_rounds started from
    static constexpr int MAX_ROUNDS = 4;
    bool fixed_gather = false, span_fail = false;
    std::vector<unsigned long long> sentmask;
    bool gather_wide = false;    // WindowSettings::gather_wide of this run()
    // The last gather to the neighbours: some owner of a body in a group resolved here is not
    // a neighbouring rank (or the exchange has none): results go out with a consensus.
    bool results_far = true;
    int neighbour_skip = 0;       // gathers left that go to every rank at once
    int neighbour_backoff = 8;    // the next such skip
    // Planned windows (WindowSettings::step_checks): this run() tries them (the same on every
    // rank); what went wrong in them on this rank (a missed pair after a window's second pass,
    // a group short of its resolver, the event cap, a result not where it belongs); the steps
    // left that take a reduction per window and the next such skip; the bodies at the step
    // start (the first window's snapshot, kept here once a second window starts: step_kept).
    bool planned = false;
    bool planned_bad = false;
    int planned_skip = 0;
    int planned_backoff = 8;
    int plan_backoff = 64;    // the next skip where WindowChooser::plan_feedback() stops
    bool plan_gave_way = false;    // planned_skip set there: no halved bounds meanwhile (run())
    std::vector<Body> step_start;
    bool step_kept = false;
    std::function<void(std::vector<Body> &)> remake_step;    // step_source()
    /// How join_missed_boundary() ends a pass: Local, the first of two passes (no reduction;
    /// the boundary groups go back to the window start whatever it found); Reduced, a
    /// reduction over all ranks; Kept, a planned window's last pass (its outcome kept in
    /// planned_bad for the step's reduction).
    enum class Check { Local, Reduced, Kept };
    std::vector<int> bsent;    // local bodies of the boundary groups of the last gather
    std::vector<double> send, recv;
    // per-atom virial (when run() is given body_virial): of the window so far, per local
    // body (replaced where a body is taken back to the window start), of the repair's
    // compacted bodies and of the gathered boundary bodies
    bool tally_virial = false;
    bool spin = false;    // rough spheres (Params::friction): the exchanges carry the spins
    double *body_virial_out = nullptr;    // run()'s body_virial
    long stats_gathers = 0;
    std::vector<double> wvir, subvir, gvir;

    // the view: the local bodies, then a copy of each foreign node's body (refreshed from its
    // owner at every window start); its candidate pairs (local, local-foreign, foreign pairs)
    int nlocal_bodies = 0;
    std::vector<Edge> xedges;
    std::vector<char> vcomplete;      // view node: all its candidate partners are in the view
    std::vector<int> vslot, vnode;    // foreign node -> view index (-1: none), and back
    std::vector<double> vsend, vrecv;
    std::vector<char> vroot;    // per union-find root: 1 has a local body, 2 an incomplete node
    int nactive = 0;            // view groups [0, nactive) are resolved here
    std::vector<char> gact, ginc;    // per view group: resolved here / has an incomplete node
    bool view_fallback = false;      // some rank's group reaches an incomplete node
    bool fresh = false;    // the foreign copies hold their owners' state (the check's last pass)
    // Groups of the view gathered (some rank that holds a body of them does not see them
    // whole): gsafe per group: complete here and no body of it in a group some owner cannot
    // see whole (then every rank that holds a body of it resolves it from the view);
    // gsel per local body: in a gathered group.
    std::vector<char> gsafe, ggat, gsel;
    std::vector<char> gloc;     // per view group: has a local body
    std::vector<char> vflag;    // view foreign node: its owner does not see its group whole
    std::vector<double> vfsend, vfrecv;    // results to the owners of flagged bodies
    bool gather_view = false;              // resolve_boundary() over the view's gathered groups
    bool gather_broken = false;            // a gathered partner was missing (then the old path)

    void refresh_foreign(std::vector<Body> &bodies, int nb, Exchange &ex, bool whole);
    long view_edges(std::vector<Body> &bodies, double t0, double t1, const WindowSettings &s,
                    Exchange &ex);
    void view_groups(int nv, int nb);
    int repair_view(std::vector<Body> &bodies, const Params &p, double t1,
                    CollisionBackend &backend, Exchange &ex, long events_before, int capped,
                    long &repairs, long &largest);
    void fallback_window(std::vector<Body> &bodies, const std::vector<Edge> &edges,
                         const std::vector<ForeignEdge> &fedges,
                         const std::vector<ForeignNode> &foreign, const Params &p,
                         const WindowSettings &s, CollisionBackend &backend, Exchange &ex,
                         double t0, double t1, Tally &tloc, Tally &tbnd, int &capped,
                         long (&acc)[5], long &largest, bool edges_made);

    double bound_rate(const double *v, bool edge, const WindowSettings &s) const;
    void start_points(std::vector<Body> &bodies, int n, const std::vector<Edge> &edges, bool gaps,
                      double t0,
                      const WindowSettings &s);
    long window_edges(std::vector<Body> &bodies, const std::vector<Edge> &edges,
                      const std::vector<ForeignEdge> &fedges,
                      const std::vector<ForeignNode> &foreign, double t0, double t1,
                      const WindowSettings &s, Exchange &ex);
    void boundary_roots(int nb, int nf, const std::vector<ForeignEdge> &fedges);
    void window_groups(int nb, int nf, const std::vector<ForeignEdge> &fedges);
    bool neighbour_gather(const std::vector<ForeignNode> &foreign,
                          const std::vector<ForeignEdge> &fedges, int nb, int nentry,
                          Exchange &ex, long &mine_off);
    void unpack_gathered(long mine_off, bool sparse);
    void unpack_more(size_t from);
    void reorder_gathered(long mine_off, size_t ng0);
    void index_gathered(long mine_off, bool sparse);
    void index_id(long id, int k);
    void link_partners(int k, int old, bool sparse);
    void unpack_bodies(int ngr);
    int gathered_index(long id) const;
    int gathered_owner(int k) const;
    void fill_destinations(const std::function<void(std::vector<double> &, int)> &pack);
    long results_to_owners(std::vector<Body> &bodies, int ngr, Exchange &ex);
    void resolve_boundary(std::vector<Body> &bodies, const std::vector<Edge> &cand,
                          const std::vector<ForeignEdge> &fedges,
                          const std::vector<ForeignNode> &foreign, const Params &p, double t1,
                          CollisionBackend &backend, Exchange &ex, Tally &tb, long &largest,
                          long &ngroups, long &nbound);
    void excursions(std::vector<Body> &bodies, double t1, const std::vector<int> *only = nullptr);
    void take_snapshot(const std::vector<Body> &bodies, const std::vector<ForeignEdge> &fedges,
                       const Params &p, bool whole);
    const Body &window_start(const std::vector<Body> &bodies, int b);
    int redo_merged(std::vector<Body> &bodies, const std::vector<Edge> &cand,
                    const std::vector<int> &failing, const Params &p, double t1,
                    CollisionBackend &backend, long events_before, long &repairs, long &largest);
    long repair_local(std::vector<Body> &bodies, const std::vector<Edge> &edges, const Params &p,
                      double t1, CollisionBackend &backend, long events_before, long &repairs);
    long join_missed_boundary(std::vector<Body> &bodies, const std::vector<Edge> &edges,
                              const std::vector<ForeignEdge> &fedges,
                              const std::vector<ForeignNode> &foreign, Exchange &ex,
                              int &capped, bool &failed, Check check = Check::Reduced);
    void run_windows(std::vector<Body> &bodies, const std::vector<Edge> &edges,
                     const std::vector<ForeignEdge> &fedges,
                     const std::vector<ForeignNode> &foreign, const Params &p,
                     const WindowSettings &s, CollisionBackend &backend, Exchange &ex,
                     Tally &mine, WindowStats &stats, int nb, int nv, bool use_view, long target);
  };

}    // namespace Collide
}    // namespace HSGPU

#endif
