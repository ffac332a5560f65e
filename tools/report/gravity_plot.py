#!/usr/bin/env python3
"""Helper of tools/report/gravity.sh (precision and cost of pair_style gravity).

  gravity_plot.py timing LOG GPU PREC          "N steps ms_per_step threads" of an
                                               in.gravity_step run (checks the path it ran on)
  gravity_plot.py error DUMP REF               "rms_rel max_rel maxabs_rel" of DUMP's forces
                                               against REF's (both write_dump files of
                                               in.gravity_forces, same atoms and positions)
  gravity_plot.py error_ld DUMP G EPS NSAMPLE  the same against a long-double direct sum (numpy)
                                               over all bodies, for NSAMPLE targets spread over
                                               the IDs (all when NSAMPLE >= N)
  gravity_plot.py same DUMP1 DUMP2             exits non-zero unless the forces are bitwise equal
  gravity_plot.py plot CSV OUTDIR GPU          gravity_error_vs_time.png, gravity_time_vs_n.png
  gravity_plot.py table CSV GPU GPU_NS         the Markdown table
  gravity_plot.py summary CSV GPU              a few sentences on what the numbers say

Every number read is checked to be finite; a NaN or a missing value exits non-zero.
"""
import math
import re
import sys

from report_checks import die, finite, load_rows

PRECS = ["single", "mixed", "double"]


def timing(log, gpu, prec):
    text = open(log, encoding="utf-8", errors="replace").read()
    if re.search(r"^ERROR", text, re.M):
        die(f"{log}: LAMMPS reported an error")
    loop = re.findall(r"^Loop time of (\S+) on \d+ procs for (\d+) steps with (\d+) atoms", text,
                      re.M)
    if not loop:
        die(f"{log}: no 'Loop time' line")
    t, steps, n = finite("loop time", loop[-1][0]), int(loop[-1][1]), int(loop[-1][2])
    if steps <= 0 or t <= 0:
        die(f"{log}: {steps} steps in {t} s")
    th = re.findall(r"(\d+) OpenMP thread\(s\) per MPI task", text)
    threads = int(th[-1]) if th else 1
    if gpu == "yes":
        if not re.search(r"Pair gravity: CUDA path, precision %s" % prec, text):
            die(f"{log}: gpu yes, precision {prec}, but no 'CUDA path, precision {prec}' line")
    elif "CUDA path" in text:
        die(f"{log}: gpu no but the CUDA path ran")
    # The thermo lines of the last step must be finite too.
    for line in re.findall(r"^\s*\d+\s+[-+0-9.eE]+(?:\s+\S+)*$", text, re.M):
        for w in line.split():
            if w.lower() in ("nan", "-nan", "inf", "-inf"):
                die(f"{log}: thermo output '{line.strip()}' is not finite")
    print(n, steps, "%.6g" % (1000.0 * t / steps), threads)


def read_dump(path):
    import numpy as np
    lines = open(path).read().split("\n")
    try:
        i = lines.index("ITEM: NUMBER OF ATOMS")
        n = int(lines[i + 1])
        j = next(k for k, l in enumerate(lines) if l.startswith("ITEM: ATOMS"))
    except (ValueError, StopIteration):
        die(f"{path}: not a LAMMPS dump")
    cols = lines[j].split()[2:]
    want = ["id", "x", "y", "z", "fx", "fy", "fz"]
    if cols != want:
        die(f"{path}: columns {cols}, expected {want}")
    body = lines[j + 1:j + 1 + n]
    if len(body) != n:
        die(f"{path}: {len(body)} atoms, header says {n}")
    ids = np.array([int(l.split()[0]) for l in body])
    if not np.array_equal(ids, np.arange(1, n + 1)):
        die(f"{path}: atom IDs are not 1 ... {n} in order")
    words = [l.split()[1:] for l in body]
    try:
        d = np.array(words, dtype=np.float64)
    except ValueError:
        die(f"{path}: a value is not a number")
    if not np.isfinite(d).all():
        die(f"{path}: a position or force is not finite")
    # 17 significant digits give back the exact doubles LAMMPS had; widen those, not the
    # decimal strings, to long double.
    ld = d.astype(np.longdouble)
    return ld[:, 0:3], ld[:, 3:6], words


def errors(f, ref):
    import numpy as np
    d = np.sqrt(((f - ref) ** 2).sum(axis=1))
    r = np.sqrt((ref ** 2).sum(axis=1))
    if np.any(r == 0):
        die("a reference force is zero")
    rel = d / r
    return (float(np.sqrt(np.mean(rel ** 2))), float(rel.max()), float(d.max() / r.max()))


def error(dump, ref):
    x1, f1, _ = read_dump(dump)
    x2, f2, _ = read_dump(ref)
    if x1.shape != x2.shape or (x1 != x2).any():
        die(f"{dump} and {ref} hold different positions")
    print("%.6g %.6g %.6g" % errors(f1, f2))


