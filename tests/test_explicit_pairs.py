"""Explicit `<contact><pair>` elements and recompiled models (issue 18).

MuJoCo sends an explicit pair straight to mjCOLLISIONFUNC with the pair's margin + gap, skipping the
contype/conaffinity test and mjcb_contactfilter, and mj_setContact gives the contact the pair's margin
(includemargin), condim, solref, solimp and friction (engine_collision_driver.c: filterCollisionPair,
collisionTask, mj_narrowphase).  So the narrow phase covers explicit pairs whose geoms have
contype = conaffinity = 0, and the filter never sees them.  `spec.recompile(model, data)` returns a
new model and data: `att.reattach` moves an attachment to them, and a mixed-up pair is refused.
"""

import copy
import math
import re

import mujoco
import numpy as np
import pytest
from pair_types import unattached_is_plain_mujoco

import ellipsim.mujoco as em
from ellipsim.core.tolerances import ANGLE_TOL, DIST_TOL, NEAR_TANGENT, POS_TOL
from ellipsim.mujoco import attachment

T = mujoco.mjtGeom
SPH, CAP, ELL, CYL, BOX = (
    int(t) for t in (T.mjGEOM_SPHERE, T.mjGEOM_CAPSULE, T.mjGEOM_ELLIPSOID, T.mjGEOM_CYLINDER, T.mjGEOM_BOX)
)
#: (type1, type2), type1 <= type2, of the pairs the narrow phase computes
HANDLED = {(ELL, ELL), (SPH, ELL), (CAP, ELL), (ELL, CYL), (ELL, BOX)}

PAIR_MARGIN, PAIR_GAP = 0.004, 0.002
PAIR_FRICTION = (0.6, 0.6, 0.02, 0.001, 0.001)
DYNAMIC_FRICTION = (1.0, 1.0, 0.005, 0.0001, 0.0001)  # MuJoCo's default geom friction, unpacked to 5D

SHAPES = [  # (type, size) of the bodies, dropped in a column; no cylinder (its rim fallbacks run
    # MuJoCo's function at the default ccd_tolerance, whose error is near DIST_TOL)
    ("ellipsoid", ".06 .09 .05"), ("ellipsoid", ".08 .05 .05"), ("sphere", ".05"), ("ellipsoid", ".05 .07 .10"),
    ("capsule", ".03 .06"), ("ellipsoid", ".07 .06 .05"), ("box", ".05 .04 .03"), ("ellipsoid", ".05 .05 .08"),
]  # fmt: skip


def column_xml(n_dynamic=0, override=None):
    """The SHAPES dropped in a column onto a floor, tilted so that they tumble into a heap.  The first
    n_dynamic collide by contype/conaffinity (with each other and the floor); the others have
    contype = conaffinity = 0 and collide only through explicit pairs: with the floor, with every
    other body (a handled type pair gets PAIR_MARGIN, PAIR_GAP and PAIR_FRICTION, geom1 and geom2 in
    either order).  override: a pair (i, j) of dynamic bodies also given an explicit pair, which
    replaces their dynamic one (MuJoCo merges them)."""
    bodies, pairs = [], []
    names = [f"g{i}" for i in range(len(SHAPES))]
    for i, (kind, size) in enumerate(SHAPES):
        bits = "" if i < n_dynamic else ' contype="0" conaffinity="0"'
        bodies.append(
            f'<body pos="{0.03 * math.sin(i)} {0.03 * math.cos(1.7 * i)} {0.12 + 0.2 * i}" euler="{23 * i} {41 * i} {7 * i}">'
            f'<freejoint/><geom name="{names[i]}" type="{kind}" size="{size}"{bits}/></body>'
        )
    params = f'margin="{PAIR_MARGIN}" gap="{PAIR_GAP}" friction="{" ".join(map(str, PAIR_FRICTION))}"'
    for i in range(n_dynamic, len(SHAPES)):
        pairs.append(f'<pair geom1="floor" geom2="{names[i]}"/>')
        for j in range(i):  # every dynamic body, and the explicit ones before i: each pair once
            a, b = (names[i], names[j]) if (i + j) % 2 else (names[j], names[i])
            pairs.append(f'<pair geom1="{a}" geom2="{b}" {params}/>')
    if override is not None:
        pairs.append(f'<pair geom1="{names[override[0]]}" geom2="{names[override[1]]}" {params}/>')
    return f"""<mujoco><option timestep="0.002"/><worldbody>
      <geom name="floor" type="plane" size="2 2 .1"/>{"".join(bodies)}
    </worldbody><contact>{"".join(pairs)}</contact></mujoco>"""


