/* HARDSPHERE_GPU collision engine: the device-resident step's kernels and device structs
   (resident_step_cuda.cu drives them; its file comment says what each phase does).  Each
   kernel's comment gives its launch contract.

   Included by resident_step_cuda.cu only: everything here is in an unnamed namespace of that
   translation unit.  Device code is compiled with --fmad=false (collide.cmake), so that every
   body and event computation is core/'s to the bit. */
#ifndef HSGPU_GPU_RESIDENT_KERNELS_CUH
#define HSGPU_GPU_RESIDENT_KERNELS_CUH

#include "resident_step_cuda.h"
#include "group_loop_warp.cuh"
#include "engine/window_chooser.h"
#include "core/verlet_motion.h"

#include <cub/block/block_reduce.cuh>

#include <cmath>
#include <cstdlib>

namespace HSGPU {
namespace Collide {

  namespace {

    constexpr int BLOCK = 256;
    constexpr int GROUP_BLOCK = 128;
    // Groups up to this size are resolved by one thread each, larger ones by a warp (measured
    // on an H100: 1, 2 and 4 within 5% at N = 65536 and 1e6, 8 and more slower).
    constexpr int SMALL_GROUP = 2;
    constexpr double MARGIN = WINDOW_MARGIN;    // engine/window_chooser.h

    int nblocks(long n, int block = BLOCK)
    {
      return (int) ((n + block - 1) / block);
    }

    /// One window's tally, and whether its group had an event (summed: groups with events).
    struct WinSum {
      long pair, wall, rest, events, groups;
      double ke_lost;
      double virial[6];
      int capped;
    };

    struct WinSumAdd {
      __host__ __device__ WinSum operator()(const WinSum &a, const WinSum &b) const
      {
        WinSum c;
        c.pair = a.pair + b.pair;
        c.wall = a.wall + b.wall;
        c.rest = a.rest + b.rest;
        c.events = a.events + b.events;
        c.groups = a.groups + b.groups;
        c.ke_lost = a.ke_lost + b.ke_lost;
        for (int k = 0; k < 6; ++k) c.virial[k] = a.virial[k] + b.virial[k];
        c.capped = a.capped | b.capped;
        return c;
      }
    };

    /// The search grid: cell widths, counts, periodic flags.
    struct Grid {
      double lo[3], prd[3], width[3];
      int n[3];
      int periodic[3];
    };

    /// What end_kernel and step_check_kernel find (zeroed together before end_kernel).
    struct EndSums {
      unsigned long long maxexc;    // bits of the largest excursion in the step
      unsigned long long vend2;     // bits of the largest |v|^2 at the step end
      int excursion;                // bodies beyond their step bound
      int missed_step;              // a pair that was not a candidate could have touched
    };

    /// Device scalars, downloaded together.
    struct Scalars {
      unsigned long long maxreach;    // bits of the largest r + bound (non-negative double)
      unsigned long long vmax2;       // bits of the largest |v|^2
      int overlap;                    // a sphere and a wall overlap at the start points
      int pair_overlap;               // a pair overlaps at the start points
      int small_box;                  // a periodic length holds fewer than three cells
      int largest;                    // largest group of the window tried
      int ngroups;                    // groups of the window tried
      int missed;                     // pairs joined by the window's check
      int changed;                    // bodies with events, compacted for the download
      int candidates;                 // candidate pairs
      int nedges;                     // of them written: min(candidates, the room for them)
      unsigned long long rmax;        // bits of the largest radius
      EndSums end;                    // the step's end and check
      int nmulti;                     // groups of two or more bodies (the rest: single bodies)
      int next_group;                 // resolve_kernel's next group to take
      Grid grid;                      // the search's cells (cell_kernel's)
      WinSum win;                     // the window's tally
    };

    __device__ void atomic_max_bits(unsigned long long *a, double v)
    {
      atomicMax(a, (unsigned long long) __double_as_longlong(v));
    }

    /// The largest of three non-negative doubles, by blocks of BLOCK threads.
    struct Max3 {
      double v[3];
    };
    struct Max3Op {
      __device__ Max3 operator()(const Max3 &a, const Max3 &b) const
      {
        return Max3{{fmax(a.v[0], b.v[0]), fmax(a.v[1], b.v[1]), fmax(a.v[2], b.v[2])}};
      }
    };

    /* Kernels that read most of each Body (208 bytes) take their block's bodies into shared
       memory first, 8-byte words side by side: a thread reading its own Body field by field
       would make every load of the warp touch 32 separate sectors. */
    constexpr int TILE = 128;    // bodies per tile, the block size of those kernels
    constexpr int BODY_WORDS = sizeof(Body) / sizeof(unsigned long long);

    /// The block's bodies [blockIdx.x TILE, + TILE) (those below n) into tile; every thread of
    /// the block must call it.
    __device__ void load_tile(const Body *bodies, int n, Body *tile)
    {
      const int first = blockIdx.x * TILE;
      const int words = max(0, min(TILE, n - first)) * BODY_WORDS;
      const unsigned long long *src = reinterpret_cast<const unsigned long long *>(bodies + first);
      unsigned long long *dst = reinterpret_cast<unsigned long long *>(tile);
      for (int w = threadIdx.x; w < words; w += TILE) dst[w] = src[w];
      __syncthreads();
    }

    // Launch: blocks of TILE threads, one thread per body (n).  Largest r + bound, radius and
    // |v|^2 into s (one atomic per block and value: bits of non-negative doubles order as
    // integers), s->overlap where a sphere is more than tol x its radius inside a wall at its
    // start point.  Reads n Bodies and n bounds.
    __global__ void __launch_bounds__(TILE)
        scan_bodies_kernel(const Body *__restrict__ bodies, const double *__restrict__ bound, int n,
                           Walls walls, double tol, Scalars *s)
    {
      using Reduce = cub::BlockReduce<Max3, TILE>;
      __shared__ typename Reduce::TempStorage scratch;
      __shared__ Body tile[TILE];
      load_tile(bodies, n, tile);
      const int b = blockIdx.x * TILE + threadIdx.x;
      Max3 m{{0.0, 0.0, 0.0}};
      if (b < n) {
        const Body &bd = tile[threadIdx.x];
        m = Max3{{bd.radius + bound[b], bd.radius, Contact::dot3(bd.v, bd.v)}};
        for (int f = 0; f < NFACES; ++f) {
          if (!walls.on[f]) continue;
          const int d = face_dim(f);
          const double gap = face_sign(f) * (bd.X0[d] - walls.pos[f]) - bd.radius;
          if (gap < -tol * bd.radius) s->overlap = 1;
        }
      }
      m = Reduce(scratch).Reduce(m, Max3Op());
      if (threadIdx.x != 0) return;
      atomic_max_bits(&s->maxreach, m.v[0]);
      atomic_max_bits(&s->rmax, m.v[1]);
      atomic_max_bits(&s->vmax2, m.v[2]);
    }

