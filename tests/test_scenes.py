"""The oval-limb figure (models/figure.xml) and the scenes built by ellipsim.figures.

Geometry is read back from MuJoCo (geom_xpos, geom_xmat, geom_size after mj_forward) and judged
with the exact `classify`, so "separated" means separated on the very numbers MuJoCo simulates.
"""

import itertools
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import mujoco
import numpy as np
import pytest

import ellipsim.mujoco
from ellipsim import Ellipsoids, Relation, classify
from ellipsim.app import scenes as figures

FIGURE_PATH = Path(__file__).resolve().parents[1] / "models" / "figure.xml"
ELLIPSOID = mujoco.mjtGeom.mjGEOM_ELLIPSOID
HINGE = mujoco.mjtJoint.mjJNT_HINGE
FREE = mujoco.mjtJoint.mjJNT_FREE


def compiled(xml):
    """Model and data of `xml` after mj_forward at qpos0."""
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return model, data


def ellipsoid_geoms(model):
    return np.flatnonzero(model.geom_type == ELLIPSOID)


def relations(model, data, pairs):
    """classify() of geom pairs (k, 2) of ellipsoid geoms, on MuJoCo's own poses and sizes."""
    pairs = np.asarray(pairs).reshape(-1, 2)
    rot = data.geom_xmat.reshape(-1, 3, 3)

    def batch(ids):
        return Ellipsoids(data.geom_xpos[ids], rot[ids], model.geom_size[ids])

    return classify(batch(pairs[:, 0]), batch(pairs[:, 1]))


def adjacent(model, g1, g2):
    """True when MuJoCo's default parent-child filter drops the pair (bodies with joints, not world)."""
    b1, b2 = model.geom_bodyid[g1], model.geom_bodyid[g2]
    return b1 == b2 or (b1 and b2 and (model.body_parentid[b1] == b2 or model.body_parentid[b2] == b1))


def z_extents(model, data, geoms):
    """Lowest and highest z (metres) of each ellipsoid: centre -+ sqrt(sum_k (R[2, k] r_k)^2)."""
    rot = data.geom_xmat.reshape(-1, 3, 3)[geoms]
    half = np.sqrt(((rot[:, 2, :] * model.geom_size[geoms]) ** 2).sum(axis=1))
    z = data.geom_xpos[geoms, 2]
    return z - half, z + half


def simulate(model, data, steps):
    """Step with zero controls (position targets = qpos0 = 0 for every hinge); assert qpos stays
    finite, MuJoCo never flags a bad acceleration (on which it silently resets the state), and
    every body stays inside the start box grown by 3 m sideways and 0.5 m upwards and above
    z = -0.2 m (nothing is thrown away or falls through the floor).  Returns data."""
    start = data.xpos[1:].copy()
    lo, hi = start.min(axis=0) - [3.0, 3.0, 0.0], start.max(axis=0) + [3.0, 3.0, 0.5]
    lo[2] = -0.2
    data.ctrl[:] = 0.0
    for step in range(steps):
        mujoco.mj_step(model, data)
        if step % 50 == 49 or step == steps - 1:
            assert np.isfinite(data.qpos).all(), f"qpos not finite at step {step}"
            assert data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number == 0, f"unstable at step {step}"
            pos = data.xpos[1:]
            assert (pos >= lo).all() and (pos <= hi).all(), f"a body left the box at step {step}"
    return data


@pytest.fixture(scope="module")
def figure():
    return compiled(figures.figure_xml())


# --- the figure -------------------------------------------------------------------------------------


def test_figure_xml_is_the_shipped_file():
    text = figures.figure_xml()
    assert text == FIGURE_PATH.read_text(encoding="utf-8")
    root = ET.fromstring(text)
    assert root.tag == "mujoco" and root.get("model") == "oval_figure"
    assert root.find("compiler").get("angle") == "degree"
    assert float(root.find("option").get("timestep")) == 0.002
    assert root.find("default/default").get("class") == "limb"
    assert root.find("worldbody/light") is not None


