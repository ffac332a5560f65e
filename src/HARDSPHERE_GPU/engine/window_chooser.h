/* HARDSPHERE_GPU collision engine: the choice of a step's time windows, shared by the host
   step driver (window_driver.h) and the device-resident step (resident_step.h), so that both
   cut a step into windows the same way (the device with its own default target).

   Fixed windows: n equal windows.  Adaptive windows: a window starts at twice the previous
   one's length (at most what is left of the step) and is halved while its largest group
   exceeds the target, down to dt / 16; if none gets there (a pile, whose touching bodies stay
   joined however short the window), the longest length within 5/4 of the smallest largest
   group is taken, the rest of the step is one window, and the next steps try one halving
   only, all lengths every 16 steps.  Planned windows (several ranks, no reduction inside a
   step): all windows of a step as long, that length following the previous steps' largest
   groups (planned_end(), plan_feedback()).  Which windows are chosen never changes a result bit
   (window_driver.h says why); it changes only how much work runs side by side.

   No LAMMPS, MPI or CUDA here. */
#ifndef HSGPU_ENGINE_WINDOW_CHOOSER_H
#define HSGPU_ENGINE_WINDOW_CHOOSER_H

#include <algorithm>
#include <utility>
#include <vector>

namespace HSGPU {
namespace Collide {

  struct WindowSettings {
    int nwindows = 0;               // > 0: that many equal windows; 0: adaptive
    double bound_factor = 1.5;      // k in d = max(k |v|, f vmax) (t1 - t0)
    double floor_fraction = 0.0;    // f: the floor, as a fraction of the fastest drift speed;
                                    // <= 0: the backend's own (floor_fraction_or())
    long target_group = 0;          // adaptive: largest group wanted; <= 0: max(256, N / 128)
    // With nwindows = 1 on the host step driver's gathering path: the one window joins every
    // candidate pair, so its groups are the connected components of the step's candidates
    // and it needs no bound test and no repair (the step's own check covers the pairs that
    // are not candidates).  Ignored elsewhere (the view's windows, the device).
    bool join_all = false;
    // A gather to the neighbouring ranks sends every boundary body to every rank that owns a
    // foreign node of this rank's boundary groups, not only to those of its own group's: more
    // bytes, but a group over three or more ranks then needs no rounds passing entries on.
    bool gather_wide = false;
    // On three ranks or more (spanning gather, gathers to the neighbouring ranks, bounds in
    // use): the bound of the bodies next to another rank's atoms is edge_factor x what it
    // would be (k and f alike): the bodies with a candidate partner owned by another rank and,
    // edge_hops candidate pairs further, the bodies reached from them.  Smaller bounds there
    // join fewer pairs across the ranks' boundaries up front, so fewer atoms end in groups
    // that span ranks (each gathered, resolved by one rank and sent back: many times the cost
    // of a local group); the pairs they miss are joined by the window's repairs.  (On two
    // ranks, where every gather is from both, the extra gathers cost more than they save.)
    // 1: the same bounds everywhere.  No result bit depends on it.
    double edge_factor = 0.5;
    int edge_hops = 1;
    // On several ranks (the host step driver without the view): the part of a group that
    // spans ranks that one rank sees (its bodies and the foreign nodes joined to them) is
    // weighed against a target of its own, the smaller of this and target_group's, since no
    // rank sees the whole group (window_driver.cpp, window_edges()).  <= 0: against the step's
    // target like any group.  No result bit depends on it.
    long span_target = 256;
    // On three ranks or more, gathers to the neighbouring ranks (Exchange::neighbours()): the
    // rounds passing entries on to a group's further ranks are this many (one more after each
    // pass they left short, up to 4), each an exchange with the neighbours and no reduction
    // (an entry goes to a rank once per gather);
    // whether each group came whole to the rank that resolves it rides in the missed pairs'
    // reduction, and where one did not, the window's boundary groups are gathered again from
    // every rank.  0: rounds while a reduction says some rank lacks part of a group of its
    // own (at most 3), as before.  No result bit depends on it.
    int fixed_rounds = 2;
    // On three ranks or more with the halved bounds at the ranks' edges (edge_factor, where
    // most windows take a second pass of the check for missed pairs anyway): every window makes
    // two passes, and only the second one's check is a reduction (a third pass where it finds
    // pairs).  false: a reduction after every pass.  No result bit depends on it.
    bool two_passes = true;
    // On three ranks or more with two passes, fixed rounds and the halved bounds at the ranks'
    // edges: the windows of a step take no reduction at all.  Their lengths are planned from
    // the previous steps' figures (WindowChooser::planned_end()); a window's second pass
    // checks for missed pairs on its rank only, and whether it found any, a group that did not
    // come whole to its resolver or the event cap stopping a group rides in the step's one
    // reduction after the windows.  Where some rank's did, the step is done again from its
    // start with a reduction per window, as without this (WindowStats::step_redos), and the
    // next steps too (8, twice as many after each further such step, at most 64).  false: a
    // reduction per window length tried and per window's check.  No result bit depends on it.
    bool step_checks = true;
    // On several ranks (the host step driver without the view): the foreign nodes' start
    // points and bound rates of each step's first window are formed here from the owners'
    // values of the step's own ghost update (WindowDriver::foreign_start()), without a ghost
    // update of their own: at the step's start a body's start point is where it is, its rate
    // follows from its velocity, and a foreign node in a candidate pair with a body here is
    // next to another rank's atoms for its owner too (edge_factor).  false: a ghost update at
    // every window start, the first too.  No result bit depends on it.
    bool start_from_step = true;
    // Both ways at the first window, the two compared (WindowStats::start_checked and
    // start_differ; the owners' values are used).  A test aid.
    bool start_check = false;
    // With planned windows (step_checks): what the foreign nodes need from their owners
    // inside a step (the later windows' start points and bound rates, each pass's excursions)
    // goes in one message to each neighbouring rank, holding only the bodies in a candidate
    // pair with an atom that rank owns, instead of a ghost update (LAMMPS's forward
    // communication: every ghost, one swap after another).  Where a message does not bring
    // what a rank expects, the step is done again with the ghost updates.  false: the ghost
    // updates.  No result bit depends on it.
    bool sparse_foreign = true;
    // A test aid: rank 0's first such message of each step leaves out its last atom, so that
    // its neighbour does not get what it expects (the step is done again).
    bool sparse_drop = false;
  };

