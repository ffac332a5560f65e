/* HARDSPHERE_GPU physics core: the order in which the events of a step are carried out.

   Both orders process events in time order, ties broken by the bodies' IDs (pair: lower ID,
   higher ID; wall: ID, then the face, walls before pairs), and compute every event time from
   the two bodies' states only (trajectory.h).  So within a set of bodies that interact only
   among themselves the sequence of events, and the arithmetic, are the same in both orders:

   - serial: the seed paper's loop (K.A. Hawick and D.P. Playne, "Hard-Sphere Collision
     Simulations with Multiple GPUs, PCIe Extension Buses and GPU-GPU Communications",
     Technical Report CSTN-138, Massey University, 2011).  Each body keeps its earliest
     candidate event; every iteration scans all bodies for the globally earliest one, carries
     it out and recomputes the candidates of the bodies involved and of their neighbours:
     O(N) per event.
   - components: the edges (pairs that can touch within the step) split the bodies into
     connected components that cannot influence each other within the step; each component is
     resolved by itself with its own event queue (time buckets): O(N + events) per step.

   Where the caller gives body_virial (6 doubles per body, indexed like the bodies), every
   event adds its per-atom virial there (collision_step.h); nullptr: not tallied.

   Host code (uses the standard library).  Nothing here depends on LAMMPS, MPI or CUDA. */
#ifndef HSGPU_CORE_EVENT_ORDER_H
#define HSGPU_CORE_EVENT_ORDER_H

#include "collision_step.h"
#include "trajectory.h"

#include <algorithm>
#include <vector>

namespace HSGPU {
namespace Collide {

  /// A candidate event.  face >= 0: wall event of body `index`; face < 0: pair event of edge
  /// `index`.  (k1, k2) is the tie-break key; s1, s2 the bodies' version stamps.
  struct Event {
    double t;
    long k1, k2;
    int index;
    int face;
    int s1, s2;
  };

  HSGPU_HD bool earlier(const Event &a, const Event &b)
  {
    if (a.t != b.t) return a.t < b.t;
    if (a.k1 != b.k1) return a.k1 < b.k1;
    return a.k2 < b.k2;
  }

  /// Body b's wall event (t = never() if none), with its tie-break key and version stamps.
  HSGPU_HD Event wall_event(const Body *bodies, const Params &p, int b)
  {
    Event ev;
    int face = -1;
    ev.t = wall_event_time(bodies[b], p.walls, p.dt, face);
    ev.k1 = bodies[b].id;
    ev.k2 = -1 - face;
    ev.index = b;
    ev.face = face;
    ev.s1 = ev.s2 = bodies[b].nevents;
    return ev;
  }

  /// Edge q's pair event whose time t is known already (pair_event_time() of the two bodies'
  /// present states; never() if none), with its tie-break key and version stamps.
  HSGPU_HD Event pair_event_at(const Body *bodies, const Edge *edges, int q, double t)
  {
    const Edge &e = edges[q];
    const Body &bi = bodies[e.i], &bj = bodies[e.j];
    Event ev;
    ev.t = t;
    ev.k1 = bi.id;
    ev.k2 = bj.id;
    ev.index = q;
    ev.face = -1;
    ev.s1 = bi.nevents;
    ev.s2 = bj.nevents;
    return ev;
  }

  /// Edge q's pair event (t = never() if none), with its tie-break key and version stamps.
  HSGPU_HD Event pair_event(const Body *bodies, const Edge *edges, const Params &p, int q)
  {
    const Edge &e = edges[q];
    return pair_event_at(bodies, edges, q, pair_event_time(bodies[e.i], bodies[e.j], e, p.dt));
  }

