import errno
import subprocess
import sys

import numpy as np
import pytest

from ellipsim import classify
from ellipsim.app.cli import main
from ellipsim import contact_scale
from ellipsim.core.samples import generic_pairs, near_contact_pairs


def test_demo_prints_the_table(capsys):
    assert main(["demo", "--pairs", "2000", "--seed", "3"]) == 0
    out = capsys.readouterr().out
    assert "2000 random ellipsoid pairs" in out
    exact_row = next(line for line in out.splitlines() if line.strip().startswith("exact "))
    sep, touch, over, wrong = (int(x) for x in exact_row.split()[1:5])
    assert (sep, touch + over, wrong) == (1000, 1000, 0)


def test_bad_arguments_exit_2_with_one_line():
    for args in (["demo", "--pairs", "0"], ["demo", "--pairs", "many"], ["frobnicate"], []):
        proc = subprocess.run([sys.executable, "-m", "ellipsim", *args], capture_output=True, text=True)
        assert proc.returncode == 2
        assert proc.stdout == "" and len(proc.stderr.strip().splitlines()) == 1
        assert "Traceback" not in proc.stderr


def test_sample_sets():
    a, b = generic_pairs(1000, seed=5)
    rel = classify(a, b)
    assert len(a) == 1000 and np.count_nonzero(rel == 0) == 500
    a, b = near_contact_pairs(300, band=0.05, seed=5)
    assert len(a) == 300 and np.all(np.abs(contact_scale(a, b) - 1) < 0.05)


def test_show_must_not_be_negative():
    proc = subprocess.run([sys.executable, "-m", "ellipsim", "compare", "replay", "--show", "-1"], capture_output=True, text=True)
    assert proc.returncode == 2 and proc.stdout == "" and "Traceback" not in proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "--show: expected a non-negative integer, got -1" in lines[0]


def test_compare_quotes_the_near_tangent_band(monkeypatch, capsys):
    monkeypatch.setattr("ellipsim.app.cli.NEAR_TANGENT", 3e-6)
    assert main(["compare", "replay", "--steps", "5", "--show", "0"]) == 0
    assert "within 3e-06 m of touching" in capsys.readouterr().out


def _unwritable(*args, **kwargs):
    raise PermissionError(errno.EACCES, "Permission denied")


@pytest.mark.parametrize(
    "args, patch",
    [
        (["compare", "replay", "--steps", "5", "--json", "{dir}/c.json"], ("ellipsim.app.cli.open", _unwritable)),
        (["compare", "replay", "--steps", "5", "--plot", "{dir}/c.png"], ("matplotlib.figure.Figure.savefig", _unwritable)),
        (["run", "replay", "--steps", "5", "--record", "{dir}/c.rrd"], ("ellipsim.app.record.save", _unwritable)),
    ],
)
def test_output_that_cannot_be_written_is_one_line(tmp_path, monkeypatch, capsys, args, patch):
    """A write that fails after the run (full disk, permissions changed meanwhile): one line, status 2."""
    if "--plot" in args:
        pytest.importorskip("matplotlib")
    target, fake = patch
    monkeypatch.setattr(target, fake, raising=False)
    args = [a.format(dir=tmp_path) for a in args]
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()  # the progress bar's lines, then the error
    assert err[-1] == f"ellipsim: error: {args[-2]}: cannot write {args[-1]!r}: Permission denied"
    assert not any("error" in line or "Traceback" in line for line in err[:-1])
