/* HARDSPHERE_GPU collision engine: one group's events in time order, run by one warp.

   collision_group_loop.h's resolve_group_exact() with its three loops spread over the 32
   lanes of a warp; the events, and every bit of the bodies, are the same:

   - the members' first best events: one member per lane (strided);
   - the earliest best event: each lane scans its members, then the warp takes the earliest
     of the lanes' candidates (keys (t, k1, k2) are unique per event; two members holding the
     same pair event are told apart by their index, so every lane agrees on one member);
   - the event: lane 0 carries it out (process_wall / process_pair);
   - the refresh: the bodies of the event and their joined edge-neighbours recompute their
     best events, one per lane, first around body i, then around body j (a neighbour of
     both is recomputed twice, in turn, to the same value: after the event both bodies' states
     are final, as in the serial loop, which also refreshes around i after moving j).
     Or, where the caller keeps the edges' pair event times (`et`), the times of the two
     bodies' edges found again, one edge per lane, and the best events of both bodies and
     their neighbours taken from those times, one body per lane (carry_out_cached()).

   Between the stages __syncwarp() orders the lanes' reads and writes of bodies and best[].

   Device code only: must be called by all 32 lanes of a warp together, with the same
   arguments.  Returns the number of events; `tally` is complete in lane 0 only. */
#ifndef HSGPU_GPU_GROUP_LOOP_WARP_CUH
#define HSGPU_GPU_GROUP_LOOP_WARP_CUH

#include "collision_group_loop.h"

namespace HSGPU {
namespace Collide {

  namespace WarpLoop {

    constexpr unsigned FULL = 0xffffffffu;

    /// A lane's candidate: the key of best[b] and the member b (-1: none).
    struct Candidate {
      double t;
      long k1, k2;
      int b;
    };

    /// a before c: earlier event, equal events by the lower member index; none last.
    __device__ inline bool before(const Candidate &a, const Candidate &c)
    {
      if (a.b < 0) return false;
      if (c.b < 0) return true;
      if (a.t != c.t) return a.t < c.t;
      if (a.k1 != c.k1) return a.k1 < c.k1;
      if (a.k2 != c.k2) return a.k2 < c.k2;
      return a.b < c.b;
    }

    /// Member b's candidate, from its best event (none where it has no event).
    __device__ inline Candidate candidate_of(const Event &e, int b)
    {
      if (e.t == Contact::never()) return Candidate{0.0, 0, 0, -1};
      return Candidate{e.t, e.k1, e.k2, b};
    }

    /// The earlier of two candidates (a reduction operator).
    struct Earliest {
      __device__ Candidate operator()(const Candidate &a, const Candidate &c) const
      {
        return before(c, a) ? c : a;
      }
    };

    /// The earliest candidate over the warp (every lane gets it).
    __device__ inline Candidate warp_earliest(Candidate c)
    {
      for (int off = 16; off > 0; off >>= 1) {
        Candidate o;
        o.t = __shfl_xor_sync(FULL, c.t, off);
        o.k1 = __shfl_xor_sync(FULL, c.k1, off);
        o.k2 = __shfl_xor_sync(FULL, c.k2, off);
        o.b = __shfl_xor_sync(FULL, c.b, off);
        if (before(o, c)) c = o;
      }
      return c;
    }

    /// Best events of body b and of its joined edge-neighbours, one body per lane.
    __device__ inline void refresh_around(const GroupGraph &g, const Params &p, int b, int lane)
    {
      const int lo = g.adj_start[b], hi = g.adj_start[b + 1];
      // Slot -1 is b itself, slot k >= 0 the other end of edge adj[lo + k].
      for (int k = lane - 1; k < hi - lo; k += 32) {
        int o = b;
        if (k >= 0) {
          const int q = g.adj[lo + k];
          if (g.joined && !g.joined[q]) continue;
          const Edge &e = g.edges[q];
          o = (e.i == b) ? e.j : e.i;
        }
        g.best[o] = group_best_event(g, p, o);
      }
    }

    /// Carries out event ev on lane 0 (tally is lane 0's) and gives every lane its bodies: i,
    /// and j for a pair (else -1).  Ends with the warp synchronized.
    __device__ inline void process_event(const GroupGraph &g, const Params &p, const Event &ev,
                                         int lane, Tally &tally, int &i, int &j)
    {
      i = ev.index;
      j = -1;
      if (ev.face >= 0) {
        if (lane == 0) process_wall(g.bodies[i], ev.face, ev.t, p, tally);
      } else {
        const Edge &e = g.edges[ev.index];
        i = e.i;
        j = e.j;
        if (lane == 0) process_pair(g.bodies[i], g.bodies[j], e, ev.t, p, tally);
      }
      __syncwarp();
    }

