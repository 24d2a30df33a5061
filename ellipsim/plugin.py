"""MuJoCo integration: ellipsim inside mj_step, and a pair-by-pair validation.

    with ellipsim.plugin.attach(model, data, mode="filter") as att:   # or mode="narrowphase"
        for _ in range(1000):
            mujoco.mj_step(model, data)
    att.counters

mode "filter" installs a compiled contact filter (mjcb_contactfilter, a numba cfunc).  MuJoCo calls
it for every candidate geom pair after its broad phase, in place of the contype/conaffinity test
(engine_collision_driver.c, filterCollisionPair), so the callback first repeats that test exactly.
Ellipsoid-ellipsoid and sphere-ellipsoid pairs are then tested on ellipsoids that enclose the
bodies MuJoCo collides (each grown by half of margin + gap + 2 ccd_tolerance: GJK reports contact
once the margin-grown bodies are within ccd_tolerance), and discarded only when a separating axis
is certified (certified.separated_by_axes).  No contact MuJoCo would make is lost, so trajectories
are bit-identical.

mode "narrowphase" writes a compiled mjfCollision into MuJoCo's table mjCOLLISIONFUNC for
ellipsoid x ellipsoid and sphere x ellipsoid (where MuJoCo has mjc_Convex: GJK, then EPA), and puts
the originals back on exit.  It returns no contact for pairs certified separated beyond the margin,
else the signed distance, normal and contact point of narrowphase.signed_distance, filling the
mjPreContact as mjc_Convex does (dist, pos, normal; tangent zero: mj_setContact completes the
frame).  A pair whose Newton run does not converge goes to MuJoCo's original function, and is
counted.

The callback is process-global and may run on several threads (mujoco.rollout); it reads geom
arrays of whatever (model, data) it is given through struct offsets found at run time (mjstruct.py)
and keeps no shared mutable state: counters live in per-data arrays of a registry.
"""

import copy
import ctypes
import dataclasses
import threading

import mujoco
import numba
import numpy as np
from numba import carray, types

from . import mjstruct
from ._jit import jit
from .certified import separated_by_axes
from .narrowphase import CERTIFIED, NOT_CONVERGED, pair_signed_distance, signed_distance
from .classify import Relation, classify
from .contact import contact_scale
from .ellipsoids import Ellipsoids
from .tolerances import (
    ANGLE_TOL,
    DIST_TOL,
    FILTER_CCD_FACTOR,
    FILTER_RELATIVE_SLACK,
    NEAR_TANGENT,
    POS_TOL,
    TIGHT_CCD_ITERATIONS,
    TIGHT_CCD_TOLERANCE,
)

MODES = ("filter", "narrowphase")
_SPHERE, _ELLIPSOID = int(mujoco.mjtGeom.mjGEOM_SPHERE), int(mujoco.mjtGeom.mjGEOM_ELLIPSOID)
_OVERRIDE = int(mujoco.mjtEnableBit.mjENBL_OVERRIDE)

# Registry of attached datas, read by the callbacks through its address.  Row 0: [number of rows
# in use, ...]; rows 1..: [mjData address, counters address, mode, pair buffer address, capacity].
MAX_ATTACHED = 256
_FILTER, _RECORD, _NARROW = 1, 2, 3
_REGISTRY = np.zeros((MAX_ATTACHED + 1, 5), dtype=np.int64)
# Per-data counters: filter: seen, discarded, passed; narrowphase: calls, separated, contacts,
# fallbacks; record: the number of recorded pairs in slot 3.
_NCOUNTERS = 6
_lock = threading.Lock()
_state = {"callback": None, "narrow": None, "previous": None, "filter_installed": False, "table": None, "attached": []}
_NARROW_FN = ctypes.CFUNCTYPE(
    ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int, ctypes.c_int, ctypes.c_double
)


@jit
def _word(addr):
    return carray(mjstruct.i64_pointer(addr), (1,))[0]


@jit
def _ellipsoid(xpos, xmat, size, gtype, g, grow):
    """Geom g as an ellipsoid tuple (frame.load layout), grown to enclose its `grow`-offset body."""
    c = (xpos[3 * g], xpos[3 * g + 1], xpos[3 * g + 2])
    k = 9 * g
    R = (xmat[k], xmat[k + 1], xmat[k + 2], xmat[k + 3], xmat[k + 4], xmat[k + 5], xmat[k + 6], xmat[k + 7], xmat[k + 8])
    if gtype == _SPHERE:
        r = size[3 * g] + grow
        return c, R, (r, r, r)
    r0, r1, r2 = size[3 * g], size[3 * g + 1], size[3 * g + 2]
    s = 1.0 + grow / min(r0, r1, r2)  # E + ball(grow) lies inside E scaled by s about its centre
    return c, R, (r0 * s, r1 * s, r2 * s)


