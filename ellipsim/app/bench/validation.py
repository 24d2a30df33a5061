"""Section 12 (validation): MuJoCo's contacts judged against the exact test on the shipped scenes and a
scene of every pair type (mujoco.validate, what `ellipsim compare` runs): the disagreements by kind, how
far MuJoCo's normals are from the exact ones on the pairs both put in contact (the reason for
judge.NORMAL_OFF_DEG), and what the judging costs per step against plain mj_step."""

import time

import mujoco
import numpy as np

from ...mujoco.geoms import pair_margins
from ...mujoco.judge import KEYS, NORMAL_OFF_DEG, judged, pair_type, sigma, verdicts
from ...mujoco.validate import KINDS, validate
from .. import scenario, simulate
from .common import say
from .inside_mujoco import SCENES

#: (name, how to build (model, data, control: validate's control or None), steps of the full and the quick suite)
CASES = (
    ("pile (12 figures dropped)", lambda: _scenario("pile"), 1500, 300),
    ("crowd (25 figures swaying)", lambda: _scenario("crowd"), 2000, 300),
    (
        "MuJoCo's replicate/leaves.xml, landing",
        lambda: _mjcf(SCENES["MuJoCo's replicate/leaves.xml, landing"][0]()),
        1000,
        300,
    ),
    ("every pair type (a mixed pile in a box)", lambda: _mjcf(mixed_pile_xml()), 1000, 300),
)


def _scenario(name):
    """(model, data, control) of a shipped dynamic scenario, its controls applied as `ellipsim compare` does."""
    s = scenario.load(name)
    model, data = simulate.build(s)
    controller = simulate.controller(model, data, s)

    def control(m, d, step):
        d.ctrl[:] = controller(d.time)

    return model, data, control


def _mjcf(xml):
    model = mujoco.MjModel.from_xml_string(xml)
    return model, mujoco.MjData(model), None


_FIELD = KEYS.index("ellipsoid-hfield")
#: the mixed pile's convex mesh (12 points of a lumpy ball about 3 cm across) and its floor's relief (8 x 8)
_PROP = np.random.default_rng(100).normal(size=(12, 3)) * np.array([0.03, 0.025, 0.02])
_RELIEF = np.random.default_rng(101).uniform(0.0, 1.0, 64)


def mixed_pile_xml(seed=0, per_type=4):
    """Free ellipsoids among free spheres, capsules, boxes, cylinders and convex meshes dropped into a box of
    walls (box geoms) onto a height field (1 cm of relief) on a floor, a few geoms with a 2 mm margin: contacts
    of every pair type ellipsim judges."""
    rng = np.random.default_rng(seed)
    shapes = [("ellipsoid", "0.05 0.035 0.025"), ("sphere", "0.03"), ("capsule", "0.02 0.04")]
    shapes += [("box", "0.03 0.025 0.02"), ("cylinder", "0.025 0.03"), ("ellipsoid", "0.04 0.03 0.02")]
    shapes += [("mesh", None)]
    bodies, k = [], 0
    for _ in range(per_type):
        for t, size in shapes:
            x, y = rng.uniform(-0.08, 0.08, 2)
            q = rng.normal(size=4)
            q /= np.linalg.norm(q)
            margin = ' margin="0.002"' if k % 5 == 3 else ""  # every type in turn (7 shapes a round)
            shape = 'mesh="prop"' if size is None else f'size="{size}"'
            bodies.append(
                f'<body pos="{x:.4f} {y:.4f} {0.05 + 0.06 * k:.4f}" quat="{" ".join(f"{v:.4f}" for v in q)}">'
                f'<freejoint/><geom name="{t}{k}" type="{t}" {shape}{margin}/></body>'
            )
            k += 1
    walls = "".join(
        f'<geom type="box" size="{sx} {sy} 0.3" pos="{px} {py} 0.3"/>'
        for sx, sy, px, py in (
            (0.01, 0.15, 0.15, 0),
            (0.01, 0.15, -0.15, 0),
            (0.15, 0.01, 0, 0.15),
            (0.15, 0.01, 0, -0.15),
        )
    )
    assets = (
        f'<asset><mesh name="prop" vertex="{" ".join(f"{x:.5f}" for x in _PROP.ravel())}"/><hfield name="relief" '
        f'nrow="8" ncol="8" size="0.15 0.15 0.01 0.005" elevation="{" ".join(f"{x:.4f}" for x in _RELIEF)}"/></asset>'
    )
    return (
        f'<mujoco><option timestep="0.002"/>{assets}<worldbody><geom type="plane" size="1 1 .1"/>'
        f'<geom type="hfield" hfield="relief"/>{walls}{"".join(bodies)}</worldbody></mujoco>'
    )


