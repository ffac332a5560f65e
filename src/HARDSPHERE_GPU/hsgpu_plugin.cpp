/* ----------------------------------------------------------------------------------
   HARDSPHERE_GPU: registers the package's styles with LAMMPS's PLUGIN package.

     plugin load /path/to/hardspheregpuplugin.so
------------------------------------------------------------------------------------- */

#include "lammpsplugin.h"
#include "version.h"

#include "fix_hardsphere.h"
#include "pair_gravity.h"

using namespace LAMMPS_NS;

static Pair *pair_gravity_creator(LAMMPS *lmp)
{
  return new PairGravity(lmp);
}

static Fix *fix_hardsphere_creator(LAMMPS *lmp, int argc, char **argv)
{
  return new FixHardSphere(lmp, argc, argv);
}

extern "C" void lammpsplugin_init(void *lmp, void *handle, void *regfunc)
{
  auto register_plugin = (lammpsplugin_regfunc) regfunc;
  lammpsplugin_t plugin;

  plugin.version = LAMMPS_VERSION;
  plugin.style = "pair";
  plugin.name = "gravity";
  plugin.info = "HARDSPHERE_GPU all-pairs Newtonian gravity v0.1";
  plugin.author = "HARDSPHERE_GPU developers";
  plugin.creator.v1 = (lammpsplugin_factory1 *) &pair_gravity_creator;
  plugin.handle = handle;
  (*register_plugin)(&plugin, lmp);

  plugin.style = "fix";
  plugin.name = "hardsphere";
  plugin.info = "HARDSPHERE_GPU hard-sphere collisions inside each timestep v0.1";
  plugin.creator.v2 = (lammpsplugin_factory2 *) &fix_hardsphere_creator;
  (*register_plugin)(&plugin, lmp);
}