def test_figure_bodies_geoms_and_joints(figure):
    model, _ = figure
    assert tuple(model.body(b).name for b in range(1, model.nbody)) == figures.LIMBS
    geoms = ellipsoid_geoms(model)
    assert len(geoms) >= 13 and len(geoms) == len(figures.LIMBS)
    # one ellipsoid per limb body, named like it, colliding with everything (contype = conaffinity = 1)
    assert sorted(model.geom_bodyid[geoms]) == list(range(1, model.nbody))
    assert all(model.geom(g).name == model.body(model.geom_bodyid[g]).name for g in geoms)
    assert (model.geom_contype[geoms] == 1).all() and (model.geom_conaffinity[geoms] == 1).all()
    assert (model.geom_size[geoms] > 0).all()
    assert model.geom("floor").type == mujoco.mjtGeom.mjGEOM_PLANE
    assert list(model.jnt_type).count(FREE) == 1 and model.jnt_type[0] == FREE
    assert model.jnt_bodyid[0] == model.body("pelvis").id
    hinges = np.flatnonzero(model.jnt_type == HINGE)
    assert len(hinges) == model.njnt - 1
    assert model.jnt_limited[hinges].all()
    lo, hi = np.degrees(model.jnt_range[hinges]).T
    assert (lo < 0).all() and (hi > 0).all() and (hi - lo <= 225).all()  # rest pose inside, human-sized
    assert (model.dof_damping[model.jnt_dofadr[hinges]] > 0).all()
    assert (model.dof_armature[model.jnt_dofadr[hinges]] > 0).all()
    assert model.opt.timestep == 0.002


def test_every_hinge_has_a_position_servo_with_its_name_and_range(figure):
    model, _ = figure
    hinges = np.flatnonzero(model.jnt_type == HINGE)
    assert model.nu == len(hinges)
    for a in range(model.nu):
        j = model.actuator_trnid[a, 0]
        assert model.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT
        assert model.actuator(a).name == model.joint(j).name
        kp = model.actuator_gainprm[a, 0]
        assert kp > 0 and model.actuator_biasprm[a, 1] == -kp  # a position servo: force = kp (ctrl - q)
        assert model.actuator_ctrllimited[a]
        # ctrlrange is written in radians to 6 decimals in figure.xml
        np.testing.assert_allclose(model.actuator_ctrlrange[a], model.jnt_range[j], rtol=0, atol=1e-6)
    assert sorted(model.actuator_trnid[:, 0]) == list(hinges)


def test_rest_pose_has_no_overlapping_non_adjacent_limbs(figure):
    model, data = figure
    geoms = ellipsoid_geoms(model)
    pairs = [(g1, g2) for g1, g2 in itertools.combinations(geoms, 2) if not adjacent(model, g1, g2)]
    assert len(pairs) == len(geoms) * (len(geoms) - 1) // 2 - (len(geoms) - 1)  # all but the 14 parent-child pairs
    rel = relations(model, data, pairs)
    bad = [(model.geom(a).name, model.geom(b).name) for (a, b), r in zip(pairs, rel) if r != Relation.SEPARATED]
    assert bad == []
    # and with room to spare: the closest non-adjacent limbs (the thighs) are 3 cm apart
    gaps = [mujoco.mj_geomDistance(model, data, a, b, 1.0, None) for a, b in pairs]
    assert min(gaps) > 0.02


def test_standing_height_and_feet_on_the_floor(figure):
    model, data = figure
    geoms = ellipsoid_geoms(model)
    bottom, top = z_extents(model, data, geoms)
    assert 1.6 <= top.max() - bottom.min() <= 1.8
    assert abs(bottom.min()) < 1e-9  # the soles just touch z = 0
    feet = [model.geom(f"foot_{s}").id for s in "lr"]
    assert np.allclose(bottom[np.searchsorted(geoms, feet)], 0.0, atol=1e-9)
    assert model.geom("head").id == geoms[np.argmax(top)]


def test_total_mass_is_human(figure):
    model, _ = figure
    assert 50.0 <= model.body_mass.sum() <= 80.0
    mass = {model.body(b).name: model.body_mass[b] for b in range(1, model.nbody)}
    assert mass["torso"] > mass["thigh_l"] > mass["shin_l"] > mass["foot_l"] > mass["hand_l"]
    for limb in ("upper_arm", "lower_arm", "hand", "thigh", "shin", "foot"):
        assert mass[f"{limb}_l"] == mass[f"{limb}_r"] > 0


