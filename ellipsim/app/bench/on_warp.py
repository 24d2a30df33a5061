"""Section 9 (warp): ellipsim on MuJoCo Warp against Warp's own float32 GJK/EPA, on Warp's device
(CPU here unless CUDA is present: the table says which).

1. Accuracy: one pair per world (two free geoms, each world its own poses and sizes set directly in
   the model's per-world arrays), ellipsoid, sphere, capsule, cylinder and box against an ellipsoid, in
   categories by distance from touching (deep, shallow, within 1e-6, inside the margin, beyond it),
   near the origin and 100 m away; every world's contact from plain Warp at its default and at tight
   settings (ccd_tolerance 1e-10, 1000 iterations) and from an attached model, against the exact
   answer: ellipsim's CPU narrow phase on the same float32 poses widened to float64 (proven global
   maxima: signed_distance, shape_distance).
2. Cost per pair, the CPU proxy for a GPU: mjw.collision over N worlds of one pair each, minus the same
   call on a model whose pair is excluded (broad phase and launches with nothing to do), over N;
   plain (Warp's GJK/EPA kernel) and attached (ellipsim's kernel), in interleaved rounds, for the
   ellipsoid, capsule, cylinder and box pairs.
3. Cost per height field x ellipsoid pair: 8 ellipsoids settled on a 30 x 30 field (MuJoCo C's steps) in N
   worlds, mjw.collision less the same call with the ellipsoids 5 m up (culled by the bounding spheres), over
   the pairs; plain (Warp's hfield kernel: GJK/EPA per prism, up to 4 contacts a pair) and attached
   (pairs/height_field.hpp: a contact per prism within the margin, up to 50), interleaved.
4. Cost per convex mesh x ellipsoid pair, as 3: 8 ellipsoids settled on a static mesh slab (MuJoCo's hull of
   40 points), then on a 300-vertex spheroid (the mesh row's posed path); plain (Warp's GJK/EPA) and attached
   (pairs/polytope.hpp on the same hull).
5. Collision stage and mjw.step per world-step on settled scenes (the 16-figure heap, the pile),
   attached vs plain, interleaved.
"""

import time

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from ...core.distance.ellipsoid_pair import signed_distance
from ...core.ellipsoids import Ellipsoids
from ...core.pairs.shape_distance import shape_distance
from .. import scenes
from .common import interleaved, say, settled

#: This section's sizes (kept here: common.py's text keys the bench's shipped kernels).
WARP_SIZES = {
    "quick": dict(warp_pairs=200, warp_cost_worlds=20_000, warp_worlds=16, warp_settle=1000),
    "full": dict(warp_pairs=1_000, warp_cost_worlds=100_000, warp_worlds=64, warp_settle=1000),
}

#: Distance from touching as a multiple of the pair's smallest semi-axis (margin: MARGIN of it).
CATEGORIES = {
    "deep (-0.3)": -0.3,
    "shallow (-1e-3)": -1e-3,
    "touching (+-1e-6)": 1e-6,
    "inside the margin (+0.5 m)": 0.5,
    "beyond the margin (+1.5 m)": 1.5,
}
MARGIN = 0.02  # of the smallest semi-axis, in the two inside/beyond-margin categories
PAIR_KINDS = ("ellipsoid", "sphere", "capsule", "cylinder", "box")  # geom 0's type; geom 1 is an ellipsoid
COST_KINDS = ("ellipsoid", "capsule", "cylinder", "box")  # (sphere x ellipsoid is the ellipsoid pair's kernel)
PAIR_NAMES = {
    "ellipsoid": "ellipsoid x ellipsoid",
    "sphere": "sphere x ellipsoid",
    "capsule": "capsule x ellipsoid",
    "cylinder": "ellipsoid x cylinder",
    "box": "ellipsoid x box",
}

_TWO = """<mujoco><worldbody>
<body><freejoint/><geom type="{t}" size=".1 .1 .1"/></body>
<body pos="1 0 0"><freejoint/><geom type="ellipsoid" size=".1 .1 .1" {excl}/></body>
</worldbody></mujoco>"""