    __device__ int cell_coord(double x, const Grid &g, int d)
    {
      const double u = floor((x - g.lo[d]) / g.width[d]);
      const double lim = 4.0 * g.n[d] + 4.0;    // far outside: clamped before the cast
      long c = (long) fmin(fmax(u, -lim), lim);
      if (g.periodic[d]) {
        c %= g.n[d];
        if (c < 0) c += g.n[d];
      } else {
        c = c < 0 ? 0 : (c >= g.n[d] ? g.n[d] - 1 : c);
      }
      return (int) c;
    }

    /* The search grid of n bodies whose largest r + bound is maxreach, in the box g holds (lo,
       prd and periodic set; width and n filled in): cells at least as wide as the longest
       candidate range, with a margin for rounding; no more of them than about twice the
       bodies (a dilute system gets wider cells), so at most most_cells(n) = max(2 n + 64, 27).
       Returns whether a periodic length holds fewer than three cells (the step then declines;
       the grid filled in is still one the kernels can use).  std::min and std::max spelled
       out: the host computed the same grid with them. */
    __device__ bool search_grid(double maxreach, int n, Grid &g)
    {
      const double w = 2.0 * maxreach * (1.0 + 1e-9) + 1e-300;
      bool small = false;
      long cells = 1;
      for (int d = 0; d < 3; ++d) {
        const double k = floor(g.prd[d] / w);
        const double kmost = 1048576.0 < k ? 1048576.0 : k;    // std::min(k, 1048576.0)
        g.n[d] = (int) (1.0 < kmost ? kmost : 1.0);            // std::max(1.0, kmost)
        if (g.periodic[d] && g.n[d] < 3) small = true;
        cells *= g.n[d];
      }
      const long most = 2L * n + 64;
      while (cells > most) {
        int d = 0;
        for (int e = 1; e < 3; ++e)
          if (g.n[e] > g.n[d]) d = e;
        const int least = g.periodic[d] ? 3 : 1;
        if (g.n[d] <= least) break;    // then every length holds at most 3 cells
        cells /= g.n[d];
        g.n[d] = max(least, g.n[d] / 2);
        cells *= g.n[d];
      }
      for (int d = 0; d < 3; ++d) g.width[d] = g.prd[d] / g.n[d];
      return small;
    }

    /* The candidates a body finds kept by the count pass (sorted positions of their other
       bodies, at stash[f * n + k] for the f-th of body k, in visiting order), so that the fill
       pass writes them without searching again; a body with more searches again.  (`keep`
       below: STASH, or fewer to test the search again: HSGPU_RESIDENT_STASH.) */
    constexpr int STASH = 16;

    /// The candidates kept per body by the count pass: STASH, or HSGPU_RESIDENT_STASH (0 ...
    /// STASH; a testing aid: fewer send more bodies through the search again).
    int stash_keep()
    {
      static const int keep = [] {
        const char *e = std::getenv("HSGPU_RESIDENT_STASH");
        const int k = e ? std::atoi(e) : STASH;
        return k < 0 ? 0 : (k > STASH ? STASH : k);
      }();
      return keep;
    }

    /// search_grid()'s most cells for n bodies.
    long most_cells(int n)
    {
      return std::max(2L * n + 64, 27L);
    }

    // Launch: one thread per body (n >= 1).  The first thread of every block works the search
    // grid out from s->maxreach (search_grid() on `box`; the same bits in each block), block
    // 0's goes to s->grid with s->small_box; key[b] = the cell of b's start point, val[b] = b.
    __global__ void cell_kernel(const Body *__restrict__ bodies, int n, Grid box, Scalars *s,
                                int *key, int *val)
    {
      __shared__ Grid g;
      if (threadIdx.x == 0) {
        g = box;
        const bool small = search_grid(__longlong_as_double((long long) s->maxreach), n, g);
        if (blockIdx.x == 0) {
          s->grid = g;
          s->small_box = small ? 1 : 0;
        }
      }
      __syncthreads();
      const int b = blockIdx.x * blockDim.x + threadIdx.x;
      if (b >= n) return;
      const double *x = bodies[b].X0;
      key[b] = (cell_coord(x[2], g, 2) * g.n[1] + cell_coord(x[1], g, 1)) * g.n[0] +
               cell_coord(x[0], g, 0);
      val[b] = b;
    }

    // Launch: grid-stride, any number of threads.  The ranges of the cells of s->grid (at most
    // most_cells(n)) emptied: cstart[c] = cend[c] = 0.
    __global__ void zero_cells_kernel(const Scalars *s, int *cstart, int *cend)
    {
      const long cells = (long) s->grid.n[0] * s->grid.n[1] * s->grid.n[2];
      const long stride = (long) gridDim.x * blockDim.x;
      for (long c = blockIdx.x * (long) blockDim.x + threadIdx.x; c < cells; c += stride) {
        cstart[c] = 0;
        cend[c] = 0;
      }
    }

    /// What the pair search reads of a body, stored in cell order so that a cell's bodies lie
    /// side by side (48 bytes instead of three scattered lines of a 208-byte Body).
    struct NearPoint {
      double x[3];    // start point X0
      double radius;
    };
    struct NearTag {
      double bound;    // step bound
      long long id;
    };

    // Launch: one thread per sorted position k (n), body order[k].  cstart/cend (zeroed) get
    // every occupied cell's range of sorted positions; pts[k] and tags[k] the body's start
    // point, radius, step bound and ID.
    __global__ void cell_range_kernel(const int *__restrict__ key, const int *__restrict__ order,
                                      const Body *__restrict__ bodies,
                                      const double *__restrict__ bound, int n, int *cstart,
                                      int *cend, NearPoint *pts, NearTag *tags)
    {
      const int k = blockIdx.x * blockDim.x + threadIdx.x;
      if (k >= n) return;
      if (k == 0 || key[k] != key[k - 1]) cstart[key[k]] = k;
      if (k == n - 1 || key[k] != key[k + 1]) cend[key[k]] = k + 1;
      const Body &b = bodies[order[k]];
      NearPoint p;
      for (int d = 0; d < 3; ++d) p.x[d] = b.X0[d];
      p.radius = b.radius;
      pts[k] = p;
      tags[k] = NearTag{bound[order[k]], (long long) b.id};
    }

    struct NearBody {
      NearPoint p;
      NearTag t;
    };

    /// The pair of bi and bj lower ID first: r and sh the nearest-image separation of the start
    /// points x_lo - x_hi and its image shift.  Returns whether bj has the lower ID.
    __device__ inline bool near_separation(const NearBody &bi, const NearBody &bj, const Grid &g,
                                           double *r, double *sh)
    {
      const bool swap = bj.t.id < bi.t.id;
      // Lower ID first, picked per component: a pointer or reference chosen between two local
      // objects would put both in local memory.
      double xl[3], xh[3];
      for (int d = 0; d < 3; ++d) {
        xl[d] = swap ? bj.p.x[d] : bi.p.x[d];
        xh[d] = swap ? bi.p.x[d] : bj.p.x[d];
      }
      nearest_image_separation(xl, xh, g.prd, g.periodic, r, sh);
      return swap;
    }