def _compile_callback():
    """The contact filter cfunc, compiled once per process with this build's struct offsets."""
    lay = mjstruct.layout()
    om, od = lay["model"], lay["data"]
    o_type, o_contype, o_conaff = om["geom_type"], om["geom_contype"], om["geom_conaffinity"]
    o_size, o_margin, o_gap = om["geom_size"], om["geom_margin"], om["geom_gap"]
    o_ccd, o_omargin, o_enable = om["opt.ccd_tolerance"], om["opt.o_margin"], om["opt.enableflags"]
    o_xpos, o_xmat = od["geom_xpos"], od["geom_xmat"]
    reg_addr, reg_rows = int(_REGISTRY.ctypes.data), _REGISTRY.shape[0]

    @numba.cfunc(types.intc(types.voidptr, types.voidptr, types.intc, types.intc), error_model="numpy")
    def contact_filter(m, d, g1, g2):
        ma, da = mjstruct.address(m), mjstruct.address(d)
        n = max(g1, g2) + 1
        contype = carray(mjstruct.i32_pointer(_word(ma + o_contype)), (n,))
        conaff = carray(mjstruct.i32_pointer(_word(ma + o_conaff)), (n,))
        if (contype[g1] & conaff[g2]) == 0 and (contype[g2] & conaff[g1]) == 0:
            return 1  # MuJoCo's own bitmask test, which this callback replaces
        gtype = carray(mjstruct.i32_pointer(_word(ma + o_type)), (n,))
        t1, t2 = gtype[g1], gtype[g2]
        if not ((t1 == _ELLIPSOID and (t2 == _ELLIPSOID or t2 == _SPHERE)) or (t1 == _SPHERE and t2 == _ELLIPSOID)):
            return 0
        reg = carray(mjstruct.i64_pointer(reg_addr), (reg_rows, 5))
        slot = _slot(reg, da)
        if slot and reg[slot, 2] == _RECORD:
            counters = carray(mjstruct.i64_pointer(reg[slot, 1]), (_NCOUNTERS,))
            i = counters[3]
            if i < reg[slot, 4]:
                pairs = carray(mjstruct.i32_pointer(reg[slot, 3]), (reg[slot, 4], 2))
                pairs[i, 0] = g1
                pairs[i, 1] = g2
            counters[3] = i + 1
            return 0
        size = carray(mjstruct.f64_pointer(_word(ma + o_size)), (3 * n,))
        margin = carray(mjstruct.f64_pointer(_word(ma + o_margin)), (n,))
        gap = carray(mjstruct.f64_pointer(_word(ma + o_gap)), (n,))
        enable = carray(mjstruct.i32_pointer(ma + o_enable), (1,))[0]
        if enable & _OVERRIDE:
            total = carray(mjstruct.f64_pointer(ma + o_omargin), (1,))[0]
        else:
            total = margin[g1] + margin[g2]
        total = max(total + gap[g1] + gap[g2], 0.0)
        total += FILTER_CCD_FACTOR * carray(mjstruct.f64_pointer(ma + o_ccd), (1,))[0]
        xpos = carray(mjstruct.f64_pointer(_word(da + o_xpos)), (3 * n,))
        xmat = carray(mjstruct.f64_pointer(_word(da + o_xmat)), (9 * n,))
        scale = max(size[3 * g1], size[3 * g1 + 1], size[3 * g1 + 2], size[3 * g2], size[3 * g2 + 1], size[3 * g2 + 2])
        grow = 0.5 * total + FILTER_RELATIVE_SLACK * scale
        A = _ellipsoid(xpos, xmat, size, t1, g1, grow)
        B = _ellipsoid(xpos, xmat, size, t2, g2, grow)
        discard = separated_by_axes(A, B)
        if slot and reg[slot, 2] == _FILTER:
            counters = carray(mjstruct.i64_pointer(reg[slot, 1]), (_NCOUNTERS,))
            counters[0] += 1
            counters[1 if discard else 2] += 1
        return 1 if discard else 0

    return contact_filter


def callback():
    """The compiled contact filter (compiled on first use, ~2 s)."""
    if _state["callback"] is None:
        _state["callback"] = _compile_callback()
    return _state["callback"]


