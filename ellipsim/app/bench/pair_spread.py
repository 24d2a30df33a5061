"""Section 11 (pairs): the other pair types' table (pair_types.py, also in section 5) measured
size["pair_repeats"] times in one process on the same poses, each cell's speed-up as its median,
lowest and highest: a single run's cell moves by several percent with the VM (deep cylinder crossings
once measured 0.96-1.15x across runs of one build), which one table cannot show."""

import numpy as np

from . import pair_types
from .common import say


def measure(size):
    """[pair_types.measure(size) per repeat] (seed 0: the same poses each time)."""
    runs = []
    for k in range(size["pair_repeats"]):
        say(f"pairs: other pair types, run {k + 1} of {size['pair_repeats']} ...")
        runs.append(pair_types.measure(size, seed=0))
    return runs


def write(result, size, out, plt):
    """Markdown lines: per pair type and category, the median ns of both sides and the speed-up's
    median, lowest and highest over the runs."""
    L = [
        "## 11. Other pair types, run after run",
        "",
        f"The pair-type table of section 5 (pair_types.py: ellipsim's narrow phase against MuJoCo's mjc_Convex per "
        f"call, each run the minimum of 5 interleaved rounds) measured {len(result)} times in one process on the same "
        "poses.  Speed-up = MuJoCo ns / ellipsim ns per run.",
        "",
        "| pair | category | ellipsim ns/pair, median | MuJoCo ns/pair, median | speed-up, median | lowest | highest "
        "| runs slower than MuJoCo |",
        "|---|---|---:|---:|---:|---:|---:|---:|",
    ]
    for kind, rows in result[0].items():
        for category in rows:
            ours = np.array([run[kind][category][0] for run in result])
            theirs = np.array([run[kind][category][1] for run in result])
            speed = theirs / ours
            L.append(
                f"| ellipsoid x {kind} | {category} | {np.median(ours):.0f} | {np.median(theirs):.0f} "
                f"| {np.median(speed):.2f}x | {speed.min():.2f}x | {speed.max():.2f}x "
                f"| {int(np.sum(speed < 1.0))} of {len(result)} |"
            )
    return L + [""]
