"""From MuJoCo to what record.py draws and the summaries count: a model's shapes (`geometry`) and,
frame by frame, its moving bodies, MuJoCo's contacts and ellipsim's exact verdicts (`FrameBuffer`).

A FrameBuffer copies a few arrays out of mjData per frame and, once it holds a chunk of frames,
decides every candidate ellipsoid pair of all of them in one batched exact classify (sweep and
prune per frame over bounding spheres, MuJoCo's pair rules, then core.exact.classify): memory is bounded
by the chunk, whatever the number of steps.  With between=True it also finds the contacts that begin
and end between two frames (mujoco.between, on the interpolated motion), the step from one chunk into
the next included.
"""

import contextvars
import dataclasses
from concurrent.futures import ThreadPoolExecutor
from time import perf_counter

import mujoco
import numpy as np

from ..core.ellipsoids import Ellipsoids
from ..core.relation import Relation
from ..core.rotations import quaternion_product, quaternions_to_rotations
from ..mujoco.between import BetweenFrames
from ..mujoco.geoms import PairRules, ellipsoid_geoms, explicit_pairs, frame_pairs, pair_margins
from ..mujoco.judge import KEYS, judged, judged_geoms, pair_type, verdicts_at
from .trajectory import GEOM_KINDS, Frames, SceneGeometry

#: Values (float64) a FrameBuffer may hold per chunk: 2^23 = 64 MB.  Per frame it keeps 12 per
#: ellipsoid (centre, rotation) and, when recording, 7 per moving body and its parent; 500 figures
#: (7500 ellipsoids, 7500 bodies) make 59 frames a chunk, 25 figures 1024 (the most).
CHUNK_VALUES = 2**23
MAX_CHUNK_FRAMES = 1024

#: Frames per background check of the contacts between frames (FrameBuffer(background=True)): only
#: the last ones wait after the final frame (16 figures, 2000 frames: 256 hides all but ~1/8 of it;
#: shorter costs more calls).
BETWEEN_STRIDE = 256

#: A height field is drawn with at most this many samples along each side (every k-th row and column).
HFIELD_SAMPLES = 256

#: An infinite plane (size 0) is drawn as a square of this many times the model's extent
#: (mjModel.stat.extent) on a side, at least PLANE_MIN_HALF metres from its centre to an edge.
PLANE_EXTENT_FACTOR = 2.0
PLANE_MIN_HALF = 2.0

_DEFAULT_RGBA = np.array([0.5, 0.5, 0.5, 1.0], dtype=np.float32)  # MuJoCo's geom rgba when none is given
_SDF = int(mujoco.mjtGeom.mjGEOM_SDF)
_MESH = int(mujoco.mjtGeom.mjGEOM_MESH)
_HFIELD = int(mujoco.mjtGeom.mjGEOM_HFIELD)
_PLANE = int(mujoco.mjtGeom.mjGEOM_PLANE)
_NO_CONTACTS = (np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 2), dtype=np.int64), np.zeros(0))
#: the pair types of two ellipsoids or an ellipsoid and a sphere (judge.KEYS), what between.py checks
_ROUND = (0, 1)


def _reach(model, ids):
    """(g,) bounding radius of each geom grown by its share of a dynamic pair's margin: MuJoCo's
    geom_rbound plus geom_margin (opt.o_margin / 2 under override), a part in 1e9 more so that rounding
    in the sphere test never drops a pair within its margin."""
    if model.opt.enableflags & int(mujoco.mjtEnableBit.mjENBL_OVERRIDE):
        share = np.full(len(ids), 0.5 * float(model.opt.o_margin))
    else:
        share = model.geom_margin[ids]
    return (model.geom_rbound[ids] + np.maximum(share, 0.0)) * (1 + 1e-9)


def _per_frame(frame, kind, f, T):
    """(f, T) int64 counts of (frame, kind) pairs."""
    return np.bincount(frame * T + kind, minlength=f * T).reshape(f, T).astype(np.int64)


def names_of(model, kind, count, prefix):
    """Names of `count` objects of type `kind`: MuJoCo's, or prefix + index for unnamed ones
    (made unique against the named ones)."""
    names = [mujoco.mj_id2name(model, kind, k) or "" for k in range(count)]
    taken = set(names)
    for k, name in enumerate(names):
        if not name:
            name = f"{prefix}{k}"
            while name in taken:
                name += "_"
            names[k] = name
            taken.add(name)
    return names