    // Calls visit(m, j, bi, bj, ilo, ihi, r, sh) for the bodies j = order[m] of the cells around c, the cell
    // of body i = order[k] (each cell once), with bi, bj their NearBody, ilo, ihi the pair
    // ordered lower ID first, and r, sh the nearest-image separation of the start points
    // x_ilo - x_ihi and its image shift.  HALF false: every body j != i of the 27 cells.
    // HALF true: the later bodies of c and those of the 13 cells at positive offsets (dz > 0,
    // or dz = 0 and dy > 0, or dz = dy = 0 and dx > 0); over all k every pair of neighbouring
    // cells is then visited once (a periodic length holds at least three cells), so every pair
    // once.
    // (first, stride): the bodies of each cell visited are first, first + stride, ... of it
    // (a warp's lanes share them with (lane, 32); one thread takes all with (0, 1)).
    template <bool HALF, class Visit>
    __device__ void for_each_near(const NearPoint *pts, const NearTag *tags, int k, int c,
                                  const Grid &g, const int *order, const int *cstart,
                                  const int *cend, Visit &&visit, int first = 0, int stride = 1)
    {
      const int ci[3] = {c % g.n[0], (c / g.n[0]) % g.n[1], c / (g.n[0] * g.n[1])};
      const int i = order[k];
      const NearBody bi{pts[k], tags[k]};
      for (int dz = HALF ? 0 : -1; dz <= 1; ++dz) {
        int cz = ci[2] + dz;
        if (g.periodic[2])
          cz = (cz + g.n[2]) % g.n[2];
        else if (cz < 0 || cz >= g.n[2])
          continue;
        for (int dy = (HALF && dz == 0) ? 0 : -1; dy <= 1; ++dy) {
          int cy = ci[1] + dy;
          if (g.periodic[1])
            cy = (cy + g.n[1]) % g.n[1];
          else if (cy < 0 || cy >= g.n[1])
            continue;
          for (int dx = (HALF && dz == 0 && dy == 0) ? 0 : -1; dx <= 1; ++dx) {
            int cx = ci[0] + dx;
            if (g.periodic[0])
              cx = (cx + g.n[0]) % g.n[0];
            else if (cx < 0 || cx >= g.n[0])
              continue;
            const int cc = (cz * g.n[1] + cy) * g.n[0] + cx;
            const bool own = dz == 0 && dy == 0 && dx == 0;
            for (int m = ((HALF && own) ? k + 1 : cstart[cc]) + first; m < cend[cc]; m += stride) {
              if (!HALF && m == k) continue;
              const int j = order[m];
              const NearBody bj{pts[m], tags[m]};
              double r[3], sh[3];
              const bool swap = near_separation(bi, bj, g, r, sh);
              visit(m, j, bi, bj, swap ? j : i, swap ? i : j, r, sh);
            }
          }
        }
      }
    }


    // Launch: one thread per sorted position k (n), body i = order[k], on the grid s->grid.
    // Tests the pairs of for_each_near<true>() as the host search does: lower ID first, nearest
    // image of the start points, |r| <= (r_lo + r_hi) + (bound_lo + bound_hi).  count[k] = its
    // pairs (and count[n] = 0, for the scan of n + 1), the first `keep` of them in stash;
    // s->pair_overlap where a pair is closer than (1 - tol) contact.  Reads about 14 x (cell
    // occupancy) x 48 bytes per thread, a cell's bodies side by side.
    __global__ void pair_count_kernel(const NearPoint *__restrict__ pts,
                                      const NearTag *__restrict__ tags, int n,
                                      const int *__restrict__ key, const int *__restrict__ order,
                                      const int *__restrict__ cstart, const int *__restrict__ cend,
                                      int *count, int *stash, int keep, double tol, Scalars *s)
    {
      const int k = blockIdx.x * blockDim.x + threadIdx.x;
      if (k >= n) return;
      const Grid g = s->grid;
      if (k == 0) count[n] = 0;
      int found = 0, overlap = 0;
      for_each_near<true>(pts, tags, k, key[k], g, order, cstart, cend,
                          [&](int m, int, const NearBody &bi, const NearBody &bj, int, int,
                              const double *r, const double *) {
                            // (sums in either order: the same bits)
                            const double range =
                                (bi.p.radius + bj.p.radius) + (bi.t.bound + bj.t.bound);
                            const double d2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
                            if (d2 > range * range) return;
                            const double lim = (bi.p.radius + bj.p.radius) * (1.0 - tol);
                            if (d2 < lim * lim) overlap = 1;
                            if (found < keep) stash[(size_t) found * n + k] = m;
                            ++found;
                          });
      count[k] = found;
      if (overlap) s->pair_overlap = 1;
    }

    // Launch: one thread per sorted position k (n), after pair_count_kernel and the scan of its
    // counts into offset.  Body k's pairs go to edges[offset[k] ...], in visiting order (the
    // stash's, or for_each_near<true>() again where it found more than `keep`), those below
    // `room` only; s->candidates = offset[n] (all of them), s->nedges = min(offset[n], room)
    // (those written).  Each pair's separation is near_separation()'s, as in the count pass.
    __global__ void pair_fill_kernel(const NearPoint *__restrict__ pts,
                                     const NearTag *__restrict__ tags, int n,
                                     const int *__restrict__ key, const int *__restrict__ order,
                                     const int *__restrict__ cstart, const int *__restrict__ cend,
                                     const int *__restrict__ stash, int keep,
                                     const int *__restrict__ offset, Edge *edges, int room,
                                     Scalars *s)
    {
      const int k = blockIdx.x * blockDim.x + threadIdx.x;
      if (k >= n) return;
      const Grid g = s->grid;
      if (k == 0) {
        const int all = offset[n];
        s->candidates = all;
        s->nedges = min(all, room);
      }
      const int first = offset[k], found = offset[k + 1] - first;
      auto put = [&](int f, int ilo, int ihi, const double *sh) {
        if (first + f >= room) return;
        Edge e;
        e.i = ilo;
        e.j = ihi;
        for (int d = 0; d < 3; ++d) e.shift[d] = sh[d];
        edges[first + f] = e;
      };
      if (found <= keep) {
        const int i = order[k];
        const NearBody bi{pts[k], tags[k]};
        for (int f = 0; f < found && first + f < room; ++f) {
          const int m = stash[(size_t) f * n + k];
          const int j = order[m];
          const NearBody bj{pts[m], tags[m]};
          double r[3], sh[3];
          const bool swap = near_separation(bi, bj, g, r, sh);
          put(f, swap ? j : i, swap ? i : j, sh);
        }
        return;
      }
      int f = 0;
      for_each_near<true>(pts, tags, k, key[k], g, order, cstart, cend,
                          [&](int, int, const NearBody &bi, const NearBody &bj, int ilo, int ihi,
                              const double *r, const double *sh) {
                            const double range =
                                (bi.p.radius + bj.p.radius) + (bi.t.bound + bj.t.bound);
                            const double d2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
                            if (d2 > range * range) return;
                            put(f++, ilo, ihi, sh);
                          });
    }

    /* The kernels over the candidate edges take their number from the device (*nedges,
       Scalars::nedges): they may be launched before the host has read it, with at least as
       many threads (the room for edges). */