def _warp():
    import mujoco_warp as mjw
    import warp as wp

    import ellipsim.warp as ew

    return wp, mjw, ew


def make_pairs(rng, n, kind, category, offset):
    """n float32 poses (ca, Ra, ra, cb, Rb, rb) and per-pair margins, B moved along the exact normal to
    the category's distance; aspect ratios 1:1:1 to 10:1:1 and 10:10:1 (a capsule's (radius, half-length)
    (and a cylinder's), and a box's half-sizes drawn from the same shapes)."""
    aspect = rng.choice([0, 1, 2], n)
    base = rng.uniform(0.02, 0.1, (n, 1))
    shape = np.where(
        (aspect == 0)[:, None],
        rng.uniform(1, 2, (n, 3)),
        np.where((aspect == 1)[:, None], np.array([10.0, 1, 1]), np.array([10.0, 10, 1]))
        * rng.uniform(0.8, 1.2, (n, 3)),
    )
    ra = base * shape
    if kind == "sphere":
        ra = np.repeat(ra[:, :1], 3, 1) / 3
    elif kind in ("capsule", "cylinder"):
        ra = np.stack([ra.min(1), ra.max(1), np.zeros(n)], 1)
    rb = rng.uniform(0.02, 0.1, (n, 1)) * np.where(
        (rng.random(n) < 0.5)[:, None],
        rng.uniform(1, 2, (n, 3)),
        np.array([10.0, 1, 1]) * rng.uniform(0.8, 1.2, (n, 3)),
    )
    Ra = Rotation.random(n, random_state=rng).as_matrix()
    Rb = Rotation.random(n, random_state=rng).as_matrix()
    if kind == "sphere":
        Ra[:] = np.eye(3)
    ca = offset + rng.uniform(-0.5, 0.5, (n, 3))
    cb = ca + rng.normal(size=(n, 3)) * 0.1
    f32 = lambda x: np.asarray(x, np.float32)  # noqa: E731
    rmin = np.minimum(_smallest(kind, ra), rb.min(1))
    target = CATEGORIES[category]
    margin = np.where(target >= 0.5, MARGIN * rmin, 0.0)
    goal = np.where(target >= 0.5, target * margin, target * rmin)
    for _ in range(3):  # float32 rounding of the moved centre: re-aim on the rounded poses
        d, nrm, _, _ = _exact(kind, f32(ca), f32(Ra), f32(ra), f32(cb), f32(Rb), f32(rb))
        cb = f32(cb) + nrm * (goal - d)[:, None]
    if target == 1e-6:  # either side of touching
        cb = cb + nrm * (rng.choice([-1.0, 1.0], n) * 1e-6 * rmin)[:, None]
    return [f32(x) for x in (ca, Ra, ra, cb, Rb, rb)], f32(margin)


def _smallest(kind, size):
    """The smallest half-size of geom 0 (a capsule's radius; a cylinder's radius or half-length)."""
    if kind == "capsule":
        return size[:, 0]
    return size[:, :2].min(1) if kind == "cylinder" else size.min(1)


def _exact(kind, ca, Ra, ra, cb, Rb, rb):
    """(dist, normal from geom 0 to geom 1, pos, status) by ellipsim's CPU narrow phase on the float32 poses
    widened to float64: signed_distance, or shape_distance for a capsule, cylinder or box (status 1 where
    a cylinder's kernel says UNPROVEN or a distance is not finite)."""
    w = lambda x: np.asarray(x, np.float32).astype(np.float64)  # noqa: E731
    if kind in ("ellipsoid", "sphere"):
        return signed_distance(Ellipsoids(w(ca), w(Ra), w(ra)), Ellipsoids(w(cb), w(Rb), w(rb)))
    dist, normal, pos, status = shape_distance(Ellipsoids(w(cb), w(Rb), w(rb)), kind, w(ca), w(Ra), w(ra))
    return dist, -normal, pos, status.astype(int)  # (its normal is from the ellipsoid, geom 1)


