"""The C++ MuJoCo contact filter (ellipsim/native/mujoco, issue 46), installed by ellipsim.mujoco.attach.

The filter on mixed piles of every pair type (it filters ellipsoid and sphere pairs, passes the others), with
speculative contacts on and off, and with margins and gaps: it sees pairs and discards some (none under
speculative contacts, which must keep every pair); its trajectory and counters are reproducible bit for bit: a
fresh data gives the first run's, and so does a rerun after mj_resetData.  The glue is compiled against the
headers of the mujoco the tests run.
"""

import mujoco
import numpy as np
import pytest

import ellipsim
import ellipsim.native as native
from ellipsim.app.bench.validation import mixed_pile_xml

ext = native.ext


def steps(model, data, n):
    qpos = []
    for _ in range(n):
        mujoco.mj_step(model, data)
        qpos.append(data.qpos.copy())
    return np.array(qpos)


def run(xml, n):
    """(qpos of n steps, counters then, qpos of n steps after mj_resetData) of a fresh data, filter attached."""
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    with ellipsim.mujoco.attach(m, d, mode="filter") as att:
        first = steps(m, d, n)
        counters = dict(att.counters)
        mujoco.mj_resetData(m, d)
        rerun = steps(m, d, n)
    return first, counters, rerun


def test_compiled_against_the_running_mujoco():
    assert ext.mujoco.MUJOCO_VERSION == mujoco.mj_version()
    assert ext.mujoco.FILTER != 0


@pytest.mark.parametrize("seed", [0, 1])
@pytest.mark.parametrize("variant", ["plain", "margins", "speculative"])
def test_the_filter_is_reproducible_and_discards_only_without_speculative_contacts(seed, variant):
    xml = mixed_pile_xml(seed=seed)
    if variant == "margins":
        xml = xml.replace("<worldbody>", '<default><geom margin="0.003" gap="0.001"/></default><worldbody>', 1)
    if variant == "speculative":
        xml = xml.replace(
            '<option timestep="0.002"/>', '<option timestep="0.002"><flag speculative="enable"/></option>'
        )
    assert xml != mixed_pile_xml(seed=seed) or variant == "plain"
    first, counters, rerun = run(xml, 300)
    assert counters["seen"] > 0
    assert (counters["discarded"] == 0) == (variant == "speculative")
    np.testing.assert_array_equal(rerun.view(np.int64), first.view(np.int64))  # after mj_resetData
    again, counters_again, _ = run(xml, 300)  # a fresh data
    assert counters_again == counters
    np.testing.assert_array_equal(again.view(np.int64), first.view(np.int64))