@dataclasses.dataclass(frozen=True)
class ModelNames:
    """A model's geom and body names as reports and recordings show them (names_of: MuJoCo's, or
    geom{i} / body{i}; body 0 is "world"), built once per model by `of`.

    geoms : (ngeom,) list of str; bodies : (nbody,) list of str; geom_body : (ngeom,) int64, each
    geom's body
    """

    geoms: list
    bodies: list
    geom_body: np.ndarray

    @classmethod
    def of(cls, model):
        bodies = names_of(model, mujoco.mjtObj.mjOBJ_BODY, model.nbody, "body")
        bodies[0] = "world"
        geoms = names_of(model, mujoco.mjtObj.mjOBJ_GEOM, model.ngeom, "geom")
        return cls(geoms, bodies, model.geom_bodyid.astype(np.int64))


def geometry(model, name, names=None):
    """SceneGeometry of `model`, a MuJoCo model, called `name`; names : its ModelNames (built when None)."""
    names = ModelNames.of(model) if names is None else names
    moving = np.flatnonzero((model.body_jntnum > 0) | (model.body_mocapid >= 0)).astype(np.int64)
    rgba = model.geom_rgba.astype(np.float64).copy()
    material = model.geom_matid
    # MuJoCo draws a geom with its material's colour when the geom's own is the default (mjv_updateScene),
    # and its texture modulates that colour: the texture's mean colour stands for it (a checker floor)
    use_material = (material >= 0) & (model.geom_rgba == _DEFAULT_RGBA).all(axis=1)
    rgba[use_material] = model.mat_rgba[material[use_material]]
    textured = material >= 0
    rgba[textured, :3] *= texture_colors(model)[material[textured]]
    kind = model.geom_type.astype(np.int64).copy()
    meshes = {}
    for g in range(model.ngeom):
        t, data_id = int(model.geom_type[g]), int(model.geom_dataid[g])
        if t in (_MESH, _SDF) and data_id >= 0:
            kind[g] = _MESH
            meshes[g] = _mesh(model, data_id)
        elif t == _HFIELD and data_id >= 0:
            meshes[g] = _hfield(model, data_id)
        elif t == _PLANE:
            meshes[g] = _plane(model, model.geom_size[g])
    drawable = kind < len(GEOM_KINDS)
    kind[~drawable] = _MESH  # an SDF without a mesh: listed as a mesh, drawn as nothing
    ids, _, _ = ellipsoid_geoms(model)
    tendons = spatial_tendons(model)
    tendon_rgba = model.tendon_rgba[tendons].astype(np.float64).copy()
    tendon_mat = model.tendon_matid[tendons]
    use_material = (tendon_mat >= 0) & (model.tendon_rgba[tendons] == _DEFAULT_RGBA).all(axis=1)
    tendon_rgba[use_material] = model.mat_rgba[tendon_mat[use_material]]
    return SceneGeometry(
        name=name,
        body_names=list(names.bodies),
        body_parent=model.body_parentid.astype(np.int64),
        body_pos=model.body_pos.copy(),
        body_quat=model.body_quat.copy(),
        moving=moving,
        geom_names=list(names.geoms),
        geom_body=names.geom_body.copy(),
        geom_kind=kind,
        geom_size=model.geom_size.copy(),
        geom_pos=model.geom_pos.copy(),
        geom_quat=model.geom_quat.copy(),
        geom_rgba=rgba,
        meshes=meshes,
        ellipsoids=ids.astype(np.int64),
        tendon_names=[names_of(model, mujoco.mjtObj.mjOBJ_TENDON, model.ntendon, "tendon")[t] for t in tendons],
        tendon_width=model.tendon_width[tendons].astype(np.float64),
        tendon_rgba=tendon_rgba,
    )


def texture_colors(model):
    """(nmat, 3): each material's RGB texture's mean colour in [0, 1] (1, 1, 1 without one): how the
    recording colours a textured geom, its material's colour times this (MuJoCo's rendering modulates
    the colour by the texture)."""
    out = np.ones((model.nmat, 3))
    role = int(mujoco.mjtTextureRole.mjTEXROLE_RGB)
    for m in range(model.nmat):
        t = int(model.mat_texid[m, role]) if model.mat_texid.ndim == 2 else int(model.mat_texid[m])
        if t < 0:
            continue
        adr, n = int(model.tex_adr[t]), int(model.tex_width[t] * model.tex_height[t])
        channels = int(model.tex_nchannel[t])
        texels = model.tex_data[adr : adr + n * channels].reshape(n, channels).astype(np.float64) / 255.0
        out[m] = texels[:, :3].mean(axis=0) if channels >= 3 else texels[:, :1].mean()
    return out


