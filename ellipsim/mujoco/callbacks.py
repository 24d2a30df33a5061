"""The compiled MuJoCo callbacks: a contact filter and a narrow phase, as numba cfuncs.

mode "filter": `mjcb_contactfilter`.  MuJoCo calls it for every candidate geom pair after its broad
phase, in place of the contype/conaffinity test (engine_collision_driver.c, filterCollisionPair), so
the callback first repeats that test exactly.  Ellipsoid-ellipsoid and sphere-ellipsoid pairs are
then tested on ellipsoids that enclose the bodies MuJoCo collides (each grown by half of margin +
gap + 2 ccd_tolerance: GJK reports contact once the margin-grown bodies are within ccd_tolerance),
and discarded only when a separating axis is certified (certified.separated_by_axes).  No contact
MuJoCo would make is lost, so trajectories are bit-identical.

mode "narrowphase": an mjfCollision for MuJoCo's table mjCOLLISIONFUNC at ellipsoid x ellipsoid and
sphere x ellipsoid (where MuJoCo has mjc_Convex: GJK, then EPA).  It returns no contact for pairs
certified separated beyond the margin, else the signed distance, normal and contact point of
core.distance, filling the mjPreContact as mjc_Convex does (dist, pos, normal; tangent zero:
mj_setContact completes the frame).  A pair whose Newton run does not converge goes to MuJoCo's
original function, and is counted.

Both read geom arrays of whatever (model, data) they are given through struct offsets
(structs.py) and keep no shared mutable state: counters live in per-data arrays of the registry.
"""

import ctypes

import mujoco
import numba
import numpy as np
from numba import carray, types

from ..core._jit import jit
from ..core.certified import separated_by_axes
from ..core.distance import NOT_CONVERGED, pair_signed_distance
from ..core.tolerances import FILTER_CCD_FACTOR, FILTER_RELATIVE_SLACK
from . import structs

SPHERE, ELLIPSOID = int(mujoco.mjtGeom.mjGEOM_SPHERE), int(mujoco.mjtGeom.mjGEOM_ELLIPSOID)
_OVERRIDE = int(mujoco.mjtEnableBit.mjENBL_OVERRIDE)

# Registry of attached datas, read by the callbacks through its address.  Row 0: [highest slot ever
# used, ...]; slots 1..: [mjData address (0: free), counters address, mode, pair buffer address,
# capacity].  A slot's other fields are written before its address and only change while that data
# is detached, and slots never move, so a callback stepping one data never sees another's fields
# half-written (attachment.py writes them under a lock).
MAX_ATTACHED = 256
FILTER, RECORD, NARROW = 1, 2, 3
REGISTRY = np.zeros((MAX_ATTACHED + 1, 5), dtype=np.int64)
# Per-data counters: filter: seen, discarded, passed; narrowphase: calls, separated, contacts,
# fallbacks; record: the number of recorded pairs in slot 3.
NCOUNTERS = 6
_compiled = {}
_NARROW_FN = ctypes.CFUNCTYPE(
    ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int, ctypes.c_int, ctypes.c_double
)


@jit
def _word(addr):
    return carray(structs.i64_pointer(addr), (1,))[0]


@jit
def _ellipsoid(xpos, xmat, size, gtype, g, grow):
    """Geom g as an ellipsoid tuple (vec3.load layout), grown to enclose its `grow`-offset body."""
    c = (xpos[3 * g], xpos[3 * g + 1], xpos[3 * g + 2])
    k = 9 * g
    R = (xmat[k], xmat[k + 1], xmat[k + 2], xmat[k + 3], xmat[k + 4], xmat[k + 5], xmat[k + 6], xmat[k + 7], xmat[k + 8])
    if gtype == SPHERE:
        r = size[3 * g] + grow
        return c, R, (r, r, r)
    r0, r1, r2 = size[3 * g], size[3 * g + 1], size[3 * g + 2]
    s = 1.0 + grow / min(r0, r1, r2)  # E + ball(grow) lies inside E scaled by s about its centre
    return c, R, (r0 * s, r1 * s, r2 * s)


