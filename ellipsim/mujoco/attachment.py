"""Attach ellipsim to mj_step of one (model, data) for the duration of a `with` block.

    with ellipsim.mujoco.attach(model, data, mode="filter") as att:   # or mode="narrowphase"
        for _ in range(1000):
            mujoco.mj_step(model, data)
    att.counters

The callbacks themselves are C++, compiled with the package (ellipsim/native/mujoco/: contact_filter.hpp,
narrowphase.hpp; their addresses are ext.mujoco.FILTER and ext.mujoco.NARROWPHASE).  This module installs
them in MuJoCo's process-global hooks (mjcb_contactfilter, the mjCOLLISIONFUNC table) while at least one data
needs them (only the mode's callback, and none for a model without ellipsoid pairs), writes the registry
rows they read (context.py), and puts MuJoCo's originals back when the last attachment ends.  An attachment covers one mjData by address:
after `spec.recompile(model, data)`, `att.reattach(new_model, new_data)` moves it to the new pair.
"""

import ctypes
import threading

import mujoco
import numpy as np

from ..native import ext
from . import publish
from .context import (
    APART,
    CAPPED,
    CONTACTS,
    FALLBACKS,
    FILTER,
    FILTER_PAIR_TYPES,
    HULL_WORDS,
    HULLS,
    MAX_ATTACHED,
    NARROW,
    NCOUNTERS,
    PAIR_TYPES,
    RECORD,
    REGISTRY,
    SEPARATED,
    WARM_ADDRESS,
    WARM_MASK,
    WARM_SLOT_WORDS,
)

MODES = ("filter", "narrowphase")
#: mjfConFilt, int (*)(const mjModel*, mjData*, int geom1, int geom2): the filter as mujoco.set_mjcb_contactfilter takes it
_FILTER = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int, ctypes.c_int)(
    ext.mujoco.FILTER
)
_lock = threading.Lock()
_state = {"previous": None, "filter_installed": False, "table": None, "attached": []}

#: the rows of context.PAIR_TYPES each mode's callback handles
_MODE_PAIR_TYPES = {"filter": FILTER_PAIR_TYPES, "record": FILTER_PAIR_TYPES, "narrowphase": PAIR_TYPES}


def explicit_pairs(model, mode="narrowphase"):
    """Indices into the model's `<contact><pair>` elements (model.pair_geom1 / pair_geom2) whose geom
    types the mode's callback handles: (k,) int array.

    Explicit pairs skip the contype/conaffinity test and mjcb_contactfilter (engine_collision_driver.c,
    filterCollisionPair with ipair >= 0) and go straight to mjCOLLISIONFUNC with the pair's own
    margin + gap; mj_setContact then gives the contact the pair's margin, condim, solref, solimp and
    friction.  So the narrow phase covers them; a contact filter never sees them, so for modes
    "filter" and "record" there are none."""
    if mode != "narrowphase" or model.npair == 0:
        return np.zeros(0, dtype=np.int64)
    t1, t2 = model.geom_type[model.pair_geom1], model.geom_type[model.pair_geom2]
    lo, hi = np.minimum(t1, t2), np.maximum(t1, t2)
    handled = np.zeros(model.npair, dtype=bool)
    for row in PAIR_TYPES:
        handled |= (lo == row.type1) & (hi == row.type2)
    return np.flatnonzero(handled)


def ellipsoid_pair_possible(model, mode="filter"):
    """True when the model has a geom pair the mode's callback handles: ellipsoid with ellipsoid or
    sphere, and in mode "narrowphase" also capsule, box or cylinder with ellipsoid (the mode's rows of
    context.PAIR_TYPES).  Dynamic pairs are
    counted by contype/conaffinity; in mode "narrowphase" explicit `<pair>` elements of those types
    count too, whatever their geoms' contype and conaffinity (explicit_pairs: the filter never sees
    them)."""
    collides = (model.geom_contype != 0) | (model.geom_conaffinity != 0)
    n = np.bincount(model.geom_type[collides], minlength=int(mujoco.mjtGeom.mjNGEOMTYPES))
    for row in _MODE_PAIR_TYPES[mode]:
        if n[row.type1] >= 1 + (row.type1 == row.type2) and n[row.type2] >= 1:
            return True
    return len(explicit_pairs(model, mode)) > 0