def handled_contacts(model, data):
    """{(g1, g2): mjContact copy} of data's contacts between geom types the narrow phase handles."""
    out = {}
    for c in data.contact[: data.ncon]:
        g1, g2 = int(c.geom1), int(c.geom2)
        if (int(model.geom_type[g1]), int(model.geom_type[g2])) in HANDLED:
            out[(g1, g2)] = dict(
                dist=float(c.dist),
                normal=c.frame[:3].copy(),
                pos=c.pos.copy(),
                includemargin=float(c.includemargin),
                exclude=int(c.exclude),
                friction=c.friction.copy(),
                solref=c.solref.copy(),
                solimp=c.solimp.copy(),
                dim=int(c.dim),
            )
    return out


def agrees_with_tight_mujoco(xml, steps=400, every=4):
    """Every `every`-th step, the attached data's handled contacts against MuJoCo's own functions run
    tight (ccd_tolerance 1e-12, 1000 iterations) at the same state, as pair_types.py compares them:
    dist within DIST_TOL, normals within ANGLE_TOL, points within POS_TOL (tolerances.py), a contact on
    one side only allowed at the margin (near-tangent); the contact parameters (includemargin,
    exclude, friction, solref, solimp, condim) equal, since MuJoCo assigns them from the same model
    arrays.  Returns (the matched contacts' parameters by pair, the attachment's counters)."""
    model, tight = mujoco.MjModel.from_xml_string(xml), mujoco.MjModel.from_xml_string(xml)
    tight.opt.ccd_tolerance, tight.opt.ccd_iterations = 1e-12, 1000
    data, check = mujoco.MjData(model), mujoco.MjData(tight)
    matched = {}
    with em.attach(model, data, mode="narrowphase") as att:
        for step in range(steps):
            qpos, qvel = data.qpos.copy(), data.qvel.copy()
            mujoco.mj_step(model, data)  # data.contact: the contacts at qpos
            if step % every:
                continue
            check.qpos[:], check.qvel[:] = qpos, qvel
            mujoco.mj_forward(tight, check)  # not attached: MuJoCo's own functions
            ours, theirs = handled_contacts(model, data), handled_contacts(tight, check)
            for key in ours.keys() | theirs.keys():
                if key not in ours or key not in theirs:
                    c = ours.get(key) or theirs.get(key)
                    assert c["dist"] >= c["includemargin"] - NEAR_TANGENT, f"step {step} pair {key}: one side only, {c}"
                    continue
                a, b = ours[key], theirs[key]
                assert abs(a["dist"] - b["dist"]) <= DIST_TOL, (
                    f"step {step} pair {key}: dist {a['dist']} vs {b['dist']}"
                )
                for name in ("includemargin", "exclude", "dim"):
                    assert a[name] == b[name], f"step {step} pair {key}: {name} {a[name]} vs {b[name]}"
                for name in ("friction", "solref", "solimp"):
                    np.testing.assert_array_equal(a[name], b[name], err_msg=f"step {step} pair {key}: {name}")
                if abs(a["dist"]) >= NEAR_TANGENT:  # MuJoCo's normal is arbitrary at a tangency
                    angle = math.acos(min(1.0, float(a["normal"] @ b["normal"])))
                    assert angle <= ANGLE_TOL, f"step {step} pair {key}: normals {angle} rad apart"
                    assert np.linalg.norm(a["pos"] - b["pos"]) <= POS_TOL, f"step {step} pair {key}: pos"
                matched.setdefault(key, []).append((a["includemargin"], tuple(a["friction"]), a["dist"]))
    return model, matched, att.counters


def explicit_keys(model):
    """{(g1, g2)} of the model's explicit pairs, both orders."""
    return {(int(a), int(b)) for a, b in zip(model.pair_geom1, model.pair_geom2)} | {
        (int(b), int(a)) for a, b in zip(model.pair_geom1, model.pair_geom2)
    }


