/* HARDSPHERE_GPU collision engine: the step driver, see window_driver.h. */
#include "window_driver.h"

#include <algorithm>
#include <chrono>
#include <functional>
#include <cmath>
#include <cstring>
#include <limits>
#include <utility>

namespace HSGPU {
namespace Collide {

  namespace {

    /// Seconds since t, and t moved to now (for DriverTimes).
    double lap(std::chrono::steady_clock::time_point &t)
    {
      const auto now = std::chrono::steady_clock::now();
      const double s = std::chrono::duration<double>(now - t).count();
      t = now;
      return s;
    }

    /// Adds the seconds of its scope to `sum` (a part of a DriverTimes part).
    struct ScopeTime {
      double &sum;
      std::chrono::steady_clock::time_point t0 = std::chrono::steady_clock::now();
      explicit ScopeTime(double &s) : sum(s) {}
      ~ScopeTime() { sum += lap(t0); }
    };

    /// Whether rank r is `self` or one of the sorted neighbouring ranks nbrs.
    bool is_neighbour(const std::vector<int> &nbrs, int r, int self)
    {
      return r == self || std::binary_search(nbrs.begin(), nbrs.end(), r);
    }

    /// Point-to-point messages of a gather: to the neighbouring ranks where `neighbours`
    /// (every destination one of them), else to any ranks; false where the exchange has no
    /// such path.
    bool messages(Exchange &ex, bool neighbours, const std::vector<int> &dest,
                  const std::vector<std::vector<double>> &send, std::vector<double> &recv)
    {
      if (!neighbours) return ex.to_ranks(dest, send, recv);
      ex.to_neighbours(dest, send, recv);
      return true;
    }

    constexpr double MARGIN = WINDOW_MARGIN;
    /// Doubles per body in the boundary exchange (pack_body; 3 more with friction: the spin),
    /// and per partner (id, shift).
    constexpr int NBODY = 29;
    static_assert(NBODY + 3 <= Exchange::MAX_VALUES, "to_foreign() takes a body's state");
    constexpr int NPARTNER = 4;
    /// Where pack_body() puts the body's ID.
    constexpr int ID_AT = 24;
    /// pack_body()'s values, the spin last with friction.
    int body_values(bool spin)
    {
      return spin ? NBODY + 3 : NBODY;
    }

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
      o[ID_AT] = (double) b.id;
      o[25] = (double) b.last;
      o[26] = b.type;
      o[27] = b.nevents;
      o[28] = b.owner;
      if (spin)
        for (int d = 0; d < 3; ++d) o[NBODY + d] = b.omega[d];
    }

    /// What a step's events change in a body (all a window start needs besides what
    /// pack_body() brought at the step's first window; w0 and wexc2 are recomputed there):
    /// ndyn() values, the spin last with friction (spin).
    constexpr int NDYN = 13;
    int ndyn(bool spin)
    {
      return spin ? NDYN + 3 : NDYN;
    }

    void pack_dynamic(const Body &b, double *o, bool spin)
    {
      for (int d = 0; d < 3; ++d) {
        o[d] = b.x[d];
        o[3 + d] = b.v[d];
        o[6 + d] = b.rest[d];
      }
      o[9] = b.tref;
      o[10] = b.tlast;
      o[11] = (double) b.last;
      o[12] = b.nevents;
      if (spin)
        for (int d = 0; d < 3; ++d) o[NDYN + d] = b.omega[d];
    }

    void unpack_dynamic(const double *o, Body &b, bool spin)
    {
      for (int d = 0; d < 3; ++d) {
        b.x[d] = o[d];
        b.v[d] = o[3 + d];
        b.rest[d] = (int) o[6 + d];
      }
      b.tref = o[9];
      b.tlast = o[10];
      b.last = (long) o[11];
      b.nevents = (int) o[12];
      if (spin)
        for (int d = 0; d < 3; ++d) b.omega[d] = o[NDYN + d];
    }

    /// A window's result for a body: what events change, with the body's excursions:
    /// nres() values.
    int nres(bool spin)
    {
      return ndyn(spin) + 2;
    }

    void pack_result(const Body &b, double *o, bool spin)
    {
      pack_dynamic(b, o, spin);
      o[ndyn(spin)] = b.exc2;
      o[ndyn(spin) + 1] = b.wexc2;
    }

