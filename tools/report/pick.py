#!/usr/bin/env python3
"""Helper of tools/report/pick.sh: the "what to pick" page, from the CSV files the other
sections wrote into the report directory (argv[1]).  Prints Markdown.  A section that was not
run (its CSV missing) shows as "not measured in this report"; numbers that no section measures
are quoted from the doc page that states them, with its date and hardware."""
import csv
import os
import sys

DIR = sys.argv[1]
NOT = "not measured in this report"


def load(name):
    path = os.path.join(DIR, name)
    if not os.path.exists(path):
        return None
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    for r in rows:
        for k, v in r.items():
            try:
                r[k] = float(v)
            except (TypeError, ValueError):
                pass
    return rows


def g(x, digits=3):
    return f"{x:.{digits}g}"


def pct(x):
    return f"{100 * abs(x):.2g} %"


def num(r, k):
    v = r.get(k)
    return v if isinstance(v, float) else None


seed = load("seed_runs.csv")
grav = load("gravity_points.csv")
pair = load("granular_pair.csv")
bounce = load("granular_bounce.csv")
column = load("granular_column.csv")
settled = load("granular_settled.csv")
fluid = load("granular_fluid.csv")

HS = "fix hardsphere"
out = []
say = out.append

say("Each kind of scene below says which styles and settings to use, what accuracy they give and")
say("what they cost, from this report's measurements (the other pages and their CSV files) and,")
say("where the report does not measure something, from the doc page that does (named with its")
say("date and hardware).  \"Exact\" means equal to the analytic or guards-off result to round-off,")
say("at any timestep.  One CPU core unless stated.")
say("")


def split(rows):
    """The fix hardsphere runs and the others (GRANULAR)."""
    return [r for r in rows if r["method"] == HS], [r for r in rows if r["method"] != HS]


def best_within(rows, limit):
    """Cheapest run of each side (fix hardsphere or not) with |error| <= limit."""
    hs, gr = split([r for r in rows if num(r, "error") is not None and abs(r["error"]) <= limit
                    and num(r, "wall") is not None])
    return (min(hs, key=lambda r: r["wall"]) if hs else None,
            min(gr, key=lambda r: r["wall"]) if gr else None)


# --- dilute gas -------------------------------------------------------------------------------
say("## Dilute gas (few collisions per particle and step, with or without a field)")
say("")
say("Use `fix hardsphere` with its defaults and the largest timestep the other forces allow: each")
say("collision is resolved at its exact time inside the step, so a larger timestep costs nothing in")
say("accuracy.")
if pair:
    hs, gr = split(pair)
    say(f"Head-on pair: restitution error {g(max(abs(r['error']) for r in hs))} at dt = "
        f"{', '.join(g(d) for d in sorted({r['dt'] for r in hs}))}; the soft contacts reach "
        f"{g(min(abs(r['error']) for r in gr))} at best and {g(max(abs(r['error']) for r in gr))} "
        "at worst ([granular.md](granular.md#head-on-pair)).")
else:
    say(f"Head-on pair: {NOT}.")
if seed:
    dil = [r for r in seed if r["config"] == "dilute" and r["backend"] == "cpu-default"]
    if dil:
        big = max(dil, key=lambda r: r["N"])
        say(f"The seed's dilute configuration (volume fraction 0.001, about "
            f"{g(big['collision_rate'], 2)} collisions per particle per step): the fix's own step "
            f"takes {g(big['fix_ms_per_step'])} ms at N = {int(big['N'])} "
            f"([seed.md](seed.md)).")
say("GRANULAR is not the tool here: it needs timesteps of a small fraction of the contact time")
say("for every step, collisions or not.")
say("")