  /// Adjacency of edges over n bodies (CSR): the edges of body b are
  /// adj[adj_start[b] .. adj_start[b + 1]): first those with b as their body i, then those with
  /// b as body j, each part in increasing edge index.  Where split is given, (*split)[b] is
  /// where body b's second part begins.  fill is scratch.
  inline void edge_adjacency(int n, const Edge *edges, int nedges, std::vector<int> &adj_start,
                             std::vector<int> &adj, std::vector<int> &fill,
                             std::vector<int> *split = nullptr)
  {
    adj_start.assign(n + 1, 0);
    for (int q = 0; q < nedges; ++q) {
      adj_start[edges[q].i + 1]++;
      adj_start[edges[q].j + 1]++;
    }
    for (int b = 0; b < n; ++b) adj_start[b + 1] += adj_start[b];
    adj.resize(adj_start[n]);
    fill.assign(adj_start.begin(), adj_start.end() - 1);
    for (int q = 0; q < nedges; ++q) adj[fill[edges[q].i]++] = q;
    if (split) split->assign(fill.begin(), fill.end());
    for (int q = 0; q < nedges; ++q) adj[fill[edges[q].j]++] = q;
  }

  /// Disjoint sets with path halving; the representative is the smallest index of a set.
  struct UnionFind {
    std::vector<int> parent;
    void reset(int n)
    {
      parent.resize(n);
      for (int i = 0; i < n; ++i) parent[i] = i;
    }
    int find(int i)
    {
      while (parent[i] != i) {
        parent[i] = parent[parent[i]];
        i = parent[i];
      }
      return i;
    }
    void unite(int a, int b)
    {
      a = find(a);
      b = find(b);
      if (a == b) return;
      if (a < b)
        parent[b] = a;
      else
        parent[a] = b;
    }
  };

  /// The heap order of events: the earliest on top.
  struct LaterEvent {
    bool operator()(const Event &a, const Event &b) const { return earlier(b, a); }
  };

  /// The candidate events of one group's resolution, in time buckets over [lo, hi).  A push
  /// appends to its bucket's list; the lowest non-empty bucket is moved into a binary heap (the
  /// front), from which the pops come, and the pushes that fall in it go there too.  A
  /// bucket's index never decreases with the time, so the front's earliest event is the
  /// earliest of all; an event pushed below the front's bucket (none is, as events come in
  /// time order) joins the front.  With about two events per bucket the front is tiny (a
  /// binary heap of all events made a dozen comparisons per pop that went either way
  /// unpredictably), and a burst of events at one time (touching spheres at a step's start)
  /// costs a heap's log, not a scan, per pop.
  class EventQueue {
   public:
    /// Empties the queue and sets nbuckets (>= 1) buckets over [lo, hi).
    void reset(double lo, double hi, int nbuckets)
    {
      nb = nbuckets;
      t_lo = lo;
      scale = hi > lo ? nb / (hi - lo) : 0.0;
      head.assign(nb, -1);
      pool.clear();
      next.clear();
      front.clear();
      free_slot = -1;
      cur = 0;
      front_bucket = -1;
      count = 0;
    }
    bool empty() const { return count == 0; }
    void push(const Event &e)
    {
      ++count;
      const double f = (e.t - t_lo) * scale;
      const int k = !(f >= cur) ? cur : f >= nb ? nb - 1 : (int) f;
      if (k == front_bucket) {
        front.push_back(e);
        std::push_heap(front.begin(), front.end(), LaterEvent());
        return;
      }
      int slot = free_slot;
      if (slot >= 0) {
        free_slot = next[slot];
        pool[slot] = e;
      } else {
        slot = (int) pool.size();
        pool.push_back(e);
        next.push_back(-1);
      }
      next[slot] = head[k];
      head[k] = slot;
    }
    /// The earliest event, removed (the queue must not be empty).
    Event pop()
    {
      if (front.empty()) {
        // The front's bucket is used up (pushes into it went to the front): the next
        // non-empty one becomes the front.
        if (front_bucket == cur) ++cur;
        while (head[cur] < 0) ++cur;
        for (int q = head[cur], nq; q >= 0; q = nq) {
          nq = next[q];
          front.push_back(pool[q]);
          next[q] = free_slot;
          free_slot = q;
        }
        head[cur] = -1;
        front_bucket = cur;
        std::make_heap(front.begin(), front.end(), LaterEvent());
      }
      std::pop_heap(front.begin(), front.end(), LaterEvent());
      const Event e = front.back();
      front.pop_back();
      --count;
      return e;
    }