@jit
def _slot(reg, da):
    """Registry row of the data at address da, 0 when it is not attached."""
    for k in range(1, reg[0, 0] + 1):
        if reg[k, 0] == da:
            return k
    return 0


def _compile_narrowphase():
    """The mjfCollision cfunc, compiled once per process with this build's struct offsets and
    MuJoCo's original ellipsoid functions (the fallbacks)."""
    lay = mjstruct.layout()
    om, od = lay["model"], lay["data"]
    o_type, o_size = om["geom_type"], om["geom_size"]
    o_xpos, o_xmat = od["geom_xpos"], od["geom_xmat"]
    reg_addr, reg_rows = int(_REGISTRY.ctypes.data), _REGISTRY.shape[0]
    table, ntypes = mjstruct.collision_table()
    fallback_ee = _NARROW_FN(table[_ELLIPSOID * ntypes + _ELLIPSOID])
    fallback_se = _NARROW_FN(table[_SPHERE * ntypes + _ELLIPSOID])

    @numba.cfunc(
        types.intc(types.voidptr, types.voidptr, types.voidptr, types.intc, types.intc, types.float64),
        error_model="numpy",
    )
    def narrowphase(m, d, con, g1, g2, margin):
        ma, da = mjstruct.address(m), mjstruct.address(d)
        n = max(g1, g2) + 1
        gtype = carray(mjstruct.i32_pointer(_word(ma + o_type)), (n,))
        size = carray(mjstruct.f64_pointer(_word(ma + o_size)), (3 * n,))
        xpos = carray(mjstruct.f64_pointer(_word(da + o_xpos)), (3 * n,))
        xmat = carray(mjstruct.f64_pointer(_word(da + o_xmat)), (9 * n,))
        reg = carray(mjstruct.i64_pointer(reg_addr), (reg_rows, 5))
        slot = _slot(reg, da)
        counters = reg[slot, 1] if slot else 0
        if counters:
            mjstruct.atomic_add(counters, 1)
        grow = 0.5 * max(margin, 0.0)
        t1, t2 = gtype[g1], gtype[g2]
        if separated_by_axes(_ellipsoid(xpos, xmat, size, t1, g1, grow), _ellipsoid(xpos, xmat, size, t2, g2, grow)):
            if counters:
                mjstruct.atomic_add(counters + 8, 1)
            return 0
        status, dist, normal, pos, _ = pair_signed_distance(
            _ellipsoid(xpos, xmat, size, t1, g1, 0.0), _ellipsoid(xpos, xmat, size, t2, g2, 0.0)
        )
        if status == NOT_CONVERGED:
            if counters:
                mjstruct.atomic_add(counters + 32, 1)
            if t1 == _SPHERE:
                return fallback_se(m, d, con, g1, g2, margin)
            return fallback_ee(m, d, con, g1, g2, margin)
        if dist >= margin:
            return 0
        c = carray(mjstruct.f64_pointer(mjstruct.address(con)), (10,))  # mjPreContact
        c[0] = dist
        c[1], c[2], c[3] = pos
        c[4], c[5], c[6] = normal
        c[7], c[8], c[9] = 0.0, 0.0, 0.0
        if counters:
            mjstruct.atomic_add(counters + 16, 1)
        return 1

    return narrowphase


def narrowphase_function():
    """The compiled narrow-phase function (compiled on first use, ~2 s)."""
    if _state["narrow"] is None:
        _state["narrow"] = _compile_narrowphase()
    return _state["narrow"]


def ellipsoid_pair_possible(model):
    """True when the model has a geom pair the filter would test (ellipsoid with ellipsoid or sphere)."""
    t = model.geom_type
    collides = (model.geom_contype != 0) | (model.geom_conaffinity != 0)
    n_ell = int(np.count_nonzero((t == _ELLIPSOID) & collides))
    n_sph = int(np.count_nonzero((t == _SPHERE) & collides))
    return n_ell >= 2 or (n_ell >= 1 and n_sph >= 1)


def _check(model, data):
    if not isinstance(model, mujoco.MjModel):
        raise ValueError(f"model must be a mujoco.MjModel, got {type(model).__name__}")
    if not isinstance(data, mujoco.MjData):
        raise ValueError(f"data must be a mujoco.MjData, got {type(data).__name__}")
    if data.signature != model.signature:
        raise ValueError(
            f"data belongs to another model: data.signature {data.signature} != model.signature {model.signature}"
        )


_MODE_CODE = {"filter": _FILTER, "record": _RECORD, "narrowphase": _NARROW}