    // Launch: one thread per edge (*nedges).  deg[b] (zeroed, n + 1 entries) += the edges of b.
    __global__ void degree_kernel(const Edge *__restrict__ edges, const int *nedges, int *deg)
    {
      const int q = blockIdx.x * blockDim.x + threadIdx.x;
      if (q >= *nedges) return;
      atomicAdd(&deg[edges[q].i], 1);
      atomicAdd(&deg[edges[q].j], 1);
    }

    // Launch: one thread per edge (*nedges).  Edge q into the adjacency of both its bodies;
    // fill starts as a copy of adj_start (the order within a body's list is that of the
    // atomics).
    __global__ void adjacency_kernel(const Edge *__restrict__ edges, const int *nedges, int *fill,
                                     int *adj)
    {
      const int q = blockIdx.x * blockDim.x + threadIdx.x;
      if (q >= *nedges) return;
      adj[atomicAdd(&fill[edges[q].i], 1)] = q;
      adj[atomicAdd(&fill[edges[q].j], 1)] = q;
    }

    // Launch: blocks of TILE threads, one thread per body.  The window [t0, t0 + delta): start
    // point w0, excursion reset, bound max(kf |v|, floor) delta (window_driver.cpp's
    // arithmetic), with floor = floor_fraction x the fastest speed (sqrt of *vmax2, the scan's
    // bits), or floor_fraction itself where vmax2 is null.  (Reading only x, v and tref of each
    // body straight from `bodies` instead of the tile was measured 2.3x slower: scattered.)
    __global__ void __launch_bounds__(TILE)
        window_start_kernel(Body *bodies, int n, double t0, double delta, double kf,
                            double floor_fraction, const unsigned long long *vmax2, double *wbound)
    {
      __shared__ Body tile[TILE];
      load_tile(bodies, n, tile);
      const int b = blockIdx.x * TILE + threadIdx.x;
      if (b >= n) return;
      const double floor_speed =
          vmax2 ? floor_fraction * sqrt(__longlong_as_double((long long) *vmax2)) : floor_fraction;
      const Body &bd = tile[threadIdx.x];
      double w0[3];
      drift_position(bd, t0, w0);
      for (int d = 0; d < 3; ++d) bodies[b].w0[d] = w0[d];
      bodies[b].wexc2 = 0.0;
      const double speed = sqrt(Contact::dot3(bd.v, bd.v));
      wbound[b] = fmax(kf * speed, floor_speed) * delta;
    }

    __device__ double window_gap(const double *wa, const double *wb, const double *shift, double s)
    {
      double r[3];
      for (int d = 0; d < 3; ++d) r[d] = wa[d] - wb[d] - shift[d];
      return sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]) - s;
    }

    // Launch: one thread per candidate edge (*nedges).  joined[q]: the pair's gap at the window
    // start is within the two bodies' window bounds.
    __global__ void join_kernel(const Body *__restrict__ bodies, const Edge *__restrict__ edges,
                                const int *nedges, const double *__restrict__ wbound,
                                unsigned char *joined)
    {
      const int q = blockIdx.x * blockDim.x + threadIdx.x;
      if (q >= *nedges) return;
      const Edge &e = edges[q];
      const Body &bi = bodies[e.i], &bj = bodies[e.j];
      const double s2 = bi.radius + bj.radius;
      joined[q] = window_gap(bi.w0, bj.w0, e.shift, s2) <= wbound[e.i] + wbound[e.j] + MARGIN * s2;
    }

    // Union-find over the bodies.  parent[x] <= x always (a root is linked under a smaller
    // one), so every root is its component's smallest index.  Finds halve paths with plain
    // stores of ancestors: racing threads only ever shorten paths.
    __device__ int uf_find(int *parent, int x)
    {
      volatile int *par = parent;
      int cur = par[x];
      if (cur != x) {
        int next, prev = x;
        while (cur > (next = par[cur])) {
          par[prev] = next;
          prev = cur;
          cur = next;
        }
      }
      return cur;
    }

    // Launch: one thread per body (n >= 1).  Every body its own root; fill[b] (members_kernel's
    // counts), s->largest and s->ngroups zeroed.
    __global__ void uf_init_kernel(int *parent, int *size, int *fill, int n, Scalars *s)
    {
      const int b = blockIdx.x * blockDim.x + threadIdx.x;
      if (b >= n) return;
      parent[b] = b;
      size[b] = 0;
      fill[b] = 0;
      if (b == 0) {
        s->largest = 0;
        s->ngroups = 0;
      }
    }

    // Launch: one thread per candidate edge (*nedges); joins the ends of the joined ones.
    __global__ void uf_unite_kernel(const Edge *__restrict__ edges, const int *nedges,
                                    const unsigned char *__restrict__ joined, int *parent)
    {
      const int q = blockIdx.x * blockDim.x + threadIdx.x;
      if (q >= *nedges || !joined[q]) return;
      int a = uf_find(parent, edges[q].i), b = uf_find(parent, edges[q].j);
      while (a != b) {
        if (a > b) {
          const int t = a;
          a = b;
          b = t;
        }
        // Link root b under a; if b stopped being a root meanwhile, go on from its parent.
        const int old = atomicCAS(&parent[b], b, a);
        if (old == b) break;
        b = uf_find(parent, old);
        a = uf_find(parent, a);
      }
    }

    // Launch: one thread per body, after every union, whole warps (blocks of a multiple of 32
    // threads).  root[b] = b's root, size[root] += 1 for each body: one atomic per warp and
    // root (the lanes of a warp with the same root counted together: a window with one
    // component of most bodies would put every thread's atomic on one address, measured at
    // 0.73 ms for 1e6 bodies on an H200).  The roots go to their own array: a find's path
    // halving in one thread may store a nearer ancestor over what another thread just wrote
    // into parent[].
    __global__ void uf_roots_kernel(int *parent, int *root, int *size, int n)
    {
      const int b = blockIdx.x * blockDim.x + threadIdx.x;
      const bool live = b < n;
      const int lane = threadIdx.x & 31;
      const int r = live ? uf_find(parent, b) : -1 - lane;    // lanes past n: no group
      if (live) root[b] = r;
      const unsigned same = __match_any_sync(WarpLoop::FULL, r);
      if (live && lane == __ffs(same) - 1) atomicAdd(&size[r], __popc(same));
    }

    /// Sums of (is a root, group size at the root) pairs: the groups' numbers and offsets.
    struct Int2Add {
      __device__ int2 operator()(const int2 &a, const int2 &b) const
      {
        return make_int2(a.x + b.x, a.y + b.y);
      }
    };