def pair_worlds(kind, poses, margin, *, exclude=False, tight=False, device="cpu"):
    """A mujoco_warp (model, data) holding pair i in world i: the model's per-world geom arrays (size,
    rbound, aabb, margin) and the data's geom poses set directly (no kinematics runs)."""
    wp, mjw, _ = _warp()
    ca, Ra, ra, cb, Rb, rb = poses
    n = len(ca)
    mjm = mujoco.MjModel.from_xml_string(_TWO.format(t=kind, excl='contype="0" conaffinity="0"' if exclude else ""))
    if tight:
        mjm.opt.ccd_tolerance, mjm.opt.ccd_iterations = 1e-10, 1000
    with wp.ScopedDevice(device):
        m = mjw.put_model(mjm)
        d = mjw.put_data(mjm, mujoco.MjData(mjm), nworld=n, naconmax=4 * n)
        radii = np.stack([ra, rb], 1)  # a sphere's (r, r, r): Warp and ellipsim read its first entry
        m.geom_size = wp.array(radii.astype(np.float32), dtype=wp.vec3)
        half = radii.copy()  # the local bounding box's half-extents and the bounding sphere (as put_model)
        if kind in ("capsule", "cylinder"):
            L = ra[:, 1] + (ra[:, 0] if kind == "capsule" else 0.0)
            half[:, 0] = np.stack([ra[:, 0], ra[:, 0], L], 1)
        rbound = radii.max(2)
        bound = {
            "capsule": ra[:, 0] + ra[:, 1],
            "cylinder": np.hypot(ra[:, 0], ra[:, 1]),
            "box": np.linalg.norm(ra, axis=1),
        }
        rbound[:, 0] = bound.get(kind, rbound[:, 0])
        m.geom_rbound = wp.array(rbound.astype(np.float32), dtype=float)
        aabb = np.zeros((n, 2, 2, 3), np.float32)
        aabb[:, :, 1] = half
        m.geom_aabb = wp.array(aabb, dtype=wp.vec3)
        m.geom_margin = wp.array(np.stack([margin / 2, margin / 2], 1).astype(np.float32), dtype=float)
        d.geom_xpos.assign(np.stack([ca, cb], 1))
        d.geom_xmat.assign(np.stack([Ra, Rb], 1))
    return m, d


def world_contacts(d, n):
    """(dist, normal from geom 0 to geom 1, pos) per world (nan where none; the deepest where Warp made
    several).  Warp names a pair's geoms lower type first: an ellipsoid before a box, so that normal is
    turned round."""
    k = min(int(d.nacon.numpy()[0]), d.naconmax)
    dist = np.full(n, np.nan)
    normal, pos = np.full((n, 3), np.nan), np.full((n, 3), np.nan)
    w = d.contact.worldid.numpy()[:k]
    dd, ff, pp = d.contact.dist.numpy()[:k], d.contact.frame.numpy()[:k], d.contact.pos.numpy()[:k]
    sign = np.where(d.contact.geom.numpy()[:k, 0] == 0, 1.0, -1.0)
    for i in np.argsort(-dd):  # deepest last, so it wins
        dist[w[i]], normal[w[i]], pos[w[i]] = dd[i], sign[i] * ff[i, 0], pp[i]
    return dist, normal, pos