def test_servos_hold_the_standing_pose_with_the_root_fixed():
    root = ET.fromstring(figures.figure_xml())
    pelvis = root.find("worldbody/body")
    pelvis.remove(pelvis.find("freejoint"))
    # a body welded to the world collides with its children (MuJoCo filters parent-child pairs
    # only below the world), so restore the filter for the pelvis by hand
    contact = ET.SubElement(root, "contact")
    for child in pelvis.findall("body"):
        ET.SubElement(contact, "exclude", body1="pelvis", body2=child.get("name"))
    model, data = compiled(ET.tostring(root, encoding="unicode"))
    simulate(model, data, 1000)
    assert np.degrees(np.abs(data.qpos).max()) < 2.0  # every hinge within 2 degrees of its target
    assert np.abs(data.qvel).max() < 0.01  # and at rest


# --- scenes of figures -------------------------------------------------------------------------------


@pytest.mark.parametrize("n", [1, 3])
def test_scene_copies_everything_with_unique_prefixed_names(figure, n):
    one, _ = figure
    model, _ = compiled(figures.scene_xml(n))
    assert model.ngeom - 1 == n * (one.ngeom - 1)  # one shared floor
    assert len(ellipsoid_geoms(model)) == n * len(ellipsoid_geoms(one))
    assert (model.nbody - 1, model.njnt, model.nu) == (n * (one.nbody - 1), n * one.njnt, n * one.nu)
    assert model.nlight == 1 and model.geom("floor").id == 0
    for kind in ("body", "joint", "geom", "actuator"):
        count = {"body": model.nbody, "joint": model.njnt, "geom": model.ngeom, "actuator": model.nu}[kind]
        names = [getattr(model, kind)(i).name for i in range(count)]
        assert len(set(names)) == len(names), kind
        owned = [name for name in names if name not in ("world", "floor")]
        assert all(re.fullmatch(r"f\d+_\w+", name) for name in owned), kind
    for a in range(model.nu):  # actuator joint="..." references were renamed with their joints
        assert model.actuator(a).name == model.joint(model.actuator_trnid[a, 0]).name
    for i in range(n):
        assert model.body_parentid[model.body(f"f{i}_torso").id] == model.body(f"f{i}_pelvis").id
        assert model.jnt_type[model.joint(f"f{i}_root").id] == FREE


def test_scene_memory_is_set_and_linear_but_for_the_broad_phase():
    """MuJoCo's default arena grows too fast (8.6 GB at 500 figures, not allocatable at 1000):
    scene_xml sets <size memory> to scene_memory, and a contact-rich heap runs within it."""
    model, data = compiled(figures.scene_xml(4, layout="pile", seed=2))
    assert model.narena == figures.scene_memory(4)
    nbody = 4 * len(figures.LIMBS) + 1
    assert (
        figures.scene_memory(4)
        == figures.ARENA_PER_BODY_PAIR * nbody**2 + 4 * figures.ARENA_PER_FIGURE + figures.ARENA_BASE
    )
    simulate(model, data, 800)
    assert data.ncon > 10 and data.maxuse_arena < model.narena / 4


def test_scene_without_floor_and_with_drop_height():
    model, _ = compiled(figures.scene_xml(2, floor=False))
    assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "floor") == -1
    assert model.ngeom == 2 * len(figures.LIMBS)
    model, data = compiled(figures.scene_xml(2, layout="line", drop_height=0.3))
    bottom, _ = z_extents(model, data, ellipsoid_geoms(model))
    assert bottom.min() == pytest.approx(0.3, abs=1e-9)


def test_terrain_replaces_the_floor_and_its_props_land_on_it():
    """terrain=True: a height field under and a metre beyond the figures instead of the floor, the lowest limb
    drop_height above its highest point, `props` free convex meshes; stepped, figures and props come to rest on
    the terrain (none falls through it), touching it through ellipsoid x height-field contacts."""
    xml = figures.scene_xml(4, terrain=True, props=5, drop_height=0.05, seed=2)
    model, data = compiled(xml)
    assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "floor") == -1
    assert model.nhfield == 1 and model.nmesh == 5
    field = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "terrain")
    top = model.hfield_size[0, 2]
    assert top == figures.TERRAIN_RELIEF
    bottom, _ = z_extents(model, data, ellipsoid_geoms(model))
    assert bottom.min() == pytest.approx(top + 0.05, abs=1e-9)
    roots = data.xpos[model.body_rootid[ellipsoid_geoms(model)], :2]
    assert np.all(np.abs(roots) + 1.0 <= model.hfield_size[0, :2] + 1e-9)
    props = np.flatnonzero(model.geom_type == mujoco.mjtGeom.mjGEOM_MESH)
    assert len(props) == 5
    with ellipsim.mujoco.attach(model, data, mode="narrowphase") as att:
        touched = set()
        for _ in range(600):
            mujoco.mj_step(model, data)
            c = data.contact.geom[: data.ncon]
            touched |= {int(g) for pair in c if field in pair for g in pair if g != field}
    assert att.counters["contacts"] > 0 and att.counters["fallbacks"] == 0
    assert set(props) <= touched and len(touched & set(ellipsoid_geoms(model))) >= 4
    assert data.geom_xpos[props, 2].min() > -model.hfield_size[0, 3]  # none fell through


