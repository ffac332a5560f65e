"""Angle of repose of a heap from tools/report/in.granular_repose's dump (x, z, radius).

    python3 repose.py repose.hs.xyz [repose.gran.xyz ...]

The surface is the highest sphere top (z + r) in bins of width 1.2 along x; the angle is the
least-squares slope of the surface where it lies between 15 % and 85 % of the heap's height
(the flank, away from the crest against the wall and the thin runout at the toe)."""
import math
import sys


def heap(path):
    xs = []
    with open(path) as f:
        lines = f.readlines()
    n = int(lines[3])
    for line in lines[9:9 + n]:
        x, z, r = (float(w) for w in line.split())
        xs.append((x, z + r))
    return xs


def angle(pts, width=1.2):
    top = {}
    for x, z in pts:
        b = int(x // width)
        top[b] = max(top.get(b, 0.0), z)
    bins = sorted(top)
    h = max(top.values())
    sel = [((b + 0.5) * width, top[b]) for b in bins if 0.15 * h <= top[b] <= 0.85 * h]
    if len(sel) < 3:
        return float("nan"), h, max(x for x, _ in pts)
    mx = sum(x for x, _ in sel) / len(sel)
    mz = sum(z for _, z in sel) / len(sel)
    sxx = sum((x - mx) ** 2 for x, _ in sel)
    sxz = sum((x - mx) * (z - mz) for x, z in sel)
    return math.degrees(math.atan(-sxz / sxx)), h, max(x for x, _ in pts)


if __name__ == "__main__":
    for path in sys.argv[1:]:
        a, h, runout = angle(heap(path))
        print(f"{path}: angle of repose {a:.1f} deg, heap height {h:.2f}, runout {runout:.2f}")
