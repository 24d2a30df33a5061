"""MJCF scenes made of ellipsoids: crowds of the oval-limb figure, piles of free ellipsoids, chains.

The figure is models/figure.xml (installed as the package ``ellipsim.models``): 15 limb bodies,
one ellipsoid each, a free root and position servos on 28 hinges.  `scene_xml` copies it n times
with ElementTree, prefixing every name with "f{i}_", and places the copies standing on a grid, in
a row, or in a heap in the air.  `pile_xml` and `chain_xml` build contact-rich scenes of plain
ellipsoids.  Every function returns MJCF text for ``mujoco.MjModel.from_xml_string``; every scene
starts with no two colliding bodies overlapping, and the tests check this with `classify`.

Lengths in metres, angles in degrees inside the MJCF (compiler angle="degree").
"""

import copy
import functools
import math
import numbers
import xml.etree.ElementTree as ET

import mujoco
import numpy as np

from .. import shipped
from ..core.rotations import quaternion_product, quaternions_to_rotations, rotations_to_quaternions

#: Limb bodies of one figure, in the body order of models/figure.xml (one ellipsoid geom each).
LIMBS = (
    "pelvis",
    "torso",
    "head",
    "upper_arm_l",
    "lower_arm_l",
    "hand_l",
    "upper_arm_r",
    "lower_arm_r",
    "hand_r",
    "thigh_l",
    "shin_l",
    "foot_l",
    "thigh_r",
    "shin_r",
    "foot_r",
)

LAYOUTS = ("grid", "line", "facing", "pile")

#: Attributes that hold a name or refer to a named element, in bodies and in the top-level
#: sections listed in _FIGURE_SECTIONS (MJCF reference: actuator, sensor, contact, equality, tendon).
_NAME_ATTRS = (
    "name",
    "joint",
    "joint1",
    "joint2",
    "jointinparent",
    "body",
    "body1",
    "body2",
    "geom",
    "geom1",
    "geom2",
    "site",
    "site1",
    "site2",
    "refsite",
    "cranksite",
    "slidersite",
    "tendon",
    "tendon1",
    "tendon2",
    "actuator",
    "objname",
    "refname",
    "target",
)

#: Top-level MJCF sections whose elements belong to the figure and are copied with it.
_FIGURE_SECTIONS = ("contact", "equality", "tendon", "actuator", "sensor")

#: Vertical clearance between consecutive figures of a "pile", metres.
_PILE_GAP = 0.05

#: Tilt from upright of a "pile" figure, degrees: mostly lying, so the heap is low and they tangle.
_PILE_TILT = (45.0, 90.0)

#: Horizontal jitter of a "pile" figure's root about the vertical axis, metres.
_PILE_JITTER = 0.1

#: Free space between the bounding spheres of neighbouring ellipsoids in pile_xml, and between them
#: and the walls, metres.
_BIN_GAP = 0.02

#: Bin walls of pile_xml: thickness, metres, and the packing fraction that sizes their height.
#: Measured: 2 s after the drop, the highest point of a pile of 40-300 ellipsoids (radii (0.03, 0.12)
#: in a 1 m bin, (0.02, 0.05) in a 0.6 m bin) is at V / (p A) with p = 0.26-0.47, V their volume and
#: A the bin floor; walls 1.5 V / (0.3 A) high keep every ellipsoid in.
_WALL_THICKNESS = 0.05
_PACKING = 0.3

#: Links of chain_xml: semi-axes (thickness x, thickness y, half-length z), metres; hinge range,
#: degrees; hinge damping, N m s / rad, and armature, kg m^2 (a link weighs 0.31 kg and has
#: 0.004 kg m^2 about its joint; these keep a falling 80-link coil stable at dt = 2 ms).
_LINK_RADII = (0.03, 0.025, 0.1)
_LINK_RANGE = 150.0
_LINK_DAMPING = 0.02
_LINK_ARMATURE = 0.002

#: The coil chain_xml starts in: links per turn, pitch per turn, metres (> 2 * 0.1, so that links
#: one turn apart start with disjoint bounding spheres), largest tilt of its axis from vertical,
#: degrees, and clearance of its lowest point above the floor, metres.
_COIL_LINKS_PER_TURN = 8
_COIL_PITCH = 0.25
_COIL_TILT = 20.0
_CHAIN_CLEARANCE = 0.05

