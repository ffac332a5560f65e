/* HARDSPHERE_GPU collision engine: the step driver, see window_driver.h. */
#include "window_driver.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

namespace HSGPU {
namespace Collide {

  namespace {

    /// Relative margin on contact distances for round-off in the join and check tests.
    constexpr double MARGIN = 1e-9;
    /// Shortest adaptive window, as a fraction of dt.
    constexpr double MIN_WINDOW = 1.0 / 64.0;
    /// Doubles per body in the boundary exchange (pack_body), and per partner (id, shift).
    constexpr int NBODY = 29;
    constexpr int NPARTNER = 4;

    /// Gap between two bodies' surfaces at the window start, from their window start points
    /// wa, wb (a has the lower ID; shift is the image shift of x_a - x_b).  Computed in this
    /// orientation on every rank, so all ranks agree on it to the bit.
    double window_gap(const double *wa, const double *wb, const double *shift, double s)
    {
      double r[3];
      for (int d = 0; d < 3; ++d) r[d] = wa[d] - wb[d] - shift[d];
      return std::sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]) - s;
    }

    void pack_body(const Body &b, double *o)
    {
      for (int d = 0; d < 3; ++d) {
        o[d] = b.x[d];
        o[3 + d] = b.v[d];
        o[6 + d] = b.a[d];
        o[9 + d] = b.X0[d];
        o[12 + d] = b.w0[d];
        o[15 + d] = b.rest[d];
      }
      o[18] = b.tref;
      o[19] = b.radius;
      o[20] = b.mass;
      o[21] = b.tlast;
      o[22] = b.exc2;
      o[23] = b.wexc2;
      o[24] = (double) b.id;
      o[25] = (double) b.last;
      o[26] = b.type;
      o[27] = b.nevents;
      o[28] = b.owner;
    }

    void unpack_body(const double *o, Body &b)
    {
      for (int d = 0; d < 3; ++d) {
        b.x[d] = o[d];
        b.v[d] = o[3 + d];
        b.a[d] = o[6 + d];
        b.X0[d] = o[9 + d];
        b.w0[d] = o[12 + d];
        b.rest[d] = (int) o[15 + d];
      }
      b.tref = o[18];
      b.radius = o[19];
      b.mass = o[20];
      b.tlast = o[21];
      b.exc2 = o[22];
      b.wexc2 = o[23];
      b.id = (long) o[24];
      b.last = (long) o[25];
      b.type = (int) o[26];
      b.nevents = (int) o[27];
      b.owner = (int) o[28];
    }

