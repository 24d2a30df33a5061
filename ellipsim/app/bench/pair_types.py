"""Section 5, pair types: ellipsim's narrow phase for an ellipsoid against a capsule, a box or a
cylinder, against MuJoCo's own table function (mjc_Convex: GJK, then EPA), per contact category.

Random poses (semi-axes and half-sizes 0.02-0.3 m, random orientations) in four categories: separated
(gap log-uniform in [1e-6, 0.1] m), touching (gap 0), penetrating (pushed in by up to half the smaller
shortest half-size) and deep (centres within 0.3 of the ellipsoid's shortest semi-axis).  Gaps are
placed exactly: the other body is translated along the normal of a separated configuration (the
distance of convex bodies shrinks by exactly the translation while they stay apart).  Each pose is a
pair of geoms of one model; both functions are called in a compiled loop over the pairs (margin 0),
ellipsim's on a data attached in mode "narrowphase", in interleaved rounds.  ellipsim's time includes
its fallbacks to MuJoCo's function (pairs whose maximum it could not prove), counted in the table.
"""

import mujoco
import numpy as np

from ...core.ellipsoids import Ellipsoids
from ...core.pairs.shape_distance import shape_distance
from ...core.rotations import quaternions_to_rotations
from ...mujoco import publish
from ...mujoco.attachment import attach
from ...native import ext
from .common import interleaved

KINDS = ("capsule", "box", "cylinder")
CATEGORIES = ("separated", "touching", "penetrating", "deep")
_TYPE = {
    "capsule": mujoco.mjtGeom.mjGEOM_CAPSULE,
    "box": mujoco.mjtGeom.mjGEOM_BOX,
    "cylinder": mujoco.mjtGeom.mjGEOM_CYLINDER,
}


def _calls(fn, m, d, con, pairs, reps):
    """The mjfCollision at address fn over the pairs (margin 0), reps times, in a compiled loop."""
    return ext.bench.collision_loop(fn, m, d, con, pairs, np.zeros(len(pairs)), reps)


def _rotations(rng, n):
    q = rng.normal(size=(n, 4))
    return quaternions_to_rotations(q / np.linalg.norm(q, axis=1)[:, None])


def poses(kind, category, n, rng):
    """(cE, RE, rE, cK, RK, sK) of n poses of the category (module docstring); sK as MuJoCo's geom_size."""
    rE = rng.uniform(0.02, 0.3, (n, 3))
    sK = rng.uniform(0.02, 0.3, (n, 3))
    if kind != "box":
        sK[:, 0] = rng.uniform(0.01, 0.15, n)  # radius
        sK[:, 2] = 0.0
    RE, RK = _rotations(rng, n), _rotations(rng, n)
    cE = np.zeros((n, 3))
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    cK = d * (2 * (np.linalg.norm(rE, axis=1) + np.linalg.norm(sK, axis=1)) + 0.1)[:, None]
    small = np.minimum(rE.min(1), sK[:, : 3 if kind == "box" else 2].min(1))
    if category == "deep":
        cK = rng.uniform(-0.3, 0.3, (n, 3)) * rE.min(1)[:, None]
        return cE, RE, rE, cK, RK, sK
    gap = {
        "separated": 10 ** rng.uniform(-6, -1, n),
        "touching": np.zeros(n),
        "penetrating": -rng.uniform(1e-6, 0.5, n) * small,
    }[category]
    dist, normal, _, _ = shape_distance(Ellipsoids(cE, RE, rE), kind, cK, RK, sK, parallel=False)
    cK = cK - normal * (dist - gap)[:, None]
    return cE, RE, rE, cK, RK, sK


def _model(kind, cE, RE, rE, cK, RK, sK):
    """A model with the poses as pairs of static geoms, ordered as MuJoCo's table (type1 <= type2), and
    the (g1, g2) pairs."""
    spec = mujoco.MjSpec()
    for i in range(len(cE)):
        for c, R, size, t in (
            (cE[i], RE[i], rE[i], mujoco.mjtGeom.mjGEOM_ELLIPSOID),
            (cK[i], RK[i], sK[i], _TYPE[kind]),
        ):
            body = spec.worldbody.add_body(pos=c)
            q = np.empty(4)
            mujoco.mju_mat2Quat(q, R.ravel())
            body.quat = q
            body.add_geom(type=t, size=size)
    model = spec.compile()
    g = np.arange(len(cE), dtype=np.int64)
    pairs = np.stack([2 * g + 1, 2 * g], 1) if kind == "capsule" else np.stack([2 * g, 2 * g + 1], 1)
    return model, np.ascontiguousarray(pairs, dtype=np.int32)


def measure(size, n=None, seed=0):
    """{kind: {category: (ellipsim ns, MuJoCo ns, fallbacks, pairs)}}."""
    n = n or size["pair_types"]
    rng = np.random.default_rng(seed)
    table, ntypes = publish.collision_table()
    ours = ext.mujoco.NARROWPHASE
    out = {}
    for kind in KINDS:
        t1, t2 = sorted((int(_TYPE[kind]), int(mujoco.mjtGeom.mjGEOM_ELLIPSOID)))
        theirs = table[t1 * ntypes + t2]
        out[kind] = {}
        for category in CATEGORIES:
            model, pairs = _model(kind, *poses(kind, category, n, rng))
            data = mujoco.MjData(model)
            mujoco.mj_kinematics(model, data)
            con = np.zeros(50 * 10)  # room for mjMAXCONPAIR mjPreContacts (10 doubles each)
            m, d, c = model._address, data._address, con.ctypes.data
            with attach(model, data, mode="narrowphase", warm_start=False) as att:
                _calls(ours, m, d, c, pairs, 1)
                fallbacks = att.counters["fallbacks"]
                reps = max(1, size["pair_type_calls"] // n)
                runs = {
                    "ellipsim": lambda: _calls(ours, m, d, c, pairs, reps),
                    "mujoco": lambda: _calls(theirs, m, d, c, pairs, reps),
                }
                t = interleaved(runs, 5)
            out[kind][category] = (*(float(np.min(t[k])) / (n * reps) * 1e9 for k in runs), fallbacks, n)
    return out


def write(result):
    """Markdown lines of the table."""
    L = [
        "",
        "Other pair types (pair_types.py): ellipsim's narrow phase and MuJoCo's mjc_Convex (default ccd_tolerance) "
        "per call, in a compiled loop over random poses per category (margin 0, no warm start; minimum of 5 "
        "interleaved rounds).  Fallbacks: pairs ellipsim handed to MuJoCo's function (its time includes them).",
        "",
        "| pair | category | pairs | ellipsim ns/pair | MuJoCo ns/pair | speed-up | fallbacks |",
        "|---|---|---:|---:|---:|---:|---:|",
    ]
    for kind, rows in result.items():
        for category, (ours, theirs, fallbacks, n) in rows.items():
            L.append(
                f"| ellipsoid x {kind} | {category} | {n} | {ours:.0f} | {theirs:.0f} | {theirs / ours:.2f}x | {fallbacks} |"
            )
    return L
