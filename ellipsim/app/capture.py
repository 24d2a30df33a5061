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

from ..core.distance.ellipsoid_pair import signed_distance
from ..core.ellipsoids import Ellipsoids
from ..core.exact.classify import classify
from ..core.relation import Relation
from ..core.rotations import quaternion_product, quaternions_to_rotations
from ..mujoco.between import BetweenFrames
from ..mujoco.geoms import ellipsoid_geoms, frame_pairs
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
_NO_CONTACTS = (
    np.zeros((0, 3)),
    np.zeros((0, 3)),
    np.zeros(0, dtype=bool),
    np.zeros((0, 2), dtype=np.int32),
    np.zeros(0),
)


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
    # MuJoCo draws a geom with its material's colour when the geom's own is the default (mjv_updateScene)
    use_material = (material >= 0) & (model.geom_rgba == _DEFAULT_RGBA).all(axis=1)
    rgba[use_material] = model.mat_rgba[material[use_material]]
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
    )


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


@dataclasses.dataclass
class Chunk:
    """What FrameBuffer.flush returns: the Frames, and every candidate ellipsoid pair it decided.

    pairs : (P, 3) int64 (frame number, i, j), i < j indices into the g ellipsoid geoms
    relation : (P,) int8 Relation
    depth : (P,) float64 penetration depth of overlapping pairs (metres, >= 0; nan for the others),
        or None when not asked for
    centers : (f, g, 3) the ellipsoids' centres, metres (a view of the buffer: copy to keep)
    rotations : (f, g, 3, 3) their rotations (a view of the buffer)
    events : between.Events of the steps into and within these frames (pairs index the g ellipsoid
        geoms), or None when not asked for (or checked in the background: FrameBuffer.collect)
    """

    frames: Frames
    pairs: np.ndarray
    relation: np.ndarray
    depth: np.ndarray
    centers: np.ndarray
    events: object = None
    rotations: np.ndarray = None