   private:
    std::vector<Event> pool, front;
    std::vector<int> next, head;
    double t_lo = 0.0, scale = 0.0;
    int nb = 1, cur = 0, front_bucket = -1, free_slot = -1, count = 0;
  };

  class Resolver {
   public:
    /// Resolves the step for all bodies, component by component.
    void resolve_components(std::vector<Body> &bodies, const std::vector<Edge> &edges,
                            const Params &p, Tally &tally, double *body_virial = nullptr)
    {
      const int n = (int) bodies.size();
      uf.reset(n);
      for (const Edge &e : edges) uf.unite(e.i, e.j);
      // Bodies grouped by component (counting sort on the representative).
      comp_start.assign(n + 1, 0);
      for (int b = 0; b < n; ++b) comp_start[uf.find(b) + 1]++;
      for (int b = 0; b < n; ++b) comp_start[b + 1] += comp_start[b];
      comp_members.resize(n);
      fill.assign(comp_start.begin(), comp_start.end() - 1);
      for (int b = 0; b < n; ++b) comp_members[fill[uf.find(b)]++] = b;
      max_component_events =
          resolve_groups(bodies.data(), n, edges.data(), (int) edges.size(), comp_start.data(),
                         comp_members.data(), n, Contact::never(), p, tally, nullptr, body_virial);
    }

    /// Resolves the groups comp_members[comp_start[g] .. comp_start[g + 1]) (empty groups
    /// allowed) one after the other, each with its own event queue, up to t_end: events at
    /// t >= t_end stay for later.  Each group's tally is summed into a fresh Tally that is then
    /// added to `tally` (or, with per_group, stored in per_group[g]).  Returns the most
    /// events one group needed.
    long resolve_groups(Body *bodies, int n, const Edge *edges, int nedges, const int *gstart,
                        const int *gmembers, int ngroups, double t_end, const Params &p,
                        Tally &tally, Tally *per_group = nullptr, double *body_virial = nullptr)
    {
      build_adjacency(n, edges, nedges);
      long most = 0, running = tally.events;
      for (int g = 0; g < ngroups; ++g) {
        Tally tg;
        const int lo = gstart[g], hi = gstart[g + 1];
        if (hi > lo && !tally.capped) {
          tg.events = running;    // the cap counts every group's events
          const long count =
              resolve_one(bodies, edges, p, tg, gmembers + lo, hi - lo, t_end, body_virial);
          tg.events -= running;
          running += tg.events;
          if (count > most) most = count;
          if (tg.capped) tally.capped = 1;
        }
        if (per_group)
          per_group[g] = tg;
        else
          tally.add(tg);
      }
      return most;
    }

    /// Resolves the step for all bodies with the seed paper's global loop.
    void resolve_serial(std::vector<Body> &bodies, const std::vector<Edge> &edges, const Params &p,
                        Tally &tally, double *body_virial = nullptr)
    {
      const int n = (int) bodies.size();
      Body *bd = bodies.data();
      const Edge *ed = edges.data();
      build_adjacency(n, ed, (int) edges.size());
      best.resize(n);
      for (int b = 0; b < n; ++b) best[b] = best_event(bd, ed, p, b);
      while (true) {
        int arg = -1;
        for (int b = 0; b < n; ++b)
          if (best[b].t != Contact::never() && (arg < 0 || earlier(best[b], best[arg]))) arg = b;
        if (arg < 0) break;
        if (tally.events >= p.maxevents) {
          tally.capped = 1;
          break;
        }
        const Event ev = best[arg];
        touched.clear();
        carry_out(bd, ed, p, tally, ev, body_virial);
        if (ev.face >= 0) {
          touched.push_back(ev.index);
        } else {
          touched.push_back(ed[ev.index].i);
          touched.push_back(ed[ev.index].j);
        }
        const size_t ntouched = touched.size();
        for (size_t k = 0; k < ntouched; ++k) {
          const int b = touched[k];
          for (int q = adj_start[b]; q < adj_start[b + 1]; ++q) {
            const Edge &e = ed[adj[q]];
            touched.push_back(e.i == b ? e.j : e.i);
          }
        }
        for (int b : touched) best[b] = best_event(bd, ed, p, b);
      }
    }

    /// Largest number of events one component needed in the last resolve_components().
    long max_component_events = 0;