  /// Relative margin on contact distances for round-off in the windows' join and check tests,
  /// the host driver's and the device step's alike (so that both choose the same windows).
  constexpr double WINDOW_MARGIN = 1e-9;

  /// The step's own bound rule (core/trajectory.h's drift_bound(): twice the drift, at least
  /// half the fastest atom's drift), as window settings: a window as long as the step with
  /// these joins the candidate pairs that the step's search found with the step's bounds
  /// (FixHardSphere takes them for `windows 1`).
  constexpr double STEP_BOUND_FACTOR = 2.0;
  constexpr double STEP_FLOOR_FRACTION = 0.5;

  /// The floor fraction of s, or `fallback` where s leaves it to the backend (the host step
  /// driver's is 0.25; the device-resident step's 0.5, as its repairs cost more).
  inline double floor_fraction_or(const WindowSettings &s, double fallback)
  {
    return s.floor_fraction > 0.0 ? s.floor_fraction : fallback;
  }

  class WindowChooser {
   public:
    /// Largest group wanted for a step over nbodies bodies (all ranks).
    static long target(const WindowSettings &s, long nbodies)
    {
      return s.target_group > 0 ? s.target_group : std::max(256L, nbodies / 128);
    }

    /// At the start of a step of length dt.
    void start_step(double dt)
    {
      guess = last_delta > 0.0 ? std::min(growth * last_delta, dt) : dt;
    }

    /// How much longer than the last window the next one starts (2 unless a backend sets it;
    /// never changes a result bit).
    void set_growth(double g) { growth = g > 1.0 ? g : 2.0; }

    /// The end that next(t0, k, dt, s, ...) tries first, so that a caller may set that window
    /// up ahead (the device-resident step does, before it waits for its candidate search).
    double first_end(double t0, int k, double dt, const WindowSettings &s) const
    {
      if (s.nwindows > 0)
        return (k + 1 >= s.nwindows) ? dt : dt * (double) (k + 1) / (double) s.nwindows;
      double t1 = t0 + guess;
      if (t1 > dt * (1.0 - 1e-9)) t1 = dt;
      if (stuck_left > 0 && k > 0) t1 = dt;    // the rest of the step
      return t1;
    }