@pytest.mark.parametrize("layout", figures.LAYOUTS)
def test_layouts_start_separated_and_run(layout):
    n = 4
    model, data = compiled(figures.scene_xml(n, layout=layout, seed=3))
    geoms = ellipsoid_geoms(model)
    owner = model.body_rootid[model.geom_bodyid[geoms]]
    assert len(set(owner)) == n
    # every pair of limbs of different figures starts separated ...
    pairs = [(a, b) for (a, fa), (b, fb) in itertools.combinations(zip(geoms, owner), 2) if fa != fb]
    assert (relations(model, data, pairs) == Relation.SEPARATED).all()
    # ... and so does every non-adjacent pair of one figure, also tilted in a "pile"
    pairs = [
        (a, b)
        for (a, fa), (b, fb) in itertools.combinations(zip(geoms, owner), 2)
        if fa == fb and not adjacent(model, a, b)
    ]
    assert (relations(model, data, pairs) == Relation.SEPARATED).all()
    bottom, _ = z_extents(model, data, geoms)
    assert bottom.min() == pytest.approx(0.0, abs=1e-9)
    root_z = data.xpos[np.unique(owner), 2]
    if layout == "pile":  # stacked: one figure above the other
        assert np.all(np.diff(root_z) > 0)
    else:  # standing side by side on the floor at the figure's own root height
        assert np.allclose(root_z, 0.95, atol=1e-12)
    simulate(model, data, 500)
    if layout == "pile":  # they fell
        assert data.xpos[np.unique(owner), 2].max() < root_z.max() - 0.5


def test_pile_is_reproducible_from_the_seed():
    assert figures.scene_xml(3, layout="pile", seed=7) == figures.scene_xml(3, layout="pile", seed=7)
    assert figures.scene_xml(3, layout="pile", seed=7) != figures.scene_xml(3, layout="pile", seed=8)


# --- piles and chains of plain ellipsoids --------------------------------------------------------------


def test_pile_xml_starts_apart_and_settles_in_the_bin():
    n, half_width = 40, 0.5
    model, data = compiled(figures.pile_xml(n, seed=2, bin_half_width=half_width))
    geoms = ellipsoid_geoms(model)
    assert len(geoms) == n and model.nbody == n + 1 and model.njnt == n
    sizes = model.geom_size[geoms]
    assert (sizes >= 0.03).all() and (sizes <= 0.12).all()
    rel = relations(model, data, list(itertools.combinations(geoms, 2)))
    assert (rel == Relation.SEPARATED).all()
    assert data.ncon == 0  # not touching the walls or the floor either
    simulate(model, data, 750)  # 1.5 s
    centres = data.xpos[1:]
    assert (np.abs(centres[:, :2]) < half_width).all()
    assert (centres[:, 2] > 0).all()
    wall_top = 2 * model.geom("wall_+x").size[2]
    assert centres[:, 2].max() < wall_top < 1.0  # all fell in (the top layer started at 1.18 m)
    speed = np.linalg.norm(data.qvel.reshape(n, 6)[:, :3], axis=1)  # free joint: world linear velocity first
    assert speed.max() < 2.0  # landed: a fall from the top layer ends at 4.8 m/s (20 seeds: < 0.8 m/s)