def spatial_tendons(model):
    """(T,) int64: the tendons with a path in space (sites, wrapping geoms, pulleys), not the fixed ones
    (a linear combination of joints): the ones a recording draws."""
    if model.ntendon == 0:
        return np.zeros(0, dtype=np.int64)
    first = model.wrap_type[model.tendon_adr]
    return np.flatnonzero((model.tendon_num > 0) & (first != int(mujoco.mjtWrap.mjWRAP_JOINT))).astype(np.int64)


def tendon_strips(model, data, tendons):
    """The paths of `tendons` at data's state (after mj_fwdPosition or mj_tendon): (strip's tendon (S,),
    points per strip (S,), points (Q, 3)); a path breaks at a pulley into strips."""
    points = data.wrap_xpos.reshape(-1, 3)
    objects = data.wrap_obj.reshape(-1)
    strip, count, out = [], [], []
    for k, t in enumerate(tendons):
        adr, num = int(data.ten_wrapadr[t]), int(data.ten_wrapnum[t])
        run = []
        for j in range(adr, adr + num):
            if objects[j] == -2:  # a pulley: the path goes on from the next point
                if len(run) >= 2:
                    strip.append(k), count.append(len(run)), out.append(np.array(run))
                run = []
            else:
                run.append(points[j])
        if len(run) >= 2:
            strip.append(k), count.append(len(run)), out.append(np.array(run))
    if not strip:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64), np.zeros((0, 3))
    return np.array(strip, dtype=np.int64), np.array(count, dtype=np.int64), np.concatenate(out)


def _mesh(model, m):
    """Vertices (n, 3) and triangles (k, 3) of mesh m, in the frame of the geoms that use it."""
    v0, nv = model.mesh_vertadr[m], model.mesh_vertnum[m]
    f0, nf = model.mesh_faceadr[m], model.mesh_facenum[m]
    return model.mesh_vert[v0 : v0 + nv].astype(np.float64), model.mesh_face[f0 : f0 + nf].astype(np.int64)


def _hfield(model, h):
    """Height field h as a triangle grid in its geom's frame (MuJoCo: x, y over [-size0, size0] x
    [-size1, size1], z = data * size2, rows along y), at most HFIELD_SAMPLES a side."""
    nrow, ncol = int(model.hfield_nrow[h]), int(model.hfield_ncol[h])
    sx, sy, sz, _ = model.hfield_size[h]
    adr = model.hfield_adr[h]
    z = model.hfield_data[adr : adr + nrow * ncol].reshape(nrow, ncol).astype(np.float64)
    rows = np.unique(np.linspace(0, nrow - 1, min(nrow, HFIELD_SAMPLES)).round().astype(int))
    cols = np.unique(np.linspace(0, ncol - 1, min(ncol, HFIELD_SAMPLES)).round().astype(int))
    x = (2 * cols / max(ncol - 1, 1) - 1) * sx
    y = (2 * rows / max(nrow - 1, 1) - 1) * sy
    X, Y = np.meshgrid(x, y)
    vertices = np.column_stack([X.ravel(), Y.ravel(), (z[np.ix_(rows, cols)] * sz).ravel()])
    r, c = len(rows), len(cols)
    k = (np.arange(r - 1)[:, None] * c + np.arange(c - 1)[None, :]).ravel()
    triangles = np.concatenate([np.column_stack([k, k + 1, k + c + 1]), np.column_stack([k, k + c + 1, k + c])])
    return vertices, triangles


def _plane(model, size):
    """A plane as two triangles in its geom's frame: its size, or a square around it when infinite."""
    half = max(PLANE_EXTENT_FACTOR * float(model.stat.extent), PLANE_MIN_HALF)
    sx = size[0] if size[0] > 0 else half
    sy = size[1] if size[1] > 0 else half
    vertices = np.array([[-sx, -sy, 0.0], [sx, -sy, 0.0], [sx, sy, 0.0], [-sx, sy, 0.0]])
    return vertices, np.array([[0, 1, 2], [0, 2, 3]])


