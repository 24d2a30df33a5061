"""The C++ MuJoCo glue (ellipsim/native/mujoco, issue 46) against the numba callbacks it replaces.

Each callback, installed in MuJoCo's hooks the way ellipsim.mujoco.attach installs numba's, must give the
same counters and a bit-identical trajectory: the contact filter on mixed piles of every pair type (it
filters ellipsoid and sphere pairs, passes the others), with speculative contacts on and off, and with
margins and gaps.  The glue is compiled against the headers of the mujoco the tests run.
"""

import ctypes
import types

import mujoco
import numpy as np
import pytest

import ellipsim
import ellipsim.native as native
from ellipsim.app.bench.validation import mixed_pile_xml
from ellipsim.mujoco import context, nativecache, publish

ext = native.ext
FILTER_T = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int, ctypes.c_int)


INSTALLED = []


def native_function(kind):
    """nativecache.function's answer, for the C++ callback of `kind`."""
    INSTALLED.append(kind)
    publish.publish_context()
    publish.fill_context()
    ext.mujoco.set_context(context.CONTEXT.ctypes.data)
    assert kind == "filter"
    return types.SimpleNamespace(address=ext.mujoco.FILTER, ctypes=FILTER_T(ext.mujoco.FILTER))


def run(xml, mode, steps, native_glue, monkeypatch):
    with monkeypatch.context() as patch:
        if native_glue:
            patch.setattr(nativecache, "function", native_function)
        m = mujoco.MjModel.from_xml_string(xml)
        d = mujoco.MjData(m)
        qpos = []
        with ellipsim.mujoco.attach(m, d, mode=mode) as att:
            for _ in range(steps):
                mujoco.mj_step(m, d)
                qpos.append(d.qpos.copy())
            return np.array(qpos), att.counters


def test_compiled_against_the_running_mujoco():
    assert ext.mujoco.MUJOCO_VERSION == mujoco.mj_version()


@pytest.mark.parametrize("seed", [0, 1])
@pytest.mark.parametrize("variant", ["plain", "margins", "speculative"])
def test_the_filter_gives_numbas_counters_and_trajectory(seed, variant, monkeypatch):
    xml = mixed_pile_xml(seed=seed)
    if variant == "margins":
        xml = xml.replace("<worldbody>", '<default><geom margin="0.003" gap="0.001"/></default><worldbody>', 1)
    if variant == "speculative":
        xml = xml.replace(
            '<option timestep="0.002"/>', '<option timestep="0.002"><flag speculative="enable"/></option>'
        )
    assert xml != mixed_pile_xml(seed=seed) or variant == "plain"
    want_qpos, want = run(xml, "filter", 300, False, monkeypatch)
    INSTALLED.clear()
    got_qpos, got = run(xml, "filter", 300, True, monkeypatch)
    assert INSTALLED == ["filter"]  # the C++ callback ran
    assert got == want and want["seen"] > 0
    assert (want["discarded"] == 0) == (variant == "speculative")
    np.testing.assert_array_equal(got_qpos.view(np.int64), want_qpos.view(np.int64))