@pytest.mark.parametrize("n_links", [2, 12])
def test_chain_xml_coils_and_collides_with_itself(n_links):
    model, data = compiled(figures.chain_xml(n_links, seed=1))
    geoms = ellipsoid_geoms(model)
    assert len(geoms) == n_links and model.njnt == n_links and model.jnt_type[0] == FREE
    hinges = model.jnt_type == HINGE
    assert hinges.sum() == n_links - 1 and model.jnt_limited[hinges].all()
    far = [(a, b) for a, b in itertools.combinations(geoms, 2) if not adjacent(model, a, b)]
    if far:
        assert (relations(model, data, far) == Relation.SEPARATED).all()
    bottom, _ = z_extents(model, data, geoms)
    assert bottom.min() == pytest.approx(0.05, abs=1e-9)
    self_contacts = 0
    for _ in range(10):
        simulate(model, data, 100)
        for c in data.contact[: data.ncon]:
            b1, b2 = model.geom_bodyid[c.geom1], model.geom_bodyid[c.geom2]
            self_contacts += bool(b1 and b2 and abs(int(b1) - int(b2)) >= 2)
    assert self_contacts > 0 if n_links >= 3 else self_contacts == 0


# --- bad input ---------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "call, argument",
    [
        (lambda: figures.scene_xml(0), "n_figures"),
        (lambda: figures.scene_xml(2.0), "n_figures"),
        (lambda: figures.scene_xml(True), "n_figures"),
        (lambda: figures.scene_xml(2, layout="circle"), "layout"),
        (lambda: figures.scene_xml(2, spacing=-1.0), "spacing"),
        (lambda: figures.scene_xml(2, spacing=0.3), "spacing"),  # figures would start overlapping
        (lambda: figures.scene_xml(2, layout="line", spacing=0.6), "spacing"),
        (lambda: figures.scene_xml(2, seed=-1), "seed"),
        (lambda: figures.scene_xml(2, drop_height=-0.1), "drop_height"),
        (lambda: figures.scene_xml(2, drop_height=float("nan")), "drop_height"),
        (lambda: figures.scene_xml(2, floor="yes"), "floor"),
        (lambda: figures.scene_xml(2, terrain=1), "terrain"),
        (lambda: figures.scene_xml(2, terrain=True, props=-1), "props"),
        (lambda: figures.scene_xml(2, props=3), "props"),  # props lie on the terrain
        (lambda: figures.pile_xml(0), "n_ellipsoids"),
        (lambda: figures.pile_xml(5, bin_half_width=0.0), "bin_half_width"),
        (lambda: figures.pile_xml(5, bin_half_width=0.1), "bin_half_width"),  # smaller than one ellipsoid
        (lambda: figures.pile_xml(5, radii=(0.1, 0.05)), "radii"),
        (lambda: figures.pile_xml(5, radii=(0.0, 0.05)), "radii"),
        (lambda: figures.pile_xml(5, radii=0.1), "radii"),
        (lambda: figures.chain_xml(0), "n_links"),
        (lambda: figures.chain_xml("3"), "n_links"),
        (lambda: figures.chain_xml(3, seed=1.5), "seed"),
        (lambda: figures.chain_xml(figures.MAX_LINKS + 1), "n_links"),
    ],
)
def test_bad_arguments_raise_value_error_naming_the_argument(call, argument):
    with pytest.raises(ValueError, match=rf"^{argument}\b"):
        call()


def test_capsule_twin_puts_a_capsule_along_each_ellipsoids_longest_axis():
    xml = figures.scene_xml(2, layout="pile", seed=4)
    m0, m1 = mujoco.MjModel.from_xml_string(xml), mujoco.MjModel.from_xml_string(figures.capsule_twin_xml(xml))
    ell = np.flatnonzero(m0.geom_type == mujoco.mjtGeom.mjGEOM_ELLIPSOID)
    assert len(ell) == 30 and (m1.geom_type[ell] == mujoco.mjtGeom.mjGEOM_CAPSULE).all()
    others = np.setdiff1d(np.arange(m0.ngeom), ell)
    assert (m1.geom_type[others] == m0.geom_type[others]).all()
    d0, d1 = mujoco.MjData(m0), mujoco.MjData(m1)
    mujoco.mj_forward(m0, d0)
    mujoco.mj_forward(m1, d1)
    for g in ell:
        size = m0.geom_size[g]
        k = int(np.argmax(size))
        axis0 = d0.geom_xmat[g].reshape(3, 3)[:, k]
        axis1 = d1.geom_xmat[g].reshape(3, 3)[:, 2]  # a capsule's axis is its z
        assert abs(abs(axis0 @ axis1) - 1) < 1e-6  # the MJCF text keeps 6 digits
        assert np.allclose(d1.geom_xpos[g], d0.geom_xpos[g], atol=1e-6)
        r = (size.sum() - size[k]) / 2
        assert np.allclose(m1.geom_size[g, :2], [r, size[k] - r], atol=1e-6)