def check_model_data(model, data):
    """ValueError unless model is an MjModel and data an MjData made for it (same signature: a model
    recompiled from its spec has a new one, and so has the data recompile returns with it)."""
    if not isinstance(model, mujoco.MjModel):
        raise ValueError(f"model must be a mujoco.MjModel, got {type(model).__name__}")
    if not isinstance(data, mujoco.MjData):
        raise ValueError(f"data must be a mujoco.MjData, got {type(data).__name__}")
    if data.signature != model.signature:  # e.g. one of the pair spec.recompile(model, data) returned, one old
        raise ValueError(
            f"data belongs to another model: data.signature {data.signature} != model.signature {model.signature}"
            " (after spec.recompile, pass the model and data it returned together)"
        )


_MODE_CODE = {"filter": FILTER, "record": RECORD, "narrowphase": NARROW}


def _claim_slot(attachment):
    """Write `attachment` into a free registry slot, its data address last (under _lock)."""
    free = np.flatnonzero(REGISTRY[1:, 0] == 0)
    if len(free) == 0:
        raise ValueError(f"at most {MAX_ATTACHED} datas can be attached at once")
    slot = int(free[0]) + 1
    a = attachment
    REGISTRY[slot, 1:WARM_ADDRESS] = (
        a._counters.ctypes.data,
        _MODE_CODE[a.mode],
        a._pairs.ctypes.data,
        len(a._pairs) if a.mode == "record" else 0,
    )
    REGISTRY[slot, WARM_ADDRESS] = a._warm.ctypes.data
    REGISTRY[slot, WARM_MASK] = len(a._warm) - 1 if len(a._warm) > 1 else 0
    REGISTRY[slot, HULLS] = a._hulls[0].ctypes.data if a._hulls is not None else 0
    REGISTRY[slot, 0] = a.data._address
    REGISTRY[0, 0] = max(REGISTRY[0, 0], slot)
    return slot


def _release_slot(slot):
    """Free a registry slot: its data address first, so no callback matches it any more (under _lock)."""
    REGISTRY[slot, 0] = 0


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
        mujoco.set_mjcb_contactfilter(_FILTER)
        _state["previous"], _state["filter_installed"] = current, True
    if attachment.mode == "narrowphase" and not any(a.mode == "narrowphase" for a in attached_before):
        table, ntypes = publish.collision_table()
        entries = tuple(row.type1 * ntypes + row.type2 for row in PAIR_TYPES)
        _state["table"] = {k: table[k] for k in entries}
        for k in entries:
            table[k] = ext.mujoco.NARROWPHASE


def _uninstall(attached_after):
    """Remove what no remaining attachment needs (under _lock)."""
    if _state["filter_installed"] and not _uses_filter(attached_after):
        mujoco.set_mjcb_contactfilter(_state["previous"])
        _state["previous"], _state["filter_installed"] = None, False
    if _state["table"] and not any(a.mode == "narrowphase" for a in attached_after):
        table, _ = publish.collision_table()
        for k, original in _state["table"].items():
            table[k] = original
        _state["table"] = None


#: Warm-start table slots per geom that can take part in a narrow-phase pair (a settled pile has 2-3
#: candidate pairs per geom: the table stays under 1/8 full, so few pairs share a set)
WARM_SLOTS_PER_GEOM = 16
#: ... at least this many, at most this many (2^20 slots of 64 bytes: 64 MiB)
WARM_SLOTS_MIN, WARM_SLOTS_MAX = 64, 1 << 20
_WARM_TYPES = sorted({t for row in PAIR_TYPES if row.warm for t in (row.type1, row.type2)})