def test_explicit_pairs_only_go_through_the_narrow_phase_and_match_tight_mujoco():
    xml = column_xml()
    model, matched, counters = agrees_with_tight_mujoco(xml)
    assert model.npair == 8 + 28 and np.all(model.geom_contype == [1] + [0] * 8)
    # the body pairs of handled types: 10 ellipsoid x ellipsoid, 5 each with the sphere, capsule, box
    assert attachment.explicit_pairs(model).size == 25
    assert counters["calls"] > 600 and counters["contacts"] > 300 and counters["fallbacks"] == 0  # 873, 392 measured
    assert len(matched) >= 8  # a real heap: 10 pairs in contact, compared 96 times
    types = {tuple(sorted(int(model.geom_type[g]) for g in key)) for key in matched}
    assert types == {(ELL, ELL), (SPH, ELL), (CAP, ELL), (ELL, BOX)}  # every kind of pair the heap has
    for key, rows in matched.items():
        assert key in explicit_keys(model)
        for includemargin, friction, _ in rows:  # the pair's own margin and friction
            assert includemargin == PAIR_MARGIN and friction == PAIR_FRICTION
    assert min(d for rows in matched.values() for _, _, d in rows) < 0  # penetrating contacts among them


def test_mixed_explicit_and_dynamic_pairs():
    """Bodies 0-3 collide dynamically, 4-7 only through explicit pairs (also with 0-3); bodies 0 and 3
    have an explicit pair too, which replaces their dynamic one."""
    model, matched, counters = agrees_with_tight_mujoco(column_xml(n_dynamic=4, override=(0, 3)))
    explicit = explicit_keys(model)
    dynamic_keys = [k for k in matched if k not in explicit]
    explicit_matched = [k for k in matched if k in explicit]
    assert len(dynamic_keys) >= 2 and len(explicit_matched) >= 5, f"both kinds in contact: {sorted(matched)}"
    assert any(set(key) == {1, 4} for key in explicit_matched)  # bodies 0 and 3 (geoms 1, 4): the pair's parameters
    assert counters["calls"] > 600 and counters["contacts"] > 300  # 898, 424 measured
    for key in dynamic_keys:  # geom parameters: margin 0, MuJoCo's default friction
        for includemargin, friction, _ in matched[key]:
            assert includemargin == 0.0 and friction == DYNAMIC_FRICTION
    for key in explicit_matched:
        for includemargin, friction, _ in matched[key]:
            assert includemargin == PAIR_MARGIN and friction == PAIR_FRICTION


def test_pair_margin_and_gap_at_known_distances():
    """Axis-aligned pairs along x, surfaces exactly s apart (the extreme points' normals are parallel);
    geom margin 0.05 (which explicit pairs ignore), pair margin 0.004, gap 0.002: s = 0.002 is a
    contact, s = 0.005 a contact inside the gap (excluded), s = 0.01 none; an ellipsoid-sphere pair
    (geom1 the sphere) at s = 0.002."""
    spacings = [0.002, 0.005, 0.01, 0.002]
    bodies, pairs = [], []
    for k, s in enumerate(spacings):
        y = 2.0 * k
        shape = 'type="sphere" size=".15"' if k == 3 else 'type="ellipsoid" size=".15 .1 .2"'
        off = 'margin=".05" contype="0" conaffinity="0"'
        bodies.append(
            f'<geom name="a{k}" type="ellipsoid" size=".1 .2 .3" pos="0 {y} 0" {off}/>'
            f'<body pos="{0.1 + 0.15 + s} {y} 0"><geom name="b{k}" {shape} {off}/></body>'
        )  # a body of its own: MuJoCo collides nothing in a model of the world body alone
        first, second = (f"b{k}", f"a{k}") if k == 3 else (f"a{k}", f"b{k}")
        pairs.append(f'<pair geom1="{first}" geom2="{second}" margin="{PAIR_MARGIN}" gap="{PAIR_GAP}"/>')
    xml = f"<mujoco><worldbody>{''.join(bodies)}</worldbody><contact>{''.join(pairs)}</contact></mujoco>"
    model = mujoco.MjModel.from_xml_string(xml)
    plain, data = mujoco.MjData(model), mujoco.MjData(model)
    mujoco.mj_forward(model, plain)
    with em.attach(model, data, mode="narrowphase") as att:
        assert att.installed
        mujoco.mj_forward(model, data)  # one collision pass
    assert att.counters == {"calls": 4, "separated": 1, "apart": 0, "contacts": 3, "fallbacks": 0, "capped": 0}
    ours, theirs = handled_contacts(model, data), handled_contacts(model, plain)
    g = {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, i): i for i in range(model.ngeom)}
    sphere_pair = (g["b3"], g["a3"])  # geom1 the sphere: MuJoCo orders a pair's geoms by type
    assert sorted(ours) == sorted(theirs) == sorted([(g["a0"], g["b0"]), (g["a1"], g["b1"]), sphere_pair])
    for key, s, exclude in (((g["a0"], g["b0"]), 0.002, 0), ((g["a1"], g["b1"]), 0.005, 1), (sphere_pair, 0.002, 0)):
        assert abs(ours[key]["dist"] - s) <= 1e-12, (key, ours[key]["dist"])  # exact
        assert abs(theirs[key]["dist"] - s) <= 1e-9  # MuJoCo's GJK, separated: ~2e-10
        assert ours[key]["includemargin"] == PAIR_MARGIN and ours[key]["exclude"] == exclude == theirs[key]["exclude"]
        np.testing.assert_allclose(ours[key]["normal"], [-1.0 if key == sphere_pair else 1.0, 0, 0], rtol=0, atol=1e-12)