def _write_registry():
    """Rewrite the registry rows from the attachment list (under _lock)."""
    attached = _state["attached"]
    for row, a in enumerate(attached, start=1):
        _REGISTRY[row] = (
            a.data._address, a._counters.ctypes.data, _MODE_CODE[a.mode],
            a._pairs.ctypes.data, len(a._pairs) if a.mode == "record" else 0,
        )  # fmt: skip
    _REGISTRY[0, 0] = len(attached)


def _uses_filter(attached):
    return any(a.mode in ("filter", "record") for a in attached)


def _install(attached_before, attachment):
    """Install what `attachment` needs and no attachment before it installed (under _lock)."""
    if attachment.mode in ("filter", "record") and not _uses_filter(attached_before):
        current = mujoco.get_mjcb_contactfilter()
        if current is not None:
            raise ValueError(
                f"a contact filter callback is already installed ({current!r}); ellipsim's filter would replace it"
            )
        mujoco.set_mjcb_contactfilter(callback().ctypes)
        _state["previous"], _state["filter_installed"] = current, True
    if attachment.mode == "narrowphase" and not any(a.mode == "narrowphase" for a in attached_before):
        fn = narrowphase_function()
        table, ntypes = mjstruct.collision_table()
        entries = (_ELLIPSOID * ntypes + _ELLIPSOID, _SPHERE * ntypes + _ELLIPSOID)
        _state["table"] = {k: table[k] for k in entries}
        for k in entries:
            table[k] = fn.address


def _uninstall(attached_after):
    """Remove what no remaining attachment needs (under _lock)."""
    if _state["filter_installed"] and not _uses_filter(attached_after):
        mujoco.set_mjcb_contactfilter(_state["previous"])
        _state["previous"], _state["filter_installed"] = None, False
    if _state["table"] and not any(a.mode == "narrowphase" for a in attached_after):
        table, _ = mjstruct.collision_table()
        for k, original in _state["table"].items():
            table[k] = original
        _state["table"] = None


class Attachment:
    """ellipsim attached to one (model, data) while the `with` block runs; see attach()."""

    def __init__(self, model, data, mode, capacity=0):
        self.model, self.data, self.mode = model, data, mode
        self.installed = False
        self._counters = np.zeros(_NCOUNTERS, dtype=np.int64)
        self._pairs = np.zeros((max(capacity, 1), 2), dtype=np.int32)

    @property
    def counters(self):
        """Per-data counts of the ellipsoid pairs ellipsim handled while attached.

        filter: seen = discarded + passed candidate pairs; narrowphase: calls = separated (certified,
        no contact) + contacts + fallbacks (to MuJoCo's function) + pairs measured apart beyond the margin.
        """
        c = [int(x) for x in self._counters]
        if self.mode == "narrowphase":
            return {"calls": c[0], "separated": c[1], "contacts": c[2], "fallbacks": c[4]}
        return {"seen": c[0], "discarded": c[1], "passed": c[2]}

    def __enter__(self):
        if self.mode != "record" and not ellipsoid_pair_possible(self.model):
            return self  # skip what the scene does not need: nothing is installed
        with _lock:
            attached = _state["attached"]
            if any(a.data is self.data for a in attached):
                raise ValueError("data is already attached to ellipsim; leave the other `with` block first")
            if len(attached) >= MAX_ATTACHED:
                raise ValueError(f"at most {MAX_ATTACHED} datas can be attached at once")
            _install(attached, self)
            attached.append(self)
            _write_registry()
            self.installed = True
        return self

    def __exit__(self, *exc):
        if not self.installed:
            return False
        with _lock:
            attached = _state["attached"]
            attached.remove(self)
            _write_registry()
            _uninstall(attached)
            self.installed = False
        return False


def attach(model, data, *, mode="filter"):
    """Attach ellipsim to mj_step of (model, data) for the duration of a `with` block.

    mode "filter": certified contact pre-filter for ellipsoid and sphere-ellipsoid pairs;
    mode "narrowphase": ellipsim computes the contacts of those pairs in place of GJK/EPA.
    A model without such pairs installs nothing.  Per-data counters are on the returned object.
    """
    _check(model, data)
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
    return Attachment(model, data, mode)


# --- validation ----------------------------------------------------------------------------------


@dataclasses.dataclass
class Disagreement:
    """A candidate pair on which MuJoCo's contact and ellipsim's verdict differ."""

    step: int
    geom1: int
    geom2: int
    names: tuple
    mujoco_contact: bool  # MuJoCo has a contact with dist < margin
    mujoco_dist: float  # that contact's dist (nan if none)
    relation: str  # ellipsim's exact relation of the margin-enclosing ellipsoids
    contact_scale: float  # Perram-Wertheim scale of the margin-enclosing ellipsoids
    geom_distance: float  # mujoco.mj_geomDistance (signed; capped at 1)
    right: str  # "ellipsim", "mujoco" or "undetermined", per the exact test
    reason: str


