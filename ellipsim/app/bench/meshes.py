"""Section 14 (meshes): ellipsim's narrow phase for an ellipsoid against a convex mesh and against a height field,
against MuJoCo's own table functions (mjc_Convex, mjc_ConvexHField: GJK, then EPA) on the same poses, and mj_step
of a scene of figures dropped onto a height field among mesh props, plain and attached.

Meshes: hulls of 8, 40, 120 and 500 random points (Gaussian, 5-15 cm), ellipsoids of semi-axes 2-15 cm, random
orientations, in four categories placed exactly through the proven distance (pair_types.py's): separated (gap
log-uniform in [1e-6, 0.1] m), touching (gap 0), penetrating (up to half the ellipsoid's shortest semi-axis) and
deep (the ellipsoid's centre within 0.3 of its shortest semi-axis of the hull's centre).  Height fields: a 30 x 30
field (2 m square, 10 cm of relief, random elevations: MuJoCo's cells are 6.9 cm) and ellipsoids over random
points of it, binned by their deepest prism: apart (0 to 2 cm above every prism), shallow (up to 1 mm in) and deep
(more); and resting: the terrain scenario's scene after 300 steps of landing (below), every ellipsoid whose
bounding sphere reaches the field's top against its field.  Each pose is a pair of geoms of one model; both
functions run in a compiled loop (margin 0), ellipsim's on a data attached in mode "narrowphase", in interleaved
rounds; the contacts per call are counted on both sides.
"""

import time

import mujoco
import numpy as np

from ...core.ellipsoids import Ellipsoids
from ...core.pairs.height_field import hfield_contacts
from ...core.pairs.shape_distance import shape_distance
from ...mujoco import publish
from ...mujoco.attachment import attach
from ...mujoco.hull import mesh_hull, model_height_field
from ...native import ext
from .. import scenes
from .common import interleaved, say

HULLS = (8, 40, 120, 500)
CATEGORIES = ("separated", "touching", "penetrating", "deep")
FIELD_CATEGORIES = ("apart", "shallow", "deep")
_CON = 50 * 10  # mjMAXCONPAIR mjPreContacts of 10 doubles: a height field's calls fill several


def _compiled(spec):
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    return model, data


def _mesh_model(points_list, n, rng):
    """A model of n static pairs (ellipsoid body 2i, mesh body 2i + 1; the meshes round-robin over points_list),
    ellipsoids of random semi-axes 2-15 cm at the origin, meshes 1 m away (moved into place later)."""
    spec = mujoco.MjSpec()
    for k, points in enumerate(points_list):
        spec.add_mesh(name=f"m{k}", uservert=points.ravel().tolist())
    for i in range(n):
        q = rng.normal(size=4)
        body = spec.worldbody.add_body(pos=[0, 0, 0], quat=q / np.linalg.norm(q))
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_ELLIPSOID, size=rng.uniform(0.02, 0.15, 3))
        q = rng.normal(size=4)
        body = spec.worldbody.add_body(pos=[1, 0, 0], quat=q / np.linalg.norm(q))
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname=f"m{i % len(points_list)}")
    return _compiled(spec)


def mesh_poses(points, category, n, rng):
    """(model, data, pairs (n, 2) int32) of n ellipsoid x mesh pairs of the category (module docstring)."""
    model, data = _mesh_model([points * rng.uniform(0.5, 1.5, 3) for _ in range(8)], n, rng)
    g = np.arange(n)
    ge, gm = 2 * g, 2 * g + 1
    E = Ellipsoids(data.geom_xpos[ge], data.geom_xmat[ge].reshape(-1, 3, 3), model.geom_size[ge])
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    mesh = model.geom_dataid[gm]
    hulls = [mesh_hull(model, k) for k in range(model.nmesh)]
    offset = model.geom_pos[gm]  # the mesh's centring (MuJoCo's), in its body's frame
    rmin = model.geom_size[ge].min(1)
    if category == "deep":
        centre = rng.uniform(-0.3, 0.3, (n, 3)) * rmin[:, None]
    else:
        centre = d * (2 * (model.geom_rbound[ge] + model.geom_rbound[gm]) + 0.1)[:, None]
        R = data.geom_xmat[gm].reshape(-1, 3, 3)
        dist, normal = np.empty(n), np.empty((n, 3))
        for k in range(model.nmesh):
            j = np.flatnonzero(mesh == k)
            dist[j], normal[j], _, _ = shape_distance(E[j], "mesh", centre[j], R[j], hulls[k], parallel=False)
        gap = {
            "separated": 10 ** rng.uniform(-6, -1, n),
            "touching": np.zeros(n),
            "penetrating": -rng.uniform(1e-6, 0.5, n) * rmin,
        }[category]
        centre = centre - normal * (dist - gap)[:, None]
    body = model.geom_bodyid[gm]
    R = data.xmat[body].reshape(-1, 3, 3)
    model.body_pos[body] = centre - np.einsum("kij,kj->ki", R, offset)  # the geom's centre where wanted
    mujoco.mj_kinematics(model, data)
    return model, data, np.ascontiguousarray(np.stack([ge, gm], 1), dtype=np.int32)


