/* HARDSPHERE_GPU collision engine: the CPU backend (see collision_backend.h).  Each group is
   resolved by core/event_order.h's Resolver with its own event queue. */
#include "collision_backend.h"

#include "core/event_order.h"

namespace HSGPU {
namespace Collide {

  namespace {
    class CpuBackend : public CollisionBackend {
     public:
      std::string name() const override { return "cpu"; }
      long resolve(const WindowWork &w, const Params &p, Tally &tally) override
      {
        return resolver.resolve_groups(w.bodies, w.nbodies, w.edges, w.nedges, w.group_start,
                                       w.group_members, w.ngroups, w.t_end, p, tally, w.group_tally,
                                       w.body_virial);
      }

     private:
      Resolver resolver;
    };
  }    // namespace

  std::unique_ptr<CollisionBackend> make_cpu_backend()
  {
    return std::unique_ptr<CollisionBackend>(new CpuBackend());
  }

}    // namespace Collide
}    // namespace HSGPU