def error_ld(dump, g, eps, nsample):
    import numpy as np
    if np.finfo(np.longdouble).eps > 1e-17:
        die("numpy's long double is no wider than double on this machine: no reference")
    x, f, _ = read_dump(dump)
    n = len(x)
    g, eps2 = np.longdouble(g), np.longdouble(eps) ** 2
    ns = min(int(nsample), n)
    idx = np.unique(np.linspace(0, n - 1, ns).round().astype(int))
    ref = np.zeros((len(idx), 3), dtype=np.longdouble)
    chunk = max(1, 2 ** 22 // n)
    for a in range(0, len(idx), chunk):
        t = idx[a:a + chunk]
        dx = x[t, None, :] - x[None, :, :]                    # (targets, sources, 3)
        r2 = (dx ** 2).sum(axis=2) + eps2
        w = 1 / (r2 * np.sqrt(r2))                            # unit masses
        ref[a:a + chunk] = -g * (dx * w[:, :, None]).sum(axis=1)
    print("%.6g %.6g %.6g %d" % (*errors(f[idx], ref), len(idx)))


def same(d1, d2):
    _, _, w1 = read_dump(d1)
    _, _, w2 = read_dump(d2)
    if w1 != w2:
        die(f"{d1} and {d2} differ")
    print("bitwise equal")


def load(path):
    return load_rows(path, ("N", "steps", "threads"), ("backend", "precision", "reference"),
                     blank_ok=True)


def label(r):
    if r["backend"] == "cpu":
        return f"CPU double, {r['threads']} thread" + ("s" if r["threads"] > 1 else "")
    return f"GPU {r['precision']}"


def plot(path, outdir, gpu):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    rows = load(path)
    groups = {}
    for r in rows:
        groups.setdefault(label(r), []).append(r)
    marks = {"CPU": "o", "GPU single": "^", "GPU mixed": "D", "GPU double": "s"}
    note = "" if gpu == "yes" else "\nGPU: not measured on this machine"

    fig, ax = plt.subplots(figsize=(7.5, 5))
    for lab, rs in groups.items():
        rs = sorted((r for r in rs if r["rms_rel"] is not None), key=lambda r: r["N"])
        if not rs:
            continue
        m = marks.get(lab, "o") if not lab.startswith("CPU") else "o"
        line, = ax.loglog([r["ms_per_step"] for r in rs], [r["rms_rel"] for r in rs], m + "-",
                          label=lab + " (RMS)")
        ax.loglog([r["ms_per_step"] for r in rs], [r["max_rel"] for r in rs], m + ":",
                  color=line.get_color(), mfc="none", label=lab + " (max)")
        if not (lab.startswith("CPU") and rs[0]["threads"] > 1):   # one label per N
            for r in rs:
                ax.annotate(str(r["N"]), (r["ms_per_step"], r["rms_rel"]), fontsize=7,
                            textcoords="offset points", xytext=(4, -8))
    ax.set_xlabel("ms per step (whole LAMMPS step)")
    ax.set_ylabel("relative force error |F - F_ref| / |F_ref|")
    ax.set_title("pair_style gravity: force error against time per step (labels: N)\n"
                 "reference: CPU against a long-double sum, GPU against the CPU" + note,
                 fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(outdir + "/gravity_error_vs_time.png", dpi=110)

    fig, ax = plt.subplots(figsize=(7.5, 5))
    for lab, rs in groups.items():
        rs = sorted(rs, key=lambda r: r["N"])
        ax.loglog([r["N"] for r in rs], [r["ms_per_step"] for r in rs], "o-", label=lab)
    cpu = sorted((r for r in rows if r["backend"] == "cpu" and r["threads"] == 1),
                 key=lambda r: r["N"])
    if cpu:
        n0, t0 = cpu[-1]["N"], cpu[-1]["ms_per_step"]
        ax.loglog([r["N"] for r in cpu], [t0 * (r["N"] / n0) ** 2 for r in cpu], ":",
                  color="grey", label="∝ N²")
    ax.set_xscale("log", base=2)
    ax.set_xlabel("N (bodies)")
    ax.set_ylabel("ms per step")
    ax.set_title("pair_style gravity: time per step against N" + note, fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(outdir + "/gravity_time_vs_n.png", dpi=110)


def fmt(v):
    if v is None:
        return ""
    if v == 0:
        return "0"
    return "%.3g" % v if abs(v) < 1000 else "%.0f" % v


def table(path, gpu, gpu_ns):
    rows = load(path)
    print("| backend | precision | threads | N | steps | ms/step | pair forces/s | reference | "
          "RMS rel. error | max rel. error | max abs. error / max force |")
    print("|---|---|---:|---:|---:|---:|---:|---|---:|---:|---:|")
    key = lambda r: (r["backend"], PRECS.index(r["precision"]), r["threads"], r["N"])
    for r in sorted(rows, key=key):
        rate = r["N"] * (r["N"] - 1) / (r["ms_per_step"] / 1000.0)
        print(f"| {r['backend'].upper()} | {r['precision']} | {r['threads']} | {r['N']} | "
              f"{r['steps']} | {fmt(r['ms_per_step'])} | {rate:.3g} | {r['reference']} | "
              f"{fmt(r['rms_rel'])} | {fmt(r['max_rel'])} | {fmt(r['maxabs_rel'])} |")
    if gpu != "yes":
        for p in PRECS:
            print(f"| GPU | {p} | | {gpu_ns} | | not measured | | CPU double | not measured | "
                  "not measured | not measured |")


def summary(path, gpu):
    rows = load(path)
    print("**What the numbers say.**")
    print()
    cpu = [r for r in rows if r["backend"] == "cpu"]
    ths = sorted({r["threads"] for r in cpu})
    nmax = max(r["N"] for r in cpu)
    at = {r["threads"]: r for r in cpu if r["N"] == nmax}
    parts = []
    for th in ths:
        r = at[th]
        parts.append(f"{fmt(r['ms_per_step'])} ms per step on {th} thread"
                     + ("s" if th > 1 else "")
                     + f" ({r['N'] * (r['N'] - 1) / (r['ms_per_step'] / 1000):.3g} pair forces/s)")
    line = f"- CPU, N = {nmax}: " + ", ".join(parts)
    if len(ths) > 1:
        sp = at[ths[0]]["ms_per_step"] / at[ths[-1]]["ms_per_step"]
        line += f"; {sp:.2f}x from {ths[-1]} threads"
        if sp < 0.75 * ths[-1]:
            line += (f" (well below {ths[-1]}x; other work may have shared the cores, see the "
                     "load average above)")
    one = sorted((r for r in cpu if r["threads"] == ths[0]), key=lambda r: r["N"])
    if len(one) > 1:
        a, b = one[0], one[-1]
        line += (f". From N = {a['N']} to {b['N']} the time grows {b['ms_per_step'] / a['ms_per_step']:.3g}x"
                 f" (N^2: {(b['N'] / a['N']) ** 2:.3g}x)")
    print(line + ".")
    rms = [r["rms_rel"] for r in cpu]
    mx = [r["max_rel"] for r in cpu]
    ulp = 2.0 ** -52
    print(f"- CPU forces against the long-double sum: RMS relative error {min(rms):.2g} to "
          f"{max(rms):.2g}, largest {max(mx):.2g} over N = {min(r['N'] for r in cpu)} ... {nmax}, "
          f"that is up to {max(rms) / ulp:.0f} (RMS) and {max(mx) / ulp:.0f} (largest) units of "
          "double rounding (2.2e-16) for sums of N terms that partly cancel: the CPU path is close "
          "to what double precision allows, and a sound reference for the GPU's precisions.")
    gp = [r for r in rows if r["backend"] == "gpu"]
    if not gp:
        print("- GPU (single, mixed, double): not measured on this machine.")
        return
    for p in PRECS:
        rs = sorted((r for r in gp if r["precision"] == p), key=lambda r: r["N"])
        if not rs:
            continue
        big = rs[-1]
        line = (f"- GPU {p}: RMS relative error {min(r['rms_rel'] for r in rs):.2g} to "
                f"{max(r['rms_rel'] for r in rs):.2g} against the CPU (largest "
                f"{max(r['max_rel'] for r in rs):.2g}); {fmt(big['ms_per_step'])} ms per step at "
                f"N = {big['N']}")
        common = [r for r in rs if any(c["N"] == r["N"] for c in cpu)]
        if common:
            g = common[-1]
            c = [r for r in cpu if r["N"] == g["N"] and r["threads"] == ths[-1]][0]
            line += (f"; at N = {g['N']} {c['ms_per_step'] / g['ms_per_step']:.3g}x faster than "
                     f"the CPU on {ths[-1]} thread" + ("s" if ths[-1] > 1 else ""))
        print(line + ".")


def main(argv):
    cmds = {"timing": (timing, 3), "error": (error, 2), "error_ld": (error_ld, 4),
            "same": (same, 2), "plot": (plot, 3), "table": (table, 3),
            "summary": (summary, 2)}
    if len(argv) < 2 or argv[1] not in cmds or len(argv) - 2 != cmds[argv[1]][1]:
        die("bad arguments: " + " ".join(argv[1:]) + "\n" + __doc__)
    cmds[argv[1]][0](*argv[2:])


if __name__ == "__main__":
    main(sys.argv)
