"""Shared by the report's python helpers (seed_plot.py, gravity_plot.py): stop with a message
naming the problem, read a number that must be finite, and load a section's CSV rows with their
numbers checked, so that a failed or wrong run never reaches a table."""
import csv
import math
import os
import sys


def die(msg):
    sys.stderr.write(os.path.basename(sys.argv[0]) + ": " + msg + "\n")
    sys.exit(1)


def finite(name, text):
    try:
        v = float(text)
    except ValueError:
        die(f"{name} = '{text}' is not a number")
    if not math.isfinite(v):
        die(f"{name} = {text} is not finite")
    return v


def load_rows(path, ints, text, blank_ok=False):
    """The rows of a CSV file (none: stop): the columns in ints as int, those in text as they
    are, every other one a finite number (an empty field as None where blank_ok)."""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        die(f"{path}: no rows")
    for r in rows:
        for k in r:
            if k in ints:
                r[k] = int(r[k])
            elif k not in text:
                r[k] = None if blank_ok and r[k] == "" else finite(k, r[k])
    return rows