def _compile_callback():
    """The contact filter cfunc, compiled once per process with this build's struct offsets."""
    lay = structs.layout()
    om, od = lay["model"], lay["data"]
    o_type, o_contype, o_conaff = om["geom_type"], om["geom_contype"], om["geom_conaffinity"]
    o_size, o_margin, o_gap = om["geom_size"], om["geom_margin"], om["geom_gap"]
    o_ccd, o_omargin, o_enable = om["opt.ccd_tolerance"], om["opt.o_margin"], om["opt.enableflags"]
    o_xpos, o_xmat = od["geom_xpos"], od["geom_xmat"]
    reg_addr, reg_rows = int(REGISTRY.ctypes.data), REGISTRY.shape[0]

    @numba.cfunc(types.intc(types.voidptr, types.voidptr, types.intc, types.intc), error_model="numpy")
    def contact_filter(m, d, g1, g2):
        ma, da = structs.address(m), structs.address(d)
        n = max(g1, g2) + 1
        contype = carray(structs.i32_pointer(_word(ma + o_contype)), (n,))
        conaff = carray(structs.i32_pointer(_word(ma + o_conaff)), (n,))
        if (contype[g1] & conaff[g2]) == 0 and (contype[g2] & conaff[g1]) == 0:
            return 1  # MuJoCo's own bitmask test, which this callback replaces
        gtype = carray(structs.i32_pointer(_word(ma + o_type)), (n,))
        t1, t2 = gtype[g1], gtype[g2]
        if not ((t1 == ELLIPSOID and (t2 == ELLIPSOID or t2 == SPHERE)) or (t1 == SPHERE and t2 == ELLIPSOID)):
            return 0
        reg = carray(structs.i64_pointer(reg_addr), (reg_rows, 5))
        slot = _slot(reg, da)
        mode = reg[slot, 2] if slot else 0
        if mode != FILTER and mode != RECORD:
            return 0  # a data ellipsim is not attached to in these modes: MuJoCo's own test, as above
        if mode == RECORD:
            i = structs.atomic_add(reg[slot, 1] + 24, 1)  # counters[3]: MuJoCo may run it on threads
            if i < reg[slot, 4]:
                pairs = carray(structs.i32_pointer(reg[slot, 3]), (reg[slot, 4], 2))
                pairs[i, 0] = g1
                pairs[i, 1] = g2
            return 0
        size = carray(structs.f64_pointer(_word(ma + o_size)), (3 * n,))
        margin = carray(structs.f64_pointer(_word(ma + o_margin)), (n,))
        gap = carray(structs.f64_pointer(_word(ma + o_gap)), (n,))
        enable = carray(structs.i32_pointer(ma + o_enable), (1,))[0]
        if enable & _OVERRIDE:
            total = carray(structs.f64_pointer(ma + o_omargin), (1,))[0]
        else:
            total = margin[g1] + margin[g2]
        total = max(total + gap[g1] + gap[g2], 0.0)
        total += FILTER_CCD_FACTOR * carray(structs.f64_pointer(ma + o_ccd), (1,))[0]
        xpos = carray(structs.f64_pointer(_word(da + o_xpos)), (3 * n,))
        xmat = carray(structs.f64_pointer(_word(da + o_xmat)), (9 * n,))
        scale = max(size[3 * g1], size[3 * g1 + 1], size[3 * g1 + 2], size[3 * g2], size[3 * g2 + 1], size[3 * g2 + 2])
        grow = 0.5 * total + FILTER_RELATIVE_SLACK * scale
        A = _ellipsoid(xpos, xmat, size, t1, g1, grow)
        B = _ellipsoid(xpos, xmat, size, t2, g2, grow)
        discard = separated_by_axes(A, B)
        counters = reg[slot, 1]
        structs.atomic_add(counters, 1)
        structs.atomic_add(counters + (8 if discard else 16), 1)
        return 1 if discard else 0

    return contact_filter