def warm_slots(model):
    """Slots of a narrow-phase warm-start table for `model`: a power of two, WARM_SLOTS_PER_GEOM per
    geom of a type in a `warm` row of context.PAIR_TYPES (ellipsoid, sphere, capsule) that collides
    (contype or conaffinity) or belongs to a handled explicit pair, within [WARM_SLOTS_MIN, WARM_SLOTS_MAX]."""
    counted = (model.geom_contype != 0) | (model.geom_conaffinity != 0)
    k = explicit_pairs(model)
    counted[model.pair_geom1[k]] = counted[model.pair_geom2[k]] = True
    n = int(np.count_nonzero(np.isin(model.geom_type, _WARM_TYPES) & counted))
    want = min(max(WARM_SLOTS_PER_GEOM * n, WARM_SLOTS_MIN), WARM_SLOTS_MAX)
    return 1 << (want - 1).bit_length()


class Attachment:
    """ellipsim attached to one (model, data) while the `with` block runs; see attach()."""

    def __init__(self, model, data, mode, capacity=0, warm_start=True):
        self.model, self.data, self.mode, self.warm_start = model, data, mode, warm_start
        self.installed = False
        self._open = False  # inside the `with` block (installed or not)
        self._counters = np.zeros(NCOUNTERS, dtype=np.int64)
        self._pairs = np.zeros((max(capacity, 1), 2), dtype=np.int32)
        self._warm = self._warm_table(model)
        self._hulls = self._hull_table(model)

    def _hull_table(self, model):
        """The narrow phase's hull table (context.HULL_WORDS) for `model`'s meshes, and the arrays it points
        into (kept alive with it), or None: not narrowphase, or no mesh.  Each mesh's hull is MuJoCo's own
        (mesh_graph, mujoco/hull.py), or, for a mesh MuJoCo keeps without one, the convex hull of its
        vertices, which is what MuJoCo's support function collides; a mesh with neither (flat) gets nv 0,
        and MuJoCo's own function."""
        if self.mode != "narrowphase" or model.nmesh == 0:
            return None
        from ..core.pairs.hull import convex_hull
        from .hull import mesh_hull

        table = np.zeros((model.nmesh, HULL_WORDS), dtype=np.int64)
        keep = [table]
        for mesh in range(model.nmesh):
            try:
                hull = mesh_hull(model, mesh)
            except ValueError:
                start, count = int(model.mesh_vertadr[mesh]), int(model.mesh_vertnum[mesh])
                try:
                    hull = convex_hull(np.asarray(model.mesh_vert[start : start + count], float))
                except ValueError:
                    continue
            v, e, n, f = (np.ascontiguousarray(x) for x in hull)
            adjacency = [np.empty(k, np.int32) for k in (len(v) + 1, 2 * len(e), len(v) + 1, 3 * len(f))]
            ext.hull_adjacency(v, e, n, f, *adjacency)
            keep += [v, e, n, f, *adjacency]
            table[mesh] = (len(v), len(e), len(f), *(x.ctypes.data for x in (v, e, n, f, *adjacency)), 0)
        return table, keep

    def _warm_table(self, model):
        """The narrow phase's warm-start table (context.WARM_SLOT_WORDS) for `model`, this data's only:
        every pair's last normal, read back as the next call's Newton seed; (1, 8) zeros for no warm start."""
        slots = warm_slots(model) if self.mode == "narrowphase" and self.warm_start else 1
        return np.zeros((slots, WARM_SLOT_WORDS), dtype=np.int64)

    def reattach(self, model, data):
        """Point this attachment at another (model, data), e.g. the pair `spec.recompile(model, data)`
        returned; same mode and warm_start, counters kept counting.  Inside the `with` block it takes
        effect at once: the old data is released (plain MuJoCo from now on) and the new one attached.
        The warm-start table starts empty (geom ids may have moved).  Returns self.

        A model and data that do not belong together (the new model with the old data, or the other
        way round) are refused (check_model_data), and so is a data another attachment holds."""
        check_model_data(model, data)
        with _lock:
            if any(a is not self and a.data._address == data._address for a in _state["attached"]):
                raise ValueError(
                    "data is already attached to ellipsim by another attachment; leave its `with` block first"
                )
        was_open = self._open
        if was_open:
            self.__exit__(None, None, None)
        self.model, self.data = model, data
        self._warm = self._warm_table(model)
        self._hulls = self._hull_table(model)
        if was_open:
            self.__enter__()
        return self

    @property
    def counters(self):
        """Per-data counts of the ellipsoid (and, narrowphase, capsule, box and cylinder with ellipsoid) pairs ellipsim handled.

        filter: seen = discarded + passed candidate pairs; narrowphase: calls = separated (proven apart
        beyond the margin, no contact) + apart (their signed distance measured beyond the margin, no
        contact) + contacts + fallbacks (to MuJoCo's function), and capped: the height-field calls among
        the contacts that made MuJoCo's most, mjMAXCONPAIR (50): their further prisms within the margin
        made no contact, as in MuJoCo's own function.
        """
        c = [int(x) for x in self._counters]
        if self.mode == "narrowphase":
            calls = c[SEPARATED] + c[CONTACTS] + c[APART] + c[FALLBACKS]
            return {
                "calls": calls,
                "separated": c[SEPARATED],
                "apart": c[APART],
                "contacts": c[CONTACTS],
                "fallbacks": c[FALLBACKS],
                "capped": c[CAPPED],
            }
        return {"seen": c[0], "discarded": c[1], "passed": c[2]}

    def __enter__(self):
        if self.mode != "record" and not ellipsoid_pair_possible(self.model, self.mode):
            self._open = True
            return self  # skip what the scene does not need: nothing is installed
        publish.fill_context()  # the registry's address and MuJoCo's own functions, once per process
        with _lock:
            attached = _state["attached"]
            if any(a.data._address == self.data._address for a in attached):
                raise ValueError("data is already attached to ellipsim; leave the other `with` block first")
            if len(attached) >= MAX_ATTACHED:
                raise ValueError(f"at most {MAX_ATTACHED} datas can be attached at once")
            _install(attached, self)
            self._slot = _claim_slot(self)
            attached.append(self)
            self.installed = self._open = True
        return self

    def __exit__(self, *exc):
        self._open = False
        if not self.installed:
            return False
        with _lock:
            attached = _state["attached"]
            attached.remove(self)
            _release_slot(self._slot)
            _uninstall(attached)
            self.installed = False
        return False