# --- free flight under gravity: the falling column --------------------------------------------
say("## Free flight and collisions under a uniform field (the falling column)")
say("")
if column:
    hs, gr = best_within(column, 0.005)
    if hs:
        say(f"For a kinetic-energy error of 0.5 % or less at t = 1, the cheapest `fix hardsphere` run "
            f"was `{hs.get('setting', '')}` at dt = {g(hs['dt'])}: {g(hs['wall'])} s, error "
            f"{pct(hs['error'])}.")
    if gr:
        say(f"The cheapest GRANULAR run within 0.5 % was {gr['method']} "
            f"(k_n {g(gr['kn'])}, dt = {g(gr['dt'])}): {g(gr['wall'])} s, error "
            f"{pct(gr['error'])}.")
    if hs and gr:
        say(f"`fix hardsphere` is {g(gr['wall'] / hs['wall'], 2)}x faster at that accuracy "
            "(the goal of issue 11 is 10x; see [granular.md](granular.md#falling-column)).")
    dflt = {r["dt"]: r for r in column
            if r["method"] == HS and str(r.get("setting", "")) == "default guards"}
    if dflt:
        say("With the default guards the error is "
            + ", ".join(f"{pct(dflt[d]['error'])} at dt = {g(d)}" for d in sorted(dflt))
            + "; with `tc 1e-7` (guards off) the result is exact at every dt.")
else:
    say(f"The falling column: {NOT}.")
say("")

# --- pour or pile ------------------------------------------------------------------------------
say("## Pour or settled pile")
say("")
say("Use `fix hardsphere` with its defaults (`tc/slow yes`, `vmin auto`): the TC model and the")
say("elastic threshold `30 |a| tc'` keep an inelastic pile from collapsing and bound its cost.")
say("Measured in [fix_hardsphere.md](../fix_hardsphere.md#guards-against-inelastic-collapse-and-resting-contacts)")
say("(CPU, LAMMPS 4 Feb 2025, 2026-11-25, `examples/hardsphere/in.pour` N = 2000, dt = 0.01):")
say("2.7-3.0 events per sphere and step at t = 75 for e = 0, 0.1 and 0.5 (7.1, 9.4 and 5.9 with")
say("`vmin 0`), at the price of a residual agitation of about 5e-4 per sphere in kinetic energy")
say("(the pile creeps slowly).  For a static pile set `vmin 0` and accept the cost; avoid periodic")
say("widths that are a whole number of diameters for monodisperse spheres (a closed ring of")
say("touching spheres defeats the guards, [hard_cases.md](../hard_cases.md#found)).")
if settled:
    hs, gr = split(settled)
    def line(r):
        parts = []
        if num(r, "floor_mom_err") is not None:
            parts.append(f"floor force {pct(r['floor_mom_err'])} from N m g")
        if num(r, "prof_err") is not None:
            parts.append(f"height profile {pct(r['prof_err'])} from the reference")
        if num(r, "wall_settled") is not None:
            parts.append(f"{g(r['wall_settled'])} s")
        return ", ".join(parts)
    if hs:
        h = min(hs, key=lambda r: r["wall_settled"])
        say(f"The settled column (t = 10 to 30, [granular.md](granular.md#settled-column)): "
            f"`fix hardsphere` at dt = {g(h['dt'])}: {line(h)}.")
    if gr:
        c = min(gr, key=lambda r: r["wall_settled"])
        say(f"The cheapest GRANULAR run there ({c['method']}, k_n {g(c['kn'])}, dt = {g(c['dt'])}): "
            f"{line(c)}.")
        if hs and c["wall_settled"] < h["wall_settled"]:
            say("Here GRANULAR is cheaper: a resting pile is what soft spheres do well, since their "
                "cost does not grow with the number of contacts per step.")
else:
    say(f"The settled column against GRANULAR: {NOT}.")
say("")

# --- dense fluid -------------------------------------------------------------------------------
say("## Dense elastic fluid")
say("")
if fluid:
    hs, gr = split(fluid)
    if hs:
        h = min(hs, key=lambda r: r["wall"])
        say(f"`fix hardsphere` (elastic, defaults) at dt = {g(h['dt'])}: compressibility factor "
            f"{g(h['Z'], 4)}, {pct(h['error'])} from Carnahan-Starling, {g(h['wall'])} s "
            "([granular.md](granular.md#dense-elastic-fluid)).")
    if gr:
        c = min(gr, key=lambda r: abs(r["error"]))
        say(f"The closest GRANULAR run ({c['method']}, k_n {g(c['kn'])}, dt = {g(c['dt'])}): "
            f"{pct(c['error'])} from Carnahan-Starling in {g(c['wall'])} s: soft spheres are not "
            "hard spheres, and their pressure depends on the stiffness.")
else:
    say(f"The dense fluid against GRANULAR: {NOT}.")