#: Chunk.contact's codes: apart, exactly touching (margin 0, ellipsoid and sphere pairs: classify), in
#: contact (signed distance < margin: judge.py's rule)
APART, TOUCHING, CONTACT = 0, 1, 2


@dataclasses.dataclass
class Chunk:
    """What FrameBuffer.flush returns: the Frames, and every candidate pair it decided.

    pairs : (P, 3) int64 (frame number, i, j), i < j indices into the buffer's judged geoms `ids`
    kind : (P,) int8 pair type (index into mujoco.judge.KEYS)
    contact : (P,) int8 APART, TOUCHING or CONTACT (signed distance < the pair's margin)
    dist : (P,) float64 signed distance where measured (pairs in contact when depth was asked for,
        capsule, box and cylinder pairs, ellipsoid pairs with a margin), else nan
    depth : (P,) float64 max(0, -dist) of the pairs in contact (metres; nan for the others), or None
        when not asked for
    centers : (f, g, 3) the judged geoms' centres, metres (a view of the buffer: copy to keep)
    rotations : (f, g, 3, 3) their rotations (a view of the buffer)
    events : between.Events of the steps into and within these frames (pairs index the buffer's
        ellipsoid and sphere geoms `ellipsoid_ids`), or None when not asked for (or checked in the
        background: FrameBuffer.collect)
    """

    frames: Frames
    pairs: np.ndarray
    kind: np.ndarray
    contact: np.ndarray
    dist: np.ndarray
    depth: np.ndarray
    centers: np.ndarray
    events: object = None
    rotations: np.ndarray = None