@dataclasses.dataclass
class Validation:
    """Per-step agreement of MuJoCo's contacts with ellipsim's exact verdicts.

    counts : (steps, 4) int64, columns COLUMNS: candidate ellipsoid pairs per step
    """

    COLUMNS = ("both", "neither", "mujoco_only", "ellipsim_only")
    steps: int
    counts: np.ndarray
    mujoco_contacts: np.ndarray  # (steps,) all contacts MuJoCo made (every geom type)
    disagreements: list

    def totals(self):
        return {name: int(self.counts[:, k].sum()) for k, name in enumerate(self.COLUMNS)}


def _pair_margins(model, pairs):
    """(k,) margin of each geom pair (k, 2): opt.o_margin under mjENBL_OVERRIDE, else the geoms' sum."""
    if model.opt.enableflags & _OVERRIDE:
        return np.full(len(pairs), float(model.opt.o_margin))
    return model.geom_margin[pairs[:, 0]] + model.geom_margin[pairs[:, 1]]


def _pair_contact_dist(model, data, pairs):
    """(k,) smallest dist of data's contacts on each geom pair (k, 2) sorted by (g1, g2), g1 < g2,
    whichever order the contact names them in; nan for a pair without contact."""
    geom = data.contact.geom[: data.ncon].astype(np.int64)
    key = np.minimum(geom[:, 0], geom[:, 1]) * model.ngeom + np.maximum(geom[:, 0], geom[:, 1])
    pair_key = pairs[:, 0].astype(np.int64) * model.ngeom + pairs[:, 1]
    i = np.minimum(np.searchsorted(pair_key, key), len(pairs) - 1)
    on_pair = pair_key[i] == key
    smallest = np.full(len(pairs), np.inf)
    np.fmin.at(smallest, i[on_pair], data.contact.dist[: data.ncon][on_pair])  # fmin: as Python's min(...)
    touched = np.zeros(len(pairs), dtype=bool)
    touched[i[on_pair]] = True
    return np.where(touched, smallest, np.nan)


def _enclosing(model, data, geoms, grow):
    """Ellipsoids (k,) of geoms, each grown to enclose its body offset by grow (k,)."""
    size = model.geom_size[geoms].copy()
    sphere = model.geom_type[geoms] == _SPHERE
    size[sphere] = size[sphere, :1]
    scale = 1.0 + grow / size.min(axis=1)
    radii = np.where(sphere[:, None], size + grow[:, None], size * scale[:, None])
    return Ellipsoids(data.geom_xpos[geoms], data.geom_xmat[geoms].reshape(-1, 3, 3), radii)