def _normals(model, data):
    """(angle deg, sigma deficit m) of every pair ellipsim judges on which MuJoCo made a contact below the
    margin that the exact test also puts in contact: the angle between MuJoCo's normal and the exact one,
    and how far sigma along MuJoCo's falls below the exact distance.  Height-field pairs are left out: a
    contact a prism, and which of its prisms a contact of MuJoCo's is does not come with it."""
    n = data.ncon
    geom = np.sort(data.contact.geom[:n].astype(np.int64), axis=1)
    mine = np.flatnonzero(judged(model, geom[:, 0], geom[:, 1]) & (pair_type(model, geom[:, 0], geom[:, 1]) != _FIELD))
    if len(mine) == 0:
        return np.zeros(0), np.zeros(0)
    geom, dist = geom[mine], data.contact.dist[:n][mine]
    normal = (
        data.contact.frame[:n][mine, :3] * np.where(data.contact.geom[:n][mine, 0] == geom[:, 0], 1.0, -1.0)[:, None]
    )
    margin = pair_margins(model, geom)
    active = dist < margin
    geom, normal, margin = geom[active], normal[active], margin[active]
    v = verdicts(model, data, geom, margin, measure=np.ones(len(geom), dtype=bool))
    both = v.within & np.isfinite(v.normal[:, 0])
    cosine = np.clip(np.einsum("ki,ki->k", normal[both], v.normal[both]), -1.0, 1.0)
    deficit = v.dist[both] - sigma(model, data, geom[both, 0], geom[both, 1], normal[both])
    return np.degrees(np.arccos(cosine)), deficit


def measure(size):
    """Per case: steps, the totals of validate, the disagreements by kind, the normals' angles and sigma
    deficits on the pairs in contact on both sides, and the seconds of validate and of plain stepping."""
    quick = size["steps"] < 200
    rows = []
    for name, build, full, short in CASES:
        steps = short if quick else full
        say(f"validation: {name}, {steps} steps ...")
        angles, deficits = [], []

        def observer(m, d, step, found):
            a, s = _normals(m, d)
            angles.append(a)
            deficits.append(s)

        model, data, control = build()
        t0 = time.perf_counter()
        v = validate(model, data, steps, control=control)  # timed alone
        seconds = time.perf_counter() - t0
        model, data, control = build()
        validate(model, data, steps, control=control, observer=observer)  # the normals, the same steps
        model, data, control = build()
        t0 = time.perf_counter()
        for k in range(steps):
            if control is not None:
                control(model, data, k)
            mujoco.mj_step(model, data)
        plain = time.perf_counter() - t0
        kinds = {kind: sum(d.kind == kind for d in v.disagreements) for kind in KINDS}
        rows.append(
            dict(
                name=name,
                steps=steps,
                ccd=float(model.opt.ccd_tolerance),
                totals=v.totals(),
                by_type=v.by_type.sum(axis=0),
                kinds=kinds,
                angles=np.concatenate(angles),
                deficits=np.concatenate(deficits),
                seconds=seconds,
                plain=plain,
            )
        )
    return rows


def write(rows, size, out, plt):
    """Markdown lines of the section."""
    L = [
        "## 12. Validation: MuJoCo's contacts against the exact test",
        "",
        "mujoco.validate (what `ellipsim compare` runs) on each scene from its initial state: every candidate pair of "
        "every type ellipsim judges, at every step, one margin rule on both sides (a contact is a distance below the "
        "pair's margin).  Both: pairs MuJoCo and the exact test put in contact; on those, the angle between MuJoCo's "
        f"normal and the exact one, and sigma's deficit along it (exact distance - sigma(MuJoCo's normal), a lower "
        f"bound on how much worse MuJoCo's normal is; height-field pairs left out: a contact a prism, and MuJoCo's "
        f"contact does not say which).  normal_off: beyond {NORMAL_OFF_DEG:g} deg and a deficit "
        "beyond MuJoCo's ccd_tolerance (with the proof tolerance).  Cost: validate's wall time per step against "
        "plain mj_step's on the same steps.",
        "",
        "| scene | steps | pairs judged | in contact, both | " + " | ".join(KINDS) + " |",
        "|---|---:|---:|---:|" + "---:|" * len(KINDS),
    ]
    for r in rows:
        t = r["totals"]
        L.append(
            f"| {r['name']} | {r['steps']} | {sum(t.values())} | {t['both']} | "
            + " | ".join(str(r["kinds"][k]) for k in KINDS)
            + " |"
        )
    L += [
        "",
        "| scene | normals: median deg | 99 % | 99.9 % | largest | beyond 1 deg | of which sigma short by > ccd_tolerance "
        "| validate ms/step | mj_step ms/step |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        a, s = r["angles"], r["deficits"]
        if len(a) == 0:
            q = ["-"] * 4
            beyond = short = 0
        else:
            q = [f"{x:.3g}" for x in (*np.percentile(a, [50, 99, 99.9]), a.max())]
            beyond = int((a > NORMAL_OFF_DEG).sum())
            short = int(((a > NORMAL_OFF_DEG) & (s > r["ccd"])).sum())
        L.append(
            f"| {r['name']} | {' | '.join(q)} | {beyond} | {short} | {r['seconds'] / r['steps'] * 1e3:.2f} "
            f"| {r['plain'] / r['steps'] * 1e3:.2f} |"
        )
    L += ["", "Pairs judged per type (the mixed pile):", ""]
    mixed = rows[-1]
    from ...mujoco.judge import KEYS

    L.append("| type | pairs | MuJoCo contacts | exact contacts |")
    L.append("|---|---:|---:|---:|")
    for k, key in enumerate(KEYS):
        both, neither, mj, el = (int(x) for x in mixed["by_type"][k])
        L.append(f"| {key} | {both + neither + mj + el} | {both + mj} | {both + el} |")
    return L + [""]