    // Launch: one thread per body (n >= 1), after uf_init_kernel, blocks of BLOCK threads.
    // Roots: the largest group and the number of groups into s (reduced over the block first:
    // one atomic each per block, as one per warp on two addresses took 50 us at n = 1e6);
    // rk[b] = (1, the group's size) at a root, else (0, 0), for the numbering scan, and
    // rk[n] = (0, 0) (the scan takes n + 1).
    __global__ void __launch_bounds__(BLOCK)
        roots_kernel(const int *__restrict__ root, const int *__restrict__ size, int n, int2 *rk,
                     Scalars *s)
    {
      __shared__ int wmost[BLOCK / 32], wcount[BLOCK / 32];
      const int b = blockIdx.x * blockDim.x + threadIdx.x;
      const bool live = b < n;
      if (b == 0) rk[n] = make_int2(0, 0);
      const bool is = live && root[b] == b;
      const int sz = is ? size[b] : 0;
      if (live) rk[b] = is ? make_int2(1, sz) : make_int2(0, 0);
      const int warp = threadIdx.x >> 5, lane = threadIdx.x & 31;
      const int most = __reduce_max_sync(WarpLoop::FULL, sz);
      const int count = __reduce_add_sync(WarpLoop::FULL, is ? 1 : 0);
      if (lane == 0) {
        wmost[warp] = most;
        wcount[warp] = count;
      }
      __syncthreads();
      if (warp == 0) {
        const int nw = blockDim.x >> 5;
        const int m = __reduce_max_sync(WarpLoop::FULL, lane < nw ? wmost[lane] : 0);
        const int c = __reduce_add_sync(WarpLoop::FULL, lane < nw ? wcount[lane] : 0);
        if (lane == 0 && c > 0) {
          atomicMax(&s->largest, m);
          atomicAdd(&s->ngroups, c);
        }
      }
    }

    // Launch: one thread per body (n >= 1).  Group g (numbered in root order: gk[b].x, the
    // exclusive scan of roots_kernel's root flags) starts at gk[root].y (the exclusive scan of
    // its sizes); members placed by atomics on fill (zeroed by uf_init_kernel).
    // s->next_group zeroed for resolve_kernel.
    __global__ void members_kernel(const int *__restrict__ root, const int2 *__restrict__ gk, int n,
                                   int ngroups, int *gstart, int *fill, int *gmembers, Scalars *s)
    {
      const int b = blockIdx.x * blockDim.x + threadIdx.x;
      if (b >= n) return;
      if (b == 0) s->next_group = 0;
      const int r = root[b];
      if (r == b) gstart[gk[b].x] = gk[b].y;
      if (b == 0) gstart[ngroups] = n;
      gmembers[gk[r].y + atomicAdd(&fill[r], 1)] = b;
    }

    /// A group's tally as the window's sums take it.
    __device__ WinSum win_sum(const Tally &t)
    {
      WinSum w;
      w.pair = t.pair;
      w.wall = t.wall;
      w.rest = t.rest;
      w.events = t.events;
      w.groups = t.events > 0 ? 1 : 0;
      w.ke_lost = t.ke_lost;
      for (int k = 0; k < 6; ++k) w.virial[k] = t.virial[k];
      w.capped = t.capped;
      return w;
    }

    /// Groups of more than `small` bodies (cub::DevicePartition puts them first).
    struct IsLarge {
      const int *gstart;
      int small;
      __device__ bool operator()(int g) const { return gstart[g + 1] - gstart[g] > small; }
    };

    // Launch: one thread per candidate edge (ne; s->nedges of them are the step's).  The pair
    // event time of every edge of the window (joined) in a group of more than `small` bodies
    // (root's size), into et[q], for first_bests_kernel and resolve_kernel: each edge's once.
    __global__ void edge_times_kernel(GroupGraph graph, const int *__restrict__ root,
                                      const int *__restrict__ size, const Scalars *s, int small,
                                      const __grid_constant__ Params p, double *et)
    {
      const int q = blockIdx.x * blockDim.x + threadIdx.x;
      if (q >= s->nedges || (graph.joined && !graph.joined[q])) return;
      const Edge &e = graph.edges[q];
      if (size[root[e.i]] <= small) return;
      et[q] = pair_event_time(graph.bodies[e.i], graph.bodies[e.j], e, p.dt);
    }

    // Launch: one thread per body (n), after edge_times_kernel where et is given.  The first
    // best event of every body in a group of more than `small` bodies (root[b]'s size), for
    // resolve_kernel: all at once, rather than a group's in turn by its warp's lanes.
    __global__ void first_bests_kernel(GroupGraph graph, const int *__restrict__ root,
                                       const int *__restrict__ size, int n, int small,
                                       const __grid_constant__ Params p, const double *et)
    {
      const int b = blockIdx.x * blockDim.x + threadIdx.x;
      if (b >= n || size[root[b]] <= small) return;
      graph.best[b] = et ? cached_best_event(graph, p, et, b) : group_best_event(graph, p, b);
    }

    // Launch: whole warps, any number, after first_bests_kernel (et: edge_times_kernel's times,
    // kept current by the warps).  Each warp takes the next of the s->nmulti groups of
    // two or more bodies (order[0 .. nmulti), taken through s->next_group, zeroed by
    // members_kernel) until none
    // is left: its events before t_end, at most budget (group_loop_warp.cuh), and its tally
    // (summed in event order from zero) into sums[k] for order[k].
    __global__ void resolve_kernel(GroupGraph graph, const int *__restrict__ gstart,
                                   const int *__restrict__ gmembers, const int *__restrict__ order,
                                   double t_end, const __grid_constant__ Params p, long budget,
                                   Scalars *s, WinSum *sums, double *et)
    {
      const int lane = threadIdx.x & 31;
      const int nmulti = s->nmulti;
      while (true) {
        int k = 0;
        if (lane == 0) k = atomicAdd(&s->next_group, 1);
        k = __shfl_sync(WarpLoop::FULL, k, 0);
        if (k >= nmulti) return;    // whole warps leave together
        const int g = order[k];
        const int lo = gstart[g], hi = gstart[g + 1];
        Tally t;
        resolve_group_warp(graph, p, gmembers + lo, hi - lo, t_end, budget, t, true, et);
        if (lane == 0) sums[k] = win_sum(t);
      }
    }

    // Launch: one thread per entry k of order[s->nmulti .. ngroups) (grid-stride): the groups
    // of one body, each resolved by one thread (collision_group_loop.h: a wall's events
    // only), the tally into sums[k].
    __global__ void resolve_single_kernel(GroupGraph graph, const int *__restrict__ gstart,
                                          const int *__restrict__ gmembers,
                                          const int *__restrict__ order, int ngroups, double t_end,
                                          const __grid_constant__ Params p, long budget,
                                          const Scalars *s, WinSum *sums)
    {
      const int stride = gridDim.x * blockDim.x;
      for (int k = s->nmulti + blockIdx.x * blockDim.x + threadIdx.x; k < ngroups; k += stride) {
        const int g = order[k];
        Tally t;
        resolve_group_exact(graph, p, gmembers + gstart[g], gstart[g + 1] - gstart[g], t_end,
                            budget, t);
        sums[k] = win_sum(t);
      }
    }

    /// The excursion of bd (a tile's copy of bodies[b]) noted at time t, and what it changed
    /// written back to bodies[b].
    __device__ __forceinline__ void excursion_at(Body &bd, double t, Body *bodies, int b)
    {
      const double exc2 = bd.exc2, wexc2 = bd.wexc2;
      double x[3];
      drift_position(bd, t, x);
      note_excursion(bd, x);
      if (bd.exc2 != exc2) bodies[b].exc2 = bd.exc2;
      if (bd.wexc2 != wexc2) bodies[b].wexc2 = bd.wexc2;
    }

