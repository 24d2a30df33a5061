"""Section 13's measuring process (baseline.py): run as `PYTHON -I -c <this file's text> INPUTS.npz ROUNDS` in this
build's interpreter and in the baseline's, it times the public API of whichever ellipsim that interpreter has
installed on the same inputs and prints one JSON object: the seconds of each item's fastest repeat per unit
(a pair, a step).  It imports nothing of this checkout (-I: no current directory on sys.path) and uses only the
API both builds share.
"""

import json
import sys
import time

import mujoco
import numpy as np

import ellipsim
from ellipsim import Ellipsoids


def best(call, units, repeats):
    """The fastest of `repeats` calls (after one warm-up call), in seconds per unit."""
    call()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        call()
        times.append(time.perf_counter() - t0)
    return min(times) / units


def batch(z, name):
    return Ellipsoids(z[f"{name}_c"], z[f"{name}_R"], z[f"{name}_r"])


def pair_items(z, repeats):
    """Per-pair seconds of every public batch function, serial (parallel=False: the cost of a pair, not of the
    machine's cores), plus classify on all cores."""
    a, b = batch(z, "a"), batch(z, "b")
    na, nb = batch(z, "na"), batch(z, "nb")
    n, m = len(a), len(na)
    e = batch(z, "e")
    t0, t1, u0, u1 = (batch(z, k) for k in ("t0", "t1", "u0", "u1"))
    out = {}
    for method in ("exact", "sturm", "descartes"):
        out[f"classify method={method}"] = best(
            lambda: ellipsim.classify(a, b, method=method, parallel=False), n, repeats
        )
    for setup, dtype in (("rearranged", "float32"), ("cofactor", "float64")):
        out[f"classify method=sturm setup={setup} dtype={dtype}"] = best(
            lambda: ellipsim.classify(a, b, method="sturm", setup=setup, dtype=dtype, parallel=False), n, repeats
        )
    out["classify, all cores"] = best(lambda: ellipsim.classify(a, b, parallel=True), n, repeats)
    both = Ellipsoids(
        np.concatenate([a.centers, b.centers]),
        np.concatenate([a.rotations, b.rotations]),
        np.concatenate([a.radii, b.radii]),
    )
    first, second = np.arange(n), np.arange(n, 2 * n)
    out["classify_pairs"] = best(lambda: ellipsim.classify_pairs(both, first, second, parallel=False), n, repeats)
    out["characteristic_polynomial"] = best(
        lambda: ellipsim.characteristic_polynomial(a, b, parallel=False), n, repeats
    )
    out["contact_scale"] = best(lambda: ellipsim.contact_scale(a, b, parallel=False), n, repeats)
    out["contains"] = best(lambda: ellipsim.contains(a, b, parallel=False), n, repeats)
    out["signed_distance (near contact)"] = best(lambda: ellipsim.signed_distance(na, nb, parallel=False), m, repeats)
    out["signed_distance derivatives=True"] = best(
        lambda: ellipsim.signed_distance(na, nb, parallel=False, derivatives=True), m, repeats
    )
    for kind in ("capsule", "box", "cylinder"):
        C, R, s = z[f"{kind}_c"], z[f"{kind}_R"], z[f"{kind}_s"]
        k = len(C)
        out[f"shape_distance {kind}"] = best(
            lambda: ellipsim.shape_distance(e, kind, C, R, s, parallel=False), k, repeats
        )
        out[f"shape_distance {kind} derivatives=True"] = best(
            lambda: ellipsim.shape_distance(e, kind, C, R, s, parallel=False, derivatives=True), k, repeats
        )
    nt = len(t0)
    out["time_of_impact"] = best(lambda: ellipsim.time_of_impact(t0, t1, u0, u1, parallel=False), nt, repeats)
    out["time_of_impact derivatives=True"] = best(
        lambda: ellipsim.time_of_impact(t0, t1, u0, u1, parallel=False, derivatives=True), nt, repeats
    )
    return out


def step_items(z, repeats):
    """Seconds per mj_step of each scene in each mode, from the same settled state (its own steps: MuJoCo alone,
    the filter, the narrow phase); the modes alternate within each repeat."""
    out = {}
    steps = int(z["steps"])
    spec = mujoco.mjtState.mjSTATE_INTEGRATION
    for name, xml in zip(z["scene_names"], z["scene_xmls"]):
        model = mujoco.MjModel.from_xml_string(str(xml))
        data = mujoco.MjData(model)
        for _ in range(int(z["settle"])):
            mujoco.mj_step(model, data)
        state = np.empty(mujoco.mj_stateSize(model, spec))
        mujoco.mj_getState(model, data, state, spec)
        times = {mode: [] for mode in ("builtin", "filter", "narrowphase")}
        for _ in range(repeats + 1):  # the first round warms up
            for mode in times:
                mujoco.mj_setState(model, data, state, spec)
                if mode == "builtin":
                    t0 = time.perf_counter()
                    for _ in range(steps):
                        mujoco.mj_step(model, data)
                    times[mode].append(time.perf_counter() - t0)
                    continue
                with ellipsim.mujoco.attach(model, data, mode=mode):
                    t0 = time.perf_counter()
                    for _ in range(steps):
                        mujoco.mj_step(model, data)
                    times[mode].append(time.perf_counter() - t0)
        for mode, t in times.items():
            out[f"mj_step {name}, {mode}"] = min(t[1:]) / steps
    return out


def main(path, repeats):
    z = np.load(path)
    result = {"version": ellipsim.__version__, "file": ellipsim.__file__}
    result.update(pair_items(z, repeats))
    result.update(step_items(z, repeats))
    print(json.dumps(result))


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]))