#: MuJoCo's memory arena for scene_xml (<size memory>), bytes.  Its broad phase takes 4 bytes per
#: pair of bodies (measured with mujoco 4.0: maxuse_arena 4.0 nbody^2 for 25-250 standing figures;
#: at 1000 figures mj_broadphase alone requests 2 nbody^2 = 450 MB); contacts and constraints up to
#: 1 MB per figure (a heap of 48 figures used 0.13 MB each); 16 MB for the rest (MuJoCo's own
#: default for one figure).  MuJoCo's default instead grows too fast: 8.6 GB at 500 figures, and at
#: 1000 it cannot be allocated.
ARENA_PER_BODY_PAIR = 4
ARENA_PER_FIGURE = 1 << 20
ARENA_BASE = 16 << 20

#: Most links chain_xml builds: each link nests one body deeper, and MuJoCo's XML parser (tinyxml2)
#: refuses elements nested deeper than 500 (measured with mujoco 4.0: 496 links compile, 497 do not).
MAX_LINKS = 400


# --- argument checks ------------------------------------------------------------------------------


def _check_count(name, value):
    """`value` as a positive int; ValueError naming `name` otherwise."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < 1:
        raise ValueError(f"{name} must be a positive int, got {value!r}")
    return int(value)


def _check_seed(seed):
    """`seed` as a non-negative int for numpy.random.default_rng."""
    if isinstance(seed, bool) or not isinstance(seed, numbers.Integral) or seed < 0:
        raise ValueError(f"seed must be a non-negative int, got {seed!r}")
    return int(seed)


def _check_real(name, value, *, positive):
    """`value` as a finite float, > 0 if `positive` else >= 0; ValueError naming `name`."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(value):
        raise ValueError(f"{name} must be a finite number, got {value!r}")
    if value < 0 or (positive and value == 0):
        raise ValueError(f"{name} must be {'positive' if positive else 'non-negative'}, got {value!r}")
    return float(value)


# --- the figure -----------------------------------------------------------------------------------


def figure_xml():
    """The MJCF text of models/figure.xml (one figure, unprefixed names, floor and light)."""
    return (shipped.folder("models") / "figure.xml").read_text(encoding="utf-8")


@functools.lru_cache(maxsize=1)
def _rest_geometry():
    """The figure at qpos0, relative to its root: (root_pos (3,), root_quat (4,) w x y z,
    offsets (g, 3) geom centre minus root position, rotations (g, 3, 3), radii (g, 3)), world frame,
    for the g geoms of the figure's bodies (the floor excluded)."""
    model = mujoco.MjModel.from_xml_string(figure_xml())
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    root = model.body(LIMBS[0]).id
    geoms = np.flatnonzero(model.geom_bodyid != 0)
    offsets = data.geom_xpos[geoms] - data.xpos[root]
    rotations = data.geom_xmat[geoms].reshape(-1, 3, 3).copy()
    return data.xpos[root].copy(), data.xquat[root].copy(), offsets, rotations, model.geom_size[geoms].copy()


def _placed_extents(quat):
    """Per geom of a figure rotated by `quat` (w x y z) about its root: (lo (g, 3), hi (g, 3))
    bounds of its axis-aligned box relative to the root position, metres."""
    _, _, offsets, rotations, radii = _rest_geometry()
    turn = quaternions_to_rotations(np.asarray(quat, dtype=float)[None])[0]
    centres = offsets @ turn.T
    axes = np.einsum("ij,gjk->gik", turn, rotations)
    half = np.sqrt(np.einsum("gik,gk->gi", axes**2, radii**2))  # support of an ellipsoid along e_i
    return centres - half, centres + half


def scene_memory(n_figures):
    """Bytes of MuJoCo arena scene_xml gives a model of `n_figures` figures (see ARENA_PER_BODY_PAIR)."""
    nbody = len(LIMBS) * int(n_figures) + 1
    return ARENA_PER_BODY_PAIR * nbody * nbody + ARENA_PER_FIGURE * int(n_figures) + ARENA_BASE