def attach(model, data, *, mode="filter", warm_start=True):
    """Attach ellipsim to mj_step of (model, data) for the duration of a `with` block.

    mode "filter": certified contact pre-filter for ellipsoid and sphere-ellipsoid pairs;
    mode "narrowphase": ellipsim computes the contacts of those pairs and of ellipsoids with capsules,
    boxes and cylinders in place of GJK/EPA (deep ellipsoid-cylinder rim contacts it cannot prove go
    to MuJoCo's function, counted as fallbacks).
    warm_start (narrowphase): start each ellipsoid pair's Newton run from its normal of the previous
    call on this data (a table owned by the returned object, never shared with another data); the
    results satisfy the same contract as cold starts (proven global maximum, distance within 1e-12
    of the smaller shortest semi-axis), but are not bit-identical to them.
    Explicit `<contact><pair>` elements of those geom types are covered in mode "narrowphase" (MuJoCo
    sends them through the same collision table with the pair's margin + gap, and gives their contacts
    the pair's margin, friction and solver parameters); they never reach a contact filter, so mode
    "filter" leaves them to MuJoCo.
    A model without such pairs installs nothing.  Per-data counters are on the returned object.

    `spec.recompile(model, data)` returns a new model and data, which an attachment made for the old
    ones does not cover (the old data stays attached; the new one runs plain MuJoCo): call
    `att.reattach(new_model, new_data)` inside the block, or attach the new pair anew.
    """
    check_model_data(model, data)
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
    if not isinstance(warm_start, bool):
        raise ValueError(f"warm_start must be True or False, got {warm_start!r}")
    return Attachment(model, data, mode, warm_start=warm_start)