    /// Carries out event ev (lane 0) and refreshes the best events around its bodies (the
    /// warp); tally is lane 0's.  Every lane must have read what it needs of best[] before.
    __device__ inline void carry_out(const GroupGraph &g, const Params &p, const Event &ev,
                                     int lane, Tally &tally)
    {
      int i, j;
      process_event(g, p, ev, lane, tally, i, j);
      refresh_around(g, p, i, lane);
      if (j >= 0) {
        __syncwarp();
        refresh_around(g, p, j, lane);
      }
      __syncwarp();
    }

    /* With the pair event times of the group's edges kept in et[] (resolve_group_warp()'s
       `et`): an event changes the times of the edges of its bodies only.  Those are found
       again, one edge per lane (body i's edges, then body j's but those to i, which are in
       i's list), and then the best events of the bodies and their neighbours are taken from
       et[] (cached_best_event()), one body per lane: no pair time is found twice, and no lane
       walks a neighbour's edges computing their times in turn. */

    /// The times of the window's edges of body i and of body j (-1: none) into et[].
    __device__ inline void edge_times_around(const GroupGraph &g, const Params &p, double *et,
                                             int i, int j, int lane)
    {
      const int li = g.adj_start[i], ni = g.adj_start[i + 1] - li;
      const int lj = j >= 0 ? g.adj_start[j] : 0, nj = j >= 0 ? g.adj_start[j + 1] - lj : 0;
      for (int s = lane; s < ni + nj; s += 32) {
        const int q = s < ni ? g.adj[li + s] : g.adj[lj + s - ni];
        if (g.joined && !g.joined[q]) continue;
        const Edge &e = g.edges[q];
        if (s >= ni && (e.i == i || e.j == i)) continue;
        et[q] = pair_event_time(g.bodies[e.i], g.bodies[e.j], e, p.dt);
      }
    }

    /// Best events of bodies i and j (-1: none) and of their joined edge-neighbours from et[],
    /// one body per lane (a body reached twice gets the same event twice).
    __device__ inline void bests_around(const GroupGraph &g, const Params &p, const double *et,
                                        int i, int j, int lane)
    {
      const int ni = g.adj_start[i + 1] - g.adj_start[i] + 1;
      const int nj = j >= 0 ? g.adj_start[j + 1] - g.adj_start[j] + 1 : 0;
      for (int s = lane; s < ni + nj; s += 32) {
        const int b = s < ni ? i : j;
        const int k = s < ni ? s - 1 : s - ni - 1;    // -1: b itself
        int o = b;
        if (k >= 0) {
          const int q = g.adj[g.adj_start[b] + k];
          if (g.joined && !g.joined[q]) continue;
          const Edge &e = g.edges[q];
          o = (e.i == b) ? e.j : e.i;
        }
        g.best[o] = cached_best_event(g, p, et, o);
      }
    }

    /// carry_out() with the edge times kept in et[].
    __device__ inline void carry_out_cached(const GroupGraph &g, const Params &p, double *et,
                                            const Event &ev, int lane, Tally &tally)
    {
      int i, j;
      process_event(g, p, ev, lane, tally, i, j);
      edge_times_around(g, p, et, i, j, lane);
      __syncwarp();
      bests_around(g, p, et, i, j, lane);
      __syncwarp();
    }

  }    // namespace WarpLoop

  /// resolve_group_exact() by one warp (see the file comment).  With `bests_ready` the
  /// members' first best events are in g.best already (group_best_event() of each, written by
  /// the caller before the warp starts).  With `et`: et[q] holds the pair event time of every
  /// edge q of the group in the window (the caller's, as the bodies are at the start), which
  /// the loop keeps current and takes the best events from (carry_out_cached()).
  __device__ inline long resolve_group_warp(const GroupGraph &g, const Params &p,
                                            const int *members, int nmembers, double t_end,
                                            long budget, Tally &tally, bool bests_ready = false,
                                            double *et = nullptr)
  {
    using namespace WarpLoop;
    const int lane = threadIdx.x & 31;
    if (!bests_ready)
      for (int k = lane; k < nmembers; k += 32)
        g.best[members[k]] = group_best_event(g, p, members[k]);
    __syncwarp();
    long count = 0;
    while (true) {
      Candidate c{0.0, 0, 0, -1};
      for (int k = lane; k < nmembers; k += 32) {
        const Candidate m = candidate_of(g.best[members[k]], members[k]);
        if (before(m, c)) c = m;
      }
      c = warp_earliest(c);
      if (c.b < 0 || !(c.t < t_end)) break;
      if (count >= budget) {
        tally.capped = 1;
        break;
      }
      const Event ev = g.best[c.b];
      __syncwarp();    // every lane has read best[] before it changes
      if (et)
        carry_out_cached(g, p, et, ev, lane, tally);
      else
        carry_out(g, p, ev, lane, tally);
      ++count;
    }
    return count;
  }

}    // namespace Collide
}    // namespace HSGPU

#endif