    /// The end of window k, which starts at t0.  try_window(t1) sets up the window [t0, t1)
    /// (its edges and groups) and returns its largest group over all ranks; the last call is
    /// for the returned end, whose largest group is left in `largest`.  The first call is for
    /// first_end(t0, k, dt, s).
    template <class TryWindow>
    double next(double t0, int k, double dt, const WindowSettings &s, long target_group,
                TryWindow &&try_window, long &largest)
    {
      double t1 = first_end(t0, k, dt, s);
      if (s.nwindows > 0) {
        largest = try_window(t1);
        return t1;
      }
      const bool rest_of_step = stuck_left > 0 && k > 0;
      largest = try_window(t1);
      if (!rest_of_step) {
        tried.clear();
        tried.emplace_back(t1, largest);
        int halvings = stuck_left > 0 ? 1 : 64;
        while (largest > target_group && t1 - t0 > dt * MIN_WINDOW && halvings-- > 0) {
          t1 = t0 + 0.5 * (t1 - t0);
          largest = try_window(t1);
          tried.emplace_back(t1, largest);
        }
        if (largest > target_group) {
          long least = largest;
          for (const auto &tl : tried) least = std::min(least, tl.second);
          size_t pick = 0;
          while (4 * tried[pick].second > 5 * least) ++pick;
          if (pick + 1 < tried.size()) {
            t1 = tried[pick].first;
            largest = try_window(t1);
          }
          stuck_left = stuck_left > 0 ? stuck_left - 1 : STUCK_RETRY;
        } else {
          stuck_left = 0;
        }
      }
      // The next window starts at twice this one (the step's last window, cut short by what
      // was left, says nothing about the length that pays).
      if (t1 < dt || k == 0) {
        last_delta = t1 - t0;
        guess = std::min(growth * last_delta, dt);
      }
      return t1;
    }

    /// Planned windows (WindowSettings::step_checks; every rank plans the same): the end of
    /// the window that starts at t0, all windows of a step as long as the plan (a power of two
    /// times dt, from 1/16 to 1), the last one cut short by what is left of the step.
    double planned_end(double t0, double dt) const
    {
      const double t1 = t0 + plan * dt;
      return t1 > dt * (1.0 - 1e-9) ? dt : t1;
    }

    /// After a planned step: `ratio` is its largest group over the target, over all ranks and
    /// windows.  Above 1 the windows halve (at most to dt / 16), and the length they had is
    /// not planned again for PLAN_MEMORY steps (a group can grow from tens of atoms to most of
    /// the system when the windows double: the fluid at packing fraction 0.4); below 1/4 they
    /// double (at most to dt).  Returns false where planning should stop for a while (the
    /// caller's choice how long): the windows halved in the last step and the largest group is
    /// still above the target and no smaller than 4/5 of what it was, or they are as short as
    /// they get (a pile, whose touching bodies stay joined however short the window: the
    /// chooser's own tries find the longest window that pays there).  A halving that did not
    /// help is undone.
    bool plan_feedback(double ratio)
    {
      if (plan_age > 0 && --plan_age == 0) plan_limit = 2.0;
      const bool halved = plan_halved;
      plan_halved = false;
      if (ratio > 1.0) {
        if (halved && ratio > 0.8 * plan_ratio) {
          plan *= 2.0;
          plan_limit = 2.0;
          plan_age = 0;
          return false;
        }
        if (plan <= MIN_WINDOW) return false;
        plan_limit = plan;
        plan *= 0.5;
        plan_age = PLAN_MEMORY;
        plan_halved = true;
        plan_ratio = ratio;
      } else if (ratio < 0.25 && 2.0 * plan <= 1.0 && 2.0 * plan < plan_limit) {
        plan *= 2.0;
      }
      return true;
    }

    /// The planned windows' length, as a fraction of dt.
    double planned() const { return plan; }

   private:
    /// Shortest adaptive window, as a fraction of dt.
    static constexpr double MIN_WINDOW = 1.0 / 16.0;
    /// Steps after a window that could not meet the target before all lengths are tried again.
    static constexpr int STUCK_RETRY = 16;
    /// Steps that planned windows keep from the length that last made too large a group.
    static constexpr int PLAN_MEMORY = 256;

    double last_delta = 0.0;    // length of the last window, for the next one's guess
    double guess = 0.0;         // length of the next window to try
    double growth = 2.0;        // next guess = growth x the last window's length
    int stuck_left = 0;         // > 0: a recent window could not meet the target
    double plan = 0.5;          // planned windows' length / dt (planned_end())
    double plan_limit = 2.0;    // the length that last made too large a group (2: none)
    int plan_age = 0;           // steps left that plan_limit holds
    bool plan_halved = false;   // the last planned step halved the windows
    double plan_ratio = 0.0;    // ... whose largest group over the target was this
    std::vector<std::pair<double, long>> tried;    // (window end, largest group) tried
  };

}    // namespace Collide
}    // namespace HSGPU

#endif