def test_filter_mode_leaves_explicit_pairs_to_mujoco():
    """Explicit pairs never reach mjcb_contactfilter: on a model with only explicit ellipsoid pairs
    the filter installs nothing, and on a mixed one it changes nothing."""
    explicit_only = mujoco.MjModel.from_xml_string(column_xml())
    assert not attachment.ellipsoid_pair_possible(explicit_only, "filter")
    with em.attach(explicit_only, mujoco.MjData(explicit_only), mode="filter") as att:
        assert not att.installed and mujoco.get_mjcb_contactfilter() is None
    mixed = mujoco.MjModel.from_xml_string(column_xml(n_dynamic=4))
    plain, data = mujoco.MjData(mixed), mujoco.MjData(mixed)
    with em.attach(mixed, data, mode="filter") as att:
        assert att.installed
        for _ in range(300):
            mujoco.mj_step(mixed, plain)
            mujoco.mj_step(mixed, data)
    np.testing.assert_array_equal(data.qpos, plain.qpos)
    assert att.counters["seen"] > 0 and att.counters["discarded"] > 0


def test_unattached_data_stays_plain_mujoco_with_explicit_pairs():
    counters = unattached_is_plain_mujoco(column_xml(n_dynamic=4, override=(0, 3)))
    assert counters["calls"] > 300 and counters["contacts"] > 50


def test_which_explicit_pairs_count():
    """Type rules of explicit_pairs / ellipsoid_pair_possible / warm_slots, geoms with contype 0."""

    def model(*pair_types, n_extra=0):
        geoms = "".join(
            f'<geom name="p{k}{s}" type="{t}" size=".1 .1 .1" pos="{k} {s} 0" contype="0" conaffinity="0"/>'
            for k, types in enumerate(pair_types)
            for s, t in enumerate(types)
        )
        extra = "".join(
            f'<geom type="ellipsoid" size=".1 .1 .1" pos="9 {k} 0" contype="0" conaffinity="0"/>'
            for k in range(n_extra)
        )
        pairs = "".join(f'<pair geom1="p{k}0" geom2="p{k}1"/>' for k in range(len(pair_types)))
        xml = f"<mujoco><worldbody>{geoms}{extra}</worldbody><contact>{pairs}</contact></mujoco>"
        return mujoco.MjModel.from_xml_string(xml)

    for types, narrow in [
        (("box", "ellipsoid"), True),
        (("ellipsoid", "sphere"), True),
        (("cylinder", "ellipsoid"), True),
        (("ellipsoid", "capsule"), True),
        (("sphere", "sphere"), False),
        (("plane", "ellipsoid"), False),
        (("box", "capsule"), False),
    ]:
        m = model(types)
        assert attachment.ellipsoid_pair_possible(m, "narrowphase") is narrow, types
        assert attachment.ellipsoid_pair_possible(m, "filter") is False, types  # the filter never sees them
    m = model(("ellipsoid", "box"), ("sphere", "sphere"), ("capsule", "ellipsoid"), n_extra=3)
    np.testing.assert_array_equal(attachment.explicit_pairs(m), [0, 2])
    assert attachment.explicit_pairs(m, "filter").size == 0
    # warm start: 16 slots per ellipsoid, sphere or capsule of a handled explicit pair (3 geoms: the
    # ellipsoid of pair 0, the capsule and ellipsoid of pair 2; not the spheres of pair 1, nor the
    # extra ellipsoids, which collide with nothing): 48 -> 64 slots; 12 such geoms -> 192 -> 256
    assert attachment.warm_slots(m) == 64
    assert attachment.warm_slots(model(*[("ellipsoid", "ellipsoid")] * 6)) == 256


# --- recompiled models -----------------------------------------------------------------------------