def mjcf_numbers(values):
    """Numbers as an MJCF attribute value, to float64 round-trip precision (shortest repr)."""
    return " ".join(repr(float(v)) for v in values)


def _names_in(elements):
    """Every `name` attribute in the subtrees of `elements`."""
    return {el.get("name") for top in elements for el in top.iter() if el.get("name") is not None}


def _prefix(element, prefix, names):
    """Prefix, in place, every name in the subtree of `element` and every reference to one of `names`."""
    for el in element.iter():
        for attr in _NAME_ATTRS:
            value = el.get(attr)
            if value is not None and (attr == "name" or value in names):
                el.set(attr, prefix + value)


def _layout_poses(n, layout, spacing, seed, drop_height):
    """Root position (n, 3), metres, and orientation (n, 4) w x y z of each figure."""
    _, root_quat, *_ = _rest_geometry()
    lo, hi = _placed_extents(root_quat)
    lo, hi = lo.min(axis=0), hi.max(axis=0)  # box of the standing figure about its root
    stand_z = drop_height - lo[2]  # root height that puts the lowest point drop_height above z = 0
    if layout == "facing":
        # two rows along y facing each other across x: figure 2k faces +x with its root at
        # x = -spacing/2, figure 2k+1 faces -x at x = +spacing/2; pairs a figure's width apart along y
        front, width = max(hi[0], -lo[0]), hi[1] - lo[1]
        if spacing <= 2 * front:
            raise ValueError(
                f"spacing must exceed {2 * front:.3f} m (twice the figure's reach in front of its root) "
                f"for layout 'facing', got {spacing!r}"
            )
        turn = np.array([0.0, 0.0, 0.0, 1.0])  # 180 degrees about z
        pos, quats = np.empty((n, 3)), np.empty((n, 4))
        for i in range(n):
            y = (i // 2 - (math.ceil(n / 2) - 1) / 2) * (width + 0.1)
            pos[i] = (spacing / 2 if i % 2 else -spacing / 2, y, stand_z)
            quats[i] = quaternion_product(turn, root_quat) if i % 2 else root_quat
        return pos, quats
    if layout in ("grid", "line"):
        depth, width = hi[0] - lo[0], hi[1] - lo[1]
        need = max(depth, width) if layout == "grid" else width
        if spacing <= need:
            what = "footprint" if layout == "grid" else "width"
            raise ValueError(
                f"spacing must exceed {need:.3f} m (the figure's {what}) for layout {layout!r} "
                f"so that figures start apart, got {spacing!r}"
            )
        if layout == "grid":
            cols = math.ceil(math.sqrt(n))
            rows = math.ceil(n / cols)
            idx = np.arange(n)
            x = (idx // cols - (rows - 1) / 2) * spacing
            y = (idx % cols - (cols - 1) / 2) * spacing
        else:
            x = np.zeros(n)
            y = (np.arange(n) - (n - 1) / 2) * spacing
        centre = (lo[:2] + hi[:2]) / 2  # centre the footprints, not the roots, on the grid points
        pos = np.column_stack([x - centre[0], y - centre[1], np.full(n, stand_z)])
        return pos, np.tile(root_quat, (n, 1))
    rng = np.random.default_rng(seed)
    pos, quats, floor_z = np.empty((n, 3)), np.empty((n, 4)), drop_height
    for i in range(n):
        yaw = rng.uniform(0.0, 2 * math.pi)
        tilt = math.radians(rng.uniform(*_PILE_TILT))
        azimuth = rng.uniform(0.0, 2 * math.pi)
        q_yaw = np.array([math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)])
        s = math.sin(tilt / 2)
        q_tilt = np.array([math.cos(tilt / 2), s * math.cos(azimuth), s * math.sin(azimuth), 0.0])
        quats[i] = quaternion_product(quaternion_product(q_tilt, q_yaw), root_quat)
        lo_i, hi_i = _placed_extents(quaternion_product(q_tilt, q_yaw))
        bottom, top = lo_i[:, 2].min(), hi_i[:, 2].max()
        pos[i, :2] = rng.uniform(-_PILE_JITTER, _PILE_JITTER, 2)
        pos[i, 2] = floor_z - bottom  # lowest point at floor_z: above the previous figure
        floor_z = pos[i, 2] + top + _PILE_GAP
    return pos, quats


#: the terrain's relief (metres from its lowest to its highest point), its base below its lowest, its cells (metres)
TERRAIN_RELIEF, TERRAIN_BASE, TERRAIN_CELL = 0.3, 0.05, 0.05


def terrain_elevation(nrow, ncol, seed):
    """(nrow, ncol) elevations in [0, 1]: a few random smooth hills and hollows (Gaussian bumps) over a gentle
    slope, normalised: a terrain a figure can stand, roll and slide on."""
    rng = np.random.default_rng(seed)
    y, x = np.meshgrid(np.linspace(-1, 1, nrow), np.linspace(-1, 1, ncol), indexing="ij")
    h = 0.3 * (rng.uniform(-1, 1) * x + rng.uniform(-1, 1) * y)
    for _ in range(8):
        cx, cy = rng.uniform(-1, 1, 2)
        h += rng.uniform(-1, 1) * np.exp(-((x - cx) ** 2 + (y - cy) ** 2) / rng.uniform(0.02, 0.15))
    return (h - h.min()) / (h.max() - h.min())


#: the seed of the terrain's hills and props: one terrain whatever the scene's seed (which places the figures),
#: so that the layouts of several seeds share one model (MuJoCo Warp's worlds: app/warp_run.py)
TERRAIN_SEED = 7


def _add_terrain(root, world, pos, props):
    """Replace the floor by a height field under the figures at `pos` (their roots) and scatter `props` free
    convex mesh props (8-40 random points, 5-12 cm) between them, dropped with them (TERRAIN_SEED)."""
    seed = TERRAIN_SEED
    half = np.abs(pos[:, :2]).max(axis=0) + 1.0  # a metre of terrain around the outermost figures
    ncol, nrow = (int(np.ceil(2 * h / TERRAIN_CELL)) + 1 for h in half)
    elevation = terrain_elevation(nrow, ncol, seed)
    asset = root.find("asset")
    if asset is None:
        asset = ET.Element("asset")
        root.insert(list(root).index(root.find("worldbody")), asset)
    ET.SubElement(
        asset, "hfield", name="terrain", nrow=str(nrow), ncol=str(ncol),
        size=mjcf_numbers([half[0], half[1], TERRAIN_RELIEF, TERRAIN_BASE]), elevation=mjcf_numbers(elevation.ravel()),
    )  # fmt: skip
    world.insert(0, ET.Element("geom", name="terrain", type="hfield", hfield="terrain", rgba="0.45 0.55 0.4 1"))
    rng = np.random.default_rng(seed + 1)
    for k in range(props):
        points = rng.normal(size=(int(rng.integers(8, 41)), 3)) * rng.uniform(0.05, 0.12, 3)
        ET.SubElement(asset, "mesh", name=f"prop{k}", vertex=mjcf_numbers(points.ravel()))
        x, y = rng.uniform(-half[0] + 0.5, half[0] - 0.5), rng.uniform(-half[1] + 0.5, half[1] - 0.5)
        body = ET.SubElement(world, "body", name=f"prop{k}", pos=mjcf_numbers([x, y, TERRAIN_RELIEF + 0.3]))
        ET.SubElement(body, "freejoint")
        ET.SubElement(body, "geom", name=f"prop{k}", type="mesh", mesh=f"prop{k}", rgba="0.6 0.45 0.3 1")


def scene_xml(
    n_figures, *, layout="grid", spacing=0.8, seed=0, drop_height=0.0, floor=True, fixed_roots=False, terrain=False,
    props=0,
):  # fmt: skip
    """MJCF text of one model with `n_figures` copies of the figure, names prefixed "f{i}_".

    layout : "grid" standing on a square grid `spacing` metres apart (x rows, y columns);
        "line" standing shoulder to shoulder along y, `spacing` metres apart;
        "pile" stacked in the air above each other with random yaw and a random tilt of 45-90
        degrees (drawn from `seed`), each 5 cm above the one below, to fall onto each other
        (`spacing` is not used).
    drop_height : clearance in metres between the floor (z = 0) and the lowest point of the
        standing figures ("grid", "line") or of the lowest figure ("pile"); 0 = touching.
    floor : keep the floor plane of figure.xml (the light is always kept).
    fixed_roots : weld each figure's root (pelvis) to the world instead of a free joint; MuJoCo does
        not filter collisions between a world-welded body and its children, so the pelvis is
        excluded from colliding with the bodies attached to it.
    The model's memory arena is scene_memory(n_figures) bytes (<size memory>): linear in the
    figures but for MuJoCo's broad phase, 4 bytes per pair of bodies.
    layout "facing": two rows facing each other across `spacing` metres (figures 0, 2, ... face +x).
    Figures start with no two of their limbs overlapping.
    terrain : replace the floor by a height field of smooth hills (TERRAIN_RELIEF high, cells TERRAIN_CELL,
        a metre beyond the outermost figures; drop_height then counts from its highest point) and scatter
        `props` free convex mesh props between the figures, dropped with them.
    """
    n = _check_count("n_figures", n_figures)
    if layout not in LAYOUTS:
        raise ValueError(f"layout must be one of {LAYOUTS}, got {layout!r}")
    spacing = _check_real("spacing", spacing, positive=True)
    seed = _check_seed(seed)
    drop_height = _check_real("drop_height", drop_height, positive=False)
    if not isinstance(floor, bool):
        raise ValueError(f"floor must be True or False, got {floor!r}")
    if not isinstance(fixed_roots, bool):
        raise ValueError(f"fixed_roots must be True or False, got {fixed_roots!r}")
    if not isinstance(terrain, bool):
        raise ValueError(f"terrain must be True or False, got {terrain!r}")
    if isinstance(props, bool) or not isinstance(props, (int, np.integer)) or props < 0:
        raise ValueError(f"props must be a non-negative integer, got {props!r}")
    if props and not terrain:
        raise ValueError(f"props need terrain=True (they are scattered on it), got props={props!r}")
    pos, quats = _layout_poses(n, layout, spacing, seed, drop_height + (TERRAIN_RELIEF if terrain else 0.0))

    root = ET.fromstring(figure_xml())
    root.set("model", f"oval_figure_scene_{n}")
    size = root.find("size")
    if size is None:
        size = ET.Element("size")
        root.insert(list(root).index(root.find("worldbody")), size)
    size.set("memory", str(scene_memory(n)))
    world = root.find("worldbody")
    figure = next(b for b in world.findall("body") if b.find("freejoint") is not None)
    world.remove(figure)
    if not floor or terrain:
        for geom in world.findall("geom"):
            if geom.get("name") == "floor":
                world.remove(geom)
    if terrain:
        _add_terrain(root, world, pos, props)
    sections = [(s, list(root.find(s))) for s in _FIGURE_SECTIONS if root.find(s) is not None]
    names = _names_in([figure] + [el for _, items in sections for el in items])
    for tag, items in sections:
        for el in items:
            root.find(tag).remove(el)

    for i in range(n):
        body = copy.deepcopy(figure)
        _prefix(body, f"f{i}_", names)
        for attr in ("euler", "axisangle", "xyaxes", "zaxis"):
            body.attrib.pop(attr, None)
        body.set("pos", mjcf_numbers(pos[i]))
        body.set("quat", mjcf_numbers(quats[i]))
        if fixed_roots:
            body.remove(body.find("freejoint"))
            contact = root.find("contact")
            if contact is None:
                contact = ET.SubElement(root, "contact")
            for child in body.findall("body"):
                ET.SubElement(contact, "exclude", body1=body.get("name"), body2=child.get("name"))
        world.append(body)
        for tag, items in sections:
            for el in items:
                el = copy.deepcopy(el)
                _prefix(el, f"f{i}_", names)
                root.find(tag).append(el)
    ET.indent(root)
    return ET.tostring(root, encoding="unicode")


# --- piles and chains of plain ellipsoids ---------------------------------------------------------


def _world_root(model_name):
    """An MJCF root with the compiler and option of figure.xml, its light and its floor."""
    figure = ET.fromstring(figure_xml())
    root = ET.Element("mujoco", model=model_name)
    for tag in ("compiler", "option"):
        root.append(copy.deepcopy(figure.find(tag)))
    world = ET.SubElement(root, "worldbody")
    for el in figure.find("worldbody"):
        if el.tag == "light" or (el.tag == "geom" and el.get("name") == "floor"):
            world.append(copy.deepcopy(el))
    return root, world


def _random_quats(rng, n):
    """n uniformly random unit quaternions (n, 4), w x y z (normalised Gaussian 4-vectors)."""
    q = rng.normal(size=(n, 4))
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def pile_xml(n_ellipsoids, *, seed=0, bin_half_width=0.5, radii=(0.03, 0.12), thickness=None):
    """MJCF text of `n_ellipsoids` free ellipsoids above a square bin, to fall into a pile.

    The bin is the floor and four box walls around |x|, |y| <= bin_half_width (metres), 1.5 times
    as high as the pile they make at packing fraction 0.3, and at least 4 * radii[1].
    Semi-axes are uniform in radii = (smallest, largest) metres, orientations uniformly random
    (drawn from `seed`); with thickness = (smallest, largest), the third semi-axis is drawn from it
    instead: thin flat ellipsoids (leaves) for a thickness well below radii.  The ellipsoids start in layers of a square grid of cubic cells of side
    2 * radii[1] + 2 cm, one per cell, so no two start overlapping and none touches a wall.
    Bodies, joints and geoms are named "e{i}"; walls "wall_{+x,-x,+y,-y}".
    """
    n = _check_count("n_ellipsoids", n_ellipsoids)
    seed = _check_seed(seed)
    half_width = _check_real("bin_half_width", bin_half_width, positive=True)
    try:
        r_lo, r_hi = (float(r) for r in radii)
    except (TypeError, ValueError):
        raise ValueError(f"radii must be a pair (smallest, largest) of semi-axes in metres, got {radii!r}") from None
    if not (math.isfinite(r_lo) and math.isfinite(r_hi) and 0 < r_lo <= r_hi):
        raise ValueError(f"radii must satisfy 0 < radii[0] <= radii[1] (finite), got {radii!r}")
    if thickness is not None:
        try:
            t_lo, t_hi = (float(r) for r in thickness)
        except (TypeError, ValueError):
            raise ValueError(
                f"thickness must be a pair (smallest, largest) of semi-axes in metres, got {thickness!r}"
            ) from None
        if not (math.isfinite(t_lo) and math.isfinite(t_hi) and 0 < t_lo <= t_hi <= r_hi):
            raise ValueError(f"thickness must satisfy 0 < thickness[0] <= thickness[1] <= radii[1], got {thickness!r}")
    cell = 2 * r_hi + _BIN_GAP
    per_row = int((2 * half_width - _BIN_GAP) // cell)
    if per_row < 1:
        raise ValueError(
            f"bin_half_width must be at least {r_hi + _BIN_GAP:.3f} m to hold an ellipsoid of semi-axis "
            f"radii[1] = {r_hi!r}, got {bin_half_width!r}"
        )
    rng = np.random.default_rng(seed)
    sizes = rng.uniform(r_lo, r_hi, (n, 3))
    quats = _random_quats(rng, n)
    if thickness is not None:  # drawn after the rest: the pile without it is unchanged
        sizes[:, 2] = rng.uniform(t_lo, t_hi, n)
    idx = np.arange(n)
    layer, slot = divmod(idx, per_row * per_row)
    row, col = divmod(slot, per_row)
    centres = np.column_stack(
        [
            (row - (per_row - 1) / 2) * cell,
            (col - (per_row - 1) / 2) * cell,
            _BIN_GAP + r_hi + layer * cell,
        ]
    )
    volume = 4 / 3 * math.pi * float(np.prod(sizes, axis=1).sum())
    wall_height = max(4 * r_hi, 1.5 * volume / (_PACKING * (2 * half_width) ** 2))

    root, world = _world_root(f"ellipsoid_pile_{n}")
    t = _WALL_THICKNESS
    outer = half_width + t / 2
    for name, (x, y), (sx, sy) in (
        ("wall_+x", (outer, 0), (t / 2, half_width + t)),
        ("wall_-x", (-outer, 0), (t / 2, half_width + t)),
        ("wall_+y", (0, outer), (half_width + t, t / 2)),
        ("wall_-y", (0, -outer), (half_width + t, t / 2)),
    ):
        ET.SubElement(
            world,
            "geom",
            name=name,
            type="box",
            pos=mjcf_numbers((x, y, wall_height / 2)),
            size=mjcf_numbers((sx, sy, wall_height / 2)),
            rgba="0.6 0.6 0.65 0.4",
        )
    for i in range(n):
        body = ET.SubElement(world, "body", name=f"e{i}", pos=mjcf_numbers(centres[i]), quat=mjcf_numbers(quats[i]))
        ET.SubElement(body, "freejoint", name=f"e{i}")
        hue = (0.35 + 0.5 * (i % 7) / 6, 0.5, 0.85 - 0.5 * (i % 7) / 6)
        ET.SubElement(
            body,
            "geom",
            name=f"e{i}",
            type="ellipsoid",
            size=mjcf_numbers(sizes[i]),
            contype="1",
            conaffinity="1",
            rgba=mjcf_numbers((*hue, 1.0)),
        )
    ET.indent(root)
    return ET.tostring(root, encoding="unicode")


def _coil_frames(rng, n):
    """Rest pose of a chain of n links laid along a helix: (frames (n, 3, 3) world rotations, columns
    = the links' x, y, z axes, each link along its -z; joints (n, 3) the top end of each link, metres).

    The helix has _COIL_LINKS_PER_TURN links per turn and _COIL_PITCH per turn, its axis tilted from
    vertical by up to _COIL_TILT degrees and turned by a random yaw (both from `rng`); the lowest
    point of the chain sits _CHAIN_CLEARANCE above z = 0.
    """
    a = _LINK_RADII[2]
    phi = 2 * math.pi / _COIL_LINKS_PER_TURN
    drop = _COIL_PITCH / _COIL_LINKS_PER_TURN  # per link; a chord of the helix is one link, 2a
    rho = math.sqrt((2 * a) ** 2 - drop**2) / (2 * math.sin(phi / 2))
    k = np.arange(n + 1)
    points = np.column_stack([rho * np.cos(k * phi), rho * np.sin(k * phi), -drop * k])
    down = (points[1:] - points[:-1]) / (2 * a)  # unit direction of each link, top to bottom
    mid = (points[1:] + points[:-1]) / 2
    inward = -mid * [1.0, 1.0, 0.0]  # towards the helix axis
    x = inward - np.sum(inward * down, axis=1, keepdims=True) * down
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    z = -down
    frames = np.stack([x, np.cross(z, x), z], axis=2)
    yaw = rng.uniform(0, 2 * math.pi)
    tilt = math.radians(rng.uniform(0, _COIL_TILT))
    azimuth = rng.uniform(0, 2 * math.pi)
    q_yaw = np.array([math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)])
    s = math.sin(tilt / 2)
    q_tilt = np.array([math.cos(tilt / 2), s * math.cos(azimuth), s * math.sin(azimuth), 0.0])
    turn = quaternions_to_rotations(quaternion_product(q_tilt, q_yaw)[None])[0]
    frames = np.einsum("ij,njk->nik", turn, frames)
    joints = points[:-1] @ turn.T
    centres = joints - a * frames[:, :, 2]
    half = np.sqrt(np.einsum("nk,k->n", frames[:, 2, :] ** 2, np.square(_LINK_RADII)))
    joints[:, 2] += _CHAIN_CLEARANCE - (centres[:, 2] - half).min()
    return frames, joints


def chain_xml(n_links, *, seed=0):
    """MJCF text of a chain of `n_links` ellipsoid links (semi-axes 3 x 2.5 x 10 cm) joined end to
    end by passive hinges (axes alternating between the links' x and y axes; range +-150 degrees;
    some damping), the first link on a free joint.

    The chain starts coiled like a loose spring (a helix of 8 links and 25 cm per turn) with its
    axis tilted by up to 20 degrees (tilt and yaw drawn from `seed`) and its lowest point 5 cm above
    the floor; it falls and collapses onto the floor, and the turns land on each other, so
    non-adjacent links collide.  Bodies and geoms are named "link{i}", joints "root" and "hinge{i}".
    n_links : 1 to MAX_LINKS.
    """
    n = _check_count("n_links", n_links)
    if n > MAX_LINKS:
        raise ValueError(f"n_links must be at most {MAX_LINKS} (MuJoCo's XML nesting limit), got {n_links!r}")
    seed = _check_seed(seed)
    frames, joints = _coil_frames(np.random.default_rng(seed), n)
    a = _LINK_RADII[2]

    root, world = _world_root(f"ellipsoid_chain_{n}")
    default = ET.SubElement(ET.SubElement(root, "default"), "default", attrib={"class": "link"})
    ET.SubElement(
        default,
        "geom",
        type="ellipsoid",
        size=mjcf_numbers(_LINK_RADII),
        contype="1",
        conaffinity="1",
        rgba="0.45 0.6 0.8 1",
    )
    ET.SubElement(
        default,
        "joint",
        type="hinge",
        limited="true",
        range=f"{-_LINK_RANGE} {_LINK_RANGE}",
        damping=repr(_LINK_DAMPING),
        armature=repr(_LINK_ARMATURE),
    )
    parent = ET.SubElement(
        world,
        "body",
        name="link0",
        pos=mjcf_numbers(joints[0]),
        quat=mjcf_numbers(rotations_to_quaternions(frames[0])),
        childclass="link",
    )
    ET.SubElement(parent, "freejoint", name="root")
    ET.SubElement(parent, "geom", name="link0", pos=mjcf_numbers((0, 0, -a)))
    for i in range(1, n):
        relative = frames[i - 1].T @ frames[i]
        parent = ET.SubElement(
            parent,
            "body",
            name=f"link{i}",
            pos=mjcf_numbers((0, 0, -2 * a)),
            quat=mjcf_numbers(rotations_to_quaternions(relative)),
        )
        ET.SubElement(parent, "joint", name=f"hinge{i}", axis="1 0 0" if i % 2 else "0 1 0")
        ET.SubElement(parent, "geom", name=f"link{i}", pos=mjcf_numbers((0, 0, -a)))
    ET.indent(root)
    return ET.tostring(root, encoding="unicode")


#: quaternion turning a geom's z axis onto its x / y / z axis (w, x, y, z)
_Z_ONTO = (
    np.array([math.sqrt(0.5), 0.0, math.sqrt(0.5), 0.0]),
    np.array([math.sqrt(0.5), -math.sqrt(0.5), 0.0, 0.0]),
    np.array([1.0, 0.0, 0.0, 0.0]),
)


def capsule_twin_xml(xml):
    """The same MJCF model with every ellipsoid geom replaced by a capsule along its longest semi-axis
    a (radius r = the mean of the other two, half-length max(a - r, 0)), in the ellipsoid's place:
    the capsule-limbed twin of a figure scene, to compare mj_step costs.  Masses follow the new volumes."""
    model = mujoco.MjModel.from_xml_string(xml)
    spec = mujoco.MjSpec.from_string(xml)
    ids = {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g): g for g in range(model.ngeom)}
    for geom in spec.geoms:
        if geom.type != mujoco.mjtGeom.mjGEOM_ELLIPSOID:
            continue
        g = ids[geom.name]
        size = model.geom_size[g]
        k = int(np.argmax(size))
        r = (float(size.sum()) - float(size[k])) / 2
        geom.type = mujoco.mjtGeom.mjGEOM_CAPSULE
        geom.size = [r, max(float(size[k]) - r, 0.0), 0.0]
        geom.pos = model.geom_pos[g]  # as compiled (an alternative orientation or fromto resolved)
        geom.quat = quaternion_product(model.geom_quat[g], _Z_ONTO[k])
        geom.alt.type = mujoco.mjtOrientation.mjORIENTATION_QUAT
    return spec.to_xml()