    // Launch: one thread per body (n >= 1).  Excursion from the window start point at t1;
    // s->missed zeroed for missed_kernel.
    __global__ void __launch_bounds__(TILE)
        excursion_kernel(Body *bodies, int n, double t1, double *lexc, Scalars *s)
    {
      __shared__ Body tile[TILE];
      load_tile(bodies, n, tile);
      const int b = blockIdx.x * TILE + threadIdx.x;
      if (b >= n) return;
      if (b == 0) s->missed = 0;
      Body &bd = tile[threadIdx.x];
      excursion_at(bd, t1, bodies, b);
      lexc[b] = sqrt(bd.wexc2);
    }

    // Launch: one thread per candidate edge (s->nedges).  A pair not joined that could have
    // touched (a body beyond its window bound, the two moved at least the gap together) is
    // joined; s->missed counts them.
    __global__ void missed_kernel(const Body *__restrict__ bodies, const Edge *__restrict__ edges,
                                  const double *__restrict__ wbound,
                                  const double *__restrict__ lexc, unsigned char *joined,
                                  Scalars *s)
    {
      const int q = blockIdx.x * blockDim.x + threadIdx.x;
      if (q >= s->nedges || joined[q]) return;
      const Edge &e = edges[q];
      if (!(lexc[e.i] > wbound[e.i]) && !(lexc[e.j] > wbound[e.j])) return;
      const Body &bi = bodies[e.i], &bj = bodies[e.j];
      const double s2 = bi.radius + bj.radius;
      if (lexc[e.i] + lexc[e.j] + MARGIN * s2 < window_gap(bi.w0, bj.w0, e.shift, s2)) return;
      joined[q] = 1;
      atomicAdd(&s->missed, 1);
    }

    /// Largest excursion and bodies beyond their bound, by blocks.
    struct ExcursionSum {
      double most;
      int beyond;
      double v2;    // largest squared speed at the step end
    };
    struct ExcursionOp {
      __device__ ExcursionSum operator()(const ExcursionSum &a, const ExcursionSum &b) const
      {
        return ExcursionSum{fmax(a.most, b.most), a.beyond + b.beyond, fmax(a.v2, b.v2)};
      }
    };

    // Launch: blocks of TILE threads, one thread per body.  The end of the step: excursion
    // noted at dt (as end_of_step() does) and kept in exc[b]; s->end (zeroed): excursion counts
    // bodies beyond their step bound, maxexc the largest excursion, vend2 the largest squared
    // speed (the host's apply_results() formula; one atomic per block each).
    __global__ void __launch_bounds__(TILE)
        end_kernel(Body *bodies, int n, double dt, const double *__restrict__ bound, double *exc,
                   Scalars *s)
    {
      using Reduce = cub::BlockReduce<ExcursionSum, TILE>;
      __shared__ typename Reduce::TempStorage scratch;
      __shared__ Body tile[TILE];
      load_tile(bodies, n, tile);
      const int b = blockIdx.x * TILE + threadIdx.x;
      ExcursionSum mine{0.0, 0, 0.0};
      if (b < n) {
        Body &bd = tile[threadIdx.x];
        excursion_at(bd, dt, bodies, b);
        const double e = sqrt(bd.exc2);
        exc[b] = e;
        const double *v = bd.v;
        mine = ExcursionSum{e, e > bound[b] ? 1 : 0, v[0] * v[0] + v[1] * v[1] + v[2] * v[2]};
      }
      mine = Reduce(scratch).Reduce(mine, ExcursionOp());
      if (threadIdx.x != 0) return;
      atomic_max_bits(&s->end.maxexc, mine.most);
      atomic_max_bits(&s->end.vend2, mine.v2);
      if (mine.beyond) atomicAdd(&s->end.excursion, mine.beyond);
    }

    // Launch: one thread per sorted position k (n), body i = order[k], whole warps (blocks of
    // a multiple of 32 threads).  The step's check (the host's FixHardSphere::step_exact()):
    // for a body beyond its step bound, a pair with a neighbour that was not a candidate could
    // have touched if the two moved at least its gap together; s->end.missed_step is set for
    // such a pair, or where the body's partners could lie beyond the cells around it (exc_i +
    // maxexc + 2 rmax not below the narrowest cell).  Few bodies are beyond their bounds:
    // each one's neighbours are shared by the lanes of its warp.
    __global__ void step_check_kernel(const NearPoint *__restrict__ pts,
                                      const NearTag *__restrict__ tags,
                                      const double *__restrict__ bound,
                                      const double *__restrict__ exc, int n, Grid g,
                                      const int *__restrict__ key, const int *__restrict__ order,
                                      const int *__restrict__ cstart, const int *__restrict__ cend,
                                      double maxexc, double rmax, double tol, Scalars *s)
    {
      const int k = blockIdx.x * blockDim.x + threadIdx.x;
      const int lane = threadIdx.x & 31;
      bool beyond = false;
      if (k < n) {
        const int i = order[k];
        beyond = exc[i] > bound[i];
      }
      unsigned todo = __ballot_sync(WarpLoop::FULL, beyond);
      const double wmin = fmin(g.width[0], fmin(g.width[1], g.width[2]));
      while (todo) {
        const int kb = k - lane + __ffs(todo) - 1;    // that lane's sorted position
        todo &= todo - 1;
        const int i = order[kb];
        if (!(exc[i] + maxexc + 2.0 * rmax < wmin)) {
          if (lane == 0) s->end.missed_step = 1;
          continue;
        }
        for_each_near<false>(
            pts, tags, kb, key[kb], g, order, cstart, cend,
            [&](int, int j, const NearBody &bi, const NearBody &bj, int, int, const double *r,
                const double *) {
              const double dist = sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
              const double contact = bi.p.radius + bj.p.radius;
              if (dist <= contact + (bi.t.bound + bj.t.bound)) return;    // a candidate
              if (dist - contact > exc[i] + exc[j] + tol * contact) return;
              s->end.missed_step = 1;
            },
            lane, 32);
      }
    }

    // Launch: one thread per body.  The bodies that had events, with their indices, into
    // out[slot[b]] and index[slot[b]] (slots from number_changed(): in body order).
    __global__ void compact_kernel(const Body *__restrict__ bodies, int n,
                                   const int *__restrict__ slot, Body *out, int *index)
    {
      const int b = blockIdx.x * blockDim.x + threadIdx.x;
      if (b >= n || bodies[b].nevents == 0) return;
      out[slot[b]] = bodies[b];
      index[slot[b]] = b;
    }

