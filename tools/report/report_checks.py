"""Shared by the report's python helpers (seed_plot.py, gravity_plot.py): stop with a message
naming the problem, and read a number that must be finite, so that a failed or wrong run never
reaches a table."""
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