class FrameBuffer:
    """Frames of one (model, data), collected with `add` after each step or pose and decided in
    chunks with `flush`.

    record : also keep the moving bodies' poses and every contact's position and normal (for a
        recording); without it a frame costs only the ellipsoids' poses and contact counts.
    depth : flush also measures the penetration depth of overlapping pairs (core.signed_distance).
    between : flush also finds the contacts that begin and end between two frames (between.Events,
        the step from the previous chunk included); between_seconds accumulates their wall time.
    background : with between, the check runs on a thread of the buffer's own every BETWEEN_STRIDE
        frames, while the next frames are collected (its kernels release the GIL; the touching pairs
        at the frames are found by its own exact classify): Chunk.events is None, `collect` returns
        the Events found so far, `close` waits for the last ones and ends the thread.
    """

    def __init__(self, model, *, record=False, depth=False, between=False, background=False):
        self.model = model
        self.ids, self.radii, self.rules = ellipsoid_geoms(model)
        self.tested = np.zeros(model.ngeom, dtype=bool)
        self.tested[self.ids] = True
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
        self.builtin = np.empty(self.capacity, dtype=np.int64)
        self.bounds = np.empty((self.capacity, 2, 3))
        solid = (model.geom_type != _PLANE) & (model.geom_type != _HFIELD)
        self._solid = np.flatnonzero(solid) if solid.any() else np.arange(model.ngeom)
        self._rbound = model.geom_rbound[self._solid][:, None]
        self.ncon = np.empty(self.capacity, dtype=np.int64)
        self.contacts = []  # per frame: (pos (k, 3), normal (k, 3), both tested (k,))
        self.n = 0
        self.next_frame = 0
        self.between = BetweenFrames(self.radii, self.rules) if between else None
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
        elif data.ncon:
            con = data.contact
            geom, dist, pos, normal = con.geom, con.dist, con.pos, con.frame[:, :3]
        ncon = len(geom) if contacts is not None else data.ncon
        self.ncon[k] = ncon
        if ncon:
            both = self.tested[geom].all(axis=1)
            self.builtin[k] = np.count_nonzero(both)
            if self.record:
                self.contacts.append((pos.copy(), normal.copy(), both, geom.copy(), dist.copy()))
        else:
            self.builtin[k] = 0
            if self.record:
                self.contacts.append(_NO_CONTACTS)
        if self.record:
            self.xpos[k] = data.xpos[self.posed]
            self.xquat[k] = data.xquat[self.posed]
        self.n += 1
        if self._worker is not None and self.n - self._sent >= BETWEEN_STRIDE:
            self._submit()
        return self.n == self.capacity

    def flush(self):
        """The Chunk of the frames added since the last flush (None if there are none)."""
        f, g = self.n, len(self.ids)
        if f == 0:
            return None
        first = self.next_frame
        centers = self.centers[:f]
        rotations = self.rotations[:f].reshape(f, g, 3, 3)
        pairs = frame_pairs(centers, self.radii, self.rules)
        state = np.zeros((f, g), dtype=np.int8)
        depth = None
        if len(pairs):
            pf, i, j = pairs.T
            if 2 * len(pairs) > f * g:  # validating every pose once is cheaper than both sides of every pair
                every = Ellipsoids(
                    centers.reshape(-1, 3),
                    rotations.reshape(-1, 3, 3),
                    np.broadcast_to(self.radii, (f, g, 3)).reshape(-1, 3),
                )
                a, b = every[pf * g + i], every[pf * g + j]  # indexing a batch does not validate again
            else:
                a = Ellipsoids(centers[pf, i], rotations[pf, i], self.radii[i])
                b = Ellipsoids(centers[pf, j], rotations[pf, j], self.radii[j])
            relation = classify(a, b)
            np.maximum.at(state, (pf, i), relation)
            np.maximum.at(state, (pf, j), relation)
            if self.depth:
                depth = np.full(len(pairs), np.nan)
                over = np.flatnonzero(relation == Relation.OVERLAPPING)
                if len(over):
                    dist = signed_distance(a[over], b[over])[0]
                    depth[over] = np.maximum(-dist, 0.0)
        else:
            relation = np.zeros(0, dtype=np.int8)
            pf = np.zeros(0, dtype=np.int64)
            if self.depth:
                depth = np.zeros(0)
        overlapping = np.bincount(pf[relation == Relation.OVERLAPPING], minlength=f)
        touching = np.bincount(pf[relation == Relation.TOUCHING], minlength=f)
        frame = first + np.arange(f, dtype=np.int64)
        body_pos, body_quat = self._relative_poses(f)
        if self.record:
            counts = np.array([len(c[0]) for c in self.contacts], dtype=np.int64)
            contact_frame = np.repeat(frame, counts)
            contact_pos = np.concatenate([c[0] for c in self.contacts]).reshape(-1, 3)
            contact_normal = np.concatenate([c[1] for c in self.contacts]).reshape(-1, 3)
            contact_ellipsoids = np.concatenate([c[2] for c in self.contacts]).astype(bool)
            contact_geoms = np.concatenate([c[3] for c in self.contacts]).reshape(-1, 2).astype(np.int64)
            contact_dist = np.concatenate([c[4] for c in self.contacts]).astype(np.float64)
        else:
            contact_frame = np.zeros(0, dtype=np.int64)
            contact_pos = contact_normal = np.zeros((0, 3))
            contact_ellipsoids = np.zeros(0, dtype=bool)
            contact_geoms, contact_dist = np.zeros((0, 2), dtype=np.int64), np.zeros(0)
        frames = Frames(
            frame=frame,
            times=self.times[:f].copy(),
            body_pos=body_pos,
            body_quat=body_quat,
            state=state,
            contact_frame=contact_frame,
            contact_pos=contact_pos,
            contact_normal=contact_normal,
            contact_ellipsoids=contact_ellipsoids,
            contact_geoms=contact_geoms,
            contact_dist=contact_dist,
            builtin_counts=self.builtin[:f].copy(),
            ellipsim_counts=overlapping.astype(np.int64),
            touching_counts=touching.astype(np.int64),
            contact_counts=self.ncon[:f].copy(),
            bounds=self.bounds[:f].copy(),
        )
        out_pairs = pairs.copy()
        out_pairs[:, 0] += first
        events = None
        if self.between is not None:
            if self._worker is None:
                events = self._check(frame, frames.times, centers, rotations, out_pairs[relation != Relation.SEPARATED])
            else:
                self._submit()
        chunk = Chunk(frames, out_pairs, relation, depth, centers, events, rotations)
        self.n = self._sent = 0
        self.next_frame += f
        self.contacts = []
        return chunk

    def _check(self, *args):
        """between.check, timed (on the buffer's thread with background=True: one at a time)."""
        t0 = perf_counter()
        events = self.between.check(*args)
        self.between_seconds += perf_counter() - t0
        return events

    def _submit(self):
        """Hand the frames added since the last hand-over to the background check (copies: the
        buffer fills up again meanwhile)."""
        lo, hi, g = self._sent, self.n, len(self.ids)
        if hi > lo:
            frames = self.next_frame + np.arange(lo, hi, dtype=np.int64)
            rotations = self.rotations[lo:hi].reshape(hi - lo, g, 3, 3)
            args = (frames, self.times[lo:hi].copy(), self.centers[lo:hi].copy(), rotations.copy())
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