    // Launch: blocks of BUILD_BLOCK threads, one per atom.  Body i from the caller's arrays
    // (start_body(), as the host's FixHardSphere::gather_bodies() builds it) and its step bound
    // (drift_bound(), as FixHardSphere::step_bound(), with boost[i] the bound raised by a failed
    // check).  omega (rough spheres; else null): the angular velocities, 3 per atom.
    constexpr int BUILD_BLOCK = 128;    // build_kernel's blocks: a tile of Bodies in shared memory
    static_assert(sizeof(Body) % sizeof(unsigned long long) == 0, "Bodies copied as 8-byte words");
    template <class Id>
    __global__ void __launch_bounds__(BUILD_BLOCK)
        build_kernel(const double *__restrict__ x, const double *__restrict__ v,
                     const double *__restrict__ f, const double *__restrict__ radius,
                     const double *__restrict__ rmass, const double *__restrict__ tlast,
                     const int *__restrict__ type, const Id *__restrict__ id,
                     const double *__restrict__ omega, const double *__restrict__ boost, int n,
                     double dt, double ftm2v,
                     double floor_bound, const unsigned long long *__restrict__ budget,
                     double reach, Body *bodies, double *bound)
    {
      const int i = blockIdx.x * BUILD_BLOCK + threadIdx.x;
      // A negative floor: half the least displacement of the step budget (the host's formula).
      if (floor_bound < 0.0)
        floor_bound = 0.5 * step_least(__longlong_as_double((long long) budget[0]),
                                       __longlong_as_double((long long) budget[1]), dt);
      // Each thread's Body goes to a tile, and the block's tile to `bodies` word by word:
      // adjacent threads write adjacent words (a Body per thread would be 26 scattered stores).
      __shared__ Body tile[BUILD_BLOCK];
      if (i < n) {
        tile[threadIdx.x] = start_body(x + 3 * i, v + 3 * i, f + 3 * i, radius[i], rmass[i],
                                       tlast[i], (long) id[i], type[i], i, dt, ftm2v);
        if (omega)    // rough spheres (the host's gather_bodies() does the same)
          for (int d = 0; d < 3; ++d) tile[threadIdx.x].omega[d] = omega[3 * i + d];
        bound[i] = drift_bound(v + 3 * i, dt, floor_bound, boost[i], reach);
      }
      __syncthreads();
      constexpr int WORDS = sizeof(Body) / sizeof(unsigned long long);
      const int first = blockIdx.x * BUILD_BLOCK;
      const int words = min(BUILD_BLOCK, n - first) * WORDS;
      const unsigned long long *src = reinterpret_cast<const unsigned long long *>(tile);
      unsigned long long *dst = reinterpret_cast<unsigned long long *>(bodies + first);
      for (int w = threadIdx.x; w < words; w += BUILD_BLOCK) dst[w] = src[w];
    }

    // Launch: one thread per body.  After a step whose check failed: every body that moved
    // further than its step bound gets the bound raised to twice its excursion (the host's
    // FixHardSphere::step_exact() raises those of the pairs it finds; this is a superset).
    __global__ void raise_kernel(const double *__restrict__ exc, const double *__restrict__ bound,
                                 int n, double *boost)
    {
      const int b = blockIdx.x * blockDim.x + threadIdx.x;
      if (b >= n || !(exc[b] > bound[b])) return;
      boost[b] = fmax(boost[b], 2.0 * exc[b]);
    }

    // Launch: blocks of BLOCK threads, one thread per atom (n).  The step budget's maxima over
    // the atoms (FixHardSphere::step_budget's loop, the same core functions): |v|^2,
    // |f| ftm2v / m and the radius, as bits into out[0 .. 2] (zeroed; one atomic per block and
    // value).  Reads 64 bytes per atom.
    __global__ void budget_kernel(const double *__restrict__ v, const double *__restrict__ f,
                                  const double *__restrict__ rmass,
                                  const double *__restrict__ radius, int n, double ftm2v,
                                  unsigned long long *out)
    {
      using Reduce = cub::BlockReduce<Max3, BLOCK>;
      __shared__ typename Reduce::TempStorage scratch;
      const int i = blockIdx.x * blockDim.x + threadIdx.x;
      Max3 m{{0.0, 0.0, 0.0}};
      if (i < n)
        m = Max3{{speed2(v + 3 * i), accel_magnitude(f + 3 * i, ftm2v, rmass[i]), radius[i]}};
      m = Reduce(scratch).Reduce(m, Max3Op());
      if (threadIdx.x != 0) return;
      for (int k = 0; k < 3; ++k) atomic_max_bits(&out[k], m.v[k]);
    }

    // The gathered step's atoms found by ID (ResidentAtoms::reordered): after LAMMPS moved
    // atoms between ranks and in their arrays, the ranks send their atoms' IDs in the new
    // order, and each atom's kept end state of the step before is found by its ID.

    // Launch: blocks of BLOCK threads, one thread per atom (n).  The largest of the n IDs into
    // *most (zeroed), one atomic per block.  Reads id_bytes per atom.
    template <class IdT>
    __global__ void id_max_kernel(const IdT *__restrict__ id, int n, unsigned long long *most)
    {
      __shared__ unsigned long long m;
      if (threadIdx.x == 0) m = 0;
      __syncthreads();
      const int i = blockIdx.x * blockDim.x + threadIdx.x;
      if (i < n && id[i] > 0) atomicMax(&m, (unsigned long long) id[i]);
      __syncthreads();
      if (threadIdx.x == 0 && m) atomicMax(most, m);
    }

    // Launch: one thread per atom (n).  slot[id] = the atom's index, for IDs 1 .. the largest.
    // Writes 4 bytes per atom, reads id_bytes.
    template <class IdT>
    __global__ void id_slot_kernel(const IdT *__restrict__ id, int n, int *__restrict__ slot)
    {
      const int i = blockIdx.x * blockDim.x + threadIdx.x;
      if (i < n && id[i] > 0) slot[id[i]] = i;
    }

    // Launch: one thread per atom (n) of the new order.  Atom j with ID nid[j] takes the kept
    // state of the old atom s = slot[nid[j]] (x, v: 3 doubles; tlast, radius, mass; type) into
    // the scratch arrays; where no old atom has that ID (checked against oid: the slots are
    // not cleared between steps), *missing counts it.  Reads and writes 76 bytes per atom.
    template <class IdT>
    __global__ void reorder_kernel(const IdT *__restrict__ nid, const IdT *__restrict__ oid,
                                   const int *__restrict__ slot, long long most, int n,
                                   const double *__restrict__ x, const double *__restrict__ v,
                                   const double *__restrict__ tl, const double *__restrict__ rad,
                                   const double *__restrict__ mass, const int *__restrict__ type,
                                   double *__restrict__ x2, double *__restrict__ v2,
                                   double *__restrict__ tl2, double *__restrict__ rad2,
                                   double *__restrict__ mass2, int *__restrict__ type2,
                                   unsigned long long *missing)
    {
      const int j = blockIdx.x * blockDim.x + threadIdx.x;
      if (j >= n) return;
      const IdT id = nid[j];
      const int s = (id > 0 && (long long) id <= most) ? slot[id] : -1;
      if (s < 0 || s >= n || oid[s] != id) {
        atomicAdd(missing, 1ULL);
        return;
      }
      for (int d = 0; d < 3; ++d) {
        x2[3 * j + d] = x[3 * s + d];
        v2[3 * j + d] = v[3 * s + d];
      }
      tl2[j] = tl[s];
      rad2[j] = rad[s];
      mass2[j] = mass[s];
      type2[j] = type[s];
    }

