#!/usr/bin/env python3
"""Helper of tools/report/seed.sh (the seed paper's benchmark).

  seed_plot.py row LOG CONFIG BACKEND GPU   one CSV row from a LAMMPS log of in.seed_config
  seed_plot.py plot CSV PNG GPU             ms per step against N, one panel per configuration
  seed_plot.py table CSV GPU GPU_NS         the Markdown tables
  seed_plot.py summary CSV                  a few sentences on what the numbers say

`row` exits non-zero, naming the problem, when the log lacks a result or holds a value that
is not finite, so that a failed or wrong run never reaches a table.
"""
import math
import re
import sys

from report_checks import die, finite, load_rows

CONFIGS = ["dilute", "lattice2d", "lattice3d"]
BACKENDS = [("cpu-serial", "CPU order serial"), ("cpu-default", "CPU default order"),
            ("gpu", "GPU (gpu yes)")]
COLORS = {"cpu-serial": "tab:blue", "cpu-default": "tab:orange", "gpu": "tab:green"}
CONFIG_TITLES = {"dilute": "dilute (vol. fraction 0.001)",
                 "lattice2d": "lattice2d (one layer, spacing 1.1)",
                 "lattice3d": "lattice3d (slab, spacing 2)"}


def row(log, config, backend, gpu):
    text = open(log, encoding="utf-8", errors="replace").read()
    if re.search(r"^ERROR", text, re.M):
        die(f"{log}: LAMMPS reported an error")
    m = re.findall(r"^seedresult (.*)$", text, re.M)
    if not m:
        die(f"{log}: no seedresult line (the run did not finish)")
    words = m[-1].split()
    res = dict(zip(words[0::2], words[1::2]))
    loop = re.findall(r"^Loop time of (\S+) on \d+ procs for (\d+) steps with (\d+) atoms", text, re.M)
    if not loop:
        die(f"{log}: no 'Loop time' line")
    loop_s, steps, natoms = finite("loop time", loop[-1][0]), int(loop[-1][1]), int(loop[-1][2])
    if steps <= 0 or steps != int(float(res["steps"])):
        die(f"{log}: {steps} steps timed, {res['steps']} reported")

    def section(name):
        s = re.findall(r"^%s\s*\|\s*(\S+)\s*\|\s*(\S+)\s*\|" % name, text, re.M)
        if not s:
            die(f"{log}: no '{name}' line in the timing breakdown")
        return finite(name + " time", s[-1][1])

    pair_s, modify_s = section("Pair"), section("Modify")
    vals = {k: finite(k, res[k]) for k in
            ("collisions", "events", "search_s", "resolve_s", "fix_s", "device", "ke", "rate")}
    if vals["collisions"] < 0 or vals["events"] < vals["collisions"]:
        die(f"{log}: impossible counts {res['collisions']} collisions, {res['events']} events")
    if gpu == "yes":
        if vals["device"] < 0 or "using the CPU path" in text:
            die(f"{log}: gpu yes but a style ran on the CPU")
    elif vals["device"] >= 0:
        die(f"{log}: gpu no but the fix reports device {vals['device']:g}")
    ms = lambda s: 1000.0 * s / steps
    print(",".join([config, backend, str(natoms), str(steps), "%.6g" % ms(loop_s),
                    "%.6g" % ms(pair_s), "%.6g" % ms(modify_s), "%.6g" % ms(vals["fix_s"]),
                    "%.6g" % ms(vals["search_s"]), "%.6g" % ms(vals["resolve_s"]),
                    "%.6g" % (vals["collisions"] / (natoms * steps)),
                    "%.6g" % (vals["events"] / steps), "%.10g" % vals["ke"]]))


def load(path):
    return load_rows(path, ("N", "steps"), ("config", "backend"))


def plot(path, png, gpu):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    rows = load(path)
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.8), sharey=True)
    for ax, config in zip(axes, CONFIGS):
        for backend, label in BACKENDS:
            rs = sorted((r for r in rows if r["config"] == config and r["backend"] == backend),
                        key=lambda r: r["N"])
            if not rs:
                continue
            n = [r["N"] for r in rs]
            ax.loglog(n, [r["ms_per_step"] for r in rs], "o-", color=COLORS[backend],
                      label=label + ": whole step")
            ax.loglog(n, [r["fix_ms_per_step"] for r in rs], "s--", color=COLORS[backend],
                      mfc="none", label=label + ": fix hardsphere")
        cpu = sorted((r for r in rows if r["config"] == config and r["backend"] == "cpu-default"),
                     key=lambda r: r["N"])
        if cpu:
            n0, t0 = cpu[-1]["N"], cpu[-1]["pair_ms_per_step"]
            ns = [r["N"] for r in cpu]
            ax.loglog(ns, [t0 * (x / n0) ** 2 for x in ns], ":", color="grey", label="∝ N²")
        ax.set_xscale("log", base=2)
        ax.set_title(CONFIG_TITLES[config])
        ax.set_xlabel("N (spheres)")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("ms per step")
    handles, labels = axes[-1].get_legend_handles_labels()
    for ax in axes[:-1]:
        h, l = ax.get_legend_handles_labels()
        for hh, ll in zip(h, l):
            if ll not in labels:
                handles.append(hh)
                labels.append(ll)
    axes[0].legend(handles, labels, fontsize=8, loc="upper left")
    note = "" if gpu == "yes" else "GPU: not measured on this machine"
    fig.suptitle("Seed benchmark with all-pairs gravity (Hawick & Playne 2011, Figs. 7-9)"
                 + (" - " + note if note else ""))
    fig.tight_layout()
    fig.savefig(png, dpi=110)
    if gpu == "yes":
        print("The dotted grey line is N² through the CPU default order's gravity time at the "
              "largest N.")
    else:
        print("The dotted grey line is N² through the CPU default order's gravity time at the "
              "largest N. No GPU curves: GPU not measured on this machine.")