def callback():
    """The compiled contact filter (compiled on first use, ~2 s)."""
    if "filter" not in _compiled:
        _compiled["filter"] = _compile_callback()
    return _compiled["filter"]


@jit
def _slot(reg, da):
    """Registry slot of the data at address da, 0 when it is not attached."""
    for k in range(1, reg[0, 0] + 1):
        if reg[k, 0] == da:
            return k
    return 0


def _compile_narrowphase():
    """The mjfCollision cfunc, compiled once per process with this build's struct offsets and
    MuJoCo's original ellipsoid functions (the fallbacks)."""
    lay = structs.layout()
    om, od = lay["model"], lay["data"]
    o_type, o_size = om["geom_type"], om["geom_size"]
    o_xpos, o_xmat = od["geom_xpos"], od["geom_xmat"]
    reg_addr, reg_rows = int(REGISTRY.ctypes.data), REGISTRY.shape[0]
    table, ntypes = structs.collision_table()
    fallback_ee = _NARROW_FN(table[ELLIPSOID * ntypes + ELLIPSOID])
    fallback_se = _NARROW_FN(table[SPHERE * ntypes + ELLIPSOID])

    @numba.cfunc(
        types.intc(types.voidptr, types.voidptr, types.voidptr, types.intc, types.intc, types.float64),
        error_model="numpy",
    )
    def narrowphase(m, d, con, g1, g2, margin):
        ma, da = structs.address(m), structs.address(d)
        n = max(g1, g2) + 1
        gtype = carray(structs.i32_pointer(_word(ma + o_type)), (n,))
        size = carray(structs.f64_pointer(_word(ma + o_size)), (3 * n,))
        xpos = carray(structs.f64_pointer(_word(da + o_xpos)), (3 * n,))
        xmat = carray(structs.f64_pointer(_word(da + o_xmat)), (9 * n,))
        reg = carray(structs.i64_pointer(reg_addr), (reg_rows, 5))
        slot = _slot(reg, da)
        t1, t2 = gtype[g1], gtype[g2]
        if slot == 0 or reg[slot, 2] != NARROW:  # not attached in this mode: MuJoCo's own function
            if t1 == SPHERE:
                return fallback_se(m, d, con, g1, g2, margin)
            return fallback_ee(m, d, con, g1, g2, margin)
        counters = reg[slot, 1]
        structs.atomic_add(counters, 1)
        grow = 0.5 * max(margin, 0.0)
        if separated_by_axes(_ellipsoid(xpos, xmat, size, t1, g1, grow), _ellipsoid(xpos, xmat, size, t2, g2, grow)):
            structs.atomic_add(counters + 8, 1)
            return 0
        status, dist, normal, pos, _ = pair_signed_distance(
            _ellipsoid(xpos, xmat, size, t1, g1, 0.0), _ellipsoid(xpos, xmat, size, t2, g2, 0.0)
        )
        if status == NOT_CONVERGED:
            structs.atomic_add(counters + 32, 1)
            if t1 == SPHERE:
                return fallback_se(m, d, con, g1, g2, margin)
            return fallback_ee(m, d, con, g1, g2, margin)
        if dist >= margin:
            return 0
        c = carray(structs.f64_pointer(structs.address(con)), (10,))  # mjPreContact
        c[0] = dist
        c[1], c[2], c[3] = pos
        c[4], c[5], c[6] = normal
        c[7], c[8], c[9] = 0.0, 0.0, 0.0
        structs.atomic_add(counters + 16, 1)
        return 1

    return narrowphase


def narrowphase_function():
    """The compiled narrow-phase function (compiled on first use, ~2 s)."""
    if "narrowphase" not in _compiled:
        _compiled["narrowphase"] = _compile_narrowphase()
    return _compiled["narrowphase"]
