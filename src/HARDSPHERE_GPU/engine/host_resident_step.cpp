/* HARDSPHERE_GPU collision engine: the host's reference resident step (see resident_step.h).

   The whole step of one rank's bodies on the host, through the same pieces the fix's own
   host path uses (the step driver with the CPU backend, or the serial loop in order serial),
   behind the ResidentStep interface that the CUDA step implements.  It exists so that the
   code around a resident step (fix hardsphere's device step on one rank, and its gathered
   step of several ranks) runs and is tested where no device is present; it is not faster than
   the fix's host path.  Its candidate search tests every pair (O(n^2)).

   It declines where the CUDA step declines (an overlap at the start, the event cap) and, more
   often, where the step's check would look further: any body that moved further than its
   step bound or than the reach (the CUDA step looks for the pairs that could have touched and
   does the step again with raised bounds).  A declined step is resolved by the caller, from
   the same start, as always. */
#include "resident_step.h"

#include "core/collision_step.h"
#include "core/event_order.h"
#include "core/verlet_motion.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>

namespace HSGPU {
namespace Collide {

  namespace {

    double seconds_since(std::chrono::steady_clock::time_point t0)
    {
      return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    }

    class HostResidentStep : public ResidentStep {
     public:
      void run_atoms(const ResidentAtoms &a, const ResidentBox &box, const Params &p,
                     const WindowSettings &s, Tally &tally, ResidentReport &report) override
      {
        const auto t0 = std::chrono::steady_clock::now();
        report = ResidentReport();
        later = Later();    // an undelivered step's results are dropped
        const int n = a.n;
        const double dt = p.dt;
        // The forces of atom i (zeros where the caller says there are none: f is not read).
        static const double none[3] = {0.0, 0.0, 0.0};
        auto force = [&](int i) { return a.zero_forces ? none : a.f + 3 * i; };
        // x and v: the caller's, or the kept copies moved as the integrator moves the caller's
        // (ResidentAtoms::motion), as the CUDA step does.
        const KeptMotion &m = a.motion;
        const bool own = !a.results && !a.omega && !a.inputs_shared;
        report.motion = motion_begin(a, own);
        // A step run ahead never reads the caller's x and v (as the CUDA step).
        if (a.defer_writes && report.motion != MotionUse::predict) return;
        if (report.motion == MotionUse::check) compare_motion(a, report);
        // advance: the caller's x and v, as they were at the last step's forces, moved here.
        if (report.motion == MotionUse::advance) {
          kx.assign(a.x, a.x + 3 * (size_t) n);
          kv.assign(a.v, a.v + 3 * (size_t) n);
        }
        const bool moved =
            report.motion == MotionUse::predict || report.motion == MotionUse::advance;
        if (moved)
          for (int i = 0; i < n; ++i)
            move_between_steps(&kx[3 * i], &kv[3 * i], force(i), a.rmass[i], m.move, m.fused);
        const double *xin = moved ? kx.data() : a.x, *vin = moved ? kv.data() : a.v;
        // The step budget's maxima (the fix's step_budget()).
        for (int i = 0; i < n; ++i) {
          report.vmax2 = std::max(report.vmax2, speed2(vin + 3 * i));
          report.amax = std::max(report.amax, accel_magnitude(force(i), a.ftm2v, a.rmass[i]));
          report.rmax = std::max(report.rmax, a.radius[i]);
        }
        const double floor =
            a.bound_floor < 0.0 ? 0.5 * step_least(report.vmax2, report.amax, dt) : a.bound_floor;
        atoms.resize(n);
        bound.resize(n);
        for (int i = 0; i < n; ++i) {
          const long id = a.id_bytes == 8 ? (long) static_cast<const long long *>(a.id)[i]
                                          : (long) static_cast<const int *>(a.id)[i];
          atoms[i] = start_body(xin + 3 * i, vin + 3 * i, force(i), a.radius[i], a.rmass[i],
                                a.tlast[i], id, a.type[i], i, dt, a.ftm2v);
          if (a.omega)
            for (int d = 0; d < 3; ++d) atoms[i].omega[d] = a.omega[3 * i + d];
          bound[i] = drift_bound(vin + 3 * i, dt, floor, 0.0, a.reach);
        }
        report.t_search = seconds_since(t0);
        Tally t;
        if (!step(atoms, box, p, s, t, report)) return;
        tally.add(t);
        // The kept copies: the step's x and v, the changed atoms' written below.
        const bool keep = m.keep && own;
        if (keep && !moved) {
          kx.assign(a.x, a.x + 3 * (size_t) n);
          kv.assign(a.v, a.v + 3 * (size_t) n);
        }
        // The results where the caller wants them (the CUDA step's order: increasing index).
        const auto t1 = std::chrono::steady_clock::now();
        if (a.results) a.results->clear();
        if (a.result_spin) a.result_spin->clear();
        // With defer_writes the results wait in `later` (tlast of every atom, x and v of the
        // changed ones) for deliver_atoms().
        const bool defer = a.defer_writes && !a.results && !a.omega;
        if (defer) later.tlast.resize(n);
        double *tl = defer ? later.tlast.data() : a.tlast;
        for (int i = 0; i < n; ++i) {
          const Body &b = atoms[i];
          tl[i] = std::max(b.tlast - dt, a.never);
          report.vend2 = std::max(report.vend2, speed2(b.v));
          if (b.nevents == 0) continue;
          ++report.changed;
          double xe[3];
          drift_position(b, dt, xe);
          if (a.results) {
            ResidentResult r;
            r.index = i;
            for (int d = 0; d < 3; ++d) {
              r.x[d] = xe[d];
              r.v[d] = b.v[d];
            }
            a.results->push_back(r);
            if (a.omega && a.result_spin)
              for (int d = 0; d < 3; ++d) a.result_spin->push_back(b.omega[d]);
            continue;
          }
          if (defer) {
            ResidentResult r;
            r.index = i;
            for (int d = 0; d < 3; ++d) {
              r.x[d] = xe[d];
              r.v[d] = b.v[d];
            }
            later.changed.push_back(r);
          }
          for (int d = 0; d < 3; ++d) {
            if (!defer) {
              a.x[3 * i + d] = xe[d];
              a.v[3 * i + d] = b.v[d];
            }
            if (keep) {
              kx[3 * i + d] = xe[d];
              kv[3 * i + d] = b.v[d];
            }
          }
          if (a.omega)
            for (int d = 0; d < 3; ++d) a.omega[3 * i + d] = b.omega[d];
        }
        motion_done(a, keep);
        if (defer) {
          later.pending = true;
          later.x = a.x;
          later.v = a.v;
          later.tlast_to = a.tlast;
        }
        report.t_resolve += seconds_since(t1);
      }

