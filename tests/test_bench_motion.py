"""The benchmark suite's motion section (ellipsim/app/bench/motion.py): its sampling checker agrees with
time_of_impact's proofs, and a small run writes the report and the plot."""

import numpy as np
import pytest

from ellipsim.app.bench import SECTIONS, motion
from ellipsim.app.bench import common as bench
from ellipsim.core.motion.time_of_impact import Impact, time_of_impact
from ellipsim.core.tolerances import TOI_TOL


@pytest.mark.parametrize("name", list(motion.SETS))
def test_sampled_contacts_never_precede_the_proven_range(name):
    """The checker classifies the same float poses that time_of_impact proves separated before toi - TOI_TOL:
    no sampled instant there is a contact, and a pair proven apart throughout has no sampled contact."""
    a0, a1, b0, b1 = motion.SETS[name](np.random.default_rng(3), 150)
    toi, status = time_of_impact(a0, a1, b0, b1, return_status=True)
    N = 257
    hits = motion.first_hits(a0, a1, b0, b1, N)
    t_hit = np.where(hits < N, hits / (N - 1.0), np.inf)
    assert np.all(t_hit >= toi - TOI_TOL)
    assert np.all(hits[status == Impact.NO_CONTACT] == N)
    assert np.count_nonzero(np.isfinite(toi)) > 30
    if name == "tunnel":  # contacts shorter than the samples' spacing: most are missed
        assert np.count_nonzero(hits < N) < 0.9 * len(toi)


def test_small_run_writes_the_section_and_its_plot(tmp_path):
    from matplotlib import pyplot

    size = dict(bench.SIZES["quick"], motion=40, motion_samples=(2, 16, 128), motion_contains=300, rounds=1)
    rows, curves, cont = result = motion.measure(size)
    assert set(rows) == set(curves) == set(motion.SETS) and SECTIONS["motion"] is motion
    assert all(r["contacts"] >= r["found64"] for r in rows.values()) and cont["escalated"] == 0
    lines = motion.write(result, size, str(tmp_path), pyplot)
    text = "\n".join(lines)
    assert "## 7. Moving ellipsoids" in text and "| tunnel | 40 |" in text and "contains on 300 pairs" in text
    assert (tmp_path / "motion.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
