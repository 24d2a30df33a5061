"""What a run or a replay produces, for recording and summaries: the model's shapes once, then
frames in chunks (body poses, ellipsim's verdicts, MuJoCo's contacts, counts).

simulate.py and replay.py fill these from MuJoCo; record.py turns them into rerun calls; nothing
here knows about MuJoCo or rerun.  A run hands frames over a chunk at a time, so that memory is
bounded by the chunk, not by the number of steps.
"""

import dataclasses

import numpy as np

#: Geom kinds, indexed by MuJoCo's mjtGeom code (mjGEOM_PLANE = 0 ... mjGEOM_MESH = 7).
GEOM_KINDS = ("plane", "hfield", "sphere", "capsule", "ellipsoid", "cylinder", "box", "mesh")


def _check_shapes(obj, shapes):
    for name, shape in shapes.items():
        got = np.shape(getattr(obj, name))
        if got != shape:
            raise ValueError(f"{type(obj).__name__}.{name} must have shape {shape}, got {got}")


@dataclasses.dataclass
class SceneGeometry:
    """The static part of a model: B bodies (body 0 is the world), G geoms, g of them tested by ellipsim.

    name : the scenario or model, for the recording's name
    body_names : list of B str (unique, non-empty)
    body_parent : (B,) int64, parent body (the world's is 0)
    body_pos, body_quat : (B, 3) metres, (B, 4) unit w x y z: pose relative to the parent body;
        exact for bodies that are not in `moving`, the rest pose for those that are
    moving : (M,) int64 bodies whose pose relative to their parent changes (joints, mocap), sorted
    geom_names : list of G str
    geom_body : (G,) int64
    geom_kind : (G,) int64, index into GEOM_KINDS
    geom_size : (G, 3) MuJoCo's geom_size, metres
    geom_pos, geom_quat : (G, 3), (G, 4) w x y z: pose in the body's frame
    geom_rgba : (G, 4) float in [0, 1]: the MJCF colour (the material's when the geom has none)
    meshes : {geom index: (vertices (n, 3) metres in the geom's frame, triangles (m, 3) int)} for
        every mesh, height field and plane geom (a plane: a finite square of its drawn size)
    ellipsoids : (g,) int64 geoms ellipsim tests (ellipsoid and sphere geoms), sorted
    tendon_names : list of T str, the spatial tendons drawn (each a path of points per frame)
    tendon_width : (T,) metres; tendon_rgba : (T, 4) float in [0, 1]
    """

    name: str
    body_names: list
    body_parent: np.ndarray
    body_pos: np.ndarray
    body_quat: np.ndarray
    moving: np.ndarray
    geom_names: list
    geom_body: np.ndarray
    geom_kind: np.ndarray
    geom_size: np.ndarray
    geom_pos: np.ndarray
    geom_quat: np.ndarray
    geom_rgba: np.ndarray
    meshes: dict
    ellipsoids: np.ndarray
    tendon_names: list = dataclasses.field(default_factory=list)
    tendon_width: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0))
    tendon_rgba: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((0, 4)))

    def __post_init__(self):
        B, G = len(self.body_names), len(self.geom_names)
        _check_shapes(
            self,
            {
                "body_parent": (B,),
                "body_pos": (B, 3),
                "body_quat": (B, 4),
                "geom_body": (G,),
                "geom_kind": (G,),
                "geom_size": (G, 3),
                "geom_pos": (G, 3),
                "geom_quat": (G, 4),
                "geom_rgba": (G, 4),
                "tendon_width": (len(self.tendon_names),),
                "tendon_rgba": (len(self.tendon_names), 4),
            },
        )
        if B < 1:
            raise ValueError("SceneGeometry.body_names must hold at least the world body")
        for name, values, top in (
            ("body_parent", self.body_parent, B),
            ("moving", self.moving, B),
            ("geom_body", self.geom_body, B),
            ("ellipsoids", self.ellipsoids, G),
            ("geom_kind", self.geom_kind, len(GEOM_KINDS)),
        ):
            values = np.asarray(values)
            bad = np.flatnonzero((values < 0) | (values >= top))
            if len(bad):
                raise ValueError(f"SceneGeometry.{name}[{bad[0]}] must be in [0, {top}), got {values[bad[0]]}")
        if len(set(self.body_names)) != B or not all(self.body_names):
            raise ValueError("SceneGeometry.body_names must be unique and non-empty")