class FrameBuffer:
    """Frames of one (model, data), collected with `add` after each step or pose and decided in
    chunks with `flush`.

    Every pair of a type ellipsim judges (mujoco.judge: an ellipsoid with an ellipsoid, sphere, capsule,
    box or cylinder) that MuJoCo's rules allow and whose bounding spheres come within the pair's margin,
    and every <pair> element of such a type, is judged with the one margin rule (judge.py): in contact
    when its signed distance is below its margin; MuJoCo's side counts its contacts with dist < margin.

    record : also keep the moving bodies' poses and every contact's position and normal (for a
        recording); without it a frame costs only the judged geoms' poses and MuJoCo's contacts.
    depth : flush also measures the signed distance of the pairs in contact (Chunk.depth).
    between : flush also finds the contacts that begin and end between two frames (between.Events of
        the ellipsoid and sphere geoms, the step from the previous chunk included); between_seconds
        accumulates their wall time.
    background : with between, the check runs on a thread of the buffer's own every BETWEEN_STRIDE
        frames, while the next frames are collected (its kernels release the GIL; the touching pairs
        at the frames are found by its own exact classify): Chunk.events is None, `collect` returns
        the Events found so far, `close` waits for the last ones and ends the thread.
    """

    def __init__(self, model, *, record=False, depth=False, between=False, background=False):
        self.model = model
        self.ids = judged_geoms(model)
        self.rules = PairRules(model, self.ids)
        self.ellipsoid_ids, self.radii, ellipsoid_rules = ellipsoid_geoms(model)
        self.round_at = np.searchsorted(self.ids, self.ellipsoid_ids)  # the ellipsoid and sphere geoms in ids
        self._is_round = np.zeros(len(self.ids), dtype=bool)
        self._is_round[self.round_at] = True
        self.rho = _reach(model, self.ids)
        explicit = explicit_pairs(model)
        self.explicit = np.searchsorted(self.ids, explicit).reshape(-1, 2)  # <pair> elements, positions in ids
        self._explicit_keys = np.sort(self.explicit[:, 0].astype(np.int64) * len(self.ids) + self.explicit[:, 1])
        self.record, self.depth = record, depth
        self.moving = np.flatnonzero((model.body_jntnum > 0) | (model.body_mocapid >= 0))
        parent = model.body_parentid[self.moving]
        self.posed = np.union1d(self.moving, parent) if record else np.zeros(0, dtype=np.intp)
        self._at_moving = np.searchsorted(self.posed, self.moving)
        self._at_parent = np.searchsorted(self.posed, parent)
        g, n = len(self.ids), len(self.posed)
        per_frame = 12 * g + 7 * n + 8
        self.capacity = int(min(MAX_CHUNK_FRAMES, max(1, CHUNK_VALUES // per_frame)))
        self.centers = np.empty((self.capacity, g, 3))
        self.rotations = np.empty((self.capacity, g, 9))
        self.xpos = np.empty((self.capacity, n, 3))
        self.xquat = np.empty((self.capacity, n, 4))
        self.times = np.empty(self.capacity)
        self.bounds = np.empty((self.capacity, 2, 3))
        solid = (model.geom_type != _PLANE) & (model.geom_type != _HFIELD)
        self._solid = np.flatnonzero(solid) if solid.any() else np.arange(model.ngeom)
        self._rbound = model.geom_rbound[self._solid][:, None]
        self.ncon = np.empty(self.capacity, dtype=np.int64)
        self.contacts = []  # per frame: (pos (k, 3), normal (k, 3), geom (k, 2), dist (k,)); pos, normal when recording
        self.tendons = spatial_tendons(model) if record else np.zeros(0, dtype=np.int64)
        self.tendon_paths = []  # per frame when recording a model with spatial tendons: tendon_strips()
        self.n = 0
        self.next_frame = 0
        self.between = BetweenFrames(self.radii, ellipsoid_rules) if between else None
        self.between_seconds = 0.0
        self._worker = ThreadPoolExecutor(1, thread_name_prefix="ellipsim-between") if between and background else None
        self._futures = []  # the background checks, in order
        self._sent = 0  # frames of the buffer handed to them

    def add(self, data, time, contacts=None):
        """Copy the current frame out of `data` (after mj_step, mj_forward or collision); True when
        the buffer is full (flush it before the next add).  contacts : optional (geom (k, 2), dist (k,),
        pos (k, 3), normal (k, 3)), another engine's contacts to take instead of data.contact (MuJoCo
        Warp's of one world)."""
        k = self.n
        self.centers[k] = data.geom_xpos[self.ids]
        self.rotations[k] = data.geom_xmat[self.ids]
        self.times[k] = time
        if len(self._solid):
            at = data.geom_xpos[self._solid]
            self.bounds[k, 0] = (at - self._rbound).min(axis=0)
            self.bounds[k, 1] = (at + self._rbound).max(axis=0)
        else:  # a model without geoms: its bodies
            self.bounds[k, 0], self.bounds[k, 1] = data.xpos.min(axis=0), data.xpos.max(axis=0)
        if contacts is not None:
            geom, dist, pos, normal = (np.asarray(x) for x in contacts)
            ncon = len(geom)
        else:
            ncon = data.ncon
            if ncon:
                con = data.contact
                geom, dist, pos, normal = con.geom, con.dist, con.pos, con.frame[:, :3]
        self.ncon[k] = ncon
        if ncon:
            kept = (pos.copy(), normal.copy()) if self.record else (None, None)
            self.contacts.append((*kept, geom.astype(np.int64), dist.astype(np.float64)))
        else:
            self.contacts.append(_NO_CONTACTS)
        if self.record:
            self.xpos[k] = data.xpos[self.posed]
            self.xquat[k] = data.xquat[self.posed]
            if len(self.tendons):
                self.tendon_paths.append(tendon_strips(self.model, data, self.tendons))
        self.n += 1
        if self._worker is not None and self.n - self._sent >= BETWEEN_STRIDE:
            self._submit()
        return self.n == self.capacity

    def flush(self):
        """The Chunk of the frames added since the last flush (None if there are none)."""
        f, g = self.n, len(self.ids)
        if f == 0:
            return None
        model = self.model
        first = self.next_frame
        centers = self.centers[:f]
        rotations = self.rotations[:f].reshape(f, g, 3, 3)
        pairs = self._pairs(centers)
        pf, i, j = pairs.T
        geoms = np.column_stack([self.ids[i], self.ids[j]])
        T = len(KEYS)
        margin = pair_margins(model, geoms)
        built = self._round(pairs)
        # the poses verdicts_at reads: every pair's, or only the capsule, box and cylinder pairs' when the
        # ellipsoid and sphere pairs come built
        rows = np.arange(len(pairs)) if built is None else np.flatnonzero(~built[2])
        xpos, xmat = np.empty((len(pairs), 2, 3)), np.empty((len(pairs), 2, 3, 3))
        xpos[rows, 0], xpos[rows, 1] = centers[pf[rows], i[rows]], centers[pf[rows], j[rows]]
        xmat[rows, 0], xmat[rows, 1] = rotations[pf[rows], i[rows]], rotations[pf[rows], j[rows]]
        built = None if built is None else built[:2]
        v = verdicts_at(model, geoms, xpos, xmat, margin, measure_within=self.depth, ellipsoids=built)
        contact = np.where(v.within, CONTACT, np.where(v.relation == Relation.TOUCHING, TOUCHING, APART)).astype(
            np.int8
        )
        depth = np.where(contact == CONTACT, np.maximum(-v.dist, 0.0), np.nan) if self.depth else None
        state = np.zeros((f, g), dtype=np.int8)
        np.maximum.at(state, (pf, i), contact)
        np.maximum.at(state, (pf, j), contact)
        ours = _per_frame(pf[contact == CONTACT], v.kind[contact == CONTACT], f, T)
        touching = np.bincount(pf[contact == TOUCHING], minlength=f)
        theirs, judged_contact = self._mujoco_counts(f, T)
        frame = first + np.arange(f, dtype=np.int64)
        body_pos, body_quat = self._relative_poses(f)
        counts = np.array([len(c[3]) for c in self.contacts], dtype=np.int64)
        contact_frame = np.repeat(frame, counts)
        contact_geoms = np.concatenate([c[2] for c in self.contacts]).reshape(-1, 2).astype(np.int64)
        contact_dist = np.concatenate([c[3] for c in self.contacts]).astype(np.float64)
        if self.record:
            contact_pos = np.concatenate([c[0] for c in self.contacts]).reshape(-1, 3)
            contact_normal = np.concatenate([c[1] for c in self.contacts]).reshape(-1, 3)
        else:
            contact_frame = np.zeros(0, dtype=np.int64)
            contact_pos = contact_normal = np.zeros((0, 3))
            judged_contact = np.zeros(0, dtype=bool)
            contact_geoms, contact_dist = np.zeros((0, 2), dtype=np.int64), np.zeros(0)
        frames = Frames(
            frame=frame,
            times=self.times[:f].copy(),
            body_pos=body_pos,
            body_quat=body_quat,
            state=state[:, self.round_at],
            contact_frame=contact_frame,
            contact_pos=contact_pos,
            contact_normal=contact_normal,
            contact_ellipsoids=judged_contact,
            contact_geoms=contact_geoms,
            contact_dist=contact_dist,
            builtin_counts=theirs.sum(axis=1),
            ellipsim_counts=ours.sum(axis=1),
            touching_counts=touching.astype(np.int64),
            contact_counts=self.ncon[:f].copy(),
            bounds=self.bounds[:f].copy(),
            builtin_by_type=theirs,
            ellipsim_by_type=ours,
            **self._tendon_fields(f),
        )
        out_pairs = pairs.copy()
        out_pairs[:, 0] += first
        events = None
        if self.between is not None:
            if self._worker is None:
                # pairs of the geoms themselves touching or overlapping at a frame (not a between event)
                round_pairs = np.isin(v.kind, _ROUND) & (v.relation != Relation.SEPARATED)
                ei = np.searchsorted(self.round_at, i[round_pairs])
                ej = np.searchsorted(self.round_at, j[round_pairs])
                events = self._check(
                    frame,
                    frames.times,
                    centers[:, self.round_at],
                    rotations[:, self.round_at],
                    np.column_stack([out_pairs[round_pairs, 0], ei, ej]),
                )
            else:
                self._submit()
        chunk = Chunk(frames, out_pairs, v.kind, contact, v.dist, depth, centers, events, rotations)
        self.n = self._sent = 0
        self.next_frame += f
        self.contacts = []
        self.tendon_paths = []
        return chunk

    def _tendon_fields(self, f):
        """Frames' tendon fields of the f frames held (none without spatial tendons or a recording)."""
        if not self.tendon_paths:
            return {}
        strip, count, points = (np.concatenate([p[k] for p in self.tendon_paths]) for k in range(3))
        return {
            "tendon_frame_strips": np.array([len(p[0]) for p in self.tendon_paths], dtype=np.int64),
            "tendon_strip": strip.astype(np.int64),
            "tendon_strip_points": count.astype(np.int64),
            "tendon_points": points.reshape(-1, 3),
        }

    def _round(self, pairs):
        """(a, b, round (P,) bool): the Ellipsoids of the ellipsoid and sphere pairs among `pairs` (frame, i,
        j), in their order, each pose validated once for all its pairs, and which pairs they are; None when
        validating per pair is cheaper (few pairs a frame: verdicts_at builds them)."""
        f, g = self.n, len(self.ids)
        pf, i, j = pairs.T
        is_round = self._is_round[i] & self._is_round[j]
        at = np.flatnonzero(is_round)
        ge = len(self.round_at)
        if 2 * len(at) <= f * ge:
            return None
        if ge == g:  # every judged geom an ellipsoid or sphere (figures): the buffer itself, no copy
            k = i[at], j[at]
            centers, rotations = self.centers[:f].reshape(-1, 3), self.rotations[:f].reshape(-1, 3, 3)
        else:
            k = np.searchsorted(self.round_at, i[at]), np.searchsorted(self.round_at, j[at])
            centers = self.centers[:f][:, self.round_at].reshape(-1, 3)
            rotations = self.rotations[:f].reshape(f, g, 3, 3)[:, self.round_at].reshape(-1, 3, 3)
        every = Ellipsoids(centers, rotations, np.broadcast_to(self.radii, (f, ge, 3)).reshape(-1, 3))
        return every[pf[at] * ge + k[0]], every[pf[at] * ge + k[1]], is_round  # indexing does not validate again

    def _pairs(self, centers):
        """(P, 3) int64 (frame, i, j), i < j into ids: the frames' judged pairs within reach (MuJoCo's rules,
        bounding spheres grown by the geoms' margins) and the <pair> elements, each once, sorted."""
        f, g = centers.shape[:2]
        found = frame_pairs(centers, self.rho, self.rules)
        if len(found):
            found = found[judged(self.model, self.ids[found[:, 1]], self.ids[found[:, 2]])]
        if len(self.explicit):
            key = found[:, 1] * g + found[:, 2]
            found = found[~np.isin(key, self._explicit_keys)]  # MuJoCo collides a named pair as its <pair> only
            named = np.column_stack(
                [np.repeat(np.arange(f), len(self.explicit)), np.tile(self.explicit, (f, 1))]
            ).astype(np.int64)
            found = np.concatenate([found, named])
            found = found[np.lexsort((found[:, 2], found[:, 1], found[:, 0]))]
        return found.reshape(-1, 3).astype(np.int64)

    def _mujoco_counts(self, f, T):
        """MuJoCo's side of the frames: ((f, T) int64 pairs of each judged type with a contact of dist <
        margin, each pair once; (K,) bool, each contact is on a judged pair)."""
        counts = np.array([len(c[3]) for c in self.contacts], dtype=np.int64)
        geom = np.concatenate([c[2] for c in self.contacts]).reshape(-1, 2).astype(np.int64)
        dist = np.concatenate([c[3] for c in self.contacts]).astype(np.float64)
        kind = pair_type(self.model, geom[:, 0], geom[:, 1]) if len(geom) else np.zeros(0, dtype=np.int8)
        judged_contact = kind >= 0
        out = np.zeros((f, T), dtype=np.int64)
        at = np.flatnonzero(judged_contact)
        if len(at):
            active = at[dist[at] < pair_margins(self.model, geom[at])]
            frame = np.repeat(np.arange(f), counts)[active]
            lo, hi = np.minimum(geom[active, 0], geom[active, 1]), np.maximum(geom[active, 0], geom[active, 1])
            key = (frame * self.model.ngeom + lo) * self.model.ngeom + hi
            _, first = np.unique(key, return_index=True)  # a pair once, however many contacts MuJoCo made
            np.add.at(out, (frame[first], kind[active][first]), 1)
        return out, judged_contact

    def _check(self, *args):
        """between.check, timed (on the buffer's thread with background=True: one at a time)."""
        t0 = perf_counter()
        events = self.between.check(*args)
        self.between_seconds += perf_counter() - t0
        return events

    def _submit(self):
        """Hand the frames added since the last hand-over to the background check (copies of the
        ellipsoid and sphere geoms' poses: the buffer fills up again meanwhile)."""
        lo, hi, g = self._sent, self.n, len(self.ids)
        if hi > lo:
            frames = self.next_frame + np.arange(lo, hi, dtype=np.int64)
            rotations = self.rotations[lo:hi].reshape(hi - lo, g, 3, 3)[:, self.round_at]
            args = (frames, self.times[lo:hi].copy(), self.centers[lo:hi, self.round_at], rotations)
            # in the caller's context: a core.threads.limit around the caller holds for the check too
            self._futures.append(self._worker.submit(contextvars.copy_context().run, self._check, *args))
            self._sent = hi

    def collect(self, wait=False):
        """The between.Events the background checks found since the last collect, in frame order: the
        finished ones, or (wait) all those submitted."""
        found = []
        while self._futures and (wait or self._futures[0].done()):
            found.append(self._futures.pop(0).result())
        return found

    def close(self):
        """Wait for the background checks submitted so far and end their thread (no-op without)."""
        if self._worker is not None:
            self._worker.shutdown(wait=True)
            self._worker = None

    def _relative_poses(self, f):
        """(f, M, 3), (f, M, 4): each moving body's pose relative to its parent, from world poses."""
        M = len(self.moving)
        if not self.record or M == 0:
            return np.zeros((f, M if self.record else 0, 3)), np.zeros((f, M if self.record else 0, 4))
        xpos, xquat = self.xpos[:f], self.xquat[:f]
        child_pos, child_quat = xpos[:, self._at_moving], xquat[:, self._at_moving]
        parent_pos, parent_quat = xpos[:, self._at_parent], xquat[:, self._at_parent]
        parent_rot = quaternions_to_rotations(parent_quat)  # (f, M, 3, 3)
        pos = np.einsum("fmji,fmj->fmi", parent_rot, child_pos - parent_pos)  # R_p^T (x - x_p)
        conj = parent_quat * np.array([1.0, -1.0, -1.0, -1.0])
        quat = quaternion_product(conj, child_quat)
        quat /= np.linalg.norm(quat, axis=-1, keepdims=True)
        return pos, quat


def describe_events(events, ids, names):
    """Contacts between frames (between.Events over the ellipsoid geoms `ids`) as dicts for reports,
    named by `names` (ModelNames): {geoms, bodies, frame, t_begin, t_end (seconds), status, point
    (metres)}, in the events' order."""
    out = []
    for e in range(len(events)):
        g1, g2 = (int(ids[k]) for k in events.pair[e])
        out.append(
            {
                "geoms": [names.geoms[g1], names.geoms[g2]],
                "bodies": [names.bodies[names.geom_body[g1]], names.bodies[names.geom_body[g2]]],
                "frame": int(events.frame[e]),
                "t_begin": float(events.begin[e]),
                "t_end": float(events.end[e]),
                "status": events.status_name(e),
                "point": [float(x) for x in events.point[e]],
            }
        )
    return out


def event_line(d):
    """One line of text for an event dict of describe_events."""
    where = f"geoms {d['geoms'][0]} / {d['geoms'][1]}"
    if d["bodies"][0] != d["geoms"][0] or d["bodies"][1] != d["geoms"][1]:
        where += f" (bodies {d['bodies'][0]} / {d['bodies'][1]})"
    return (
        f"frames {d['frame']}-{d['frame'] + 1}: {where} touch from {d['t_begin']:.6g} s to {d['t_end']:.6g} s "
        f"({d['status']})"
    )


def between_lines(events, candidates, seconds, show, unit):
    """The report's lines of contacts between frames (or steps: `unit`): event dicts of describe_events
    (with "step" for "frame" when unit is steps), a count, then a line each, `show` at most;
    candidates : pairs time_of_impact decided; seconds : their check's wall time, or None."""
    timing = f" {seconds:.2f} s" if seconds is not None else ""
    lines = [
        f"  contacts between {unit} (separated at two consecutive {unit}, touching in between on the interpolated "
        f"motion): {len(events)}; time_of_impact on {candidates} pairs{timing}"
    ]
    for d in events[:show]:
        lines.append(
            "    " + event_line(d if "frame" in d else {**d, "frame": d["step"]}).replace("frames ", f"{unit} ", 1)
        )
    if len(events) > show:
        lines.append(f"    ... and {len(events) - show} more (--show N, or --json)")
    return lines


def record_events(recorder, events, ids, names):
    """Send contacts between frames (between.Events over the ellipsoid geoms `ids`, named by
    `names`) to a record.Recorder as markers: the contact point, labelled with the geoms, and a log line."""
    if events is None or len(events) == 0:
        return
    described = describe_events(events, ids, names)
    recorder.write_events(
        events.frame,
        events.begin,
        events.until,
        events.point,
        [f"{d['geoms'][0]} / {d['geoms'][1]}" for d in described],
        ["contact between " + event_line(d) for d in described],
    )
