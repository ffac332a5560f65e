/* HARDSPHERE_GPU collision engine: one group's events, in time order, without a heap.

   The loop that the CUDA backend runs in one thread per group (collision_backend_cuda.cu),
   written host-device so that the host can run it too (tests compare it with the CPU backend
   where no device is present).  It is core/event_order.h's serial loop restricted to a group:

   - every member b keeps best[b], the earliest (by earlier()) of its wall event and of the
     pair events of its edges;
   - each iteration takes the member whose best is earliest; the group stops when there is
     none or its time is >= t_end (that event and all later ones wait for the next window);
   - the event is carried out with collision_step.h's process_wall / process_pair, then the
     bests of the bodies involved and of their edge-neighbours are recomputed.

   The sequence of events, and so every bit of the result, is that of the CPU backend's event
   queue (engine/cpu_backend.cpp): both carry out the earliest current candidate of the group,
   computed by the same functions from the same two bodies' states.

   A group must be closed under the edges: every edge of a member joins two members (the
   window's groups are connected components of its edges).  Then groups touch disjoint bodies
   and best entries, and any number of them can run at once.

   Host-device (core/hd.h).  Nothing here depends on LAMMPS, MPI or CUDA. */
#ifndef HSGPU_GPU_COLLISION_GROUP_LOOP_H
#define HSGPU_GPU_COLLISION_GROUP_LOOP_H

#include "core/collision_step.h"
#include "core/event_order.h"
#include "core/hd.h"

namespace HSGPU {
namespace Collide {

  /// A window's bodies and edges with the edges' adjacency: the edges of body b are
  /// edges[adj[adj_start[b] .. adj_start[b + 1])] (in any order: no two events have equal
  /// keys).  best: one Event per body, scratch for the loop.  joined (optional): only edges q
  /// with joined[q] != 0 are the window's (the resident step keeps one adjacency of the whole
  /// step's candidates and marks each window's edges).
  struct GroupGraph {
    Body *bodies;
    const Edge *edges;
    const int *adj_start;
    const int *adj;
    Event *best;
    const unsigned char *joined = nullptr;
  };

  /// The earliest candidate event of body b: its wall event, or the earliest pair event of
  /// its edges (first in adjacency order among equal keys).
  HSGPU_HD Event group_best_event(const GroupGraph &g, const Params &p, int b)
  {
    Event e = wall_event(g.bodies, p, b);
    for (int k = g.adj_start[b]; k < g.adj_start[b + 1]; ++k) {
      if (g.joined && !g.joined[g.adj[k]]) continue;
      const Event c = pair_event(g.bodies, g.edges, p, g.adj[k]);
      if (c.t != Contact::never() && (e.t == Contact::never() || earlier(c, e))) e = c;
    }
    return e;
  }

  /// group_best_event() from the pair event times of b's edges found before: et[q] is
  /// pair_event_time() of edge q's two bodies as they are now, for every edge of b in the
  /// window (joined).  The same event: the earliest by earlier() of b's wall event and of the
  /// edges with the least time, the first in adjacency order among equal keys (only edges tied
  /// at the least time need their keys).
  HSGPU_HD Event cached_best_event(const GroupGraph &g, const Params &p, const double *et, int b)
  {
    Event e = wall_event(g.bodies, p, b);
    const double never = Contact::never();
    const int lo = g.adj_start[b], hi = g.adj_start[b + 1];
    double least = never;
    int arg = -1;
    bool tie = false;
    for (int k = lo; k < hi; ++k) {
      const int q = g.adj[k];
      if (g.joined && !g.joined[q]) continue;
      const double t = et[q];
      if (t == never) continue;
      if (arg < 0 || t < least) {
        least = t;
        arg = q;
        tie = false;
      } else if (t == least) {
        tie = true;
      }
    }
    if (arg < 0) return e;
    auto take = [&](int q) {
      const Event c = pair_event_at(g.bodies, g.edges, q, least);
      if (e.t == never || earlier(c, e)) e = c;
    };
    if (!tie) {
      take(arg);
    } else {    // every edge at the least time, in adjacency order
      for (int k = lo; k < hi; ++k) {
        const int q = g.adj[k];
        if (!(g.joined && !g.joined[q]) && et[q] == least) take(q);
      }
    }
    return e;
  }

  /// Recomputes the best events of body b and of its edge-neighbours.
  HSGPU_HD void group_refresh_around(const GroupGraph &g, const Params &p, int b)
  {
    g.best[b] = group_best_event(g, p, b);
    for (int k = g.adj_start[b]; k < g.adj_start[b + 1]; ++k) {
      if (g.joined && !g.joined[g.adj[k]]) continue;
      const Edge &e = g.edges[g.adj[k]];
      const int o = (e.i == b) ? e.j : e.i;
      g.best[o] = group_best_event(g, p, o);
    }
  }