   private:
    std::vector<int> adj_start, adj, adj_split, comp_start, comp_members, fill, touched;
    std::vector<Event> pending, best;
    EventQueue queue;
    double t_cut = 0.0;    // events at or after this time are not queued
    UnionFind uf;

    void build_adjacency(int n, const Edge *edges, int nedges)
    {
      edge_adjacency(n, edges, nedges, adj_start, adj, fill, &adj_split);
    }

    Event best_event(const Body *bodies, const Edge *edges, const Params &p, int b) const
    {
      Event e = wall_event(bodies, p, b);
      for (int q = adj_start[b]; q < adj_start[b + 1]; ++q) {
        const Event c = pair_event(bodies, edges, p, adj[q]);
        if (c.t != Contact::never() && (e.t == Contact::never() || earlier(c, e))) e = c;
      }
      return e;
    }

    static bool is_current(const Body *bodies, const Edge *edges, const Event &ev)
    {
      if (ev.face >= 0) return bodies[ev.index].nevents == ev.s1;
      const Edge &e = edges[ev.index];
      return bodies[e.i].nevents == ev.s1 && bodies[e.j].nevents == ev.s2;
    }

    static void carry_out(Body *bodies, const Edge *edges, const Params &p, Tally &tally,
                          const Event &ev, double *body_virial)
    {
      if (ev.face >= 0) {
        process_wall(bodies[ev.index], ev.face, ev.t, p, tally,
                     body_virial ? body_virial + 6 * (size_t) ev.index : nullptr);
      } else {
        const Edge &e = edges[ev.index];
        process_pair(bodies[e.i], bodies[e.j], e, ev.t, p, tally,
                     body_virial ? body_virial + 6 * (size_t) e.i : nullptr,
                     body_virial ? body_virial + 6 * (size_t) e.j : nullptr);
      }
    }

    void push(const Event &ev)
    {
      if (!(ev.t < t_cut)) return;    // also never()
      queue.push(ev);
    }

    void push_body(const Body *bodies, const Edge *edges, const Params &p, int b)
    {
      push(wall_event(bodies, p, b));
      for (int q = adj_start[b]; q < adj_start[b + 1]; ++q)
        push(pair_event(bodies, edges, p, adj[q]));
    }

    long resolve_one(Body *bodies, const Edge *edges, const Params &p, Tally &tally,
                     const int *members, int nmembers, double t_end, double *body_virial)
    {
      // Events at or after t_end wait for a later window: they are never queued (the loop
      // below ends when no current event before t_end is left, as it would on reaching
      // the first current one after it).
      t_cut = t_end < p.dt ? t_end : p.dt;
      pending.clear();
      for (int k = 0; k < nmembers; ++k) {
        const int b = members[k];
        const Event w = wall_event(bodies, p, b);
        if (w.t < t_cut) pending.push_back(w);
        // Each edge once: from its body i (the first part of b's edges; no test per edge,
        // which went either way unpredictably).
        for (int q = adj_start[b]; q < adj_split[b]; ++q) {
          const Event e = pair_event(bodies, edges, p, adj[q]);
          if (e.t < t_cut) pending.push_back(e);
        }
      }
      // Buckets from the earliest candidate to the cut, about two events each.
      double lo = t_cut;
      for (const Event &e : pending) lo = e.t < lo ? e.t : lo;
      queue.reset(lo, t_cut, (int) (pending.size() / 2) + 1);
      for (const Event &e : pending) queue.push(e);
      long count = 0;
      while (!queue.empty()) {
        const Event ev = queue.pop();
        if (!is_current(bodies, edges, ev)) continue;
        if (tally.events >= p.maxevents) {
          tally.capped = 1;
          break;
        }
        carry_out(bodies, edges, p, tally, ev, body_virial);
        ++count;
        if (ev.face >= 0) {
          push_body(bodies, edges, p, ev.index);
        } else {
          push_body(bodies, edges, p, edges[ev.index].i);
          push_body(bodies, edges, p, edges[ev.index].j);
        }
      }
      return count;
    }
  };

}    // namespace Collide
}    // namespace HSGPU

#endif