def accuracy(size, device):
    wp, mjw, ew = _warp()
    rng = np.random.default_rng(21)
    n = size["warp_pairs"]
    rows = []
    for kind in PAIR_KINDS:
        for offset in (0.0, 100.0):
            for category in CATEGORIES:
                poses, margin = make_pairs(rng, n, kind, category, offset)
                dc, nc, _, _ = _exact(kind, *poses)
                rmin = np.minimum(_smallest(kind, poses[2]), poses[5].min(1)).astype(float)
                want = dc < margin
                for method in ("Warp GJK/EPA, default", "Warp GJK/EPA, tight", "ellipsim on Warp"):
                    m, d = pair_worlds(kind, poses, margin, tight="tight" in method, device=device)
                    with wp.ScopedDevice(device):
                        att = ew.attach(m) if method.startswith("ellipsim") else None
                        mjw.collision(m, d)
                        dist, normal, _ = world_contacts(d, n)
                        unproven = att.counters["unproven"] if att else None
                    got = ~np.isnan(dist)
                    both = got & want
                    err = np.abs(dist - dc)[both] / rmin[both]
                    # the angle as atan2(|a x b|, a . b): exact near 0, where arccos of a float32 unit vector's
                    # dot product reads its length's rounding (6e-8) as 3e-4 rad
                    a, b = normal[both], nc[both]
                    angle = np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), (a * b).sum(1))
                    rows.append(
                        dict(
                            kind=kind,
                            offset=offset,
                            category=category,
                            method=method,
                            n=n,
                            exact=int(want.sum()),
                            mujoco_missed=int((want & ~got).sum()),
                            mujoco_extra=int((got & ~want).sum()),
                            err=float(err.max()) if err.size else 0.0,
                            angle=float(np.degrees(angle).max()) if err.size else 0.0,
                            unproven=unproven,
                        )
                    )
    return rows


def cost_per_pair(size, device, kind):
    """Seconds per pair of mjw.collision, plain and attached, less the empty model's (module docstring)."""
    wp, mjw, ew = _warp()
    rng = np.random.default_rng(5)
    n = size["warp_cost_worlds"]
    poses, margin = make_pairs(rng, n, kind, "shallow (-1e-3)", 0.0)
    plain = pair_worlds(kind, poses, margin, device=device)
    attached = pair_worlds(kind, poses, margin, device=device)
    empty = pair_worlds(kind, poses, margin, exclude=True, device=device)
    with wp.ScopedDevice(device):
        att = ew.attach(attached[0])

        def call(md):
            def fn():
                mjw.collision(*md)
                wp.synchronize()

            return fn

        fns = {"plain": call(plain), "attached": call(attached), "empty": call(empty)}
        for fn in fns.values():
            fn()  # compile
        times = interleaved(fns, size["rounds"])
        att.detach()
    per = {k: (times[k] - times["empty"]) / n for k in ("plain", "attached")}
    return dict(
        kind=kind,
        n=n,
        plain=float(np.median(per["plain"])),
        attached=float(np.median(per["attached"])),
        ratio=float(np.median(per["attached"] / per["plain"])),
        empty=float(np.median(times["empty"])) / n,
    )


def _field_xml(rng, n):
    """n ellipsoids (2-10 cm) over a 30 x 30 field 2 m square with 10 cm of relief; only field pairs collide."""
    bodies = []
    for _ in range(n):
        (x, y), r = rng.uniform(-0.7, 0.7, 2), rng.uniform(0.03, 0.1, 3)
        bodies.append(
            f'<body pos="{x} {y} 0.3"><freejoint/>'
            f'<geom type="ellipsoid" size="{r[0]} {r[1]} {r[2]}" contype="1" conaffinity="2"/></body>'
        )
    elevation = " ".join(f"{v:.4f}" for v in rng.uniform(0, 1, 900))
    return (
        f'<mujoco><asset><hfield name="t" nrow="30" ncol="30" size="1 1 0.1 0.05" elevation="{elevation}"/></asset>'
        f'<worldbody><geom type="hfield" hfield="t" contype="2" conaffinity="1"/>{"".join(bodies)}</worldbody>'
        "</mujoco>"
    )


def hfield_cost(size, device, n=8):
    """Seconds per height field x ellipsoid pair of mjw.collision, plain and attached (module docstring)."""
    return _settled_cost(_field_xml(np.random.default_rng(6), n), n, size, device)