@dataclasses.dataclass
class Frames:
    """f consecutive frames of a SceneGeometry's M moving bodies and g ellipsim geoms, K contacts.

    frame : (f,) int64, frame numbers (consecutive, from 0 for the first chunk of a run)
    times : (f,) float64 seconds
    body_pos, body_quat : (f, M, 3), (f, M, 4) w x y z: pose of each moving body relative to its parent
    state : (f, g) int8, per ellipsoid or sphere geom: 0 free, 1 touching, 2 in contact (the worst over
        its pairs: capture.APART, TOUCHING, CONTACT)
    contact_frame : (K,) int64 frame number of each of MuJoCo's contacts (every geom pair type)
    contact_pos, contact_normal : (K, 3) metres, (K, 3) unit (first row of MuJoCo's contact frame)
    contact_ellipsoids : (K,) bool, the contact is on a pair ellipsim judges (mujoco.judge: an ellipsoid
        with an ellipsoid, sphere, capsule, box, cylinder, convex mesh or height field)
    contact_geoms : (K, 2) int64, the contact's two geoms; contact_dist : (K,) float64, MuJoCo's
        distance (metres, negative: penetration)
    builtin_counts : (f,) int64, pairs ellipsim judges on which MuJoCo made a contact with dist < margin
    ellipsim_counts : (f,) int64, pairs ellipsim finds in contact (signed distance < margin)
    touching_counts : (f,) int64, ellipsoid and sphere pairs ellipsim classifies exactly touching
    contact_counts : (f,) int64, all of MuJoCo's contacts
    bounds : (f, 2, 3) metres, the lower and upper corner of the bodies' bounding box in each frame
        (every geom but planes and height fields, world frame; the recording's camera frames their union)
    builtin_by_type, ellipsim_by_type : (f, T) int64, builtin_counts and ellipsim_counts per pair type
        (mujoco.judge.KEYS)
    tendon_frame_strips : (f,) int64, the tendon paths drawn at each frame (a tendon's path breaks at a
        pulley into strips); tendon_strip : (S,) int64, each strip's tendon (index into the geometry's
        tendons); tendon_strip_points : (S,) int64, its number of points; tendon_points : (Q, 3) metres,
        the strips' points in order (empty for a model without spatial tendons)
    """

    frame: np.ndarray
    times: np.ndarray
    body_pos: np.ndarray
    body_quat: np.ndarray
    state: np.ndarray
    contact_frame: np.ndarray
    contact_pos: np.ndarray
    contact_normal: np.ndarray
    contact_ellipsoids: np.ndarray
    contact_geoms: np.ndarray
    contact_dist: np.ndarray
    builtin_counts: np.ndarray
    ellipsim_counts: np.ndarray
    touching_counts: np.ndarray
    contact_counts: np.ndarray
    bounds: np.ndarray
    builtin_by_type: np.ndarray
    ellipsim_by_type: np.ndarray
    tendon_frame_strips: np.ndarray = None
    tendon_strip: np.ndarray = None
    tendon_strip_points: np.ndarray = None
    tendon_points: np.ndarray = None

    def __post_init__(self):
        f = len(self.frame)
        if self.tendon_frame_strips is None:  # no tendons drawn
            self.tendon_frame_strips = np.zeros(f, dtype=np.int64)
            self.tendon_strip = np.zeros(0, dtype=np.int64)
            self.tendon_strip_points = np.zeros(0, dtype=np.int64)
            self.tendon_points = np.zeros((0, 3))

    def __len__(self):
        return len(self.frame)

    def check(self, geometry):
        """ValueError naming the field when the shapes do not fit `geometry` or values are not finite."""
        f, M, g, K = len(self.frame), len(geometry.moving), len(geometry.ellipsoids), len(self.contact_frame)
        types = np.shape(self.builtin_by_type)[-1] if np.ndim(self.builtin_by_type) == 2 else 0
        _check_shapes(
            self,
            {
                "times": (f,),
                "body_pos": (f, M, 3),
                "body_quat": (f, M, 4),
                "state": (f, g),
                "contact_pos": (K, 3),
                "contact_normal": (K, 3),
                "contact_ellipsoids": (K,),
                "contact_geoms": (K, 2),
                "contact_dist": (K,),
                "builtin_counts": (f,),
                "ellipsim_counts": (f,),
                "touching_counts": (f,),
                "contact_counts": (f,),
                "bounds": (f, 2, 3),
                "builtin_by_type": (f, types),
                "ellipsim_by_type": (f, types),
                "tendon_frame_strips": (f,),
                "tendon_strip": (int(np.sum(self.tendon_frame_strips)),),
                "tendon_strip_points": (int(np.sum(self.tendon_frame_strips)),),
                "tendon_points": (int(np.sum(self.tendon_strip_points)), 3),
            },
        )
        if f and np.any(np.diff(self.frame) != 1):
            raise ValueError("Frames.frame must be consecutive frame numbers")
        if K and not np.isin(self.contact_frame, self.frame).all():
            bad = np.flatnonzero(~np.isin(self.contact_frame, self.frame))[0]
            raise ValueError(
                f"Frames.contact_frame[{bad}] must be one of the chunk's frames, got {self.contact_frame[bad]}"
            )
        state = np.asarray(self.state)
        bad = np.argwhere((state < 0) | (state > 2))
        if len(bad):
            raise ValueError(f"Frames.state[{bad[0][0]}, {bad[0][1]}] must be 0, 1 or 2, got {state[tuple(bad[0])]}")
        bad = np.flatnonzero(
            (np.asarray(self.tendon_strip) < 0) | (np.asarray(self.tendon_strip) >= len(geometry.tendon_names))
        )
        if len(bad):
            raise ValueError(
                f"Frames.tendon_strip[{bad[0]}] must be a tendon of the geometry, got {self.tendon_strip[bad[0]]}"
            )
        for name in (
            "times",
            "body_pos",
            "body_quat",
            "contact_pos",
            "contact_normal",
            "contact_dist",
            "bounds",
            "tendon_points",
        ):
            values = np.asarray(getattr(self, name), dtype=np.float64)
            bad = np.argwhere(~np.isfinite(values))
            if len(bad):
                index = ", ".join(str(i) for i in bad[0])
                raise ValueError(f"Frames.{name}[{index}] must be finite, got {values[tuple(bad[0])]}")


def concatenate(chunks):
    """One Frames of consecutive chunks (for tests and small runs kept in memory)."""
    if not chunks:
        raise ValueError("chunks must hold at least one Frames")
    fields = {}
    for field in dataclasses.fields(Frames):
        fields[field.name] = np.concatenate([getattr(c, field.name) for c in chunks])
    return Frames(**fields)