  /// The member whose best event is the earliest by earlier() (the first among equal keys),
  /// or -1 where none has an event.
  HSGPU_HD int group_earliest(const GroupGraph &g, const int *members, int nmembers)
  {
    int arg = -1;
    for (int k = 0; k < nmembers; ++k) {
      const int b = members[k];
      if (g.best[b].t != Contact::never() && (arg < 0 || earlier(g.best[b], g.best[arg])))
        arg = b;
    }
    return arg;
  }

  /// The loop of resolve_group_exact() below, with the carrying out given: carry(ev) carries
  /// out event ev (a copy of the member's best) and refreshes the best events it changes.
  template <class Carry>
  HSGPU_HD long group_event_loop(const GroupGraph &g, const int *members, int nmembers,
                                 double t_end, long budget, Tally &tally, Carry carry)
  {
    long count = 0;
    while (true) {
      const int arg = group_earliest(g, members, nmembers);
      if (arg < 0 || !(g.best[arg].t < t_end)) break;
      if (count >= budget) {
        tally.capped = 1;
        break;
      }
      carry(g.best[arg]);
      ++count;
    }
    return count;
  }

  /// Carries out the events of the group members[0 .. nmembers) with t < t_end in time order
  /// and adds them to tally.  At most `budget` events: when one more is due, tally.capped is
  /// set and the group stops (the CPU backend's maxevents check, with budget = maxevents
  /// minus the events counted before the group).  Returns the number of events carried out.
  HSGPU_HD long resolve_group_exact(const GroupGraph &g, const Params &p, const int *members,
                                    int nmembers, double t_end, long budget, Tally &tally)
  {
    for (int k = 0; k < nmembers; ++k) g.best[members[k]] = group_best_event(g, p, members[k]);
    return group_event_loop(g, members, nmembers, t_end, budget, tally, [&](const Event ev) {
      if (ev.face >= 0) {
        process_wall(g.bodies[ev.index], ev.face, ev.t, p, tally);
        group_refresh_around(g, p, ev.index);
      } else {
        const Edge &e = g.edges[ev.index];
        process_pair(g.bodies[e.i], g.bodies[e.j], e, ev.t, p, tally);
        group_refresh_around(g, p, e.i);
        group_refresh_around(g, p, e.j);
      }
    });
  }

  /// Where the CPU backend's cap stops a window whose groups were all resolved at once, each
  /// with the budget maxevents - events_before: tallies[g] is group g's tally from that run
  /// (groups with gstart[g + 1] <= gstart[g] are empty and ignored).  The CPU backend resolves
  /// the groups in order against one cap and stops at the first group that has an event due
  /// when the cap is reached.  Returns that group, with the budget the CPU leaves it in
  /// stop_budget, or -1 when the cap does not stop the window (then every group's run was
  /// the CPU's).  Host code.
  inline int cap_stop_group(const int *gstart, int ngroups, const Tally *tallies, long maxevents,
                            long events_before, long &stop_budget)
  {
    long total = events_before;
    for (int g = 0; g < ngroups; ++g) {
      if (gstart[g + 1] <= gstart[g]) continue;
      const long left = maxevents - total;
      // The group wanted more events than are left: it ran into its own budget (which is at
      // least `left`) or carried out more than `left`.
      if (tallies[g].capped || tallies[g].events > (left > 0 ? left : 0)) {
        stop_budget = left;
        return g;
      }
      total += tallies[g].events;
    }
    stop_budget = 0;
    return -1;
  }

  /// Hands the tallies of a window's groups to the caller as the CPU backend does, in group
  /// order: group g's tally is tallies[g] if it ran (g <= last and not empty), else zero; it
  /// goes to per_group[g] when per_group is given (WindowWork::group_tally), else it is added
  /// to `tally`; a capped group sets tally.capped either way.  Returns the most events of one
  /// group.  Host code.
  inline long hand_over_tallies(const int *gstart, int ngroups, const Tally *tallies, int last,
                                Tally *per_group, Tally &tally)
  {
    long most = 0;
    for (int g = 0; g < ngroups; ++g) {
      Tally tg;
      if (g <= last && gstart[g + 1] > gstart[g]) {
        tg = tallies[g];
        if (tg.events > most) most = tg.events;
        if (tg.capped) tally.capped = 1;
      }
      if (per_group)
        per_group[g] = tg;
      else
        tally.add(tg);
    }
    return most;
  }

}    // namespace Collide
}    // namespace HSGPU

#endif