def _mesh_xml(rng, n, large=False):
    """n ellipsoids (3-10 cm) over a static convex mesh slab (MuJoCo's hull of 40 points, 2 m square, 10 cm
    thick), or, large, a flat spheroid (1 m by 5 cm semi-axes) of 300 points on its surface (a hull of 300
    vertices: the mesh row's posed path); only mesh pairs collide."""
    if large:
        u = rng.normal(size=(300, 3))
        points = u / np.linalg.norm(u, axis=1)[:, None] * [1.0, 1.0, 0.05]
    else:
        points = np.c_[rng.uniform(-1, 1, (40, 2)), rng.uniform(-0.05, 0.05, 40)]
    vertex = " ".join(f"{x:.6f}" for x in points.ravel())
    bodies = []
    for _ in range(n):
        (x, y), r = rng.uniform(-0.5, 0.5, 2), rng.uniform(0.03, 0.1, 3)
        bodies.append(
            f'<body pos="{x} {y} 0.3"><freejoint/>'
            f'<geom type="ellipsoid" size="{r[0]} {r[1]} {r[2]}" contype="1" conaffinity="2"/></body>'
        )
    return (
        f'<mujoco><asset><mesh name="slab" vertex="{vertex}"/></asset>'
        f'<worldbody><geom type="mesh" mesh="slab" contype="2" conaffinity="1"/>{"".join(bodies)}</worldbody>'
        "</mujoco>"
    )


def mesh_cost(size, device, n=8, large=False):
    """Seconds per convex mesh x ellipsoid pair of mjw.collision (8 ellipsoids settled on a mesh slab, or on the
    300-vertex spheroid: _mesh_xml), plain (Warp's GJK/EPA) and attached (pairs/polytope.hpp on MuJoCo's hull),
    as hfield_cost."""
    return _settled_cost(_mesh_xml(np.random.default_rng(7), n, large), n, size, device)


