import subprocess
import sys

import numpy as np

from ellipsim import classify
from ellipsim.cli import main
from ellipsim import contact_scale
from ellipsim.samples import generic_pairs, near_contact_pairs


def test_demo_prints_the_table(capsys):
    assert main(["demo", "--pairs", "2000", "--seed", "3"]) == 0
    out = capsys.readouterr().out
    assert "2000 random ellipsoid pairs" in out
    exact_row = next(line for line in out.splitlines() if line.strip().startswith("exact "))
    sep, touch, over, wrong = (int(x) for x in exact_row.split()[1:5])
    assert (sep, touch + over, wrong) == (1000, 1000, 0)


def test_bad_arguments_exit_2_with_one_line():
    for args in (["demo", "--pairs", "0"], ["demo", "--pairs", "many"], ["frobnicate"], []):
        proc = subprocess.run([sys.executable, "-m", "ellipsim.cli", *args], capture_output=True, text=True)
        assert proc.returncode == 2
        assert proc.stdout == "" and len(proc.stderr.strip().splitlines()) == 1
        assert "Traceback" not in proc.stderr


def test_sample_sets():
    a, b = generic_pairs(1000, seed=5)
    rel = classify(a, b)
    assert len(a) == 1000 and np.count_nonzero(rel == 0) == 500
    a, b = near_contact_pairs(300, band=0.05, seed=5)
    assert len(a) == 300 and np.all(np.abs(contact_scale(a, b) - 1) < 0.05)