    // Launch: one thread per body (n).  Every atom's time of last collision, relative to the
    // step end (the host's shift: max(t - dt, never)), into the device copy of the caller's.
    __global__ void tlast_end_kernel(const Body *__restrict__ bodies, int n, double dt,
                                     double never, double *tlast)
    {
      const int b = blockIdx.x * blockDim.x + threadIdx.x;
      if (b < n) tlast[bodies[b].owner] = fmax(bodies[b].tlast - dt, never);
    }

    /// What goes back to the caller for an atom that had events (56 bytes; rough spheres'
    /// angular velocities go in an array of their own, 3 per result).
    using AtomResult = ResidentResult;

    // Launch: one thread per body (n >= 1).  flag[b] = 1 where body b had events, else 0, and
    // flag[n] = 0 (for the scan of n + 1).
    __global__ void changed_kernel(const Body *__restrict__ bodies, int n, int *flag)
    {
      const int b = blockIdx.x * blockDim.x + threadIdx.x;
      if (b == 0) flag[n] = 0;
      if (b < n) flag[b] = bodies[b].nevents > 0 ? 1 : 0;
    }

    // Launch: one thread per body.  The atoms that had events, in increasing body order (slot
    // = the exclusive sum of changed_kernel's flags): end-of-step position and velocity into
    // out[slot], and the angular velocity into spin[3 slot ...] (rough spheres; else null).
    __global__ void atom_results_kernel(const Body *__restrict__ bodies, int n, double dt,
                                        const int *__restrict__ slot, AtomResult *out, double *spin)
    {
      const int b = blockIdx.x * blockDim.x + threadIdx.x;
      if (b >= n || bodies[b].nevents == 0) return;
      AtomResult r;
      r.index = bodies[b].owner;
      drift_position(bodies[b], dt, r.x);
      for (int d = 0; d < 3; ++d) r.v[d] = bodies[b].v[d];
      out[slot[b]] = r;
      if (spin)
        for (int d = 0; d < 3; ++d) spin[3 * slot[b] + d] = bodies[b].omega[d];
    }

    // Launch: one thread per result (changed).  Result k into the device copies of the
    // caller's x and v, and its angular velocity spin[3 k ...] into omega (rough spheres; else
    // both null).
    __global__ void atom_write_kernel(const AtomResult *__restrict__ res,
                                      const double *__restrict__ spin, int changed, double *x,
                                      double *v, double *omega)
    {
      const int k = blockIdx.x * blockDim.x + threadIdx.x;
      if (k >= changed) return;
      const AtomResult &r = res[k];
      for (int d = 0; d < 3; ++d) {
        x[3 * r.index + d] = r.x[d];
        v[3 * r.index + d] = r.v[d];
      }
      if (omega)
        for (int d = 0; d < 3; ++d) omega[3 * r.index + d] = spin[3 * k + d];
    }

    // Launch: one thread per (result, one of its six numbers), 6 changed threads.  Result k's
    // x and v into the caller's arrays x and v, which lie in host memory mapped into the
    // device's address space: the writes cross the link, so the six threads of one result
    // write its two runs of 24 bytes side by side (48 bytes per result over the link).
    // Where kx and kv are given (the step keeps its copies of x and v, KeptMotion::keep), the
    // same numbers into those device arrays too.
    __global__ void atom_write_direct_kernel(const AtomResult *__restrict__ res, int changed,
                                             double *x, double *v, double *kx, double *kv)
    {
      const long t = (long) blockIdx.x * blockDim.x + threadIdx.x;
      if (t >= 6L * changed) return;
      const int k = (int) (t / 6), c = (int) (t % 6);
      const AtomResult &r = res[k];
      const double w = c < 3 ? r.x[c] : r.v[c - 3];
      const long at = 3 * (long) r.index + c % 3;
      if (c < 3) {
        x[at] = w;
        if (kx) kx[at] = w;
      } else {
        v[at] = w;
        if (kv) kv[at] = w;
      }
    }

    // Launch: blocks of BLOCK threads, one thread per atom (n).  The kept copies x, v of the
    // last step's end moved in place as LAMMPS moved the caller's since (move_between_steps(),
    // core/verlet_motion.h: a reneighboring's wrap, the integrator) with this step's f.  Reads
    // 80 and writes 48 bytes per atom; 15 flops and a division.
    __global__ void verlet_kernel(double *__restrict__ x, double *__restrict__ v,
                                  const double *__restrict__ f, const double *__restrict__ rmass,
                                  int n, StepMotion move, bool fused)
    {
      const int i = blockIdx.x * blockDim.x + threadIdx.x;
      if (i >= n) return;
      double xi[3], vi[3], fi[3];
      for (int d = 0; d < 3; ++d) {
        xi[d] = x[3 * i + d];
        vi[d] = v[3 * i + d];
        fi[d] = f[3 * i + d];
      }
      move_between_steps(xi, vi, fi, rmass[i], move, fused);
      for (int d = 0; d < 3; ++d) {
        x[3 * i + d] = xi[d];
        v[3 * i + d] = vi[d];
      }
    }

    // Launch: blocks of BLOCK threads, one thread per atom (n).  The check of the kept copies
    // kx, kv: moved both ways of rounding (plain, fused) and compared bit for bit with x, v as
    // copied up; miss[0 .. 3] (zeroed) count the atoms whose x (plain), v (plain), x (fused),
    // v (fused) differ, one atomic per warp and count.  Reads 128 bytes per atom.
    __global__ void verlet_check_kernel(const double *__restrict__ kx, const double *__restrict__ kv,
                                        const double *__restrict__ x, const double *__restrict__ v,
                                        const double *__restrict__ f,
                                        const double *__restrict__ rmass, int n,
                                        StepMotion move, unsigned long long *miss)
    {
      const int i = blockIdx.x * blockDim.x + threadIdx.x;
      bool bad[4] = {false, false, false, false};
      if (i < n)
        for (int way = 0; way < 2; ++way) {
          double xi[3], vi[3], fi[3];
          for (int d = 0; d < 3; ++d) {
            xi[d] = kx[3 * i + d];
            vi[d] = kv[3 * i + d];
            fi[d] = f[3 * i + d];
          }
          move_between_steps(xi, vi, fi, rmass[i], move, way == 1);
          for (int d = 0; d < 3; ++d) {
            bad[2 * way] |= __double_as_longlong(xi[d]) != __double_as_longlong(x[3 * i + d]);
            bad[2 * way + 1] |= __double_as_longlong(vi[d]) != __double_as_longlong(v[3 * i + d]);
          }
        }
      for (int k = 0; k < 4; ++k) {
        const unsigned votes = __ballot_sync(0xffffffffu, bad[k]);
        if ((threadIdx.x & 31) == 0 && votes) atomicAdd(&miss[k], (unsigned long long) __popc(votes));
      }
    }

  }    // namespace

}    // namespace Collide
}    // namespace HSGPU

#endif