def field_poses(n, rng):
    """{category: (model, data, pairs)}: ellipsoids over a 30 x 30 height field, binned by their deepest prism."""
    spec = mujoco.MjSpec()
    spec.add_hfield(name="terrain", nrow=30, ncol=30, size=[1, 1, 0.1, 0.05], userdata=rng.uniform(0, 1, 900).tolist())
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_HFIELD, hfieldname="terrain")
    total = 6 * n
    radii = rng.uniform(0.02, 0.15, (total, 3))
    for i in range(total):
        q = rng.normal(size=4)
        z = rng.uniform(0.0, 0.1) + radii[i].min() * rng.uniform(-0.5, 1.2)
        body = spec.worldbody.add_body(pos=[*rng.uniform(-0.8, 0.8, 2), z], quat=q / np.linalg.norm(q))
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_ELLIPSOID, size=radii[i])
    model, data = _compiled(spec)
    ge = np.arange(1, total + 1)
    E = Ellipsoids(data.geom_xpos[ge], data.geom_xmat[ge].reshape(-1, 3, 3), model.geom_size[ge])
    c = hfield_contacts(
        E, data.geom_xpos[0], data.geom_xmat[0].reshape(3, 3), model_height_field(model, 0), 0.02, maxcon=500
    )
    listed = np.arange(500) < c.count[:, None]
    deepest = np.where(c.count > 0, np.min(np.where(listed, c.dist, np.inf), axis=1), np.inf)
    bins = {
        "apart": (deepest >= 0) & (deepest < 0.02),
        "shallow": (deepest < 0) & (deepest > -1e-3),
        "deep": deepest <= -1e-3,
    }
    out = {}
    for category, take in bins.items():
        chosen = ge[take][:n]
        out[category] = (
            model,
            data,
            np.ascontiguousarray(np.stack([np.zeros_like(chosen), chosen], 1), dtype=np.int32),
        )
    return out


def _terrain_scene():
    """The terrain scenario's scene (6 figures on a height field among 8 mesh rocks) and its state after 300 steps
    of landing."""
    model = mujoco.MjModel.from_xml_string(
        scenes.scene_xml(6, spacing=0.9, seed=4, terrain=True, props=8, drop_height=0.15)
    )
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, 300)
    mujoco.mj_forward(model, data)
    return model, data


def resting_field_pairs():
    """(model, data, pairs) of the terrain scene at rest: (field, ellipsoid) for every ellipsoid whose bounding
    sphere reaches the field's top (the figures' limbs resting on it and those just above)."""
    model, data = _terrain_scene()
    field = int(np.flatnonzero(model.geom_type == mujoco.mjtGeom.mjGEOM_HFIELD)[0])
    top = data.geom_xpos[field][2] + model.hfield_size[model.geom_dataid[field]][2]
    ell = np.flatnonzero(model.geom_type == mujoco.mjtGeom.mjGEOM_ELLIPSOID)
    near = ell[data.geom_xpos[ell, 2] - model.geom_rbound[ell] < top]
    return model, data, np.ascontiguousarray(np.stack([np.full_like(near, field), near], 1), dtype=np.int32)