say("Large dense systems: the default order resolves each step in time windows of small groups")
say("(`f_ID[7]` the largest); `gpu yes` resolves them on a CUDA device, bitwise the same")
say("([bench_collisions.md](../bench_collisions.md)).  On one MPI rank without a GPU nothing runs")
say("side by side, and up to some 1e5 atoms `windows 1` (the whole step as one window joining every")
say("candidate pair) is the faster setting, the same bits; at a million atoms `auto` is")
say("([fix_hardsphere.md](../fix_hardsphere.md#order-of-events)).")
say("")

# --- self-gravitating cloud --------------------------------------------------------------------
say("## Self-gravitating cloud (all-pairs gravity)")
say("")
if grav:
    cpu = [r for r in grav if r["backend"] == "cpu" and r["threads"] == 1]
    if cpu:
        big = max(cpu, key=lambda r: r["N"])
        rate = big["N"] * big["N"] / (big["ms_per_step"] * 1e-3)
        say(f"`pair_style gravity` on the CPU (double precision): {g(big['ms_per_step'])} ms per step "
            f"at N = {int(big['N'])} on one thread ({g(rate)} pair terms per second), force error "
            f"{g(max(r['rms_rel'] for r in cpu))} RMS relative to a long-double sum "
            "([gravity.md](gravity.md)).")
    gpu = [r for r in grav if r["backend"] == "gpu"]
    if gpu:
        for prec in ("single", "mixed", "double"):
            rs = [r for r in gpu if r["precision"] == prec]
            if rs:
                big = max(rs, key=lambda r: r["N"])
                say(f"GPU {prec}: {g(big['ms_per_step'])} ms per step at N = {int(big['N'])}, "
                    f"force error {g(big['rms_rel'])} RMS.")
if not grav or not [r for r in grav if r["backend"] == "gpu"]:
    say("The GPU rows are not measured in this report; [bench_gravity_gpu.md](../bench_gravity_gpu.md)")
    say("measured them on an NVIDIA H200 on 2026-11-21: pairs-once kernels at N = 65536 ... 1048576")
    say("evaluate 2.7-2.9e12 pair terms per second in single precision (RMS force error 1e-7),")
    say("2.6-2.8e12 in mixed (0.9-1.9e-7) and 1.3e12 in double (3e-16): a GPU is three to four")
    say("orders of magnitude faster than a CPU core.")
say("Pick `precision single` or `mixed` on the GPU when a relative force error of 1e-7 is far")
say("below the integration error (it is, at any practical timestep); `double` when the run must")
say("agree with the CPU path to round-off.  Softening `eps` and `dt` set the accuracy of close")
say("encounters, not the precision.")
say("")

# --- the seed's benchmark ----------------------------------------------------------------------
say("## The seed paper's benchmark (hard spheres, all-pairs gravity, a uniform field)")
say("")
if seed:
    cpu = [r for r in seed if r["backend"] == "cpu-default"]
    if cpu:
        nmax = max(r["N"] for r in cpu)
        big = [r for r in cpu if r["N"] == nmax]
        share = [100 * r["pair_ms_per_step"] / r["ms_per_step"] for r in big]
        say(f"On the CPU at N = {int(nmax)} the all-pairs gravity takes {g(min(share), 3)} to "
            f"{g(max(share), 3)} % of a step ([seed.md](seed.md)); the collisions are not what to "
            "speed up there, the gravity is: run `pair_style gravity ... gpu yes`.")
        ser = {(r["config"], r["N"]): r for r in seed if r["backend"] == "cpu-serial"}
        ratios = [ser[(r["config"], r["N"])]["fix_ms_per_step"] / r["fix_ms_per_step"]
                  for r in big if (r["config"], r["N"]) in ser]
        if ratios:
            say(f"The fix's default order is {g(min(ratios), 2)} to {g(max(ratios), 2)}x faster than "
                "`order serial` (the paper's loop) at that N, with the same collisions.")
    gpu = [r for r in seed if r["backend"] == "gpu"]
    if not gpu:
        say("GPU rows: not measured in this report; [bench_collisions.md](../bench_collisions.md)")
        say("measured the fix's device step on an NVIDIA H100 (2026-11-25): lattice3d at N = 65536")
        say("in about 1.1 ms per step, 55x faster than `order serial` on the device.")
else:
    say(f"The seed's benchmark: {NOT}.")
say("")
print("\n".join(out))
