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
    /// Doubles per body in the boundary exchange (pack_body; 3 more with friction: the spin),
    /// and per partner (id, shift).
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

    /// window_gap() of a local body and a foreign node (window start point fw), computed
    /// with the lower ID first, as the node's owner computes it.
    double foreign_gap(const Body &b, const double *fw, const ForeignEdge &fe,
                       const ForeignNode &node, double s)
    {
      if (b.id < node.id) return window_gap(b.w0, fw, fe.shift, s);
      const double ns[3] = {-fe.shift[0], -fe.shift[1], -fe.shift[2]};
      return window_gap(fw, b.w0, ns, s);
    }

    void pack_body(const Body &b, double *o, bool spin)
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
      if (spin)
        for (int d = 0; d < 3; ++d) o[NBODY + d] = b.omega[d];
    }

    void unpack_body(const double *o, Body &b, bool spin)
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
      if (spin)
        for (int d = 0; d < 3; ++d) b.omega[d] = o[NBODY + d];
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

  /* The window [t0, t1): window start points, bounds, the window's edges and the local groups
     (gstart/gmembers; boundary groups are left out, their roots flagged in isb).  Returns the
     largest local group over all ranks. */
  long WindowDriver::window_edges(std::vector<Body> &bodies, const std::vector<Edge> &edges,
                                  const std::vector<ForeignEdge> &fedges,
                                  const std::vector<ForeignNode> &foreign, double t0, double t1,
                                  const WindowSettings &s, Exchange &ex)
  {
    const int nb = (int) bodies.size(), nf = (int) foreign.size();
    const double delta = t1 - t0;
    // The window's start points, the bodies' bound rates and the edges' gaps there depend on
    // t0 only: the chooser's tries of one window (several ends t1) compute them once.
    if (!start_cached) {
      rate.resize(nb);
      for (int b = 0; b < nb; ++b) {
        Body &bd = bodies[b];
        drift_position(bd, t0, bd.w0);
        bd.wexc2 = 0.0;
        const double speed = std::sqrt(Contact::dot3(bd.v, bd.v));
        rate[b] = std::max(s.bound_factor * speed, speed_floor);
      }
      egap.resize(edges.size());
      emargin.resize(edges.size());
      for (size_t q = 0; q < edges.size(); ++q) {
        const Edge &e = edges[q];
        const Body &bi = bodies[e.i], &bj = bodies[e.j];
        const double s2 = bi.radius + bj.radius;
        egap[q] = window_gap(bi.w0, bj.w0, e.shift, s2);
        emargin[q] = MARGIN * s2;
      }
      start_cached = true;
    }
    bound.resize(nb);
    wstate.resize((size_t) 4 * nb);
    for (int b = 0; b < nb; ++b) {
      bound[b] = rate[b] * delta;
      for (int d = 0; d < 3; ++d) wstate[(size_t) 4 * b + d] = bodies[b].w0[d];
      wstate[(size_t) 4 * b + 3] = bound[b];
    }
    if (ex.nranks() > 1) ex.to_foreign(wstate, 4, fstate);

    wedges.clear();
    ljoined.assign(edges.size(), 0);
    for (size_t q = 0; q < edges.size(); ++q) {
      const Edge &e = edges[q];
      if (egap[q] <= bound[e.i] + bound[e.j] + emargin[q]) {
        wedges.push_back(e);
        ljoined[q] = 1;
      }
    }
    fwin.clear();
    fjoined.assign(fedges.size(), 0);
    for (size_t q = 0; q < fedges.size(); ++q) {
      const ForeignEdge &fe = fedges[q];
      const double *fw = &fstate[(size_t) 4 * fe.node];
      const double s2 = bodies[fe.body].radius + foreign[fe.node].radius;
      if (foreign_gap(bodies[fe.body], fw, fe, foreign[fe.node], s2) <=
          bound[fe.body] + fw[3] + MARGIN * s2) {
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
    // The local parts of boundary groups count too (a lower bound of their size).
    if (nf > 0) {
      fill.assign(nb + nf, 0);
      for (int b = 0; b < nb; ++b) {
        const int r = uf.find(b);
        if (isb[r]) largest = std::max(largest, (long) ++fill[r]);
      }
    }
    double l = (double) largest;
    ex.max(&l, 1);
    return (long) l;
  }

  void WindowDriver::resolve_boundary(std::vector<Body> &bodies,
                                      const std::vector<ForeignEdge> &fedges,
                                      const std::vector<ForeignNode> &foreign, const Params &p,
                                      double t1, CollisionBackend &backend, Exchange &ex, Tally &tb,
                                      long &largest, long &ngroups, long &nbound)
  {
    const int nb = (int) bodies.size();
    const bool spin = p.friction != 0;
    const int nbody = spin ? NBODY + 3 : NBODY;
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
    std::vector<int> &sent = bsent;
    sent.clear();
    for (int b = 0; b < nb; ++b) {
      if (!isb[uf.find(b)]) continue;
      const size_t at = send.size();
      send.resize(at + nbody + 1);
      pack_body(bodies[b], &send[at], spin);
      send[at + nbody] = pstart[b + 1] - pstart[b];
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
      off += nbody + 1 + (size_t) NPARTNER * (size_t) recv[off + nbody];
    }
    std::sort(order.begin(), order.end());
    const int ng = (int) order.size();
    gbodies.resize(ng);
    gmine.assign(ng, -1);
    std::vector<long> ids(ng);
    for (int k = 0; k < ng; ++k) {
      unpack_body(&recv[order[k].second], gbodies[k], spin);
      ids[k] = gbodies[k].id;
    }
    {
      size_t off = (size_t) mine_off;
      for (int b : sent) {
        const long id = (long) recv[off + 24];
        const int k = (int) (std::lower_bound(ids.begin(), ids.end(), id) - ids.begin());
        gmine[k] = b;
        off += nbody + 1 + (size_t) NPARTNER * (size_t) recv[off + nbody];
      }
    }
    for (int k = 0; k < ng; ++k) {
      const double *h = &recv[order[k].second];
      const int np = (int) h[nbody];
      for (int q = 0; q < np; ++q) {
        const double *o = h + nbody + 1 + (size_t) NPARTNER * q;
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
    WindowWork w{gbodies.data(),
                 ng,
                 gedges.data(),
                 (int) gedges.size(),
                 gstart2.data(),
                 gmembers2.data(),
                 ngr,
                 t1};
    if (tally_virial) {
      gvir.assign(6 * (size_t) ng, 0.0);
      w.body_virial = gvir.data();
    }
    backend.resolve(w, p, tb);
    for (int k = 0; k < ng; ++k)
      if (gmine[k] >= 0) {
        const int owner = bodies[gmine[k]].owner;
        bodies[gmine[k]] = gbodies[k];
        bodies[gmine[k]].owner = owner;
        // Resolved from the window start: its window virial is this resolution's.
        if (tally_virial)
          std::copy(gvir.begin() + 6 * (size_t) k, gvir.begin() + 6 * (size_t) (k + 1),
                    wvir.begin() + 6 * (size_t) gmine[k]);
      }
  }

  /* Each local body's largest distance from its window start point, at the window end t1
     (only the bodies in `only`, when given: those resolved again since the last call). */
  void WindowDriver::excursions(std::vector<Body> &bodies, double t1, const std::vector<int> *only)
  {
    const int nb = (int) bodies.size();
    lexc.resize(nb);
    double p[3];
    auto note = [&](int b) {
      drift_position(bodies[b], t1, p);
      note_excursion(bodies[b], p);
      lexc[b] = std::sqrt(bodies[b].wexc2);
    };
    if (only) {
      for (int b : *only) note(b);
    } else {
      for (int b = 0; b < nb; ++b) note(b);
    }
  }

  /* A candidate pair that was not joined could only have touched if a body of it moved
     further than its bound and the two moved at least the pair's gap together.  For such
     pairs between two local groups the groups are merged and resolved again from the window
     start, until no such pair is left.  Returns the largest merged group. */
  long WindowDriver::repair_local(std::vector<Body> &bodies, const std::vector<Edge> &edges,
                                  const Params &p, double t1, CollisionBackend &backend,
                                  long events_before, long &repairs)
  {
    const int ng = nlocal_groups;
    long largest = 0;
    std::vector<int> failing;
    std::vector<char> redo(ng, 0);
    for (int pass = 0;; ++pass) {
      failing.clear();
      for (size_t q = 0; q < edges.size(); ++q) {
        if (ljoined[q]) continue;
        const Edge &e = edges[q];
        const int gi = group_of[e.i], gj = group_of[e.j];
        if (gi < 0 || gj < 0) continue;    // a boundary group: checked after its resolution
        if (!(lexc[e.i] > bound[e.i]) && !(lexc[e.j] > bound[e.j])) continue;
        const Body &bi = bodies[e.i], &bj = bodies[e.j];
        const double s2 = bi.radius + bj.radius;
        if (lexc[e.i] + lexc[e.j] + MARGIN * s2 < window_gap(bi.w0, bj.w0, e.shift, s2)) continue;
        failing.push_back((int) q);
      }
      if (failing.empty()) return largest;
      // Merge, and take the merged groups back to the window start.
      std::fill(redo.begin(), redo.end(), 0);
      for (int q : failing) {
        ljoined[q] = 1;
        wedges.push_back(edges[q]);
        uf.unite(edges[q].i, edges[q].j);
        merged.unite(merged.find(group_of[edges[q].i]), merged.find(group_of[edges[q].j]));
      }
      for (int q : failing) redo[merged.find(group_of[edges[q].i])] = 1;
      // The merged groups' bodies, compacted (in body order within each), and their edges.
      subgroups.clear();
      for (int g = 0; g < ng; ++g)
        if (redo[merged.find(g)]) subgroups.push_back(g);
      std::vector<int> root_slot(ng, -1);
      int nsets = 0;
      for (int g : subgroups)
        if (root_slot[merged.find(g)] < 0) root_slot[merged.find(g)] = nsets++;
      substart.assign(nsets + 1, 0);
      for (int g : subgroups) substart[root_slot[merged.find(g)] + 1] += gstart[g + 1] - gstart[g];
      for (int k = 0; k < nsets; ++k) substart[k + 1] += substart[k];
      submembers.resize(substart[nsets]);
      {
        std::vector<int> pos(substart.begin(), substart.end() - 1);
        for (int g : subgroups)
          for (int m = gstart[g]; m < gstart[g + 1]; ++m)
            submembers[pos[root_slot[merged.find(g)]]++] = gmembers[m];
      }
      sub.resize(submembers.size());
      sub_of.resize(bodies.size());
      for (int k = 0; k < nsets; ++k) {
        std::sort(submembers.begin() + substart[k], submembers.begin() + substart[k + 1]);
        largest = std::max(largest, (long) (substart[k + 1] - substart[k]));
      }
      for (size_t m = 0; m < submembers.size(); ++m) {
        const int b = submembers[m];
        sub[m] = snap[b];
        sub[m].owner = b;
        sub_of[b] = (int) m;
      }
      // Members of a set occupy one contiguous range: the groups list is the identity.
      std::vector<int> ident(submembers.size());
      for (size_t m = 0; m < ident.size(); ++m) ident[m] = (int) m;
      subedges.clear();
      for (const Edge &e : wedges) {
        const int g = group_of[e.i];
        if (g < 0 || !redo[merged.find(g)]) continue;
        Edge se = e;
        se.i = sub_of[e.i];
        se.j = sub_of[e.j];
        subedges.push_back(se);
      }
      std::vector<Tally> st(nsets);
      Tally cap;
      cap.events = events_before;
      for (int g = 0; g < ng; ++g)
        if (!redo[merged.find(g)]) cap.events += gtally[g].events;
      WindowWork w{sub.data(),      (int) sub.size(), subedges.data(), (int) subedges.size(),
                   substart.data(), ident.data(),     nsets,           t1,
                   st.data()};
      if (tally_virial) {
        subvir.assign(6 * sub.size(), 0.0);
        w.body_virial = subvir.data();
      }
      backend.resolve(w, p, cap);
      repairs += nsets;
      // Back into place; the merged set's tally goes to its root group.
      for (size_t m = 0; m < sub.size(); ++m) {
        const int b = submembers[m];
        const int owner = bodies[b].owner;
        bodies[b] = sub[m];
        bodies[b].owner = owner;
        if (tally_virial)
          std::copy(subvir.begin() + 6 * m, subvir.begin() + 6 * (m + 1),
                    wvir.begin() + 6 * (size_t) b);
        double pe[3];
        drift_position(bodies[b], t1, pe);
        note_excursion(bodies[b], pe);
        lexc[b] = std::sqrt(bodies[b].wexc2);
      }
      for (int g : subgroups) gtally[g] = Tally();
      for (int g : subgroups) {
        const int r = merged.find(g);
        if (r == g) gtally[g] = st[root_slot[r]];
      }
      if (cap.capped) {
        gtally[subgroups[0]].capped = 1;
        return largest;
      }
    }
  }

  /* After the boundary groups: the pairs not joined that involve a boundary group or a
     foreign node and could have touched.  They are joined (their local groups become part of
     the boundary groups); every rank sees the same foreign pairs.  Returns the number joined
     over all ranks. */
  long WindowDriver::join_missed_boundary(std::vector<Body> &bodies, const std::vector<Edge> &edges,
                                          const std::vector<ForeignEdge> &fedges,
                                          const std::vector<ForeignNode> &foreign, Exchange &ex)
  {
    const int nb = (int) bodies.size();
    ex.to_foreign(lexc, 1, fexc);
    long joined = 0;
    for (size_t q = 0; q < edges.size(); ++q) {
      if (ljoined[q]) continue;
      const Edge &e = edges[q];
      if (group_of[e.i] >= 0 && group_of[e.j] >= 0) continue;    // repaired already
      if (!(lexc[e.i] > bound[e.i]) && !(lexc[e.j] > bound[e.j])) continue;
      const Body &bi = bodies[e.i], &bj = bodies[e.j];
      const double s2 = bi.radius + bj.radius;
      if (lexc[e.i] + lexc[e.j] + MARGIN * s2 < window_gap(bi.w0, bj.w0, e.shift, s2)) continue;
      ljoined[q] = 1;
      wedges.push_back(e);
      uf.unite(e.i, e.j);
      ++joined;
    }
    for (size_t q = 0; q < fedges.size(); ++q) {
      if (fjoined[q]) continue;
      const ForeignEdge &fe = fedges[q];
      const double *fw = &fstate[(size_t) 4 * fe.node];
      const double fx = fexc[fe.node];
      if (!(lexc[fe.body] > bound[fe.body]) && !(fx > fw[3])) continue;
      const double s2 = bodies[fe.body].radius + foreign[fe.node].radius;
      if (lexc[fe.body] + fx + MARGIN * s2 <
          foreign_gap(bodies[fe.body], fw, fe, foreign[fe.node], s2))
        continue;
      fjoined[q] = 1;
      fwin.push_back((int) q);
      uf.unite(fe.body, nb + fe.node);
      ++joined;
    }
    long c[1] = {joined};
    ex.sum(c, 1);
    if (c[0] == 0) return 0;
    // Boundary roots anew; every body in a boundary group (old or new) back to the window
    // start; local groups that joined one leave the local tallies.
    const int nf = (int) foreign.size();
    isb.assign(nb + nf, 0);
    for (int k = 0; k < nf; ++k) isb[uf.find(nb + k)] = 1;
    for (int b = 0; b < nb; ++b) {
      if (!isb[uf.find(b)]) continue;
      const int g = group_of[b];
      if (g >= 0) {
        gtally[merged.find(g)] = Tally();
        gtally[g] = Tally();
      }
      group_of[b] = -1;
      const int owner = bodies[b].owner;
      bodies[b] = snap[b];
      bodies[b].owner = owner;
      if (tally_virial)
        std::fill(wvir.begin() + 6 * (size_t) b, wvir.begin() + 6 * (size_t) (b + 1), 0.0);
    }
    return c[0];
  }

  void WindowDriver::run(std::vector<Body> &bodies, const std::vector<Edge> &edges,
                         const std::vector<ForeignEdge> &fedges,
                         const std::vector<ForeignNode> &foreign, const Params &p,
                         const WindowSettings &s, CollisionBackend &backend, Exchange &ex,
                         Tally &mine, WindowStats &stats, double *body_virial)
  {
    const double dt = p.dt;
    tally_virial = body_virial != nullptr;
    const int nb = (int) bodies.size();
    long counts[1] = {(long) nb};
    ex.sum(counts, 1);
    const long target = WindowChooser::target(s, counts[0]);
    // Every body's window bound assumes at least a quarter of the fastest drift speed: a body
    // at rest that is hit moves about as fast as what hit it, and a bound of zero would make
    // every such hit a repair (in a settled pile, of the whole pile).
    double vmax = 0.0;
    for (const Body &b : bodies) vmax = std::max(vmax, Contact::dot3(b.v, b.v));
    ex.max(&vmax, 1);
    speed_floor = floor_fraction_or(s, 0.25) * std::sqrt(vmax);
    stats = WindowStats();
    Tally tloc, tbnd;
    double t0 = 0.0;
    chooser.start_step(dt);
    int k = 0;
    while (t0 < dt) {
      long largest;
      start_cached = false;    // a new window start: window_edges() computes its start points
      const double t1 = chooser.next(
          t0, k, dt, s, target,
          [&](double t) { return window_edges(bodies, edges, fedges, foreign, t0, t, s, ex); },
          largest);

      // Local groups, each with its own tally (a repair replaces a group's tally).
      // The snapshot keeps its capacity with some slack: on several ranks the number of
      // bodies changes every step, and a fresh allocation of this size costs page faults.
      if (snap.capacity() < bodies.size()) snap.reserve(bodies.size() + bodies.size() / 8 + 64);
      snap.assign(bodies.begin(), bodies.end());
      group_of.assign(nb, -1);
      for (int g = 0; g < nlocal_groups; ++g)
        for (int m = gstart[g]; m < gstart[g + 1]; ++m) group_of[gmembers[m]] = g;
      gtally.assign(nlocal_groups, Tally());
      Tally cap;
      cap.events = tloc.events;
      WindowWork w{
          bodies.data(), nb, wedges.data(), (int) wedges.size(), gstart.data(), gmembers.data(),
          nlocal_groups, t1, gtally.data()};
      if (tally_virial) {
        wvir.assign(6 * (size_t) nb, 0.0);
        w.body_virial = wvir.data();
      }
      backend.resolve(w, p, cap);
      excursions(bodies, t1);
      long repairs = 0;
      merged.reset(nlocal_groups);
      largest =
          std::max(largest, repair_local(bodies, edges, p, t1, backend, tloc.events, repairs));
      // Boundary groups, the same on every rank; repaired until no missed pair is left.
      long bl = 0, bg = 0, nbound = 0;
      if (ex.nranks() > 1) {
        const Tally tbnd_start = tbnd;
        for (int pass = 0;; ++pass) {
          tbnd = tbnd_start;
          bl = bg = nbound = 0;
          resolve_boundary(bodies, fedges, foreign, p, t1, backend, ex, tbnd, bl, bg, nbound);
          excursions(bodies, t1, &bsent);    // the others are as the local pass left them
          const long joined = join_missed_boundary(bodies, edges, fedges, foreign, ex);
          ++stats.gathers;
          if (joined == 0) break;
          repairs += joined;
        }
      }
      if (tally_virial)
        for (size_t k = 0; k < 6 * (size_t) nb; ++k) body_virial[k] += wvir[k];
      int capped = cap.capped | tbnd.capped;
      long ngroups = 0;
      for (int g = 0; g < nlocal_groups; ++g) {
        capped |= gtally[g].capped;
        tloc.add(gtally[g]);
        if (gtally[g].events > 0) ++ngroups;
      }
      double flags[2] = {capped ? 1.0 : 0.0, (double) largest};
      ex.max(flags, 2);
      long c[2] = {ngroups, repairs};
      ex.sum(c, 2);
      stats.largest_group = std::max({stats.largest_group, (long) flags[1], bl});
      stats.groups += c[0] + bg;
      stats.boundary_bodies += nbound;
      stats.repairs += c[1];
      ++k;
      if (flags[0] != 0.0) {
        tloc.capped = 1;
        break;
      }
      t0 = t1;
    }
    stats.windows = k;
    mine = tloc;
    if (ex.rank() == 0) mine.add(tbnd);
  }

}    // namespace Collide
}    // namespace HSGPU