def _settled_cost(xml, n, size, device):
    """hfield_cost's and mesh_cost's measure: n free ellipsoids settled against one static geom (MuJoCo C's steps)."""
    wp, mjw, ew = _warp()
    nworld = size["warp_worlds"]
    model, data, _ = settled(xml, size["warp_settle"])
    far = mujoco.MjData(model)
    far.qpos[:] = data.qpos
    far.qpos[2::7] += 5.0  # every body a free ellipsoid: its z up 5 m
    runs, fns = {}, {}
    with wp.ScopedDevice(device):
        for mode in ("plain", "attached"):
            m = mjw.put_model(model)
            att = ew.attach(m) if mode == "attached" else None
            for where, state in (("settled", data), ("culled", far)):
                d = mjw.put_data(model, state, nworld=nworld, naconmax=nworld * n * 50)
                mjw.kinematics(m, d)
                runs[mode, where] = (m, d, att)

                def fn(m=m, d=d):
                    mjw.collision(m, d)
                    wp.synchronize()

                fns[f"{mode} {where}"] = fn
        for fn in fns.values():
            fn()  # compile
        times = interleaved(fns, size["rounds"])
        contacts = {k: int(runs[k, "settled"][1].nacon.numpy()[0]) // nworld for k in ("plain", "attached")}
        counters = runs["attached", "settled"][2].counters
        runs["attached", "settled"][2].detach()
    per = {k: (times[f"{k} settled"] - times[f"{k} culled"]) / (nworld * n) for k in ("plain", "attached")}
    return dict(
        n=n,
        nworld=nworld,
        plain=float(np.median(per["plain"])),
        attached=float(np.median(per["attached"])),
        ratio=float(np.median(per["attached"] / per["plain"])),
        contacts=contacts,
        failed=counters["failed"],
    )


def scenes_rows(size, device):
    wp, mjw, ew = _warp()
    out = []
    for name, make, nworld in (
        ("16 figures in a heap", lambda: scenes.scene_xml(16, layout="pile", seed=1), size["warp_worlds"]),
        ("pile of 100 ellipsoids", lambda: scenes.pile_xml(100, seed=1), size["warp_worlds"]),
    ):
        say(f"warp: {name}, {nworld} worlds ...")
        model, data, _ = settled(make(), size["warp_settle"])
        runs = {}
        for mode in ("plain", "attached"):
            with wp.ScopedDevice(device):
                m = mjw.put_model(model)
                d = mjw.put_data(model, data, nworld=nworld, naconmax=nworld * max(64, 4 * model.ngeom))
                att = ew.attach(m) if mode == "attached" else None
                runs[mode] = (m, d, att)
        with wp.ScopedDevice(device):

            def collide(md):
                def fn():
                    mjw.collision(md[0], md[1])
                    wp.synchronize()

                return fn

            def step(md):
                def fn():
                    mjw.step(md[0], md[1])
                    wp.synchronize()

                return fn

            fns = {f"collision {k}": collide(v) for k, v in runs.items()}
            fns.update({f"step {k}": step(v) for k, v in runs.items()})
            for fn in fns.values():
                fn()  # compile
            t0 = time.perf_counter()
            times = interleaved(fns, size["rounds"])
            seconds = time.perf_counter() - t0
            att = runs["attached"][2]
            counters = att.counters
            contacts = {k: int(v[1].nacon.numpy()[0]) for k, v in runs.items()}
            att.detach()
        out.append(
            dict(
                name=name,
                nworld=nworld,
                ncontacts=contacts,
                seconds=seconds,
                per_world={k: float(np.median(v)) / nworld for k, v in times.items()},
                collision_ratio=float(np.median(times["collision attached"] / times["collision plain"])),
                step_ratio=float(np.median(times["step attached"] / times["step plain"])),
                counters=counters,
                pairs=att.npairs,
            )
        )
    return out


def measure(size):
    size = {**size, **WARP_SIZES["quick" if size.get("quick") else "full"]}
    try:
        wp, _, _ = _warp()
    except ImportError as exc:
        return dict(missing=str(exc))
    from .. import warp_run

    warp_run.quiet()  # the suite's own process: Warp's per-module load lines off
    device = "cuda" if wp.get_cuda_device_count() > 0 else "cpu"
    say(f"warp: accuracy against the exact narrow phase on {device} ...")
    acc = accuracy(size, device)
    say("warp: cost per pair ...")
    cost = [cost_per_pair(size, device, kind) for kind in COST_KINDS]
    say("warp: cost per height-field pair ...")
    field = hfield_cost(size, device)
    say("warp: cost per mesh pair ...")
    mesh = mesh_cost(size, device)
    say("warp: cost per pair on a 300-vertex hull ...")
    large = mesh_cost(size, device, large=True)
    rows = scenes_rows(size, device)
    return dict(device=device, accuracy=acc, cost=cost, field=field, mesh=mesh, mesh_large=large, scenes=rows)


def write(result, size, out, plt):
    r = result
    if "missing" in r:
        return ["## 9. ellipsim on MuJoCo Warp", "", f"Not run: {r['missing']}", ""]
    dev = "Warp's CPU device (LLVM), the proxy until a GPU is measured" if r["device"] == "cpu" else "CUDA"
    L = [
        "## 9. ellipsim on MuJoCo Warp",
        "",
        f"On {dev}.  One pair per world, {r['accuracy'][0]['n']} worlds per row; exact: ellipsim's CPU narrow phase "
        "on the same float32 poses (widened to float64; proven global maxima).  mujoco_missed: the exact distance is "
        "below the margin, no contact from the engine; mujoco_extra: the engine's contact the exact test does not make.  Error: |dist - exact| over the "
        "pair's smallest semi-axis, and the normal's angle (degrees), on pairs both have.  Tight: ccd_tolerance "
        "1e-10, ccd_iterations 1000.",
        "",
        "| pair | where | category | method | exact contacts | mujoco_missed | mujoco_extra | max distance error / r_min | "
        "max normal error (deg) | unproven |",
        "|---|---|---|---|---:|---:|---:|---:|---:|---:|",
    ]
    for a in r["accuracy"]:
        pair = PAIR_NAMES[a["kind"]]
        where = "origin" if a["offset"] == 0 else f"{a['offset']:.0f} m away"
        un = "-" if a["unproven"] is None else str(a["unproven"])
        L.append(
            f"| {pair} | {where} | {a['category']} | {a['method']} | {a['exact']} | {a['mujoco_missed']} | {a['mujoco_extra']} | "
            f"{a['err']:.1e} | {a['angle']:.1e} | {un} |"
        )
    c = r["cost"]
    L += [
        "",
        f"Cost per pair ({c[0]['n']} worlds of one shallow pair, mjw.collision less the same call with the pair "
        "excluded; medians of interleaved rounds; goal <= 0.5x):",
        "",
        "| pair | empty call per world (ns) | Warp's GJK/EPA (ns per pair) | ellipsim's kernel (ns per pair) | ratio |",
        "|---|---:|---:|---:|---:|",
    ]
    for k in c:
        L.append(
            f"| {PAIR_NAMES[k['kind']]} | {k['empty'] * 1e9:.0f} | {k['plain'] * 1e9:.0f} | {k['attached'] * 1e9:.0f} | "
            f"**{k['ratio']:.2f}x** |"
        )
    if "field" in r:
        f = r["field"]
        L += [
            "",
            f"Height field x ellipsoid ({f['nworld']} worlds of {f['n']} ellipsoids settled on a 30 x 30 field, "
            "mjw.collision less the same call with them culled, over the pairs): Warp's hfield kernel "
            f"{f['plain'] * 1e6:.1f} us per pair ({f['contacts']['plain']} contacts a world, up to 4 a pair), "
            f"ellipsim's {f['attached'] * 1e6:.1f} us ({f['contacts']['attached']} contacts a world, one per prism "
            f"within the margin), **{f['ratio']:.2f}x**; {f['failed']} pairs failed.",
        ]
    if "mesh" in r:
        f = r["mesh"]
        L += [
            "",
            f"Convex mesh x ellipsoid ({f['nworld']} worlds of {f['n']} ellipsoids settled on a mesh slab, the hull "
            "of 40 points, mjw.collision less the same call with them culled, over the pairs): Warp's GJK/EPA "
            f"{f['plain'] * 1e6:.2f} us per pair ({f['contacts']['plain']} contacts a world), ellipsim's "
            f"{f['attached'] * 1e6:.2f} us ({f['contacts']['attached']} contacts a world), **{f['ratio']:.2f}x**.",
        ]
    if "mesh_large" in r:
        f = r["mesh_large"]
        L += [
            "",
            f"The same on a hull of 300 vertices (a flat spheroid, 1 m by 5 cm; over the 64 the mesh row stores, so "
            "the core's posed path: each vertex and normal computed where read): Warp's GJK/EPA "
            f"{f['plain'] * 1e6:.2f} us per pair ({f['contacts']['plain']} contacts a world), ellipsim's "
            f"{f['attached'] * 1e6:.2f} us ({f['contacts']['attached']} contacts a world), **{f['ratio']:.2f}x**.",
        ]
    L += [
        "",
        "| scene | worlds | ellipsim pairs per world | contacts (plain / attached) | collision per world-step, plain / "
        "attached (us) | ratio | mjw.step per world-step, plain / attached (us) | ratio | unproven / evaluated pairs |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for s in r["scenes"]:
        p = s["per_world"]
        L.append(
            f"| {s['name']} | {s['nworld']} | {s['pairs']} | {s['ncontacts']['plain']} / {s['ncontacts']['attached']} | "
            f"{p['collision plain'] * 1e6:.1f} / {p['collision attached'] * 1e6:.1f} | {s['collision_ratio']:.2f}x | "
            f"{p['step plain'] * 1e6:.1f} / {p['step attached'] * 1e6:.1f} | {s['step_ratio']:.2f}x | "
            f"{s['counters']['unproven']} / {s['counters']['pairs']} |"
        )
    L += [
        "",
        "Ratios below 1 are ellipsim faster.  Unproven: pairs whose branch and bound ran out of its budget (ellipsoid "
        "pairs deeper than the rolling-radius proof go to the CPU's branch and bound over the sphere, cylinder "
        "rims to theirs; counted in att.counters); capsule and box pairs are always proven (certified, else every "
        "critical point evaluated).",
        "",
    ]
    return L