    /// Groups of the union-find forest over nodes [0, n) that contain no flagged root:
    /// counting sort of the nodes by representative.  Returns the largest group's size.
    long group_by_root(UnionFind &uf, int n, const std::vector<char> *excluded,
                       std::vector<int> &start, std::vector<int> &members, std::vector<int> &fill,
                       int &ngroups)
    {
      fill.assign(n, -1);    // root -> group
      ngroups = 0;
      for (int b = 0; b < n; ++b) {
        const int r = uf.find(b);
        if (excluded && (*excluded)[r]) continue;
        if (fill[r] < 0) fill[r] = ngroups++;
      }
      start.assign(ngroups + 1, 0);
      for (int b = 0; b < n; ++b) {
        const int r = uf.find(b);
        if (fill[r] >= 0) start[fill[r] + 1]++;
      }
      long largest = 0;
      for (int g = 0; g < ngroups; ++g) {
        largest = std::max(largest, (long) start[g + 1]);
        start[g + 1] += start[g];
      }
      members.resize(start[ngroups]);
      std::vector<int> pos(start.begin(), start.end() - 1);
      for (int b = 0; b < n; ++b) {
        const int r = uf.find(b);
        if (fill[r] >= 0) members[pos[fill[r]]++] = b;
      }
      return largest;
    }

  }    // namespace

  void WindowDriver::begin_step(int nbodies)
  {
    boost.assign(nbodies, 0.0);
    redos_this_step = 0;
  }

  /* The window [t0, t1): window start points, bounds, the window's edges and the local groups
     (gstart/gmembers; boundary groups are left out, their roots flagged in isb).  Returns the
     largest local group over all ranks. */
  long WindowDriver::window_edges(std::vector<Body> &bodies, const std::vector<Edge> &edges,
                                  const std::vector<ForeignEdge> &fedges,
                                  const std::vector<ForeignNode> &foreign, double t0, double t1,
                                  const WindowSettings &s, Exchange &ex)
  {
    const int nb = (int) bodies.size(), nf = (int) foreign.size();
    const bool join_all = redos_this_step >= s.max_redos;
    const double delta = t1 - t0;
    const double inf = std::numeric_limits<double>::infinity();
    bound.resize(nb);
    wstate.resize((size_t) 4 * nb);
    for (int b = 0; b < nb; ++b) {
      Body &bd = bodies[b];
      drift_position(bd, t0, bd.w0);
      bd.wexc2 = 0.0;
      const double speed = std::sqrt(Contact::dot3(bd.v, bd.v));
      bound[b] = join_all ? inf : std::max(s.bound_factor * speed * delta, boost[b]);
      for (int d = 0; d < 3; ++d) wstate[(size_t) 4 * b + d] = bd.w0[d];
      wstate[(size_t) 4 * b + 3] = bound[b];
    }
    if (ex.nranks() > 1) ex.to_foreign(wstate, 4, fstate);

    wedges.clear();
    ljoined.assign(edges.size(), 0);
    for (size_t q = 0; q < edges.size(); ++q) {
      const Edge &e = edges[q];
      const Body &bi = bodies[e.i], &bj = bodies[e.j];
      const double s2 = bi.radius + bj.radius;
      if (window_gap(bi.w0, bj.w0, e.shift, s2) <= bound[e.i] + bound[e.j] + MARGIN * s2) {
        wedges.push_back(e);
        ljoined[q] = 1;
      }
    }
    fwin.clear();
    fjoined.assign(fedges.size(), 0);
    for (size_t q = 0; q < fedges.size(); ++q) {
      const ForeignEdge &fe = fedges[q];
      const Body &b = bodies[fe.body];
      const double *fw = &fstate[(size_t) 4 * fe.node];
      const double s2 = b.radius + foreign[fe.node].radius;
      double gap;
      if (b.id < foreign[fe.node].id) {
        gap = window_gap(b.w0, fw, fe.shift, s2);
      } else {
        const double ns[3] = {-fe.shift[0], -fe.shift[1], -fe.shift[2]};
        gap = window_gap(fw, b.w0, ns, s2);
      }
      if (gap <= bound[fe.body] + fw[3] + MARGIN * s2) {
        fwin.push_back((int) q);
        fjoined[q] = 1;
      }
    }

    uf.reset(nb + nf);
    for (const Edge &e : wedges) uf.unite(e.i, e.j);
    for (int q : fwin) uf.unite(fedges[q].body, nb + fedges[q].node);
    isb.assign(nb + nf, 0);
    for (int k = 0; k < nf; ++k) isb[uf.find(nb + k)] = 1;
    int ngroups = 0;
    long largest = group_by_root(uf, nb, &isb, gstart, gmembers, fill, ngroups);
    nlocal_groups = ngroups;
    double l = (double) largest;
    ex.max(&l, 1);
    return (long) l;
  }

  void WindowDriver::resolve_boundary(std::vector<Body> &bodies,
                                      const std::vector<ForeignEdge> &fedges,
                                      const std::vector<ForeignNode> &foreign, const Params &p,
                                      double t1, CollisionBackend &backend, Exchange &ex,
                                      Tally &tb, long &largest, long &ngroups, long &nbound)
  {
    const int nb = (int) bodies.size();
    // Partners with a higher ID of each boundary body: window edges only.
    std::vector<int> pstart(nb + 1, 0);
    for (const Edge &e : wedges)
      if (isb[uf.find(e.i)]) pstart[e.i + 1]++;
    for (int q : fwin)
      if (foreign[fedges[q].node].id > bodies[fedges[q].body].id) pstart[fedges[q].body + 1]++;
    for (int b = 0; b < nb; ++b) pstart[b + 1] += pstart[b];
    std::vector<double> partners((size_t) NPARTNER * pstart[nb]);
    std::vector<int> pos(pstart.begin(), pstart.end() - 1);
    auto put = [&](int b, long id, const double *shift) {
      double *o = &partners[(size_t) NPARTNER * pos[b]++];
      o[0] = (double) id;
      for (int d = 0; d < 3; ++d) o[1 + d] = shift[d];
    };
    for (const Edge &e : wedges)
      if (isb[uf.find(e.i)]) put(e.i, bodies[e.j].id, e.shift);
    for (int q : fwin) {
      const ForeignEdge &fe = fedges[q];
      if (foreign[fe.node].id > bodies[fe.body].id) put(fe.body, foreign[fe.node].id, fe.shift);
    }

    send.clear();
    std::vector<int> sent;
    for (int b = 0; b < nb; ++b) {
      if (!isb[uf.find(b)]) continue;
      const size_t at = send.size();
      send.resize(at + NBODY + 1);
      pack_body(bodies[b], &send[at]);
      send[at + NBODY] = pstart[b + 1] - pstart[b];
      send.insert(send.end(), partners.begin() + (size_t) NPARTNER * pstart[b],
                  partners.begin() + (size_t) NPARTNER * pstart[b + 1]);
      sent.push_back(b);
    }
    long mine_off = 0;
    ex.allgather(send, recv, mine_off);
    gbodies.clear();
    gedges.clear();
    if (recv.empty()) return;

    // Entries in body-ID order.
    std::vector<std::pair<long, size_t>> order;
    for (size_t off = 0; off < recv.size();) {
      order.emplace_back((long) recv[off + 24], off);
      off += NBODY + 1 + (size_t) NPARTNER * (size_t) recv[off + NBODY];
    }
    std::sort(order.begin(), order.end());
    const int ng = (int) order.size();
    gbodies.resize(ng);
    gmine.assign(ng, -1);
    std::vector<long> ids(ng);
    for (int k = 0; k < ng; ++k) {
      unpack_body(&recv[order[k].second], gbodies[k]);
      ids[k] = gbodies[k].id;
    }
    {
      size_t off = (size_t) mine_off;
      for (int b : sent) {
        const long id = (long) recv[off + 24];
        const int k = (int) (std::lower_bound(ids.begin(), ids.end(), id) - ids.begin());
        gmine[k] = b;
        off += NBODY + 1 + (size_t) NPARTNER * (size_t) recv[off + NBODY];
      }
    }
    for (int k = 0; k < ng; ++k) {
      const double *h = &recv[order[k].second];
      const int np = (int) h[NBODY];
      for (int q = 0; q < np; ++q) {
        const double *o = h + NBODY + 1 + (size_t) NPARTNER * q;
        const auto it = std::lower_bound(ids.begin(), ids.end(), (long) o[0]);
        Edge e;
        e.i = k;
        e.j = (int) (it - ids.begin());
        for (int d = 0; d < 3; ++d) e.shift[d] = o[1 + d];
        gedges.push_back(e);
      }
    }
    UnionFind guf;
    guf.reset(ng);
    for (const Edge &e : gedges) guf.unite(e.i, e.j);
    int ngr = 0;
    largest = std::max(largest, group_by_root(guf, ng, nullptr, gstart2, gmembers2, fill, ngr));
    for (int g = 0; g < ngr; ++g)
      if (gstart2[g + 1] - gstart2[g] > 1) ++ngroups;
    nbound += ng;
    WindowWork w{gbodies.data(), ng, gedges.data(), (int) gedges.size(), gstart2.data(),
                 gmembers2.data(), ngr, t1};
    backend.resolve(w, p, tb);
    for (int k = 0; k < ng; ++k)
      if (gmine[k] >= 0) {
        const int owner = bodies[gmine[k]].owner;
        bodies[gmine[k]] = gbodies[k];
        bodies[gmine[k]].owner = owner;
      }
  }

  /* After the window: could a pair that was not joined have touched?  Only if a body of it
     moved further than its bound, and the two moved at least the pair's gap together.  Raises
     the bounds of the bodies that did so.  Returns true when the window is exact. */
  bool WindowDriver::check_window(std::vector<Body> &bodies, const std::vector<Edge> &edges,
                                  const std::vector<ForeignEdge> &fedges,
                                  const std::vector<ForeignNode> &foreign, double t1,
                                  Exchange &ex)
  {
    const int nb = (int) bodies.size();
    lexc.resize(nb);
    double p[3];
    for (int b = 0; b < nb; ++b) {
      drift_position(bodies[b], t1, p);
      note_excursion(bodies[b], p);
      lexc[b] = std::sqrt(bodies[b].wexc2);
    }
    if (ex.nranks() > 1) ex.to_foreign(lexc, 1, fexc);
    double fail = 0.0;
    for (size_t q = 0; q < edges.size(); ++q) {
      if (ljoined[q]) continue;
      const Edge &e = edges[q];
      const bool vi = lexc[e.i] > bound[e.i], vj = lexc[e.j] > bound[e.j];
      if (!vi && !vj) continue;
      const Body &bi = bodies[e.i], &bj = bodies[e.j];
      const double s2 = bi.radius + bj.radius;
      if (lexc[e.i] + lexc[e.j] + MARGIN * s2 < window_gap(bi.w0, bj.w0, e.shift, s2)) continue;
      fail = 1.0;
      if (vi) boost[e.i] = std::max(boost[e.i], 2.0 * lexc[e.i]);
      if (vj) boost[e.j] = std::max(boost[e.j], 2.0 * lexc[e.j]);
    }
    for (size_t q = 0; q < fedges.size(); ++q) {
      if (fjoined[q]) continue;
      const ForeignEdge &fe = fedges[q];
      const double *fw = &fstate[(size_t) 4 * fe.node];
      const double fx = fexc[fe.node];
      const bool vi = lexc[fe.body] > bound[fe.body], vj = fx > fw[3];
      if (!vi && !vj) continue;
      const Body &b = bodies[fe.body];
      const double s2 = b.radius + foreign[fe.node].radius;
      double gap;
      if (b.id < foreign[fe.node].id) {
        gap = window_gap(b.w0, fw, fe.shift, s2);
      } else {
        const double ns[3] = {-fe.shift[0], -fe.shift[1], -fe.shift[2]};
        gap = window_gap(fw, b.w0, ns, s2);
      }
      if (lexc[fe.body] + fx + MARGIN * s2 < gap) continue;
      fail = 1.0;
      if (vi) boost[fe.body] = std::max(boost[fe.body], 2.0 * lexc[fe.body]);
    }
    ex.max(&fail, 1);
    return fail == 0.0;
  }

  bool WindowDriver::run(std::vector<Body> &bodies, const std::vector<Edge> &edges,
                         const std::vector<ForeignEdge> &fedges,
                         const std::vector<ForeignNode> &foreign, const Params &p,
                         const WindowSettings &s, CollisionBackend &backend, Exchange &ex,
                         Tally &mine, WindowStats &stats)
  {
    const double dt = p.dt;
    const bool join_all = redos_this_step >= s.max_redos;
    long counts[2] = {(long) bodies.size(), 0};
    ex.sum(counts, 1);
    const long target = s.target_group > 0 ? s.target_group : std::max(128L, counts[0] / 512);
    stats = WindowStats();
    Tally tloc, tbnd;
    double t0 = 0.0;
    double guess = last_delta > 0.0 ? std::min(2.0 * last_delta, dt) : dt;
    int k = 0;
    long largest_all = 0, ngroups_all = 0, nbound_all = 0;
    while (t0 < dt) {
      double t1;
      long largest;
      if (join_all) {
        t1 = dt;
        largest = window_edges(bodies, edges, fedges, foreign, t0, t1, s, ex);
      } else if (s.nwindows > 0) {
        t1 = (k + 1 >= s.nwindows) ? dt : dt * (double) (k + 1) / (double) s.nwindows;
        largest = window_edges(bodies, edges, fedges, foreign, t0, t1, s, ex);
      } else {
        t1 = t0 + guess;
        if (t1 > dt * (1.0 - 1e-9)) t1 = dt;
        largest = window_edges(bodies, edges, fedges, foreign, t0, t1, s, ex);
        while (largest > target && t1 - t0 > dt * MIN_WINDOW) {
          const double half = t0 + 0.5 * (t1 - t0);
          const long l2 = window_edges(bodies, edges, fedges, foreign, t0, half, s, ex);
          if ((double) l2 > 0.75 * (double) largest) {
            // Halving no longer pays (a pile: touching bodies stay joined): keep the longer.
            window_edges(bodies, edges, fedges, foreign, t0, t1, s, ex);
            break;
          }
          t1 = half;
          largest = l2;
        }
        // The next window starts at twice this one (the step's last window, cut short by
        // what was left, says nothing about the length that pays).
        if (t1 < dt || k == 0) {
          last_delta = t1 - t0;
          guess = std::min(2.0 * last_delta, dt);
        }
      }
      largest_all = std::max(largest_all, largest);

      // Local groups.
      long ngroups = 0;
      for (int g = 0; g < nlocal_groups; ++g)
        if (gstart[g + 1] - gstart[g] > 1) ++ngroups;
      WindowWork w{bodies.data(), (int) bodies.size(), wedges.data(), (int) wedges.size(),
                   gstart.data(), gmembers.data(), nlocal_groups, t1};
      backend.resolve(w, p, tloc);
      // Boundary groups, the same on every rank.
      long bl = 0, bg = 0, nbound = 0;
      if (ex.nranks() > 1) {
        resolve_boundary(bodies, fedges, foreign, p, t1, backend, ex, tbnd, bl, bg, nbound);
        largest_all = std::max(largest_all, bl);
      }
      long c[1] = {ngroups};
      ex.sum(c, 1);
      ngroups_all += c[0] + bg;
      nbound_all += nbound;

      const bool ok = check_window(bodies, edges, fedges, foreign, t1, ex);
      double capped = (tloc.capped | tbnd.capped) ? 1.0 : 0.0;
      ex.max(&capped, 1);
      ++k;
      if (!ok && !join_all && capped == 0.0) {
        ++redos_this_step;
        return false;
      }
      if (capped != 0.0) {
        tloc.capped = 1;
        break;
      }
      t0 = t1;
    }
    stats.largest_group = largest_all;
    stats.groups = ngroups_all;
    stats.windows = k;
    stats.boundary_bodies = nbound_all;
    mine = tloc;
    if (ex.rank() == 0) mine.add(tbnd);
    return true;
  }

}    // namespace Collide
}    // namespace HSGPU