      void deliver_atoms() override
      {
        if (!later.pending) return;
        for (const ResidentResult &r : later.changed)
          for (int d = 0; d < 3; ++d) {
            later.x[3 * r.index + d] = r.x[d];
            later.v[3 * r.index + d] = r.v[d];
          }
        std::copy(later.tlast.begin(), later.tlast.end(), later.tlast_to);
        later = Later();
      }

      void forget_host_arrays() override
      {
        motion_forget();
        later = Later();
      }

      void run(Body *bodies, const double *bnd, int n, const ResidentBox &box, const Params &p,
               const WindowSettings &s, Tally &tally, ResidentReport &report) override
      {
        report = ResidentReport();
        atoms.assign(bodies, bodies + n);
        bound.assign(bnd, bnd + n);
        Tally t;
        if (!step(atoms, box, p, s, t, report)) return;
        tally.add(t);
        for (int i = 0; i < n; ++i)
          if (atoms[i].nevents > 0) {
            bodies[i] = atoms[i];
            ++report.changed;
          }
      }

     private:
      // A done run_atoms() with defer_writes: its results, for deliver_atoms().
      struct Later {
        bool pending = false;
        std::vector<ResidentResult> changed;
        std::vector<double> tlast;
        double *x = nullptr, *v = nullptr, *tlast_to = nullptr;
      } later;
      // Copies of x and v as the last done run_atoms() with KeptMotion::keep left them
      // (ResidentStep::motion_done()).
      std::vector<double> kx, kv;
      std::vector<Body> atoms;    // the step's bodies, resolved in place
      std::vector<double> bound;
      std::vector<Edge> edges;
      WindowDriver driver;
      Resolver resolver;
      std::unique_ptr<CollisionBackend> cpu = make_cpu_backend();