SPEC_XML = """<mujoco><option timestep="0.002"/><worldbody><geom type="plane" size="2 2 .1"/>
  <body pos="0 0 .1"><freejoint/><geom type="ellipsoid" size=".1 .07 .05"/></body>
  <body pos=".03 .01 .3" euler="20 30 0"><freejoint/><geom type="ellipsoid" size=".08 .06 .05"/></body>
</worldbody></mujoco>"""


def add_ellipsoid(spec, z):
    body = spec.worldbody.add_body(pos=[-0.02, 0.02, z], quat=[0.9, 0.3, 0.2, 0.1])
    body.add_freejoint()
    body.add_geom(type=mujoco.mjtGeom.mjGEOM_ELLIPSOID, size=[0.07, 0.05, 0.06])


def test_recompile_mixed_up_pairs_are_refused_and_reattach_redoes_the_attachment():
    spec = mujoco.MjSpec.from_string(SPEC_XML)
    m = spec.compile()
    d = mujoco.MjData(m)
    with em.attach(m, d, mode="narrowphase") as att:
        for _ in range(200):
            mujoco.mj_step(m, d)
        calls = att.counters["calls"]
        assert calls > 100 and att.counters["contacts"] > 100  # 127 and 113 measured
        add_ellipsoid(spec, 0.5)
        m2, d2 = spec.recompile(m, d)
        assert m2.ngeom == 4 and m2.signature != m.signature
        # the new pair is not covered by the old attachment: plain MuJoCo, no word from ellipsim
        probe = copy.copy(d2)
        for _ in range(5):
            mujoco.mj_step(m2, probe)
        assert att.counters["calls"] == calls
        # a model and data from different compiles are refused, with both signatures named
        stale = f"data belongs to another model: data.signature {d.signature} != model.signature {m2.signature}"
        with pytest.raises(ValueError, match=re.escape(stale)):
            em.attach(m2, d)
        with pytest.raises(ValueError, match=re.escape(stale)):
            att.reattach(m2, d)
        with pytest.raises(
            ValueError, match=re.escape(f"data.signature {d2.signature} != model.signature {m.signature}")
        ):
            att.reattach(m, d2)
        assert att.data is d and att.installed  # a refused reattach changes nothing
        fresh = copy.copy(d2)  # the same state, for a fresh attachment below
        before = copy.copy(d)
        assert att.reattach(m2, d2) is att and att.model is m2 and att.data is d2 and att.installed
        for _ in range(300):
            mujoco.mj_step(m2, d2)
            mujoco.mj_step(m, d)  # released: plain MuJoCo from now on
            mujoco.mj_step(m, before)
        assert att.counters["calls"] > calls + 200  # counters keep counting, now on the new data (+260)
    np.testing.assert_array_equal(d.qpos, before.qpos)
    assert not att.installed and not attachment._state["attached"]
    # attaching the new pair anew gives the same trajectory to the bit (both warm tables start empty)
    with em.attach(m2, fresh, mode="narrowphase") as again:
        for _ in range(300):
            mujoco.mj_step(m2, fresh)
    np.testing.assert_array_equal(fresh.qpos, d2.qpos)
    assert again.counters["calls"] == att.counters["calls"] - calls


def test_reattach_installs_what_the_recompiled_model_needs_and_refuses_a_held_data():
    spec = mujoco.MjSpec.from_string(
        '<mujoco><worldbody><geom type="plane" size="1 1 .1"/><body pos="0 0 .1"><freejoint/>'
        '<geom type="ellipsoid" size=".1 .07 .05"/></body></worldbody></mujoco>'
    )
    m = spec.compile()
    d = mujoco.MjData(m)
    with em.attach(m, d, mode="narrowphase") as att:
        assert not att.installed  # one ellipsoid: nothing to do
        add_ellipsoid(spec, 0.3)
        m2, d2 = spec.recompile(m, d)
        with em.attach(m2, d2, mode="narrowphase"):
            with pytest.raises(ValueError, match="data is already attached to ellipsim by another attachment"):
                att.reattach(m2, d2)
        att.reattach(m2, d2)
        assert att.installed and att._warm.shape == (64, 8)
        for _ in range(200):
            mujoco.mj_step(m2, d2)
        assert att.counters["contacts"] > 20
    assert not att.installed and not attachment._state["attached"]
    att.reattach(m, d)  # outside the block: only swaps what the next `with` covers
    assert att.model is m and att.data is d and not att.installed