    void unpack_result(const double *o, Body &b, bool spin)
    {
      unpack_dynamic(o, b, spin);
      b.exc2 = o[ndyn(spin)];
      b.wexc2 = o[ndyn(spin) + 1];
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
      b.id = (long) o[ID_AT];
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
                       int &ngroups, std::vector<int> &pos)
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
      pos.assign(start.begin(), start.end() - 1);
      for (int b = 0; b < n; ++b) {
        const int r = uf.find(b);
        if (fill[r] >= 0) members[pos[fill[r]]++] = b;
      }
      return largest;
    }

  }    // namespace

  /* A body's bound per unit of window length, from its drift velocity v: at least the
     floor of the step's fastest drift, times edge_factor for a body next to another rank's
     atoms (edge).  Its owner's rate and the one a rank forms for a foreign node at the step's
     first window (window_edges()) come from here alike. */
  double WindowDriver::bound_rate(const double *v, bool edge, const WindowSettings &s) const
  {
    const double speed = std::sqrt(Contact::dot3(v, v));
    const double k = edge ? s.edge_factor : 1.0;
    return k * std::max(s.bound_factor * speed, speed_floor);
  }

  /* The lists of sparse_to_foreign(), once per step: for each neighbouring rank, the local
     bodies in a foreign edge with a node it owns (in ID order), and the foreign nodes of the
     foreign edges as the messages bring them (by their owners' places among the neighbouring
     ranks, then by ID).  The two ranks of a pair across them each hold it as a foreign edge
     (the candidate search is the same on both), so what a rank sends another is what that one
     expects; a node whose owner is not a neighbouring rank (never expected) makes the step's
     results missing. */
  void WindowDriver::sparse_lists(const std::vector<Body> &bodies,
                                  const std::vector<ForeignEdge> &fedges,
                                  const std::vector<ForeignNode> &foreign, Exchange &ex)
  {
    const std::vector<int> &nbrs = *ex.neighbours();
    const int nn = (int) nbrs.size(), nf = (int) foreign.size(), nb = (int) bodies.size();
    // Each node's owner's place among the neighbouring ranks (-1: none).
    sf_nbr.assign(nf, -1);
    for (int f = 0; f < nf; ++f) {
      const auto it = std::lower_bound(nbrs.begin(), nbrs.end(), foreign[f].owner);
      if (it != nbrs.end() && *it == foreign[f].owner) sf_nbr[f] = (int) (it - nbrs.begin());
    }
    // Bodies by destination (a counting sort over the foreign edges; a body once per
    // destination: sf_stamp holds the last destination it was listed for, plus one).
    std::vector<int> &count = sf_start;
    count.assign(nn + 1, 0);
    std::vector<char> need(nf, 0);
    for (const ForeignEdge &fe : fedges) {
      need[fe.node] = 1;
      if (sf_nbr[fe.node] < 0)
        results_missing = true;
      else
        ++count[sf_nbr[fe.node] + 1];
    }
    for (int k = 0; k < nn; ++k) count[k + 1] += count[k];
    std::vector<int> all(count[nn]), at(count.begin(), count.end() - 1);
    for (const ForeignEdge &fe : fedges)
      if (sf_nbr[fe.node] >= 0) all[at[sf_nbr[fe.node]]++] = fe.body;
    sf_stamp.assign(nb, 0);
    sf_dest.clear();
    sf_body.clear();
    std::vector<int> starts{0};
    for (int k = 0; k < nn; ++k) {
      const size_t from = sf_body.size();
      for (int q = count[k]; q < count[k + 1]; ++q) {
        const int b = all[q];
        if (sf_stamp[b] == k + 1) continue;
        sf_stamp[b] = k + 1;
        sf_body.push_back(b);
      }
      if (sf_body.size() == from) continue;
      std::sort(sf_body.begin() + from, sf_body.end(),
                [&](int a, int c) { return bodies[a].id < bodies[c].id; });
      sf_dest.push_back(nbrs[k]);
      starts.push_back((int) sf_body.size());
    }
    sf_start.swap(starts);
    // The nodes expected: by their owners' places, then by ID.
    sf_node.clear();
    for (int f = 0; f < nf; ++f)
      if (need[f] && sf_nbr[f] >= 0) sf_node.push_back(f);
    std::sort(sf_node.begin(), sf_node.end(), [&](int a, int c) {
      return sf_nbr[a] != sf_nbr[c] ? sf_nbr[a] < sf_nbr[c] : foreign[a].id < foreign[c].id;
    });
    sf_send.resize(sf_dest.size());
    sf_ready = true;
  }

  /* nval values of each local body (put(b, o) writes them at o) to the foreign nodes of the
     foreign edges (out: nval per node; the other nodes' values are left as they were): one
     message to each neighbouring rank with the bodies it needs, each as its ID and values,
     where a ghost update would send every body's to every ghost, one swap after another
     (WindowSettings::sparse_foreign).  The same values as a ghost update brings.  Where a
     message does not bring what this rank expects (never expected), the step's results are
     missing and the step is done again with the ghost updates (planned windows only). */
  template <class Put>
  void WindowDriver::sparse_to_foreign(const std::vector<Body> &bodies, int nval, Put put,
                                       const std::vector<ForeignEdge> &fedges,
                                       const std::vector<ForeignNode> &foreign,
                                       std::vector<double> &out, Exchange &ex)
  {
    if (!sf_ready) sparse_lists(bodies, fedges, foreign, ex);
    for (size_t k = 0; k < sf_dest.size(); ++k) {
      std::vector<double> &o = sf_send[k];
      o.resize((size_t) (1 + nval) * (sf_start[k + 1] - sf_start[k]));
      double *w = o.data();
      for (int q = sf_start[k]; q < sf_start[k + 1]; ++q, w += 1 + nval) {
        const int b = sf_body[q];
        w[0] = (double) bodies[b].id;
        put(b, w + 1);
      }
    }
    if (sparse_drop && ex.rank() == 0 && !sf_send.empty() && !sf_send[0].empty()) {
      sf_send[0].resize(sf_send[0].size() - (size_t) (1 + nval));    // (the test aid)
      sparse_drop = false;
    }
    ex.to_neighbours(sf_dest, sf_send, sf_recv);
    out.resize((size_t) nval * foreign.size());
    const size_t n = sf_node.size();
    if (sf_recv.size() != (size_t) (1 + nval) * n) {
      results_missing = true;
      return;
    }
    const double *r = sf_recv.data();
    for (size_t q = 0; q < n; ++q, r += 1 + nval) {
      const int f = sf_node[q];
      if (r[0] != (double) foreign[f].id) {
        results_missing = true;
        return;
      }
      std::copy(r + 1, r + 1 + nval, out.begin() + (size_t) nval * f);
    }
  }

  /* The window's start points (w0) of bodies[0 .. n), their bound rates and (gaps) the gaps
     of `edges` there: they depend on t0 only, so the chooser's tries of one window (several
     ends t1) compute them once (start_cached). */
  void WindowDriver::start_points(std::vector<Body> &bodies, int n, const std::vector<Edge> &edges,
                                  bool gaps, double t0, const WindowSettings &s)
  {
    if (start_cached) return;
    rate.resize(n);
    for (int b = 0; b < n; ++b) {
      Body &bd = bodies[b];
      drift_position(bd, t0, bd.w0);
      bd.wexc2 = 0.0;
      rate[b] = bound_rate(bd.v, b < (int) near_edge.size() && near_edge[b], s);
    }
    egap.resize(edges.size());
    emargin.resize(edges.size());
    for (size_t q = 0; gaps && q < edges.size(); ++q) {
      const Edge &e = edges[q];
      const Body &bi = bodies[e.i], &bj = bodies[e.j];
      const double s2 = bi.radius + bj.radius;
      egap[q] = window_gap(bi.w0, bj.w0, e.shift, s2);
      emargin[q] = MARGIN * s2;
    }
    start_cached = true;
  }

  /* The window [t0, t1): window start points, bounds, the window's edges and their union-find
     forest (window_groups() places the groups of the window chosen).  Returns the largest
     group over all ranks as the chooser weighs it (below). */
  long WindowDriver::window_edges(std::vector<Body> &bodies, const std::vector<Edge> &edges,
                                  const std::vector<ForeignEdge> &fedges,
                                  const std::vector<ForeignNode> &foreign, double t0, double t1,
                                  const WindowSettings &s, Exchange &ex)
  {
    const int nb = (int) bodies.size(), nf = (int) foreign.size();
    const double delta = t1 - t0;
    const bool new_start = !start_cached;
    const bool all = s.join_all && s.nwindows == 1;
    auto clock = std::chrono::steady_clock::now();
    start_points(bodies, nb, edges, !all, t0, s);
    wdelta = delta;
    bound.resize(nb);
    for (int b = 0; b < nb; ++b) bound[b] = rate[b] * delta;
    if (ex.nranks() > 1 && new_start) {
      // Once per window start, not per length tried: the start points and bound rates to the
      // foreign nodes (a node's bound is its rate times the window's length, the product its
      // owner forms), and the gaps of the foreign edges there.
      // At the step's first window they are formed here, from the owners' values of the
      // step's own ghost update (WindowSettings::start_from_step), as start_points() forms
      // them for the owner's body: every body is at its step start point (t0 = 0, tref = 0),
      // and a foreign node in a candidate pair with a body here has a candidate partner owned
      // by another rank, so its owner gives it the bound factor at the ranks' edges (only the
      // nodes of such pairs are read).
      const bool from_step = fstart && s.start_from_step && t0 == 0.0;
      if (from_step) {
        std::vector<double> &own = s.start_check ? fstep : fstate;
        own.resize((size_t) 4 * nf);
        for (int f = 0; f < nf; ++f) {
          const double *x0 = fstart->data() + (size_t) 6 * f, *v = x0 + 3;
          const double h = t0 - 0.0;    // drift_position() at t0 of a body with tref 0
          for (int d = 0; d < 3; ++d) own[(size_t) 4 * f + d] = x0[d] + v[d] * h;
          own[(size_t) 4 * f + 3] = bound_rate(v, edge_bounds, s);
        }
      }
      if (!from_step || s.start_check) {
        // A body's values: its window start point and bound rate.  (By messages to the
        // neighbouring ranks at the later windows of planned ones.)
        auto put = [&](int b, double *o) {
          for (int d = 0; d < 3; ++d) o[d] = bodies[b].w0[d];
          o[3] = rate[b];
        };
        const bool sparse = sparse_now && t0 > 0.0;
        if (!sparse) {
          wstate.resize((size_t) 4 * nb);
          for (int b = 0; b < nb; ++b) put(b, &wstate[(size_t) 4 * b]);
        }
        times.edges_start += lap(clock);
        if (sparse)
          sparse_to_foreign(bodies, 4, put, fedges, foreign, fstate, ex);
        else
          ex.to_foreign(wstate, 4, fstate);
        times.edges_ghosts += lap(clock);
      }
      if (from_step && s.start_check)
        for (const ForeignEdge &fe : fedges) {
          const size_t at = (size_t) 4 * fe.node;
          ++start_checked;
          if (std::memcmp(&fstate[at], &fstep[at], 4 * sizeof(double)) != 0) ++start_differ;
        }
      fgap.resize(fedges.size());
      for (size_t q = 0; !all && q < fedges.size(); ++q) {
        const ForeignEdge &fe = fedges[q];
        const double s2 = bodies[fe.body].radius + foreign[fe.node].radius;
        fgap[q] = foreign_gap(bodies[fe.body], &fstate[(size_t) 4 * fe.node], fe, foreign[fe.node],
                              s2);
      }
    }
    times.edges_start += lap(clock);

    wedges.clear();
    ljoined.assign(edges.size(), all ? 1 : 0);
    jseq.resize(edges.size());
    if (all) wedges.assign(edges.begin(), edges.end());
    for (size_t q = 0; !all && q < edges.size(); ++q) {
      const Edge &e = edges[q];
      if (egap[q] <= bound[e.i] + bound[e.j] + emargin[q]) {
        wedges.push_back(e);
        ljoined[q] = 1;
      }
    }
    fwin.clear();
    fjoined.assign(fedges.size(), all ? 1 : 0);
    for (size_t q = 0; all && q < fedges.size(); ++q) fwin.push_back((int) q);
    for (size_t q = 0; !all && q < fedges.size(); ++q) {
      const ForeignEdge &fe = fedges[q];
      const double s2 = bodies[fe.body].radius + foreign[fe.node].radius;
      if (fgap[q] <= bound[fe.body] + fstate[(size_t) 4 * fe.node + 3] * delta + MARGIN * s2) {
        fwin.push_back((int) q);
        fjoined[q] = 1;
      }
    }

    uf.reset(nb + nf);
    for (const Edge &e : wedges) uf.unite(e.i, e.j);
    for (int q : fwin) uf.unite(fedges[q].body, nb + fedges[q].node);
    // The largest local group, and the largest part of a boundary group that this rank sees
    // (its local bodies and the foreign nodes joined to them).  A boundary group is weighed
    // against a target of its own, WindowSettings::span_target: each rank sees only its part,
    // and a group threading through many small domains, each part below the step's target,
    // can join most atoms (on 64 ranks of the fluid at 1728 atoms per rank, one group of 42000
    // of 110592 atoms, gathered everywhere; on 64 ranks at 32768 per rank, a run that filled
    // the host's memory).  Returns the larger of the two over all ranks, the boundary part
    // scaled to the step's target, for the chooser; window_seen gets the larger part itself
    // (this rank's only, with fixed windows).
    // The groups themselves are placed by window_groups(), once the window is chosen.
    // (A foreign node joins a group with a body here through a joined foreign edge only (the
    // unions are of the window's edges): the others, most of the ghosts, are alone and weigh
    // nothing here.)
    fill.assign(nb + nf, 0);
    boundary_roots(nb, nf, fedges);    // (as window_groups())
    for (int b = 0; b < nb; ++b) ++fill[uf.find(b)];
    fseen.assign(nf, 0);
    for (int q : fwin) {
      const int f = fedges[q].node;
      if (fseen[f]) continue;
      fseen[f] = 1;
      ++fill[uf.find(nb + f)];
    }
    double l[2] = {0.0, 0.0};
    for (int b = 0; b < nb; ++b) {
      const int r = uf.find(b);
      const int at = isb[r] ? 1 : 0;
      l[at] = std::max(l[at], (double) fill[r]);
    }
    // With fixed or planned windows (WindowSettings::nwindows, step_checks) nothing is chosen
    // from it: the figures are reduced with the step's after the windows, and the window needs
    // no reduction here.
    if (s.nwindows <= 0 && !planned) {
      ScopeTime st(times.edges_reduce);
      ex.max(l, 2);
    }
    window_seen = (long) std::max(l[0], l[1]);
    const double span_target =
        (double) (s.span_target > 0 ? std::min(step_target, s.span_target) : step_target);
    return (long) std::max(l[0], std::ceil(l[1] * (double) step_target / span_target));
  }

  /* The local groups of the window last set up by window_edges() (gstart/gmembers; boundary
     groups are left out, their roots flagged in isb). */
  /* isb: the roots of the window's groups with a foreign node.  A foreign node joins a group
     with a body here through a joined foreign edge only (the unions are of the window's
     edges, fwin's among them), so only those edges' nodes are visited; the others, most of
     the ghosts, are alone (as window_edges() counts them). */
  void WindowDriver::boundary_roots(int nb, int nf, const std::vector<ForeignEdge> &fedges)
  {
    isb.assign(nb + nf, 0);
    for (int q : fwin) isb[uf.find(nb + fedges[q].node)] = 1;
  }

  void WindowDriver::window_groups(int nb, int nf, const std::vector<ForeignEdge> &fedges)
  {
    boundary_roots(nb, nf, fedges);
    group_by_root(uf, nb, &isb, gstart, gmembers, fill, nlocal_groups, group_pos);
  }

  /* A boundary body's gathered entry: its body (nbody values), the number of its window
     partners with a higher ID and with a lower one, its owner's rank, each higher partner's ID
     and image shift (NPARTNER values), each lower one's ID. */
  namespace {
    constexpr int NHEAD = 3;    // after the body: partners above, below, the owner's rank
    constexpr int OWNER_AT = 2;    // the owner's rank, after the body
    /// Slot of an ID (> 0) in a table of mask + 1 (a power of two) slots.
    size_t id_slot(long id, size_t mask)
    {
      return (size_t) (((unsigned long long) id * 0x9E3779B97F4A7C15ULL) >> 20) & mask;
    }
    size_t entry_length(const double *h, int nbody)
    {
      return nbody + NHEAD + (size_t) NPARTNER * (size_t) h[nbody] + (size_t) h[nbody + 1];
    }
  }    // namespace

  /* The gather to the neighbouring ranks: each boundary body's entry (in `send`, at the offsets
     of bsent's bodies) goes to the ranks that own a foreign node of its group here; what they
     send comes back into `recv` after this rank's own entries.  Returns false where the
     exchange has no point-to-point path. */
  bool WindowDriver::neighbour_gather(const std::vector<ForeignNode> &foreign,
                                      const std::vector<ForeignEdge> &fedges, int nb,
                                      int nentry, Exchange &ex, long &mine_off)
  {
    const int nf = (int) foreign.size();
    // (root, rank) of every foreign node in a boundary group of a body of this rank (bchosen);
    // an unknown owner is rank -1.  (The groups of foreign nodes alone, most of the ghosts,
    // are their owners' business: nothing goes from here for them.  The wide sends go to the
    // owners of all foreign nodes, so that no group needs rounds passing entries on.)
    std::vector<char> &mine = gmark;
    mine.assign(nb + nf, gather_wide ? 1 : 0);
    for (int b = 0; b < nb && !gather_wide; ++b)
      if (bchosen[b]) mine[uf.find(b)] = 1;
    rootrank.clear();
    if (gather_wide) {
      for (int k = 0; k < nf; ++k) rootrank.emplace_back(uf.find(nb + k), foreign[k].owner);
    } else {
      // (Those of the joined foreign edges: no other foreign node is in a group with a body
      // here; a node of several comes once after the sort.)
      for (int q : fwin) {
        const int k = fedges[q].node, r = uf.find(nb + k);
        if (mine[r]) rootrank.emplace_back(r, foreign[k].owner);
      }
    }
    std::sort(rootrank.begin(), rootrank.end());
    rootrank.erase(std::unique(rootrank.begin(), rootrank.end()), rootrank.end());
    ndest.clear();
    for (const auto &rr : rootrank)
      if (rr.second >= 0) ndest.push_back(rr.second);
    std::sort(ndest.begin(), ndest.end());
    ndest.erase(std::unique(ndest.begin(), ndest.end()), ndest.end());
    nsend.resize(ndest.size());
    for (auto &v : nsend) v.clear();
    size_t off = 0;
    if (gather_wide)    // every boundary body to every such rank
      for (auto &v : nsend) v = send;
    for (size_t k = 0; !gather_wide && k < bsent.size(); ++k) {
      const int b = bsent[k];
      const size_t len = entry_length(&send[off], nentry);
      const int r = uf.find(b);
      auto it = std::lower_bound(rootrank.begin(), rootrank.end(), std::make_pair(r, -1));
      for (; it != rootrank.end() && it->first == r; ++it) {
        if (it->second < 0) continue;
        const size_t d = std::lower_bound(ndest.begin(), ndest.end(), it->second) - ndest.begin();
        nsend[d].insert(nsend[d].end(), send.begin() + off, send.begin() + off + len);
      }
      off += len;
    }
    unknown_owner = false;
    for (const auto &rr : rootrank) unknown_owner |= rr.second < 0;
    std::vector<double> &got = gotbuf;
    {
      ScopeTime st(times.gather_messages);
      if (!messages(ex, ex.neighbours() != nullptr, ndest, nsend, got)) return false;
    }
    recv = send;
    recv.insert(recv.end(), got.begin(), got.end());
    mine_off = 0;
    return true;
  }

  /* The messages of sendto's (rank, gathered body) pairs: ndest the distinct ranks in order,
     nsend[d] what pack() appends for each body going to ndest[d]. */
  void WindowDriver::fill_destinations(
      const std::function<void(std::vector<double> &, int)> &pack)
  {
    std::sort(sendto.begin(), sendto.end());
    ndest.clear();
    for (const auto &dk : sendto)
      if (ndest.empty() || ndest.back() != dk.first) ndest.push_back(dk.first);
    nsend.resize(ndest.size());
    for (auto &v : nsend) v.clear();
    size_t d = 0;
    for (const auto &dk : sendto) {
      while (ndest[d] != dk.first) ++d;
      pack(nsend[d], dk.second);
    }
  }

  /* The rank that owns gathered body k (from its entry in recv). */
  int WindowDriver::gathered_owner(int k) const
  {
    return (int) recv[gentry[k] + body_values(spin) + OWNER_AT];
  }

  /* The gathered body of ID id (its index in gbodies), or -1. */
  int WindowDriver::gathered_index(long id) const
  {
    const size_t mask = idkey.size() - 1;
    for (size_t h = id_slot(id, mask); idkey[h] != 0; h = (h + 1) & mask)
      if (idkey[h] == id) return idval[h];
    return -1;
  }

  /* The gathered entries in `recv` into gbodies (in ID order), gmine (this rank's body of each,
     -1: another rank's) and gedges (from the higher-ID partner lists).  sparse: a gather to the
     neighbouring ranks, where a partner may be missing (gmissing); else every partner is
     expected (gather_broken where one is not). */
  void WindowDriver::unpack_gathered(long mine_off, bool sparse)
  {
    const int nbody = body_values(spin);
    std::vector<std::pair<long, size_t>> &order = gorder;
    order.clear();
    for (size_t off = 0; off < recv.size(); off += entry_length(&recv[off], nbody))
      order.emplace_back((long) recv[off + ID_AT], off);
    std::sort(order.begin(), order.end());
    // A body's entry may come twice from a gather to the neighbouring ranks (from its owner
    // and passed on by another rank): the same values, kept once.
    order.erase(std::unique(order.begin(), order.end(),
                            [](const std::pair<long, size_t> &a, const std::pair<long, size_t> &b) {
                              return a.first == b.first;
                            }),
                order.end());
    index_gathered(mine_off, sparse);
  }

  /* After rounds passing entries on (unpack_more()): the index in ID order again, as
     unpack_gathered() would make it from the whole of recv, without walking and sorting all
     of it: the first unpack's bodies are in ID order, the ones added since are sorted and
     merged in. */
  void WindowDriver::reorder_gathered(long mine_off, size_t ng0)
  {
    std::vector<std::pair<long, size_t>> &order = gorder;
    order.clear();
    for (size_t k = 0; k < gentry.size(); ++k)
      order.emplace_back((long) recv[gentry[k] + ID_AT], gentry[k]);
    std::sort(order.begin() + (long) ng0, order.end());
    std::inplace_merge(order.begin(), order.begin() + (long) ng0, order.end());
    index_gathered(mine_off, true);
  }

  /* The index of the gathered entries of gorder (in ID order, one per ID; see
     unpack_gathered()). */
  void WindowDriver::index_gathered(long mine_off, bool sparse)
  {
    const int nbody = body_values(spin);
    const std::vector<std::pair<long, size_t>> &order = gorder;
    // The bodies themselves only once the gather is complete, and only those resolved here
    // (unpack_bodies()): the rounds passing entries on need the IDs, partners and owners alone.
    gedges.clear();
    const int ng = (int) order.size();
    gentry.resize(ng);
    for (int k = 0; k < ng; ++k) gentry[k] = order[k].second;
    gmine.assign(ng, -1);
    gmissing.assign(ng, 0);
    // ID -> index: open addressing (IDs are positive), twice as many slots as bodies.
    size_t slots = 16;
    while (slots < 2 * (size_t) ng) slots <<= 1;
    idkey.assign(slots, 0);
    idval.resize(slots);
    for (int k = 0; k < ng; ++k) index_id(order[k].first, k);
    {
      size_t off = (size_t) mine_off;
      for (int b : bsent) {
        gmine[gathered_index((long) recv[off + ID_AT])] = b;
        off += entry_length(&recv[off], nbody);
      }
    }
    for (int k = 0; k < ng; ++k) link_partners(k, 0, sparse);
  }

  /* Gathered body k of ID id into the ID table (idkey/idval, with a free slot). */
  void WindowDriver::index_id(long id, int k)
  {
    const size_t mask = idkey.size() - 1;
    size_t h = id_slot(id, mask);
    while (idkey[h] != 0) h = (h + 1) & mask;
    idkey[h] = id;
    idval[h] = k;
  }

  /* Gathered body k's edges (from its list of partners with a higher ID: an edge is its
     lower-ID body's) to the partners here, except those to a partner below `old` where k is
     below it too (added before); sparse: gmissing[k] says whether a partner of either list is
     not here; else none is expected missing (gather_broken where one is: every rank sees the
     same gathered data and falls back alike). */
  void WindowDriver::link_partners(int k, int old, bool sparse)
  {
    const int nbody = body_values(spin);
    const double *h = &recv[gentry[k]];
    const int nhigh = (int) h[nbody], nlow = (int) h[nbody + 1];
    bool missing = false;
    for (int q = 0; q < nhigh; ++q) {
      const double *o = h + nbody + NHEAD + (size_t) NPARTNER * q;
      const int j = gathered_index((long) o[0]);
      if (j < 0) {
        missing = true;    // sparse: a partner on a rank that is not a neighbour here
        continue;
      }
      if (k < old && j < old) continue;
      Edge e;
      e.i = k;
      e.j = j;
      for (int d = 0; d < 3; ++d) e.shift[d] = o[1 + d];
      gedges.push_back(e);
    }
    if (!sparse) {
      if (missing) gather_broken = true;
      return;
    }
    for (int q = 0; q < nlow && !missing; ++q)
      if (gathered_index((long) h[nbody + NHEAD + (size_t) NPARTNER * nhigh + q]) < 0)
        missing = true;
    gmissing[k] = missing ? 1 : 0;
  }

  /* The entries of recv from offset `from` on (a round passing entries on), added to the
     last unpack_gathered()'s index after its bodies, not in ID order (the rounds need the IDs,
     partners and owners alone; reorder_gathered() puts them in order once the rounds are
     over): entries of bodies not yet here, the edges they bring, and the partners that were
     missing and came. */
  void WindowDriver::unpack_more(size_t from)
  {
    const int nbody = body_values(spin);
    const int old_ng = (int) gentry.size();
    for (size_t off = from; off < recv.size(); off += entry_length(&recv[off], nbody)) {
      const long id = (long) recv[off + ID_AT];
      if (gathered_index(id) >= 0) continue;
      const int k = (int) gentry.size();
      gentry.push_back(off);
      gmine.push_back(-1);
      gmissing.push_back(0);
      if (2 * gentry.size() > idkey.size()) {    // twice as many slots as bodies
        idkey.assign(2 * idkey.size(), 0);
        idval.resize(idkey.size());
        for (int m = 0; m < k; ++m) index_id((long) recv[gentry[m] + ID_AT], m);
      }
      index_id(id, k);
    }
    // The new bodies' edges to any partner here, and the earlier bodies' edges to the new ones
    // (an earlier body whose partners were all here has them all already).
    const int ng = (int) gentry.size();
    for (int k = 0; k < ng; ++k)
      if (k >= old_ng || gmissing[k]) link_partners(k, old_ng, true);
  }

  /* The gathered bodies (gbodies, indexed as the last unpack_gathered()'s entries) of the ngr
     groups of gstart2/gmembers2 from their entries: those resolved here.  The others' places
     hold what they held (no backend reads a body outside the groups it resolves). */
  void WindowDriver::unpack_bodies(int ngr)
  {
    const size_t ng = gentry.size();
    if (gbodies.size() < ng) gbodies.resize(ng);
    for (int m = 0; m < gstart2[ngr]; ++m) {
      Body &b = gbodies[gmembers2[m]];
      unpack_body(&recv[gentry[gmembers2[m]]], b, spin);
      if (!spin)
        for (int d = 0; d < 3; ++d) b.omega[d] = 0.0;    // (smooth spheres: as made)
    }
  }

  /* The boundary groups of the window (bodies in groups that hold a foreign node, or, over
     the view, those marked in gsel), resolved from their window start up to t1.  Each rank
     gathers the entries of the groups' bodies (to the neighbouring ranks where every rank
     then holds each of its groups whole; else from every rank), and resolves the groups that
     hold a body of its own, keeping its own bodies' results.  Each group's tally and figures
     are counted by the rank of its lowest-ID body.  cand: the step's candidate pairs (the
     window's edges are among them, except over the view). */
  void WindowDriver::resolve_boundary(std::vector<Body> &bodies, const std::vector<Edge> &cand,
                                      const std::vector<ForeignEdge> &fedges,
                                      const std::vector<ForeignNode> &foreign, const Params &p,
                                      double t1, CollisionBackend &backend, Exchange &ex, Tally &tb,
                                      long &largest, long &ngroups, long &nbound)
  {
    const int nbody = body_values(spin);
    auto clock = std::chrono::steady_clock::now();
    // Over the view (gather_view): the local bodies of the groups marked in gsel, whose window
    // edges are all among the view's (each sent by the owner of its lower-ID body).
    const int nb = gather_view ? nlocal_bodies : (int) bodies.size();
    bchosen.resize(nb);
    // (Else the bodies in boundary groups: group_of is -1 for them alone (fallback_window()).)
    for (int b = 0; b < nb; ++b) bchosen[b] = gather_view ? gsel[b] != 0 : group_of[b] < 0;
    auto chosen = [&](int b) { return bchosen[b] != 0; };
    // Window partners of each boundary body: those with a higher ID (the edge, sent with its
    // shift) and those with a lower one (their IDs, for the completeness of a gather to the
    // neighbouring ranks).
    // (Scratch kept between calls: these span all nb bodies, every window that gathers.)
    std::vector<int> &pos = ppos;
    pstart.assign(nb + 1, 0);
    lstart.assign(nb + 1, 0);
    // Without the view, from the candidate pairs by body: each boundary body's window edges
    // (bwq[bwstart[c] .. bwstart[c + 1]) for the c-th of them), in the order of wedges (the
    // window's own in ascending order, then those joined since, as they were joined).
    // (Over the view, a walk over wedges.)
    bwq.clear();
    bwstart.assign(1, 0);
    if (!gather_view) {
      incidence(nb, cand);
      for (int b = 0; b < nb; ++b) {
        if (!chosen(b)) continue;
        const size_t first = bwq.size();
        for (int m = inc_start[b]; m < inc_start[b + 1]; ++m)
          if (ljoined[inc_q[m]] == 1) bwq.push_back(inc_q[m]);
        const size_t mid = bwq.size();
        for (int m = inc_start[b]; m < inc_start[b + 1]; ++m)
          if (ljoined[inc_q[m]] == 2) bwq.push_back(inc_q[m]);
        if (bwq.size() - mid > 1)
          std::sort(bwq.begin() + (long) mid, bwq.end(),
                    [&](int x, int y) { return jseq[x] < jseq[y]; });
        bwstart.push_back((int) bwq.size());
        for (size_t m = first; m < bwq.size(); ++m) {
          if (cand[bwq[m]].i == b)
            pstart[b + 1]++;
          else
            lstart[b + 1]++;
        }
      }
    } else {
      for (const Edge &e : wedges) {
        if (e.i < nb && chosen(e.i)) pstart[e.i + 1]++;
        if (e.j < nb && chosen(e.j)) lstart[e.j + 1]++;
      }
    }
    if (!gather_view)
      for (int q : fwin) {
        const ForeignEdge &fe = fedges[q];
        if (foreign[fe.node].id > bodies[fe.body].id)
          pstart[fe.body + 1]++;
        else
          lstart[fe.body + 1]++;
      }
    for (int b = 0; b < nb; ++b) {
      pstart[b + 1] += pstart[b];
      lstart[b + 1] += lstart[b];
    }
    std::vector<double> &partners = bpartners, &lows = blows;
    partners.resize((size_t) NPARTNER * pstart[nb]);
    lows.resize(lstart[nb]);
    pos.assign(pstart.begin(), pstart.end() - 1);
    lpos.assign(lstart.begin(), lstart.end() - 1);
    auto put = [&](int b, long id, const double *shift) {
      double *o = &partners[(size_t) NPARTNER * pos[b]++];
      o[0] = (double) id;
      for (int d = 0; d < 3; ++d) o[1 + d] = shift[d];
    };
    if (!gather_view) {
      int c = 0;
      for (int b = 0; b < nb; ++b) {
        if (!chosen(b)) continue;
        for (int m = bwstart[c]; m < bwstart[c + 1]; ++m) {
          const Edge &e = cand[bwq[m]];
          if (e.i == b)
            put(b, bodies[e.j].id, e.shift);
          else
            lows[lpos[b]++] = (double) bodies[e.i].id;
        }
        ++c;
      }
    } else {
      for (const Edge &e : wedges) {
        if (e.i < nb && chosen(e.i)) put(e.i, bodies[e.j].id, e.shift);
        if (e.j < nb && chosen(e.j)) lows[lpos[e.j]++] = (double) bodies[e.i].id;
      }
    }
    if (!gather_view)
      for (int q : fwin) {
        const ForeignEdge &fe = fedges[q];
        if (foreign[fe.node].id > bodies[fe.body].id)
          put(fe.body, foreign[fe.node].id, fe.shift);
        else
          lows[lpos[fe.body]++] = (double) foreign[fe.node].id;
      }

    send.clear();
    std::vector<int> &sent = bsent;
    sent.clear();
    for (int b = 0; b < nb; ++b) {
      if (!chosen(b)) continue;
      const size_t at = send.size();
      send.resize(at + nbody + NHEAD);
      pack_body(bodies[b], &send[at], spin);
      send[at + nbody] = pstart[b + 1] - pstart[b];
      send[at + nbody + 1] = lstart[b + 1] - lstart[b];
      send[at + nbody + OWNER_AT] = ex.rank();
      send.insert(send.end(), partners.begin() + (size_t) NPARTNER * pstart[b],
                  partners.begin() + (size_t) NPARTNER * pstart[b + 1]);
      send.insert(send.end(), lows.begin() + lstart[b], lows.begin() + lstart[b + 1]);
      sent.push_back(b);
    }
    times.span_pack += lap(clock);
    long mine_off = 0;
    auto group_gathered = [&](int &ngr) {
      UnionFind &guf = gunion;
      guf.reset((int) gentry.size());
      for (const Edge &e : gedges) guf.unite(e.i, e.j);
      group_by_root(guf, (int) gentry.size(), nullptr, gstart2, gmembers2, fill, ngr, group_pos);
    };
    int ngr = 0;
    // To the neighbouring ranks first (more than two ranks: on two, that is everyone), if
    // every rank then holds each group of its own whole; else from every rank.
    // After a gather to the neighbours that ended in the gather from every rank (a pile whose
    // touching spheres join one group over many ranks), the next ones go to every rank at
    // once, for 8 gathers and twice as many after each further such end (at most 64).  The
    // outcome is the same on every rank, and so is this choice.
    bool sparse = false;
    fixed_gather = false;
    if (!gather_view && ex.nranks() > 2) {
      if (neighbour_skip > 0)
        --neighbour_skip;
      else
        sparse = neighbour_gather(foreign, fedges, nb, nbody, ex, mine_off);
    }
    const bool tried = sparse;
    if (sparse) {
      {
        ScopeTime st(times.gather_unpack);
        unpack_gathered(mine_off, true);
        group_gathered(ngr);
      }
      // Whether some rank lacks a partner of a body in a group of its own (a foreign node
      // whose owner is not known counts as such).
      // With it, whether some rank holds a body of a group with a body owned by a rank that
      // is not its neighbour (then the results go to their owners with a consensus, since
      // the rank that resolves the group may not be a neighbour of every owner).
      const std::vector<int> *nbrs = ex.neighbours();
      auto incomplete = [&]() {
        long c[2] = {unknown_owner ? 1L : 0L, 0L};
        for (int g = 0; g < ngr && !(c[0] && (c[1] || !nbrs)); ++g) {
          bool here = false, missing = false, far = false;
          for (int m = gstart2[g]; m < gstart2[g + 1]; ++m) {
            here |= gmine[gmembers2[m]] >= 0;
            missing |= gmissing[gmembers2[m]] != 0;
            if (nbrs) far |= !is_neighbour(*nbrs, gathered_owner(gmembers2[m]), ex.rank());
          }
          if (here && missing) c[0] = 1;
          if (here && far) c[1] = 1;
        }
        ScopeTime st(times.gather_messages);
        ex.sum(c, nbrs ? 2 : 1);
        results_far = !nbrs || c[1] > 0;
        return c[0] > 0;
      };
      // A group over three ranks or more may reach a rank through another one only: each
      // rank passes the entries it holds of such a group of its own on to the group's other
      // ranks (the owners of its bodies).  incremental: an entry goes to a rank once per
      // gather (sentmask, by the rank's place among the neighbours; the first exchange's
      // entries marked as sent); else every round sends all of them again.
      constexpr int FORWARD_ROUNDS = 3;
      bool passed_on = false;
      const size_t first_ng = gentry.size();    // in ID order; unpack_more() adds after them
      const bool fixed = nbrs && fixed_rounds > 0;
      const bool incremental = fixed && nbrs->size() <= 64;
      auto bit = [&](int d) {
        return 1ULL << (std::lower_bound(nbrs->begin(), nbrs->end(), d) - nbrs->begin());
      };
      if (incremental) {
        sentmask.assign(gentry.size(), 0ULL);
        for (size_t k = 0; k < gentry.size(); ++k) {
          if (gmine[k] < 0) continue;
          const int r = uf.find(gmine[k]);
          auto it = std::lower_bound(rootrank.begin(), rootrank.end(), std::make_pair(r, -1));
          for (; it != rootrank.end() && it->first == r; ++it)
            if (it->second >= 0 && it->second != ex.rank()) sentmask[k] |= bit(it->second);
          if (gather_wide)    // (ndest: still the first exchange's destinations)
            for (int d : ndest) sentmask[k] |= bit(d);
        }
      }
      auto pass_on = [&]() {
        ++stats_forwards;
        std::vector<int> owners;
        sendto.clear();
        for (int g = 0; g < ngr; ++g) {
          bool here = false;
          owners.clear();
          for (int m = gstart2[g]; m < gstart2[g + 1]; ++m) {
            const int k = gmembers2[m];
            here |= gmine[k] >= 0;
            owners.push_back(gathered_owner(k));
          }
          std::sort(owners.begin(), owners.end());
          owners.erase(std::unique(owners.begin(), owners.end()), owners.end());
          if (!here || owners.size() < 3) continue;
          for (int d : owners) {
            // (With neighbouring ranks, entries pass on to them only: a group's owners are
            // linked through neighbours, so more rounds reach the others.)
            if (d == ex.rank() || (nbrs && !is_neighbour(*nbrs, d, -1))) continue;
            const unsigned long long db = incremental ? bit(d) : 0ULL;
            for (int m = gstart2[g]; m < gstart2[g + 1]; ++m) {
              const int k = gmembers2[m];
              if (gathered_owner(k) == d) continue;
              if (incremental) {
                if (sentmask[k] & db) continue;
                sentmask[k] |= db;
              }
              sendto.emplace_back(d, k);
            }
          }
        }
        fill_destinations([&](std::vector<double> &o, int k) {
          const double *h = &recv[gentry[k]];
          o.insert(o.end(), h, h + entry_length(h, nbody));
        });
        std::vector<double> &got = gotbuf;
        {
          ScopeTime st(times.gather_messages);
          messages(ex, nbrs != nullptr, ndest, nsend, got);
        }
        if (!got.empty()) {
          ScopeTime st(times.gather_unpack);
          const size_t from = recv.size();
          recv.insert(recv.end(), got.begin(), got.end());
          unpack_more(from);
          group_gathered(ngr);
          if (incremental) sentmask.resize(gentry.size(), 0ULL);
          passed_on = true;
        }
      };
      if (fixed) {
        // A fixed number of rounds, with no reduction: whether every group came whole to the
        // rank that resolves it is known after the results (span_fail), and told in the
        // missed pairs' reduction; where one did not, the boundary groups of the window are
        // gathered again from every rank (join_missed_boundary()).
        // (The wide sends bring a group whole from the first exchange where it reaches no
        // further than the neighbouring ranks: no rounds, but those grown after passes left
        // short.)
        const int rounds = gather_wide ? fixed_rounds - fixed_setting : fixed_rounds;
        for (int round = 0; round < rounds; ++round) pass_on();
        results_far = false;
      } else {
        for (int round = 0;; ++round) {
          sparse = !incomplete();
          if (sparse || round == FORWARD_ROUNDS) break;
          pass_on();
        }
      }
      if (sparse && passed_on) {
        // In ID order again (each group's first member its lowest-ID body, on every rank).
        ScopeTime st(times.gather_unpack);
        reorder_gathered(mine_off, first_ng);
        group_gathered(ngr);
      }
      fixed_gather = fixed;
    }
    if (tried && !fixed_gather) {
      neighbour_skip = sparse ? 0 : neighbour_backoff;
      neighbour_backoff = sparse ? 8 : std::min(2 * neighbour_backoff, 64);
    }
    if (sparse) {
      ++stats_neighbour;
    } else {
      {
        ScopeTime st(times.gather_messages);
        ex.allgather(send, recv, mine_off);
      }
      gedges.clear();
      if (recv.empty()) {
        times.span_gather += lap(clock);
        return;
      }
      ScopeTime st(times.gather_unpack);
      unpack_gathered(mine_off, false);
      group_gathered(ngr);
    }
    const int ng = (int) gentry.size();
    // Only the groups with a body of this rank are resolved here (the others' results would
    // be thrown away): the work per rank follows its own boundary.  Each group's tally and
    // figures are counted by the rank of its lowest-ID body (its first member: gbodies are in
    // ID order).  After a gather to the neighbours that rank alone resolves the group (every
    // rank holding a body of it holds it whole) and sends the other owners their bodies'
    // results; after the gather from every rank, every rank holding a body resolves it.
    long expect = 0;    // this rank's bodies whose results another rank sends
    {
      int nmine = 0, at = 0;
      for (int g = 0; g < ngr; ++g) {
        bool here = false;
        if (sparse) {
          const int first = gmembers2[gstart2[g]];
          here = gmine[first] >= 0;
          if (fixed_gather) {
            // After the fixed rounds, a group is resolved by the rank of its first member
            // where that rank holds it whole (then the first member is the group's lowest-ID
            // body), which sends the results to the neighbouring ranks among its owners; an
            // owner that is not a neighbour of that rank resolves it itself, from the same
            // entries, where it holds it whole (the same result; results_to_owners() sends
            // nothing for it).  Otherwise the window's boundary groups are gathered again
            // (span_fail).
            bool whole = true, holds = here;
            for (int m = gstart2[g]; m < gstart2[g + 1]; ++m) {
              whole &= !gmissing[gmembers2[m]];
              holds |= gmine[gmembers2[m]] >= 0;
            }
            if (here && !whole) {
              here = false;
              span_fail = true;
            } else if (!here && holds &&
                       !is_neighbour(*ex.neighbours(), gathered_owner(first), ex.rank())) {
              here = whole;
              if (!whole) span_fail = true;
            }
          }
          if (!here)
            for (int m = gstart2[g]; m < gstart2[g + 1]; ++m) expect += gmine[gmembers2[m]] >= 0;
        } else {
          for (int m = gstart2[g]; m < gstart2[g + 1] && !here; ++m)
            here = gmine[gmembers2[m]] >= 0;
        }
        if (!here) continue;
        const int len = gstart2[g + 1] - gstart2[g];
        largest = std::max(largest, (long) len);
        if (gmine[gmembers2[gstart2[g]]] >= 0) {
          if (len > 1) ++ngroups;
          nbound += len;
        }
        // Compacted in place: group g's members move down to `at`, g to nmine <= g.
        std::copy(gmembers2.begin() + gstart2[g], gmembers2.begin() + gstart2[g + 1],
                  gmembers2.begin() + at);
        gstart2[nmine] = at;
        at += len;
        ++nmine;
      }
      gstart2[nmine] = at;
      ngr = nmine;
    }
    {
      ScopeTime st(times.gather_unpack);
      unpack_bodies(ngr);
    }
    times.span_gather += lap(clock);    // (the choice of the groups resolved here with it)
    gtally2.assign(ngr, Tally());
    WindowWork w{gbodies.data(),
                 ng,
                 gedges.data(),
                 (int) gedges.size(),
                 gstart2.data(),
                 gmembers2.data(),
                 ngr,
                 t1,
                 gtally2.data()};
    if (tally_virial) {
      gvir.assign(6 * (size_t) ng, 0.0);
      w.body_virial = gvir.data();
    }
    backend.resolve(w, p, tb);
    for (int g = 0; g < ngr; ++g) {
      tb.capped |= gtally2[g].capped;
      if (gmine[gmembers2[gstart2[g]]] >= 0) tb.add(gtally2[g]);
    }
    // (The bodies here of the groups resolved here; the others' results come from their
    // resolvers.)
    for (int m = 0; m < gstart2[ngr]; ++m)
      if (const int k = gmembers2[m]; gmine[k] >= 0) {
        const int owner = bodies[gmine[k]].owner;
        bodies[gmine[k]] = gbodies[k];
        bodies[gmine[k]].owner = owner;
        // Resolved from the window start: its window virial is this resolution's.
        if (tally_virial)
          std::copy(gvir.begin() + 6 * (size_t) k, gvir.begin() + 6 * (size_t) (k + 1),
                    wvir.begin() + 6 * (size_t) gmine[k]);
      }
    times.span_resolve += lap(clock);
    if (sparse && results_to_owners(bodies, ngr, ex) != expect) {
      if (fixed_gather)
        span_fail = true;    // a group resolved nowhere, or whose resolver is not a neighbour
      else
        results_missing = true;
    }
    if (fixed_gather && unknown_owner) span_fail = true;
    times.span_results += lap(clock);
  }

  /* After a gather to the neighbours: the results of the bodies of the ngr groups resolved here
     (gstart2, gmembers2) that other ranks own go to those ranks (ID, result, per-atom virial on
     the steps that tally it), and the results of this rank's bodies that others resolved come
     in.  Returns how many came in. */
  long WindowDriver::results_to_owners(std::vector<Body> &bodies, int ngr, Exchange &ex)
  {
    const int nr = nres(spin), nval = 1 + nr + (virial_all ? 6 : 0);
    sendto.clear();
    for (int g = 0; g < ngr; ++g) {
      // (After fixed rounds, a rank that is not a neighbour of the group's resolver resolves
      // it itself; results go from the resolver, the rank of the first member, only.)
      if (gmine[gmembers2[gstart2[g]]] < 0) continue;
      for (int m = gstart2[g]; m < gstart2[g + 1]; ++m) {
        const int k = gmembers2[m];
        const int r = gathered_owner(k);
        if (r == ex.rank()) continue;
        if (fixed_gather && !is_neighbour(*ex.neighbours(), r, -1)) continue;
        sendto.emplace_back(r, k);
      }
    }
    fill_destinations([&](std::vector<double> &o, int k) {
      const size_t at = o.size();
      o.resize(at + nval, 0.0);
      o[at] = (double) gbodies[k].id;
      pack_result(gbodies[k], &o[at + 1], spin);
      if (virial_all && tally_virial)
        std::copy(gvir.begin() + 6 * (size_t) k, gvir.begin() + 6 * (size_t) (k + 1),
                  o.begin() + at + 1 + nr);
    });
    std::vector<double> &got = gotbuf;
    messages(ex, !results_far, ndest, nsend, got);
    long taken = 0;
    for (size_t off = 0; off + nval <= got.size(); off += nval) {
      const int k = gathered_index((long) got[off]);
      if (k < 0 || gmine[k] < 0) {
        results_missing = true;    // never expected: a result for a body that is not here
        continue;
      }
      unpack_result(&got[off + 1], bodies[gmine[k]], spin);
      if (tally_virial)
        std::copy(got.begin() + off + 1 + nr, got.begin() + off + 1 + nr + 6,
                  wvir.begin() + 6 * (size_t) gmine[k]);
      ++taken;
    }
    return taken;
  }

  /* The bodies at the window start (snap), for the repairs and the passes over the boundary
     groups.  Without walls a body with no window partner cannot have an event in the window's
     first resolution: only the bodies with one are copied (sparse_snap; most of a fluid's are
     alone in a window), with every body's exc2; window_start() gives the others from their
     current state the first time it is asked for them.  whole: every body. */
  void WindowDriver::take_snapshot(const std::vector<Body> &bodies,
                                   const std::vector<ForeignEdge> &fedges, const Params &p,
                                   bool whole)
  {
    const int nb = (int) bodies.size();
    if (snap.capacity() < bodies.size()) snap.reserve(bodies.size() + bodies.size() / 8 + 64);
    for (int f = 0; f < NFACES && !whole; ++f) whole = p.walls.on[f] != 0;
    sparse_snap = !whole;
    if (whole) {
      snap.assign(bodies.begin(), bodies.end());
      return;
    }
    snap.resize(bodies.size());
    snapped.assign(nb, 0);
    start_exc2.resize(nb);
    for (const Edge &e : wedges) snapped[e.i] = snapped[e.j] = 1;
    for (int q : fwin) snapped[fedges[q].body] = 1;
    for (int b = 0; b < nb; ++b) {
      start_exc2[b] = bodies[b].exc2;
      if (snapped[b]) snap[b] = bodies[b];
    }
  }

  /* Body b at the window start.  One not copied by take_snapshot() has had no event in the
     window before the first call for it (every path that resolves a body again takes its start
     from here first): its state then but for what excursions() noted. */
  const Body &WindowDriver::window_start(const std::vector<Body> &bodies, int b)
  {
    if (sparse_snap && !snapped[b]) {
      snap[b] = bodies[b];
      snap[b].exc2 = start_exc2[b];
      snap[b].wexc2 = 0.0;    // as start_points() left it
      snapped[b] = 1;
    }
    return snap[b];
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

  /* Whether candidate pair e, not joined in the window, could have touched in it: a body of
     it moved further than its bound (lexc against bound), and the two together at least the
     pair's gap at the window start. */
  bool WindowDriver::could_touch(const std::vector<Body> &bodies, const Edge &e) const
  {
    if (!(lexc[e.i] > bound[e.i]) && !(lexc[e.j] > bound[e.j])) return false;
    const Body &bi = bodies[e.i], &bj = bodies[e.j];
    const double s2 = bi.radius + bj.radius;
    return !(lexc[e.i] + lexc[e.j] + MARGIN * s2 < window_gap(bi.w0, bj.w0, e.shift, s2));
  }

  /* Candidate pair q (e) joined to the window after its start (a repair, a missed pair):
     into wedges, with its place there (jseq), and into the window's groups. */
  void WindowDriver::join_pair(int q, const Edge &e)
  {
    ljoined[q] = 2;
    jseq[q] = (int) wedges.size();
    wedges.push_back(e);
    uf.unite(e.i, e.j);
  }

  /* Merges the groups that the candidate pairs `failing` (indices into cand) join, and
     resolves the merged sets again from the window start.  A set counts as a repair here only
     where its lowest-ID body is local (a set that spans ranks is resolved again on each rank
     that holds a body of it).  Returns 1 where the event cap stopped it. */
  int WindowDriver::redo_merged(std::vector<Body> &bodies, const std::vector<Edge> &cand,
                                const std::vector<int> &failing, const Params &p, double t1,
                                CollisionBackend &backend, long events_before, long &repairs,
                                long &largest)
  {
    const int ng = nlocal_groups;
    std::vector<char> redo(ng, 0);
    // Merge, and take the merged groups back to the window start.
    for (int q : failing) {
      join_pair(q, cand[q]);
      merged.unite(merged.find(group_of[cand[q].i]), merged.find(group_of[cand[q].j]));
    }
    for (int q : failing) redo[merged.find(group_of[cand[q].i])] = 1;
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
      sub[m] = window_start(bodies, b);
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
    for (int k = 0; k < nsets; ++k) {
      int low = submembers[substart[k]];
      for (int m = substart[k] + 1; m < substart[k + 1]; ++m)
        if (bodies[submembers[m]].id < bodies[low].id) low = submembers[m];
      if (low < nlocal_bodies) ++repairs;
    }
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
      return 1;
    }
    return 0;
  }

  /* The step's candidate pairs by body (counting sort; each body's in ascending order). */
  void WindowDriver::incidence(int nb, const std::vector<Edge> &edges)
  {
    if (inc_ready) return;
    inc_ready = true;
    inc_start.assign(nb + 1, 0);
    for (const Edge &e : edges) {
      ++inc_start[e.i + 1];
      ++inc_start[e.j + 1];
    }
    for (int b = 0; b < nb; ++b) inc_start[b + 1] += inc_start[b];
    inc_q.resize(inc_start[nb]);
    std::vector<int> pos(inc_start.begin(), inc_start.end() - 1);
    for (size_t q = 0; q < edges.size(); ++q) {
      inc_q[pos[edges[q].i]++] = (int) q;
      inc_q[pos[edges[q].j]++] = (int) q;
    }
    qmask.assign((edges.size() + 63) / 64, 0ULL);
  }

  /* visit(q) for each candidate pair of a body in `from`, once, in ascending order of q (the
     order of a walk over all the candidate pairs). */
  template <class Visit> void WindowDriver::visit_pairs(const std::vector<int> &from, Visit visit)
  {
    size_t lo = qmask.size(), hi = 0;
    for (int b : from)
      for (int m = inc_start[b]; m < inc_start[b + 1]; ++m) {
        const size_t w = (size_t) inc_q[m] >> 6;
        qmask[w] |= 1ULL << (inc_q[m] & 63);
        lo = std::min(lo, w);
        hi = std::max(hi, w + 1);
      }
    for (size_t w = lo; w < hi; ++w)
      while (qmask[w]) {
        const int bit = __builtin_ctzll(qmask[w]);
        qmask[w] &= qmask[w] - 1;
        visit((size_t) (w << 6) + (size_t) bit);
      }
  }

  /* A candidate pair that was not joined could only have touched if a body of it moved
     further than its bound and the two moved at least the pair's gap together.  For such
     pairs between two local groups the groups are merged and resolved again from the window
     start, until no such pair is left.  Returns the largest merged group.
     Only the pairs that can pass are visited: at first those of the bodies beyond their
     bounds, then those of the bodies resolved again (the others' excursions, and so their
     pairs' outcome, did not change). */
  long WindowDriver::repair_local(std::vector<Body> &bodies, const std::vector<Edge> &edges,
                                  const Params &p, double t1, CollisionBackend &backend,
                                  long events_before, long &repairs)
  {
    long largest = 0;
    std::vector<int> failing;
    const int nb = (int) bodies.size();
    auto check = [&](size_t q) {
      if (ljoined[q]) return;
      const Edge &e = edges[q];
      const int gi = group_of[e.i], gj = group_of[e.j];
      if (gi < 0 || gj < 0) return;    // a boundary group: checked after its resolution
      if (could_touch(bodies, e)) failing.push_back((int) q);
    };
    // (The first pass walks over every pair where the pairs by body are not made yet: on one
    // rank, a window without repairs makes none.)
    std::vector<int> &from = qfrom;
    from.clear();
    if (inc_ready) {
      for (int b = 0; b < nb; ++b)
        if (lexc[b] > bound[b]) from.push_back(b);
      visit_pairs(from, check);
    } else {
      for (size_t q = 0; q < edges.size(); ++q) check(q);
    }
    for (;;) {
      if (failing.empty()) return largest;
      if (redo_merged(bodies, edges, failing, p, t1, backend, events_before, repairs, largest))
        return largest;
      incidence(nb, edges);
      from.assign(submembers.begin(), submembers.end());
      failing.clear();
      visit_pairs(from, check);
    }
  }

  /* After the boundary groups: the pairs not joined that involve a boundary group or a
     foreign node and could have touched.  They are joined (their local groups become part of
     the boundary groups); every rank sees the same foreign pairs.  Returns the number joined
     over all ranks.  `capped` (whether the event cap stopped a group here) rides in the same
     reduction: it comes back as whether it did on any rank; so does span_fail (a gather to the
     neighbours after fixed rounds left a group of this rank short): `failed` says whether it
     did on any rank, and then every boundary body goes back to the window start too, and the
     next gathers go to every rank. */
  long WindowDriver::join_missed_boundary(std::vector<Body> &bodies, const std::vector<Edge> &edges,
                                          const std::vector<ForeignEdge> &fedges,
                                          const std::vector<ForeignNode> &foreign, Exchange &ex,
                                          int &capped, bool &failed, Check check)
  {
    const int nb = (int) bodies.size();
    if (sparse_now)
      sparse_to_foreign(
          bodies, 1, [&](int b, double *o) { o[0] = lexc[b]; }, fedges, foreign, fexc, ex);
    else
      ex.to_foreign(lexc, 1, fexc);
    long joined = 0;
    // (The pairs of the bodies in boundary groups: the others were repaired already.)
    incidence(nb, edges);
    std::vector<int> &from = qfrom;
    from.clear();
    for (int b = 0; b < nb; ++b)
      if (group_of[b] < 0) from.push_back(b);
    visit_pairs(from, [&](size_t q) {
      if (ljoined[q]) return;
      const Edge &e = edges[q];
      if (group_of[e.i] >= 0 && group_of[e.j] >= 0) return;    // repaired already
      if (!could_touch(bodies, e)) return;
      join_pair(q, e);
      ++joined;
    });
    for (size_t q = 0; q < fedges.size(); ++q) {
      if (fjoined[q]) continue;
      const ForeignEdge &fe = fedges[q];
      const double fx = fexc[fe.node];
      if (!(lexc[fe.body] > bound[fe.body]) && !(fx > fstate[(size_t) 4 * fe.node + 3] * wdelta))
        continue;
      const double s2 = bodies[fe.body].radius + foreign[fe.node].radius;
      if (lexc[fe.body] + fx + MARGIN * s2 < fgap[q]) continue;
      fjoined[q] = 1;
      fwin.push_back((int) q);
      uf.unite(fe.body, nb + fe.node);
      ++joined;
    }
    long c[3] = {joined, capped ? 1L : 0L, span_fail ? 1L : 0L};
    span_fail = false;
    // Local: a pass that another one follows whatever it found (WindowSettings::two_passes):
    // the pairs joined here, every boundary body back to the window start, no reduction (what
    // the pass resolved, its cap and its gathers' outcome are redone).  Kept: this rank's
    // outcome only (planned windows; the caller notes it for the step's reduction), which
    // changes nothing of what the next gathers do.  Reduced: over all ranks.
    if (check == Check::Reduced) ex.sum(c, 3);
    capped = c[1] > 0 ? 1 : 0;
    failed = check != Check::Local && c[2] > 0;
    // A group that did not come whole to its resolver after the fixed rounds (some rank):
    // the window's boundary groups again, from the window start, gathered from every rank
    // (and the next gathers too, as after a gather to the neighbours that ended so).
    if (check == Check::Reduced) {
      if (failed) {
        ++stats_round_fails;
        if (fixed_rounds > 0 && fixed_rounds < MAX_ROUNDS) ++fixed_rounds;
        neighbour_skip = neighbour_backoff;
        neighbour_backoff = std::min(2 * neighbour_backoff, 64);
      } else if (fixed_gather) {
        neighbour_backoff = 8;
      }
    }
    if (check != Check::Local && c[0] == 0 && !failed) return 0;
    // Boundary roots anew; every body in a boundary group (old or new) back to the window
    // start; local groups that joined one leave the local tallies.
    boundary_roots(nb, (int) foreign.size(), fedges);
    for (int b = 0; b < nb; ++b) {
      if (!isb[uf.find(b)]) continue;
      const int g = group_of[b];
      if (g >= 0) {
        gtally[merged.find(g)] = Tally();
        gtally[g] = Tally();
      }
      group_of[b] = -1;
      const int owner = bodies[b].owner;
      bodies[b] = window_start(bodies, b);
      bodies[b].owner = owner;
      if (tally_virial)
        std::fill(wvir.begin() + 6 * (size_t) b, wvir.begin() + 6 * (size_t) (b + 1), 0.0);
    }
    return c[0];
  }

  /* Every foreign node's body of the view as its owner has it at this window start (a
     neighbour communication: LAMMPS's forward communication to the ghosts); the whole body at
     the step's first window, what events change at the others. */
  void WindowDriver::refresh_foreign(std::vector<Body> &bodies, int nb, Exchange &ex, bool whole)
  {
    const int nval = whole ? body_values(spin) : ndyn(spin);
    vsend.resize((size_t) nval * nb);
    for (int b = 0; b < nb; ++b) {
      if (whole)
        pack_body(bodies[b], &vsend[(size_t) nval * b], spin);
      else
        pack_dynamic(bodies[b], &vsend[(size_t) nval * b], spin);
    }
    ex.to_foreign(vsend, nval, vrecv);
    for (size_t k = 0; k < vnode.size(); ++k) {
      Body &fb = bodies[nb + k];
      const double *o = &vrecv[(size_t) nval * vnode[k]];
      if (whole) {
        unpack_body(o, fb, spin);
        fb.owner = -1;
      } else {
        unpack_dynamic(o, fb, spin);
      }
    }
  }

  /* The window [t0, t1) over the view (local bodies and foreign nodes): start points, bounds,
     window edges and groups.  Groups of the view are its connected components; those with a
     local body and no incomplete node come first (nactive of them) and are resolved here, the
     others are kept for repairs that may join them.  A group with a local body and an
     incomplete node can only be resolved by the gather: view_fallback says whether any rank
     has one (the same reduction as the largest group's).  Returns the largest group resolved
     here over all ranks. */
  long WindowDriver::view_edges(std::vector<Body> &bodies, double t0, double t1,
                                const WindowSettings &s, Exchange &ex)
  {
    const int nv = (int) bodies.size(), nb = nlocal_bodies;
    const double delta = t1 - t0;
    start_points(bodies, nv, xedges, true, t0, s);
    bound.resize(nv);
    for (int b = 0; b < nv; ++b) bound[b] = rate[b] * delta;
    wedges.clear();
    ljoined.assign(xedges.size(), 0);
    jseq.resize(xedges.size());
    for (size_t q = 0; q < xedges.size(); ++q) {
      const Edge &e = xedges[q];
      if (egap[q] <= bound[e.i] + bound[e.j] + emargin[q]) {
        wedges.push_back(e);
        ljoined[q] = 1;
      }
    }
    uf.reset(nv);
    for (const Edge &e : wedges) uf.unite(e.i, e.j);
    vroot.assign(nv, 0);
    for (int b = 0; b < nv; ++b) {
      const int r = uf.find(b);
      if (b < nb) vroot[r] |= 1;
      if (!vcomplete[b]) vroot[r] |= 2;
    }
    // The largest group with a local body (resolved here or elsewhere), from the roots' sizes;
    // the groups themselves are made for the chosen window only (view_groups()).
    fill.assign(nv, 0);
    long largest = 0;
    int fb = 0;
    for (int b = 0; b < nv; ++b) {
      const int r = uf.find(b);
      ++fill[r];
    }
    for (int b = 0; b < nv; ++b) {
      if (uf.find(b) != b) continue;
      if (vroot[b] & 1) largest = std::max(largest, (long) fill[b]);
      if (vroot[b] == 3) fb = 1;
    }
    double l[2] = {(double) largest, (double) fb};
    ex.max(l, 2);
    view_fallback = l[1] != 0.0;
    return (long) l[0];
  }

  /* The groups of the chosen window (view_edges()' last call): connected components of the
     view, those with a local body and no incomplete node first (nactive of them, resolved
     here), then the others (kept for repairs that may join them), each in order of its first
     body, members in body order. */
  void WindowDriver::view_groups(int nv, int nb)
  {
    // Group numbers: resolved here first, then the others, each in order of their first body.
    fill.assign(nv, -1);
    int ng = 0;
    for (int b = 0; b < nv; ++b) {
      const int r = uf.find(b);
      if (vroot[r] == 1 && fill[r] < 0) fill[r] = ng++;
    }
    nactive = ng;
    for (int b = 0; b < nv; ++b) {
      const int r = uf.find(b);
      if (fill[r] < 0) fill[r] = ng++;
    }
    nlocal_groups = ng;
    gstart.assign(ng + 1, 0);
    for (int b = 0; b < nv; ++b) gstart[fill[uf.find(b)] + 1]++;
    gloc.assign(ng, 0);
    for (int b = 0; b < nb; ++b) gloc[fill[uf.find(b)]] = 1;
    for (int g = 0; g < ng; ++g) gstart[g + 1] += gstart[g];
    gmembers.resize(nv);
    {
      std::vector<int> pos(gstart.begin(), gstart.end() - 1);
      for (int b = 0; b < nv; ++b) gmembers[pos[fill[uf.find(b)]]++] = b;
    }
    gact.assign(ng, 0);
    ginc.assign(ng, 0);
    for (int g = 0; g < ng; ++g) {
      gact[g] = g < nactive;
      ginc[g] = (vroot[uf.find(gmembers[gstart[g]])] & 2) != 0;
    }
  }

  /* Repairs over the view (repair_local()'s check and merge): the candidate pairs not joined
     that touch a group resolved here and could have touched.  Both ends' excursions are
     known: a foreign node's comes from its owner, which resolved its group (the same bits
     where it was resolved here too), so every rank that resolves a group finds the same
     pairs.  A pair that would join a group with an incomplete node needs the gather: returns
     -1, and every rank does, from one reduction per pass.  Else returns 1 where the event cap
     stopped some rank, 0 when no pair is left. */
  int WindowDriver::repair_view(std::vector<Body> &bodies, const Params &p, double t1,
                                CollisionBackend &backend, Exchange &ex, long events_before,
                                int capped, long &repairs, long &largest)
  {
    const int nv = (int) bodies.size(), nb = nlocal_bodies;
    std::vector<int> failing;
    for (int pass = 0;; ++pass) {
      if (ex.nranks() > 1) {
        // Excursions, with what the window's events changed: where this pass finds nothing
        // to repair, the foreign copies are then up to date for the next window.
        const int nval = 1 + ndyn(spin);
        vsend.resize((size_t) nval * nb);
        for (int b = 0; b < nb; ++b) {
          vsend[(size_t) nval * b] = lexc[b];
          pack_dynamic(bodies[b], &vsend[(size_t) nval * b + 1], spin);
        }
        ex.to_foreign(vsend, nval, vrecv);
        for (int k = 0; k < nv - nb; ++k) {
          const double *o = &vrecv[(size_t) nval * vnode[k]];
          lexc[nb + k] = o[0];
          unpack_dynamic(o + 1, bodies[nb + k], spin);
        }
        fresh = true;
      }
      failing.clear();
      long need = 0;
      for (size_t q = 0; q < xedges.size(); ++q) {
        if (ljoined[q]) continue;
        const Edge &e = xedges[q];
        const int gi = merged.find(group_of[e.i]), gj = merged.find(group_of[e.j]);
        // Pairs of groups resolved here, from the view or gathered (a gathered group's
        // pairs are checked by the owners of its bodies).
        if (!gact[gi] && !gact[gj] && !(e.i < nb && ggat[gi]) && !(e.j < nb && ggat[gj])) continue;
        if (!could_touch(bodies, e)) continue;
        failing.push_back((int) q);
        // A merge that some rank holding a body of it could not resolve from its view.
        if (!gsafe[gi] || !gsafe[gj]) need = 1;
      }
      if (gather_broken) need = 1;
      long c[3] = {(long) failing.size(), need, capped ? 1L : 0L};
      ex.sum(c, 3);
      if (c[1] > 0) return -1;
      if (c[2] > 0) return 1;
      if (c[0] == 0) return 0;
      if (failing.empty()) continue;    // other ranks repair; nothing here changes
      capped =
          redo_merged(bodies, xedges, failing, p, t1, backend, events_before, repairs, largest);
      for (int g : subgroups) gact[merged.find(g)] = gsafe[merged.find(g)] = 1;
    }
  }

  /* A window resolved as before this view existed: local groups here, groups that reach a
     foreign node gathered from every rank and resolved on all of them (bodies holds the local
     bodies only).  Every rank takes this path for the same windows. */
  void WindowDriver::fallback_window(std::vector<Body> &bodies, const std::vector<Edge> &edges,
                                     const std::vector<ForeignEdge> &fedges,
                                     const std::vector<ForeignNode> &foreign, const Params &p,
                                     const WindowSettings &s, CollisionBackend &backend,
                                     Exchange &ex, double t0, double t1, Tally &tloc, Tally &tbnd,
                                     int &capped, long (&acc)[5], long &largest, bool edges_made)
  {
    const int nb = (int) bodies.size();
    auto clock = std::chrono::steady_clock::now();
    if (!edges_made) {
      start_cached = false;
      window_edges(bodies, edges, fedges, foreign, t0, t1, s, ex);
      largest = std::max(largest, window_seen);
      times.edges += lap(clock);
    }
    window_groups(nb, (int) foreign.size(), fedges);
    times.groups += lap(clock);
    // Local groups, each with its own tally (a repair replaces a group's tally).
    // (Planned windows keep the first window's snapshot, the step start, in step_start: that
    // one whole; not where the caller can make the step's bodies again, step_source().)
    const bool keep_start = planned && !remake_step;
    if (keep_start && t0 > 0.0 && !step_kept) {
      snap.swap(step_start);
      step_kept = true;
    }
    take_snapshot(bodies, fedges, p, keep_start && t0 == 0.0);
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
    largest = std::max(largest, repair_local(bodies, edges, p, t1, backend, tloc.events, repairs));
    times.local += lap(clock);
    // Boundary groups, the same on every rank; repaired until no missed pair is left.
    long bl = 0, bg = 0, nbound = 0, joined_all = 0;
    const Tally tbnd_start = tbnd;
    // Whether the event cap stopped a group here (the local groups' tallies and the boundary
    // groups' of the last pass); over all ranks, in the missed pairs' reduction of the last
    // pass (which joins nothing, so no tally changes after it).
    auto capped_here = [&]() {
      int cp = cap.capped | tbnd.capped;
      for (int g = 0; g < nlocal_groups; ++g) cp |= gtally[g].capped;
      return cp;
    };
    int capped_all = 0;
    // With the halved bounds at the ranks' edges most windows take a second pass anyway: with
    // WindowSettings::two_passes every window makes two, and only the second one's check is
    // reduced (the first one's joined pairs are each rank's own, the same on both ranks of a
    // pair across them; they are summed with the step's figures).
    // (The same on every rank: a rank without bodies makes the same passes.)
    const bool two = s.two_passes && edge_bounds;
    long joined_here = 0;
    // With planned windows (two passes) the second pass's outcome stays on the rank: where it
    // joined pairs, or something else went wrong, the step is done again (run()).
    for (int pass = 0; ex.nranks() > 1; ++pass) {
      tbnd = tbnd_start;
      bl = bg = nbound = 0;
      resolve_boundary(bodies, edges, fedges, foreign, p, t1, backend, ex, tbnd, bl, bg, nbound);
      auto join_clock = std::chrono::steady_clock::now();
      excursions(bodies, t1, &bsent);    // the others are as the local pass left them
      capped_all = capped_here();
      bool failed = false;
      const Check check = two && pass == 0 ? Check::Local : planned ? Check::Kept : Check::Reduced;
      const long joined =
          join_missed_boundary(bodies, edges, fedges, foreign, ex, capped_all, failed, check);
      times.span_join += lap(join_clock);
      ++stats_gathers;
      if (check == Check::Local) {
        joined_here += joined;
        continue;
      }
      if (check == Check::Kept) {
        joined_here += joined;
        if (joined > 0 || failed || capped_all) planned_bad = true;
        capped_all = 0;    // the next windows go on; the step is done again anyway
        break;
      }
      if (joined == 0 && !failed) break;
      joined_all += joined;
    }
    times.spanning += lap(clock);
    if (tally_virial)
      for (size_t k = 0; k < 6 * (size_t) nb; ++k) body_virial_out[k] += wvir[k];
    long ngroups = 0;
    for (int g = 0; g < nlocal_groups; ++g) {
      tloc.add(gtally[g]);
      if (gtally[g].events > 0) ++ngroups;
    }
    capped = ex.nranks() > 1 ? capped_all : capped_here();
    largest = std::max(largest, bl);
    // The boundary groups' figures are counted by the rank of each one's lowest-ID body; the
    // joined pairs, the same on every rank, on rank 0.
    acc[0] += ngroups + bg;
    acc[1] += repairs + (ex.rank() == 0 ? joined_all : 0) + joined_here;
    acc[2] += nbound;
    acc[4] += nbound;
  }

  void WindowDriver::run(std::vector<Body> &bodies, const std::vector<Edge> &edges,
                         const std::vector<ForeignEdge> &fedges,
                         const std::vector<ForeignNode> &foreign, const Params &p,
                         const WindowSettings &s, CollisionBackend &backend, Exchange &ex,
                         Tally &mine, WindowStats &stats, double *body_virial,
                         const std::vector<Edge> *foreign_pairs)
  {
    auto run_clock = std::chrono::steady_clock::now();
    tally_virial = body_virial != nullptr;
    body_virial_out = body_virial;
    spin = p.friction != 0;    // rough spheres: the exchanges carry the spins
    const int nb = (int) bodies.size(), nf = (int) foreign.size();
    // The view's foreign nodes: those in some candidate pair (the others join nothing).
    vslot.assign(nf, -1);
    vnode.clear();
    auto slot = [&](int f) {
      if (vslot[f] < 0) {
        vslot[f] = nb + (int) vnode.size();
        vnode.push_back(f);
      }
      return vslot[f];
    };
    // (With the count: whether some rank tallies per-atom virials; a rank without bodies has
    // no buffer for them, and the results sent to owners must be the same size everywhere.)
    long counts[2] = {(long) nb, tally_virial ? 1L : 0L};
    // With them (the same reduction), the fastest drift speed.
    double vmax = 0.0;
    for (const Body &b : bodies) vmax = std::max(vmax, Contact::dot3(b.v, b.v));
    ex.max_sum(&vmax, 1, counts, 2);
    const long target = WindowChooser::target(s, counts[0]);
    step_target = target;
    const bool virial_step = counts[1] > 0;
    virial_all = virial_step;
    results_missing = false;
    // Every body's window bound assumes at least a quarter of the fastest drift speed: a body
    // at rest that is hit moves about as fast as what hit it, and a bound of zero would make
    // every such hit a repair (in a settled pile, of the whole pile).
    speed_floor = floor_fraction_or(s, 0.25) * std::sqrt(vmax);
    stats = WindowStats();
    start_checked = start_differ = 0;
    stats_gathers = 0;
    stats_neighbour = 0;
    stats_forwards = 0;
    stats_round_fails = 0;
    span_fail = false;
    gather_wide = s.gather_wide;
    // The rounds of a gather start at the setting's and grow by one after each pass that they
    // left short (up to MAX_ROUNDS): every rank knows of such a pass (a reduction tells it), so
    // every rank makes the same rounds.
    if (s.fixed_rounds != fixed_setting) {
      fixed_setting = s.fixed_rounds;
      fixed_rounds = s.fixed_rounds;
    }

    // The view: local bodies [0, nb), foreign nodes [nb, nv); its candidate pairs with the
    // lower ID first.
    // Without foreign_pairs (or on one rank) there is no view: every window as before it.
    const bool use_view = ex.nranks() > 1 && foreign_pairs != nullptr;
    // The bodies next to another rank's atoms (WindowSettings::edge_factor): those with a
    // candidate partner owned by another rank, and edge_hops candidate pairs further.  On three
    // ranks or more, where the gathers go to the neighbouring ranks; not over the view, whose
    // foreign nodes' bounds each rank forms itself.
    // Where planned windows gave way because halving them did not shrink the largest group
    // (plan_gave_way: touching spheres, a settled pile, are one group however short the
    // window), the bounds are not halved at the ranks' edges either until planning is tried
    // again: they cannot shrink such a group, and they made each of its windows take two passes,
    // the pile resolved twice (a settled pile of 16384 atoms on 4 ranks of a 16-core host: 2.6
    // passes and 213-273 ms per step against 1.3 and 106-112 ms; the same bits).
    near_edge.clear();
    const bool pile = plan_gave_way && planned_skip > 0;
    edge_bounds = ex.nranks() > 2 && !use_view && s.edge_factor != 1.0 &&
                  !(s.join_all && s.nwindows == 1) && !pile;
    if (edge_bounds) {
      near_edge.assign(nb, 0);
      for (const ForeignEdge &fe : fedges) near_edge[fe.body] = 1;
      for (int h = 0; h < s.edge_hops; ++h) {
        near_next.assign(near_edge.begin(), near_edge.end());
        for (const Edge &e : edges)
          if (near_edge[e.i] || near_edge[e.j]) near_next[e.i] = near_next[e.j] = 1;
        near_edge.swap(near_next);
      }
    }
    nlocal_bodies = nb;
    xedges.clear();
    if (use_view) xedges.assign(edges.begin(), edges.end());
    for (size_t q = 0; use_view && q < fedges.size(); ++q) {
      const ForeignEdge &fe = fedges[q];
      Edge e;
      const int node = slot(fe.node);
      const bool body_first = bodies[fe.body].id < foreign[fe.node].id;
      e.i = body_first ? fe.body : node;
      e.j = body_first ? node : fe.body;
      for (int d = 0; d < 3; ++d) e.shift[d] = body_first ? fe.shift[d] : -fe.shift[d];
      xedges.push_back(e);
    }
    if (use_view)
      for (const Edge &fp : *foreign_pairs) {
        Edge e = fp;
        e.i = slot(fp.i);
        e.j = slot(fp.j);
        xedges.push_back(e);
      }
    const int nv = nb + (int) vnode.size();
    vcomplete.assign(nv, 1);
    for (int k = 0; k < nv - nb; ++k) vcomplete[nb + k] = foreign[vnode[k]].complete ? 1 : 0;
    bodies.resize(nv);

    // Planned windows (WindowSettings::step_checks): no reduction until the step's after
    // them; where that says some rank's went wrong, the step again from its start, with a
    // reduction per window, and so the next steps (the outcome is the same on every rank, and
    // so is this choice).
    planned = s.step_checks && ex.nranks() > 2 && edge_bounds && s.two_passes &&
              s.fixed_rounds > 0 && ex.neighbours() != nullptr && neighbour_skip == 0 &&
              planned_skip == 0 && !use_view;
    if (planned_skip > 0) --planned_skip;
    // (The foreign nodes' values by messages to the neighbouring ranks: planned windows only,
    // whose step is done again where one did not bring what a rank expects.)
    sparse_now = planned && s.sparse_foreign;    // (planned: the neighbours are known)
    sparse_drop = s.sparse_drop;
    sf_ready = false;
    inc_ready = false;
    times.before += lap(run_clock);
    run_windows(bodies, edges, fedges, foreign, p, s, backend, ex, mine, stats, nb, nv, use_view,
                target);
    if (planned && planned_bad) {
      // The bodies as the caller made them, or the first window's snapshot (its start points
      // are made again).
      if (remake_step) {
        remake_step(bodies);
      } else {
        const std::vector<Body> &start = step_kept ? step_start : snap;
        bodies.assign(start.begin(), start.end());
      }
      if (tally_virial) std::fill(body_virial, body_virial + 6 * (size_t) nb, 0.0);
      planned = false;
      sparse_now = false;
      planned_skip = planned_backoff;
      planned_backoff = std::min(2 * planned_backoff, 64);
      run_windows(bodies, edges, fedges, foreign, p, s, backend, ex, mine, stats, nb, nv, use_view,
                  target);
      stats.step_redos = 1;
    } else if (planned) {
      planned_backoff = 8;
    }
    stats.start_checked = start_checked;
    stats.start_differ = start_differ;
  }

  /* The windows of the step (run() has set the step up), and the step's one reduction after
     them.  With planned windows (`planned`) no reduction before it. */
  void WindowDriver::run_windows(std::vector<Body> &bodies, const std::vector<Edge> &edges,
                                 const std::vector<ForeignEdge> &fedges,
                                 const std::vector<ForeignNode> &foreign, const Params &p,
                                 const WindowSettings &s, CollisionBackend &backend, Exchange &ex,
                                 Tally &mine, WindowStats &stats, int nb, int nv, bool use_view,
                                 long target)
  {
    const double dt = p.dt;
    const int nf = (int) foreign.size();
    const bool virial_step = virial_all;
    double *body_virial = body_virial_out;
    Tally tloc, tbnd;
    // groups, repairs, boundary bodies, spanning groups resolved here, bodies gathered
    long acc[5] = {0, 0, 0, 0, 0};
    long largest_all = 0;
    double t0 = 0.0;
    planned_bad = false;
    double planned_ratio = 0.0;    // the largest group over the target, planned windows
    step_kept = false;
    if (!planned) chooser.start_step(dt);
    int k = 0;
    bool whole = true;    // the next refresh sends whole bodies
    while (t0 < dt && !use_view) {
      // No view: local groups here, boundary groups gathered, as before the view existed.
      long largest;
      start_cached = false;
      auto clock = std::chrono::steady_clock::now();
      auto try_window = [&](double t) {
        return window_edges(bodies, edges, fedges, foreign, t0, t, s, ex);
      };
      double t1;
      if (planned) {
        t1 = s.nwindows > 0 ? chooser.first_end(t0, k, dt, s) : chooser.planned_end(t0, dt);
        largest = try_window(t1);
        planned_ratio = std::max(planned_ratio, (double) largest / (double) target);
      } else {
        t1 = chooser.next(t0, k, dt, s, target, try_window, largest);
      }
      times.edges += lap(clock);
      largest_all = std::max(largest_all, window_seen);
      int capped = 0;
      fallback_window(bodies, edges, fedges, foreign, p, s, backend, ex, t0, t1, tloc, tbnd, capped,
                      acc, largest_all, true);
      // (The plan also weighs the groups resolved whole here, a spanning group's too: a small
      // pile over many ranks, each rank's part of it below the spanning target, is one group
      // that halving does not shrink, and planning gives way.)
      if (planned) planned_ratio = std::max(planned_ratio, (double) largest_all / (double) target);
      ++k;
      if (capped) {
        tloc.capped = 1;
        break;
      }
      t0 = t1;
    }
    while (t0 < dt) {
      // The foreign copies are current where the last window's check brought them.
      auto clock = std::chrono::steady_clock::now();
      if (whole || !fresh) refresh_foreign(bodies, nb, ex, whole);
      whole = false;
      fresh = false;
      times.groups += lap(clock);
      long largest;
      start_cached = false;    // a new window start: view_edges() computes its start points
      const double t1 = chooser.next(
          t0, k, dt, s, target, [&](double t) { return view_edges(bodies, t0, t, s, ex); },
          largest);
      times.edges += lap(clock);
      largest_all = std::max(largest_all, largest);
      view_groups(nv, nb);
      times.groups += lap(clock);
      int capped = 0;
      bool gather = false;    // the whole window by the old path
      if (!gather) {
        // The groups resolved here, each with its own tally (a repair replaces a group's).
        take_snapshot(bodies, fedges, p, true);    // (the view's foreign copies too)
        const int ng = nlocal_groups;
        group_of.resize(nv);
        for (int g = 0; g < ng; ++g)
          for (int m = gstart[g]; m < gstart[g + 1]; ++m) group_of[gmembers[m]] = g;
        gtally.assign(ng, Tally());
        gsafe.assign(ng, 0);
        ggat.assign(ng, 0);
        for (int g = 0; g < ng; ++g) gsafe[g] = !ginc[g];
        vflag.assign(nv - nb, 0);
        if (view_fallback) {
          // Some rank does not see a group of its own whole: the bodies of such groups are
          // flagged to the ghosts.  A rank that holds a body of the group and sees it whole
          // resolves it and sends the flagged bodies' results to their owners; a group that
          // no rank holding a body of it sees whole is gathered.
          vsend.resize(nb);
          for (int b = 0; b < nb; ++b) vsend[b] = ginc[group_of[b]] ? 1.0 : 0.0;
          ex.to_foreign(vsend, 1, fexc);
          for (int k = 0; k < nv - nb; ++k)
            if (fexc[vnode[k]] != 0.0) {
              vflag[k] = 1;
              gsafe[group_of[nb + k]] = 0;
            }
          for (int g = 0; g < ng; ++g)
            if (gloc[g] && ginc[g]) ggat[g] = 1;
        }
        Tally cap;
        cap.events = tloc.events;
        if (tally_virial) wvir.assign(6 * (size_t) nv, 0.0);
        {
          WindowWork w{
              bodies.data(), nv, wedges.data(), (int) wedges.size(), gstart.data(), gmembers.data(),
              nactive,       t1, gtally.data()};
          if (tally_virial) w.body_virial = wvir.data();
          backend.resolve(w, p, cap);
        }
        times.local += lap(clock);
        Tally tgw;
        long bl = 0, bg = 0, nbound = 0;
        gather_broken = false;
        if (view_fallback) {
          // To the owners: flag, result, per-atom virial on the steps that tally it.
          const int nr = nres(spin), nval = 1 + nr + (virial_step ? 6 : 0);
          vfsend.assign((size_t) nval * nf, 0.0);
          for (int k = 0; k < nv - nb; ++k) {
            if (!vflag[k] || !gact[group_of[nb + k]]) continue;
            double *o = &vfsend[(size_t) nval * vnode[k]];
            o[0] = (double) bodies[nb + k].id;    // the flag: the body's ID, checked there
            pack_result(bodies[nb + k], o + 1, spin);
            if (tally_virial)
              std::copy(wvir.begin() + 6 * (size_t) (nb + k),
                        wvir.begin() + 6 * (size_t) (nb + k + 1), o + 1 + nr);
          }
          ex.to_owner(vfsend, nval, nb, vfrecv);
          std::vector<int> got(ng, 0), want(ng, 0);
          bool misrouted = false;
          for (int b = 0; b < nb; ++b) {
            const int g = group_of[b];
            if (!ggat[g]) continue;
            ++want[g];
            const double *o = &vfrecv[(size_t) nval * b];
            if (o[0] == 0.0) continue;
            if (o[0] != (double) bodies[b].id) {
              misrouted = true;    // never expected: the old path then
              continue;
            }
            ++got[g];
            unpack_result(o + 1, bodies[b], spin);
            if (tally_virial)
              std::copy(o + 1 + nr, o + 1 + nr + 6, wvir.begin() + 6 * (size_t) b);
          }
          long c[2] = {0, 0};
          gsel.assign(nb, 0);
          for (int b = 0; b < nb; ++b) {
            const int g = group_of[b];
            if (ggat[g] && got[g] == 0) gsel[b] = 1;
          }
          for (int g = 0; g < ng; ++g) {
            if (!ggat[g]) continue;
            if (got[g] == 0)
              c[0] = 1;
            else if (got[g] != want[g])
              c[1] = 1;    // never expected: the old path then
          }
          if (misrouted) c[1] = 1;
          ex.sum(c, 2);
          if (c[1] > 0) gather_broken = true;
          if (c[0] > 0) {
            gather_view = true;
            resolve_boundary(bodies, edges, fedges, foreign, p, t1, backend, ex, tgw, bl, bg,
                             nbound);
            gather_view = false;
            ++stats_gathers;
          }
        }
        times.spanning += lap(clock);
        excursions(bodies, t1);
        merged.reset(ng);
        long repairs = 0, rl = 0;
        const int r = repair_view(bodies, p, t1, backend, ex, tloc.events, cap.capped | tgw.capped,
                                  repairs, rl);
        largest_all = std::max({largest_all, rl, bl});
        times.local += lap(clock);
        if (r < 0) {
          // A repair reaches an incomplete node somewhere: the window again, with the gather.
          for (int b = 0; b < nv; ++b) bodies[b] = snap[b];
          gather = true;
        } else {
          capped = r;
          // Each group's tally once over the ranks: by the rank of its lowest-ID body.
          std::vector<long> low(ng, 0);
          std::vector<int> lowb(ng, -1);
          std::vector<char> spans(ng, 0);
          std::vector<int> size(ng, 0);
          for (int g = 0; g < ng; ++g) {
            const int rt = merged.find(g);
            if (!gact[rt]) continue;
            for (int m = gstart[g]; m < gstart[g + 1]; ++m) {
              const int b = gmembers[m];
              if (b >= nb) spans[rt] = 1;
              // Among the bodies whose owners resolve the group (not flagged).
              if (b >= nb && vflag[b - nb]) continue;
              if (lowb[rt] < 0 || bodies[b].id < low[rt]) {
                low[rt] = bodies[b].id;
                lowb[rt] = b;
              }
            }
            size[rt] += gstart[g + 1] - gstart[g];
          }
          for (int g = 0; g < ng; ++g) {
            if (merged.find(g) != g || !gact[g]) continue;
            if (lowb[g] >= nb) continue;
            tloc.add(gtally[g]);
            if (gtally[g].events > 0) ++acc[0];
            if (spans[g]) {
              ++acc[3];
              acc[2] += size[g];
            }
          }
          acc[1] += repairs;
          // The gathered groups' tallies and figures by the rank of each one's lowest-ID body.
          tbnd.add(tgw);
          acc[0] += bg;
          acc[2] += nbound;
          acc[4] += nbound;
          if (tally_virial)
            for (size_t q = 0; q < 6 * (size_t) nb; ++q) body_virial[q] += wvir[q];
        }
      }
      if (gather) {
        ++stats.fallbacks;
        bodies.resize(nb);    // the foreign copies are made whole again at the next window
        whole = true;
        fallback_window(bodies, edges, fedges, foreign, p, s, backend, ex, t0, t1, tloc, tbnd,
                        capped, acc, largest_all, false);
        bodies.resize(nv);
      }
      ++k;
      if (capped) {
        tloc.capped = 1;
        break;
      }
      t0 = t1;
    }
    bodies.resize(nb);
    stats.windows = k;
    stats.gathers = stats_gathers;
    stats.neighbour = stats_neighbour;
    stats.forwards = stats_forwards;
    stats.round_fails = stats_round_fails;
    // The step's figures over all ranks: one reduction per step (with, for planned windows,
    // whether some rank's went wrong, and their largest group over the target).
    if (planned && results_missing) planned_bad = true;    // the step again will tell
    double l[3] = {(double) largest_all, planned_bad ? 1.0 : 0.0, planned_ratio};
    {
      ScopeTime st(times.after);
      ex.max_sum(l, 3, acc, 5);
    }
    planned_bad = l[1] > 0.0;
    // (Where planning stops, the chooser's own windows, with their reductions, for the next
    // 64 steps, twice as many after each further such stop, at most 1024.)
    if (planned && !planned_bad) {
      if (chooser.plan_feedback(l[2])) {
        plan_backoff = 64;
        plan_gave_way = false;
      } else {
        planned_skip = plan_backoff;
        plan_backoff = std::min(2 * plan_backoff, 1024);
        plan_gave_way = true;
      }
    }
    if (planned_bad) results_missing = false;
    stats.largest_group = (long) l[0];
    stats.groups = acc[0];
    stats.repairs = acc[1];
    stats.boundary_bodies = acc[2];
    stats.spanning = acc[3];
    stats.gathered = acc[4];
    mine = tloc;
    mine.add(tbnd);
  }

}    // namespace Collide
}    // namespace HSGPU