      /* A check (MotionUse::check): the atoms whose kept copies, moved both ways of
         rounding, differ in any bit from the caller's x or v. */
      void compare_motion(const ResidentAtoms &a, ResidentReport &report) const
      {
        count_motion_misses(kx.data(), kv.data(), a.zero_forces ? nullptr : a.f, a.rmass, a.x,
                            a.v, a.n, a.motion.move, report.motion_miss);
      }

      /* The step of the bodies b (a scratch copy, resolved in place) with the step bounds in
         `bound`; false where it declines (report.outcome says why). */
      bool step(std::vector<Body> &b, const ResidentBox &box, const Params &p,
                const WindowSettings &s, Tally &t, ResidentReport &report)
      {
        const auto t0 = std::chrono::steady_clock::now();
        const int n = (int) b.size();
        // Candidates: start points within their radii and bounds (nearest image), the lower ID
        // first with its separation; overlaps decline.
        edges.clear();
        double rmax = 0.0, bmax = 0.0;
        for (int i = 0; i < n; ++i) {
          rmax = std::max(rmax, b[i].radius);
          bmax = std::max(bmax, bound[i]);
        }
        for (int d = 0; d < 3; ++d)
          if (box.periodic[d] && box.prd[d] < 4.0 * (rmax + bmax)) {
            // A pair must be found through one periodic image only.
            report.outcome = ResidentOutcome::small_box;
            return false;
          }
        for (int i = 0; i < n; ++i)
          for (int j = i + 1; j < n; ++j) {
            const bool swap = b[j].id < b[i].id;
            const int lo = swap ? j : i, hi = swap ? i : j;
            double r[3], sh[3];
            nearest_image_separation(b[lo].X0, b[hi].X0, box.prd, box.periodic, r, sh);
            const double d2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
            const double contact = b[lo].radius + b[hi].radius;
            const double range = contact + (bound[lo] + bound[hi]);
            if (d2 > range * range) continue;
            const double lim = contact * (1.0 - box.overlap_tol);
            if (d2 < lim * lim) {
              report.outcome = ResidentOutcome::overlap;
              return false;
            }
            edges.push_back({lo, hi, {sh[0], sh[1], sh[2]}});
          }
        for (int i = 0; i < n; ++i)
          for (int f = 0; f < NFACES; ++f) {
            if (!p.walls.on[f]) continue;
            const int d = face_dim(f);
            const double gap = face_sign(f) * (b[i].X0[d] - p.walls.pos[f]) - b[i].radius;
            if (gap < -box.overlap_tol * b[i].radius) {
              report.outcome = ResidentOutcome::overlap;
              return false;
            }
          }
        report.candidates = (long) edges.size();
        report.t_search += seconds_since(t0);
        const auto t1 = std::chrono::steady_clock::now();
        if (serial) {
          resolver.resolve_serial(b, edges, p, t);
          report.stats = WindowStats();
          report.stats.windows = 1;
          report.stats.groups = 1;
          report.stats.largest_group = n;
        } else {
          SingleRank single;
          driver.run(b, edges, {}, {}, p, s, *cpu, single, t, report.stats);
        }
        report.t_resolve += seconds_since(t1);
        if (t.capped) {
          report.outcome = ResidentOutcome::capped;
          return false;
        }
        // The step's check, the conservative way: no body further from its drift line than
        // its bound or the reach.
        for (int i = 0; i < n; ++i) {
          double xe[3], ve[3];
          end_of_step(b[i], p.dt, xe, ve);
          const double exc = std::sqrt(b[i].exc2);
          if (exc > bound[i] || exc > box.reach) {
            report.outcome = ResidentOutcome::excursion;
            return false;
          }
        }
        report.outcome = ResidentOutcome::done;
        return true;
      }
    };

  }    // namespace

  std::unique_ptr<ResidentStep> make_host_resident_step()
  {
    return std::unique_ptr<ResidentStep>(new HostResidentStep());
  }

}    // namespace Collide
}    // namespace HSGPU