def _time(model, data, pairs, theirs, size, rounds=5):
    """(ellipsim ns/call, MuJoCo ns/call, ellipsim contacts, MuJoCo contacts, fallbacks) on the pairs."""
    con = np.zeros(_CON)
    m, d, c = model._address, data._address, con.ctypes.data
    zeros = np.zeros(len(pairs))
    ours = ext.mujoco.NARROWPHASE
    with attach(model, data, mode="narrowphase", warm_start=False) as att:
        made = ext.bench.collision_loop(ours, m, d, c, pairs, zeros, 1)
        fallbacks = att.counters["fallbacks"]
        reps = max(1, size["mesh_calls"] // len(pairs))
        runs = {
            "ellipsim": lambda: ext.bench.collision_loop(ours, m, d, c, pairs, zeros, reps),
            "mujoco": lambda: ext.bench.collision_loop(theirs, m, d, c, pairs, zeros, reps),
        }
        t = interleaved(runs, rounds)
    theirs_made = ext.bench.collision_loop(theirs, m, d, c, pairs, zeros, 1)
    per = len(pairs) * reps
    return (*(float(np.min(t[k])) / per * 1e9 for k in runs), int(made), int(theirs_made), fallbacks)


def terrain_steps(size, rounds=5):
    """(plain mj_step us, narrowphase mj_step us, narrowphase counters) on the terrain scenario's scene (6 figures
    on a height field among 8 mesh rocks) after 300 steps of landing, size["terrain_steps"] steps a round from that
    state, interleaved rounds."""
    model, start = _terrain_scene()
    k = size["terrain_steps"]
    counters = {}

    def run(mode):
        data = mujoco.MjData(model)
        mujoco.mj_copyData(data, model, start)
        if mode == "builtin":
            t = time.perf_counter()
            mujoco.mj_step(model, data, k)
            return time.perf_counter() - t
        with attach(model, data, mode="narrowphase") as att:
            t = time.perf_counter()
            mujoco.mj_step(model, data, k)
            t = time.perf_counter() - t
        counters.update(att.counters)
        return t

    t = interleaved({m: (lambda m=m: run(m)) for m in ("builtin", "narrowphase")}, rounds, self_timed=True)
    ratio = float(np.median(np.asarray(t["narrowphase"]) / np.asarray(t["builtin"])))
    return float(np.median(t["builtin"])) / k * 1e6, float(np.median(t["narrowphase"])) / k * 1e6, ratio, counters


def measure(size):
    """{"mesh": {points: {category: row}}, "hfield": {category: row}, "pairs": n, "terrain": terrain_steps};
    row = _time's."""
    rng = np.random.default_rng(0)
    table, ntypes = publish.collision_table()
    n = size["mesh_pairs"]
    out = {"mesh": {}, "hfield": {}, "pairs": n}
    convex = table[int(mujoco.mjtGeom.mjGEOM_ELLIPSOID) * ntypes + int(mujoco.mjtGeom.mjGEOM_MESH)]
    for count in HULLS:
        say(f"meshes: ellipsoid x mesh of {count} points ...")
        points = rng.normal(size=(count, 3)) * rng.uniform(0.05, 0.15, 3)
        out["mesh"][count] = {c: _time(*mesh_poses(points, c, n, rng), convex, size) for c in CATEGORIES}
    say("meshes: ellipsoid x height field ...")
    field = table[int(mujoco.mjtGeom.mjGEOM_HFIELD) * ntypes + int(mujoco.mjtGeom.mjGEOM_ELLIPSOID)]
    for category, (model, data, pairs) in field_poses(n, rng).items():
        out["hfield"][category] = _time(model, data, pairs, field, size) if len(pairs) else None
    model, data, pairs = resting_field_pairs()
    out["hfield"]["resting"] = _time(model, data, pairs, field, size)
    say("meshes: mj_step on the terrain scene ...")
    out["terrain"] = terrain_steps(size)
    return out


def write(result, size, out, plt):
    """Markdown lines of the tables."""
    n = result["pairs"]
    L = [
        "## 14. Meshes and height fields",
        "",
        f"ellipsim's narrow phase against MuJoCo's mjc_Convex (ellipsoid x mesh) and mjc_ConvexHField (ellipsoid x "
        f"height field) at their default ccd_tolerance, per call, in a compiled loop over {n} poses per row (meshes.py; "
        "margin 0, minimum of 5 interleaved rounds).  Contacts: made by each side over the poses (a height-field "
        "call makes one per prism the ellipsoid overlaps).",
        "",
        "| pair | category | ellipsim ns/call | MuJoCo ns/call | speed-up | contacts ellipsim / MuJoCo | fallbacks |",
        "|---|---|---:|---:|---:|---:|---:|",
    ]
    for count, rows in result["mesh"].items():
        for category, (ours, theirs, made, theirs_made, fallbacks) in rows.items():
            L.append(
                f"| ellipsoid x mesh of {count} points | {category} | {ours:.0f} | {theirs:.0f} | {theirs / ours:.2f}x "
                f"| {made} / {theirs_made} | {fallbacks} |"
            )
    for category, row in result["hfield"].items():
        if row is None:
            L.append(f"| ellipsoid x height field | {category} | - | - | - | no pose | - |")
            continue
        ours, theirs, made, theirs_made, fallbacks = row
        field = "the terrain scene's" if category == "resting" else "30 x 30"
        L.append(
            f"| ellipsoid x height field, {field} | {category} | {ours:.0f} | {theirs:.0f} | {theirs / ours:.2f}x "
            f"| {made} / {theirs_made} | {fallbacks} |"
        )
    plain, ours, ratio, c = result["terrain"]
    L += [
        "",
        f"mj_step on the terrain scenario's scene (6 figures on a 30 cm hilly height field among 8 convex mesh rocks, "
        f"from the state after 300 steps of landing, {size['terrain_steps']} steps a round, median of 5 interleaved "
        f"rounds): plain MuJoCo {plain:.0f} us, narrowphase {ours:.0f} us a step, **{ratio:.2f}x** plain's time "
        f"(narrow-phase calls {c.get('calls', 0)}: {c.get('contacts', 0)} with contacts, {c.get('fallbacks', 0)} "
        "fallbacks).",
    ]
    return L + [""]