def candidate_pairs(model, data):
    """(k, 2) int32: the ellipsoid and sphere-ellipsoid geom pairs MuJoCo's broad phase sends to
    collision at the current state (runs mj_forward; contacts and state as plain MuJoCo leaves them)."""
    _check(model, data)
    ell = np.count_nonzero((model.geom_type == _ELLIPSOID) | (model.geom_type == _SPHERE))
    with Attachment(model, data, "record", capacity=max(ell * (ell - 1) // 2, 1)) as att:
        mujoco.mj_forward(model, data)
        k = int(att._counters[3])
        return np.unique(np.sort(att._pairs[:k], axis=1), axis=0)


def validate(model, data, nstep, *, control=None, advance=True, progress=None):
    """Step plain MuJoCo nstep times and compare, pair by pair, its contacts with ellipsim's verdicts.

    At each step, before mj_step, mj_forward runs collision; every candidate ellipsoid pair MuJoCo's
    broad phase produced (recorded by the callback, which otherwise behaves exactly like MuJoCo) is
    classified: MuJoCo says contact when it made one with dist < margin; ellipsim says contact when
    the ellipsoids grown by margin/2 each (enclosing the margin bodies; exact when margin = 0)
    overlap.  Disagreements carry contact_scale, mj_geomDistance and who is right by the exact test.

    control : optional callable(model, data, step) run before each mj_forward (set ctrl, or a pose)
    advance : mj_step after each comparison (False for kinematic replays that set every pose)
    progress : optional callable(step, nstep), called after each step
    """
    _check(model, data)
    if not isinstance(nstep, (int, np.integer)) or nstep < 1:
        raise ValueError(f"nstep must be a positive integer, got {nstep!r}")
    ell = np.flatnonzero((model.geom_type == _ELLIPSOID) | (model.geom_type == _SPHERE))
    capacity = max(len(ell) * (len(ell) - 1) // 2, 1)
    att = Attachment(model, data, "record", capacity=capacity)
    counts = np.zeros((nstep, 4), dtype=np.int64)
    ncon = np.zeros(nstep, dtype=np.int64)
    disagreements = []
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or f"geom{g}" for g in range(model.ngeom)]
    with att:
        for step in range(nstep):
            att._counters[3] = 0
            if control is not None:
                control(model, data, step)
            mujoco.mj_forward(model, data)
            k = int(att._counters[3])
            pairs = np.unique(np.sort(att._pairs[:k], axis=1), axis=0)
            ncon[step] = data.ncon
            if len(pairs):
                margin = _pair_margins(model, pairs)
                a = _enclosing(model, data, pairs[:, 0], np.maximum(margin, 0) / 2)
                b = _enclosing(model, data, pairs[:, 1], np.maximum(margin, 0) / 2)
                relation = classify(a, b)
                dist = _pair_contact_dist(model, data, pairs)
                mj = dist < margin
                el = relation == Relation.OVERLAPPING
                counts[step] = np.bincount(np.where(mj, np.where(el, 0, 2), np.where(el, 3, 1)), minlength=4)
                for i in np.flatnonzero(mj != el):
                    g1, g2 = int(pairs[i, 0]), int(pairs[i, 1])
                    disagreements.append(_explain(model, data, step, g1, g2, names, bool(mj[i]), dist[i], relation[i], margin[i], a[i], b[i]))
            if advance:
                mujoco.mj_step(model, data)
            if progress is not None:
                progress(step + 1, nstep)
    return Validation(nstep, counts, ncon, disagreements)


def _explain(model, data, step, g1, g2, names, mj, dist, relation, margin, a, b):
    geom_distance = float(mujoco.mj_geomDistance(model, data, g1, g2, 1.0, None))
    scale = float(contact_scale(a, b)[0])
    rel = Relation(int(relation)).name.lower()
    if mj:  # MuJoCo made a contact the exact test rules out
        right, reason = "ellipsim", f"exact: {rel} at margin {margin:g}; MuJoCo's contact is within its ccd tolerance"
    elif margin <= 0 or _bare_overlap(model, data, g1, g2):
        right, reason = "ellipsim", "exact: overlapping; MuJoCo made no contact"
    else:
        right = "undetermined"
        reason = f"ellipsim tested an ellipsoid enclosing the margin body; mj_geomDistance {geom_distance:.3g} vs margin {margin:g}"
    return Disagreement(step, g1, g2, (names[g1], names[g2]), mj, float(dist), rel, scale, geom_distance, right, reason)


def _bare_overlap(model, data, g1, g2):
    zero = np.zeros(1)
    a = _enclosing(model, data, np.array([g1]), zero)
    b = _enclosing(model, data, np.array([g2]), zero)
    return classify(a, b)[0] == Relation.OVERLAPPING


# --- narrow-phase comparison ---------------------------------------------------------------------


@dataclasses.dataclass
class ContactDifference:
    """An ellipsoid pair whose contact differs between MuJoCo and ellipsim beyond the bounds."""

    step: int
    geom1: int
    geom2: int
    names: tuple
    mujoco: tuple  # (dist, normal (3,), pos (3,)) or None: no contact
    ellipsim: tuple  # likewise
    ddist: float
    angle: float  # radians between the normals (nan if one side has no contact)
    dpos: float
    sigma_mujoco: float  # sigma(n) at MuJoCo's normal: the signed distance is the maximum of sigma
    sigma_ellipsim: float  # ... and at ellipsim's
    certified: bool  # ellipsim's maximum is provably the global one
    right: str  # "ellipsim", "mujoco" or "undetermined"
    reason: str


@dataclasses.dataclass
class NarrowphaseComparison:
    """Contacts of MuJoCo's GJK/EPA and of ellipsim's narrow phase on the same states."""

    steps: int
    matched: int  # ellipsoid pairs in contact on both sides
    near_tangent: int  # pairs in contact on one side only, with |dist| < NEAR_TANGENT
    max_ddist: float  # over matched pairs
    max_angle: float
    max_dpos: float
    differences: list  # ContactDifference beyond DIST_TOL / ANGLE_TOL / POS_TOL, or unmatched


@dataclasses.dataclass
class _Contacts:
    """The ellipsoid and sphere-ellipsoid contacts of a data, one per (geom1, geom2) as the contacts
    name them (the last, when MuJoCo made several), sorted by key = geom1 * ngeom + geom2."""

    key: np.ndarray  # (k,) int64
    dist: np.ndarray  # (k,)
    normal: np.ndarray  # (k, 3)
    pos: np.ndarray  # (k, 3)

    def at(self, j):
        """Contact j as (dist, normal (3,), pos (3,))."""
        return float(self.dist[j]), self.normal[j].copy(), self.pos[j].copy()

    def get(self, key):
        """The contact with `key`, or None."""
        j = int(np.searchsorted(self.key, key))
        return self.at(j) if j < len(self.key) and self.key[j] == key else None


def _ellipsoid_contacts(model, data):
    """_Contacts of the ellipsoid and sphere-ellipsoid contacts in data."""
    con, n = data.contact, data.ncon
    geom = con.geom[:n].astype(np.int64)
    t = model.geom_type[geom]
    kept = np.flatnonzero(((t == _ELLIPSOID) | (t == _SPHERE)).all(axis=1) & (t == _ELLIPSOID).any(axis=1))
    key, first_from_end = np.unique((geom[kept, 0] * model.ngeom + geom[kept, 1])[::-1], return_index=True)
    last = kept[::-1][first_from_end]
    return _Contacts(key, con.dist[:n][last], con.frame[:n][last, :3], con.pos[:n][last])


def _sigma(model, data, g1, g2, n):
    """sigma(n) = n . (c2 - c1) - h1(n) - h2(-n) for the geoms' ellipsoids, n normalised."""
    n = np.asarray(n, float) / np.linalg.norm(n)

    def h(g, v):
        r = model.geom_size[g] if model.geom_type[g] == _ELLIPSOID else np.repeat(model.geom_size[g, 0], 3)
        return float(np.linalg.norm(r * (data.geom_xmat[g].reshape(3, 3).T @ v)))

    return float(n @ (data.geom_xpos[g2] - data.geom_xpos[g1]) - h(g1, n) - h(g2, -n))


def compare_narrowphase(model, data, nstep, *, progress=None):
    """Step plain MuJoCo nstep times; at each state compare MuJoCo's ellipsoid contacts with ellipsim's.

    At every step the same state is collided twice (mj_forward): with MuJoCo's functions and with
    mode="narrowphase"; then plain mj_step advances.  Pairs in contact on both sides are compared
    (dist, normal angle, position); a difference beyond the bounds in tolerances.py, or a contact on
    one side only with |dist| >= NEAR_TANGENT, is reported with the referee: the signed distance is
    the maximum over n of sigma(n), so sigma at each side's normal shows whose is better, and when
    ellipsim's maximum is certified global it is the exact answer to rounding.  Deep penetrations that
    sigma cannot settle are re-collided by MuJoCo at ccd_tolerance TIGHT_CCD_TOLERANCE.
    """
    _check(model, data)
    if not isinstance(nstep, (int, np.integer)) or nstep < 1:
        raise ValueError(f"nstep must be a positive integer, got {nstep!r}")
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.empty(mujoco.mj_stateSize(model, spec))
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or f"geom{g}" for g in range(model.ngeom)]
    matched = near = 0
    worst = [0.0, 0.0, 0.0]
    differences = []
    tight = copy.copy(model)  # a third opinion for what sigma cannot settle: GJK/EPA run to 1e-11
    tight.opt.ccd_tolerance, tight.opt.ccd_iterations = TIGHT_CCD_TOLERANCE, TIGHT_CCD_ITERATIONS
    tight_data = mujoco.MjData(tight)
    for step in range(nstep):
        mujoco.mj_getState(model, data, state, spec)
        mujoco.mj_forward(model, data)
        theirs = _ellipsoid_contacts(model, data)
        with Attachment(model, data, "narrowphase"):
            mujoco.mj_setState(model, data, state, spec)
            mujoco.mj_forward(model, data)
            ours = _ellipsoid_contacts(model, data)
        mujoco.mj_setState(model, data, state, spec)
        mujoco.mj_forward(model, data)
        keys = np.union1d(theirs.key, ours.key)
        i_mj, i_el = np.searchsorted(theirs.key, keys), np.searchsorted(ours.key, keys)
        on_mj, on_el = np.isin(keys, theirs.key), np.isin(keys, ours.key)
        both = on_mj & on_el
        m, e = i_mj[both], i_el[both]
        ddist = np.abs(theirs.dist[m] - ours.dist[e])
        # vecdot and sqrt(vecdot) are the per-vector a @ b and np.linalg.norm, to the bit
        angle = np.arccos(np.clip(np.vecdot(theirs.normal[m], ours.normal[e]), -1.0, 1.0))
        dp = theirs.pos[m] - ours.pos[e]
        dpos = np.sqrt(np.vecdot(dp, dp))
        matched += int(both.sum())
        worst = [float(np.fmax.reduce(x, initial=w)) for w, x in zip(worst, (ddist, angle, dpos))]  # fmax: as max()
        within = np.zeros(len(keys), dtype=bool)
        within[both] = (ddist <= DIST_TOL) & (angle <= ANGLE_TOL) & (dpos <= POS_TOL)
        one_dist = np.empty(len(keys))  # the dist of the one side in contact
        one_dist[on_el], one_dist[on_mj] = ours.dist[i_el[on_el]], theirs.dist[i_mj[on_mj]]
        tangent = ~both & (np.abs(one_dist) < NEAR_TANGENT)
        near += int(tangent.sum())
        for j in np.flatnonzero(~(within | tangent)):
            mj = theirs.at(i_mj[j]) if on_mj[j] else None
            el = ours.at(i_el[j]) if on_el[j] else None
            differences.append(_referee(model, data, step, divmod(int(keys[j]), model.ngeom), names, mj, el))
        undetermined = [x for x in differences if x.step == step and x.right == "undetermined"]
        if undetermined:
            mujoco.mj_setState(tight, tight_data, state, spec)
            mujoco.mj_forward(tight, tight_data)
            third = _ellipsoid_contacts(tight, tight_data)
            for x in undetermined:
                t = third.get(x.geom1 * model.ngeom + x.geom2)
                if t is not None and x.mujoco and x.ellipsim:
                    el_err, mj_err = abs(t[0] - x.ellipsim[0]), abs(t[0] - x.mujoco[0])
                    x.right = "ellipsim" if el_err < mj_err else "mujoco"
                    x.reason += (
                        f"; MuJoCo at ccd_tolerance {TIGHT_CCD_TOLERANCE:g} gives {t[0]:.12g}: "
                        f"{el_err:.2g} from ellipsim, {mj_err:.2g} from MuJoCo's default"
                    )
        mujoco.mj_step(model, data)
        if progress is not None:
            progress(step + 1, nstep)
    return NarrowphaseComparison(nstep, matched, near, *worst, differences)


def _referee(model, data, step, key, names, mj, el):
    g1, g2 = key
    zero = np.zeros(1)
    a = _enclosing(model, data, np.array([g1]), zero)
    b = _enclosing(model, data, np.array([g2]), zero)
    dist, normal, pos, status = signed_distance(a, b)
    certified = bool(status[0] == CERTIFIED)
    s_el = _sigma(model, data, g1, g2, normal[0])
    s_mj = _sigma(model, data, g1, g2, mj[1]) if mj else float("nan")
    ddist = abs(mj[0] - el[0]) if mj and el else float("nan")
    angle = float(np.arccos(np.clip(mj[1] @ el[1], -1, 1))) if mj and el else float("nan")
    dpos = float(np.linalg.norm(mj[2] - el[2])) if mj and el else float("nan")
    eps = 1e-12 * float(np.abs(model.geom_size[[g1, g2]]).max())
    if mj and s_mj > s_el + eps:
        right, reason = "mujoco", f"MuJoCo's normal reaches sigma {s_mj:.9g} > ellipsim's {s_el:.9g}"
    elif certified:
        right = "ellipsim"
        if mj and el:
            reason = (
                f"ellipsim's maximum is certified: signed distance {s_el:.9g}; MuJoCo reports {mj[0]:.9g} "
                f"and its normal reaches only sigma {s_mj:.9g} (ccd_tolerance {model.opt.ccd_tolerance:g})"
            )
        else:
            side = "MuJoCo only" if mj else "ellipsim only"
            reason = f"contact on {side}; certified signed distance {s_el:.9g}"
    elif mj and mj[0] < s_el - eps:
        right = "ellipsim"
        reason = (
            f"deep penetration (multi-start, not certified global): MuJoCo's depth {-mj[0]:.9g} exceeds the "
            f"depth {-s_el:.9g} along ellipsim's normal, so it is too deep by at least the difference"
        )
    else:
        right, reason = "undetermined", f"deep penetration, best of a multi-start: sigma {s_el:.9g}"
    return ContactDifference(step, g1, g2, (names[g1], names[g2]), mj, el, ddist, angle, dpos, s_mj, s_el, certified, right, reason)