def fmt(v, digits=3):
    if v == 0:
        return "0"
    if abs(v) >= 100:
        return "%.0f" % v
    return "%.*g" % (digits, v)


def table(path, gpu, gpu_ns):
    rows = load(path)
    for config in CONFIGS:
        print(f"### {config}")
        print()
        print("| N | backend | steps | ms/step | gravity ms/step | fix hardsphere ms/step | "
              "all fixes ms/step | fix share | collisions/particle/step | events/step |")
        print("|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|")
        for backend, label in BACKENDS:
            rs = sorted((r for r in rows if r["config"] == config and r["backend"] == backend),
                        key=lambda r: r["N"])
            if backend == "gpu" and gpu != "yes":
                print(f"| {gpu_ns} | {label} | | not measured | not measured | not measured | "
                      "not measured | | not measured | |")
                continue
            for r in rs:
                share = 100.0 * r["fix_ms_per_step"] / r["ms_per_step"]
                print(f"| {r['N']} | {label} | {r['steps']} | {fmt(r['ms_per_step'])} | "
                      f"{fmt(r['pair_ms_per_step'])} | {fmt(r['fix_ms_per_step'])} | "
                      f"{fmt(r['modify_ms_per_step'])} | "
                      f"{share:.1f} % | {r['collision_rate']:.4f} | {fmt(r['events_per_step'])} |")
        print()
    print("ms/step: LAMMPS's loop time over the timed steps (the whole step). gravity: LAMMPS's "
          "Pair time. fix hardsphere: the fix's own step (`f_hs[20]`: budget, candidate search, "
          "resolution, results; its search and resolve timers `f_hs[12]`, `f_hs[13]` are in the "
          "CSV). all fixes: LAMMPS's Modify time (fix hardsphere, the integrator nve/sphere and "
          "fix gravity). fix share: fix hardsphere over the whole step. "
          "collisions/particle/step: `f_hs[2]/(N steps)` over the timed steps; events/step: pair "
          "and wall collisions per step (`f_hs[6]`).")

def summary(path):
    rows = load(path)
    print("**What the numbers say.**")
    print()
    for config in CONFIGS:
        rs = [r for r in rows if r["config"] == config]
        cpu = {r["backend"]: r for r in rs if r["backend"] != "gpu" and
               r["N"] == max(x["N"] for x in rs if x["backend"] != "gpu")}
        if "cpu-default" not in cpu or "cpu-serial" not in cpu:
            continue
        d, s = cpu["cpu-default"], cpu["cpu-serial"]
        rates = [r["collision_rate"] for r in rs]
        line = (f"- {config}: {min(rates):.4f} to {max(rates):.4f} collisions per particle per "
                f"step. At N = {d['N']} on the CPU a step takes {fmt(d['ms_per_step'])} ms in "
                f"the default order, {100 * d['pair_ms_per_step'] / d['ms_per_step']:.1f} % "
                f"of it the all-pairs gravity; the fix's own step is "
                f"{fmt(d['fix_ms_per_step'])} ms in the default order and "
                f"{fmt(s['fix_ms_per_step'])} ms in order serial "
                f"({fmt(s['fix_ms_per_step'] / d['fix_ms_per_step'], 2)}x)")
        g = [r for r in rs if r["backend"] == "gpu"]
        if g:
            gd = {r["N"]: r for r in g}
            if d["N"] in gd:
                line += (f"; the GPU takes {fmt(gd[d['N']]['ms_per_step'])} ms per step at that N "
                         f"({fmt(d['ms_per_step'] / gd[d['N']]['ms_per_step'], 2)}x faster)")
            big = max(g, key=lambda r: r["N"])
            line += f" and {fmt(big['ms_per_step'])} ms at N = {big['N']}"
        print(line + ".")
    cpu = [r for r in rows if r["backend"] != "gpu"]
    if not cpu:
        return
    nmax = max(r["N"] for r in cpu)
    big = [r for r in cpu if r["N"] == nmax]
    grav = [100 * r["pair_ms_per_step"] / r["ms_per_step"] for r in big]
    fix = [100 * r["fix_ms_per_step"] / r["ms_per_step"] for r in big]
    ratio = []
    for config in CONFIGS:
        c = {r["backend"]: r for r in big if r["config"] == config}
        if "cpu-serial" in c and "cpu-default" in c:
            ratio.append(c["cpu-serial"]["fix_ms_per_step"] / c["cpu-default"]["fix_ms_per_step"])
    print()
    text = (f"On the CPU at N = {nmax} the all-pairs gravity (O(N^2), one thread) takes "
            f"{min(grav):.0f} to {max(grav):.0f} % of the step and fix hardsphere "
            f"{min(fix):.1f} to {max(fix):.1f} %")
    if ratio:
        text += (f"; order serial's fix step is {min(ratio):.2g} to {max(ratio):.2g}x the default "
                 "order's, " + ("a difference that the gravity hides in the whole step"
                                if max(fix) < 10 else "a difference that shows in the whole step"))
    print(text + ". Both orders resolve the same collisions (the same counts in the tables).")

def main(argv):
    if len(argv) < 2:
        die(__doc__)
    cmd, args = argv[1], argv[2:]
    if cmd == "row" and len(args) == 4:
        row(*args)
    elif cmd == "plot" and len(args) == 3:
        plot(*args)
    elif cmd == "table" and len(args) == 3:
        table(*args)
    elif cmd == "summary" and len(args) == 1:
        summary(*args)
    else:
        die("bad arguments: " + " ".join(argv[1:]) + "\n" + __doc__)


if __name__ == "__main__":
    main(sys.argv)
