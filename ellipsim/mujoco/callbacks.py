"""The compiled MuJoCo callbacks: a contact filter and a narrow phase, as numba cfuncs.

mode "filter": `mjcb_contactfilter`.  MuJoCo calls it for every candidate geom pair after its broad
phase, in place of the contype/conaffinity test (engine_collision_driver.c, filterCollisionPair), so
the callback first repeats that test exactly.  Ellipsoid-ellipsoid and sphere-ellipsoid pairs are
then tested on ellipsoids that enclose the bodies MuJoCo collides (each grown by half of margin +
gap + 2 ccd_tolerance: GJK reports contact once the margin-grown bodies are within ccd_tolerance),
and discarded only when a separating axis is certified (certified.separated_by_axes).  No contact
MuJoCo would make is lost, so trajectories are bit-identical.  With speculative contacts on
(mjENBL_SPECULATIVE) no pair is discarded: MuJoCo's conservative advancement runs only for pairs that
reach its narrow phase, and a pair apart now may meet within the step.

mode "record" (geoms.PairRecorder, what validate judges): the same callback keeps every pair, after
MuJoCo's bitmask test, and records those of every row of PAIR_TYPES (ellipsoid with ellipsoid,
sphere, capsule, box or cylinder) in the data's pair buffer.

mode "narrowphase": an mjfCollision for MuJoCo's table mjCOLLISIONFUNC at ellipsoid x ellipsoid,
sphere x ellipsoid, capsule x ellipsoid, ellipsoid x box and ellipsoid x cylinder (where MuJoCo has
mjc_Convex: GJK, then EPA).  It returns no contact for pairs certified separated beyond the margin, else the signed
distance, normal and contact point of core.distance.ellipsoid_pair (core.pairs.capsule, core.pairs.box, core.pairs.cylinder for those),
filling the mjPreContact as mjc_Convex does (dist, pos, normal from g1 to g2; tangent zero:
mj_setContact completes the frame).  The table is indexed type1 <= type2 (engine_collision_driver.c
swaps the pair by type), so the capsule is g1 (its normal is core.pairs.capsule's flipped) and the box or
cylinder is g2.  A pair whose maximum is not proven global (core.distance.ellipsoid_pair UNPROVEN: the branch and
bound's budget ran out, for two ellipsoids or a cylinder's rim; a non-finite result) goes to
MuJoCo's original function, and is counted; for two ellipsoids the contact it makes then carries the
better of MuJoCo's normal and ellipsim's best, sigma evaluated by ellipsim at both (each is a lower
bound on the signed distance), so the answer is never worse than ellipsim's best.

Warm start (issue 13): a data attached in mode "narrowphase" owns a table (attachment.py; layout in
context.py, address and size in its registry row) of each ellipsoid pair's last two normals, in the
world frame, and whether the last call made a contact.  The seed is the last normal extrapolated by
the one before (1.0-1.3 Newton steps on the bench's settled scenes, 2.0 from the last normal, 3.3-3.9
from the bisector).  Every pair is first tried against the centre line (certified_filter.
centre_line_separates), before its slot is read: MuJoCo's bounding spheres leave ~650 such pairs a
step on the 16-figure heap, and the slot is most often a cache miss.  Then a pair in contact at its
last call goes straight to Newton from the seed; another is tried against the bisector of the exit
normals and against sigma along the seed (a direction whose sigma exceeds the margin proves the pair
apart beyond it: distance.sigma_lower_bound).  A pair proven apart by an axis keeps its slot as it
was (only a seed, and whether the bisector is tried next time).  The seed
never decides the proof (distance.pair_signed_distance_from), so warm results meet the cold
contract; the table has epochs (context.py): when the data's time goes back or jumps ahead (a reset,
mj_setState, a rollout's next initial state) the next trajectory starts cold, bit-identical to a
fresh data's; capsule, box and cylinder pairs start cold (a box's local solve starts at its best face
normal).  One data's table is read and written only by calls on that
data.

A data not attached in the callback's mode gets MuJoCo's own answer: the bitmask test, or MuJoCo's
original function.  Both read geom arrays of whatever (model, data) they are given through struct
offsets (structs.py) and keep no shared mutable state: counters live in per-data arrays of the
registry.  They contain no per-process constant: offsets, the registry and MuJoCo's original
functions are read from the context (context.py), so their machine code is cached across processes
(nativecache.py).  This module is imported only to compile them, the first run on a machine.

The cache keys hash this module and every module it imports at module level, transitively
(nativecache.kernel_sources): a jitted function sees only module globals, so that is all its code
depends on.  Imports inside functions here are for the Python side only.
"""

import math
import time

from llvmlite import ir
from numba import carray, types
from numba.core.ccallback import CFunc
from numba.extending import intrinsic

from ..core._jit import jit
from ..core.distance.ellipsoid_pair import GLOBAL, contact_at, pair_signed_distance_from, sigma_lower_bound
from ..core.exact.certified_filter import bisector_separates_pair, centre_line_separates, separated_by_axes
from ..core.pairs import box, capsule, cylinder
from ..core.tolerances import FILTER_CCD_FACTOR, FILTER_RELATIVE_SLACK
from .context import (
    APART,
    BOX,
    CAPSULE,
    CONTACTS,
    CYLINDER,
    DATA_WORDS,
    DISCARDED,
    ELLIPSOID,
    FALLBACK_BOX,
    FALLBACK_CAPSULE,
    FALLBACK_CYLINDER,
    FALLBACK_ELLIPSOID,
    FALLBACK_SPHERE,
    FALLBACKS,
    FILTER,
    MODEL_WORDS,
    NARROW,
    OVERRIDE,
    PAIR_TYPES,
    PASSED,
    PRECONTACT_WORDS,
    RECORD,
    RECORDED,
    REGISTRY_ADDRESS,
    REGISTRY_COLUMNS,
    REGISTRY_ROWS,
    SEEN,
    SEPARATED,
    SPECULATIVE,
    SPHERE,
    SYMBOL,
    WARM_ADDRESS,
    WARM_EPOCH,
    WARM_JUMP,
    WARM_MASK,
    WARM_SLOT_WORDS,
    WARM_TIME,
    WORDS,
)

_TYPE, _CONTYPE, _CONAFF = MODEL_WORDS["geom_type"], MODEL_WORDS["geom_contype"], MODEL_WORDS["geom_conaffinity"]
_SIZE, _MARGIN, _GAP = MODEL_WORDS["geom_size"], MODEL_WORDS["geom_margin"], MODEL_WORDS["geom_gap"]
_CCD, _OMARGIN, _ENABLE = MODEL_WORDS["opt.ccd_tolerance"], MODEL_WORDS["opt.o_margin"], MODEL_WORDS["opt.enableflags"]
_XPOS, _XMAT, _TIME, _STEP = (
    DATA_WORDS["geom_xpos"],
    DATA_WORDS["geom_xmat"],
    DATA_WORDS["time"],
    MODEL_WORDS["opt.timestep"],
)
_DIST, _POS, _NORMAL, _TANGENT = (PRECONTACT_WORDS[k] for k in ("dist", "pos", "normal", "tangent"))

# --- numba intrinsics: the context, typed pointers from addresses, atomics, calls through pointers


@intrinsic
def _context(typingctx):
    """int64* to the context: the address of the external global SYMBOL, resolved at load time."""

    def codegen(context, builder, signature, args):
        return builder.bitcast(_declare_context(builder.module), context.get_value_type(types.CPointer(types.int64)))

    return types.CPointer(types.int64)(), codegen


def _declare_context(module):
    """The declaration (external linkage, no initialiser) of SYMBOL in an LLVM module."""
    return module.globals.get(SYMBOL) or ir.GlobalVariable(module, ir.IntType(64), SYMBOL)


@intrinsic
def address(typingctx, ptr):
    """The integer address of a void pointer."""

    def codegen(context, builder, signature, args):
        return builder.ptrtoint(args[0], context.get_value_type(types.intp))

    return types.intp(types.voidptr), codegen


def _pointer_intrinsic(numba_type):
    @intrinsic
    def pointer(typingctx, addr):
        ptr_type = types.CPointer(numba_type)

        def codegen(context, builder, signature, args):
            return builder.inttoptr(args[0], context.get_value_type(ptr_type))

        return ptr_type(types.intp), codegen

    return pointer


f64_pointer = _pointer_intrinsic(types.float64)
i32_pointer = _pointer_intrinsic(types.int32)
i64_pointer = _pointer_intrinsic(types.int64)


@intrinsic
def atomic_add(typingctx, addr, value):
    """*(int64*)addr += value, atomically (MuJoCo may run one data's collisions on several threads);
    the value before."""

    def codegen(context, builder, signature, args):
        ptr = builder.inttoptr(args[0], ir.PointerType(ir.IntType(64)))
        return builder.atomic_rmw("add", ptr, args[1], "monotonic")

    return types.int64(types.intp, types.int64), codegen


def _collision_type():
    """mjfCollision: int (*)(const mjModel*, const mjData*, mjPreContact*, int, int, mjtNum)."""
    vp = ir.IntType(8).as_pointer()
    return ir.FunctionType(ir.IntType(32), [vp, vp, vp, ir.IntType(32), ir.IntType(32), ir.DoubleType()])


@intrinsic
def call_collision(typingctx, fn, m, d, con, g1, g2, margin):
    """((mjfCollision) fn)(m, d, con, g1, g2, margin)."""

    def codegen(context, builder, signature, args):
        return builder.call(builder.inttoptr(args[0], _collision_type().as_pointer()), list(args[1:]))

    sig = types.intc(types.intp, types.voidptr, types.voidptr, types.voidptr, types.intc, types.intc, types.float64)
    return sig, codegen


# --- the callbacks --------------------------------------------------------------------------------


@jit
def _word(addr):
    return carray(i64_pointer(addr), (1,))[0]


@jit
def _slot(reg, da):
    """Registry slot of the data at address da, 0 when it is not attached."""
    for k in range(1, reg[0, 0] + 1):
        if reg[k, 0] == da:
            return k
    return 0


@jit
def _geom(xpos, xmat, size, g):
    """Geom g as (centre, rotation row-major, geom_size) tuples (vec3.load layout)."""
    c = (xpos[3 * g], xpos[3 * g + 1], xpos[3 * g + 2])
    k = 9 * g
    R = (
        xmat[k],
        xmat[k + 1],
        xmat[k + 2],
        xmat[k + 3],
        xmat[k + 4],
        xmat[k + 5],
        xmat[k + 6],
        xmat[k + 7],
        xmat[k + 8],
    )
    return c, R, (size[3 * g], size[3 * g + 1], size[3 * g + 2])


@jit
def _ellipsoid(xpos, xmat, size, gtype, g, grow):
    """Geom g as an ellipsoid tuple (vec3.load layout), grown to enclose its `grow`-offset body."""
    c, R, (r0, r1, r2) = _geom(xpos, xmat, size, g)
    if gtype == SPHERE:
        r = r0 + grow
        return c, R, (r, r, r)
    if grow == 0.0:
        return c, R, (r0, r1, r2)
    s = 1.0 + grow / min(r0, r1, r2)  # E + ball(grow) lies inside E scaled by s about its centre
    return c, R, (r0 * s, r1 * s, r2 * s)


@jit
def _warm_set(g1, g2, mask):
    """The first slot of the two-slot set of pair (g1, g2) in a table of mask + 1 slots (a power of two):
    a multiplicative hash (g < 2^31 and constants < 2^31: no int64 overflow), folded once."""
    h = g1 * 1540483477 + g2 * 668265261
    h ^= h >> 17
    return (h << 1) & mask


@jit
def _warm_epoch(counters, t, step):
    """The table's epoch for a call at data time t, advanced when t goes back or jumps ahead by more
    than WARM_JUMP timesteps since the table's last read (context.py): a new trajectory starts cold.
    Plain reads and writes: one data is stepped by one thread (mujoco.rollout gives each thread its
    own data); under mju_threadpool two threads may both advance it, which only starts more pairs
    cold (the seed never decides the proof)."""
    words = carray(i64_pointer(counters), (WARM_EPOCH + 1,))
    clock = carray(f64_pointer(counters), (WARM_EPOCH + 1,))
    last = clock[WARM_TIME]
    if t < last or t > last + WARM_JUMP * step:
        words[WARM_EPOCH] += 1
    if t != last:
        clock[WARM_TIME] = t
    return words[WARM_EPOCH]


@jit
def _warm_find(table, first, key, epoch):
    """The slot holding `key` of this epoch in the set starting at `first`, or -1."""
    if table[first, 0] >> 1 == key and table[first, WARM_SLOT_WORDS - 1] == epoch:
        return first
    if table[first + 1, 0] >> 1 == key and table[first + 1, WARM_SLOT_WORDS - 1] == epoch:
        return first + 1
    return -1


@jit
def _warm_store(table, normals, first, k, key, normal, contact, epoch):
    """Write (key, contact, normal) in slot k of its set (its last normal kept as the one before), or,
    k < 0, in a free slot of the set; in a
    full set the entry of the first slot moves to the second (whose entry is dropped: that pair
    starts cold next time).

    MuJoCo runs one data's narrow phase on several threads when the data has a thread pool
    (mju_threadpool; tests/test_warm_start.py): different pairs then write different slots, but
    pairs whose keys share a set can interleave their writes (no lock, no sequence word).  A reader may then
    see one pair's key with a normal made of another's words: only a worse seed, since the result is
    proven whatever the seed (distance.pair_signed_distance_from), and a wrong contact bit only
    chooses whether the separating axes are tried first (both paths are proofs)."""
    if k >= 0:  # the last normal becomes the one before
        normals[k, 4], normals[k, 5], normals[k, 6] = normals[k, 1], normals[k, 2], normals[k, 3]
    else:  # a slot of another epoch is free (as on a fresh table: reruns are bit-identical)
        if table[first, 0] == 0 or table[first, WARM_SLOT_WORDS - 1] != epoch:
            k = first
        elif table[first + 1, 0] == 0 or table[first + 1, WARM_SLOT_WORDS - 1] != epoch:
            k = first + 1
        else:
            for w in range(1, WARM_SLOT_WORDS):
                normals[first + 1, w] = normals[first, w]
            table[first + 1, 0] = table[first, 0]
            k = first
        normals[k, 4], normals[k, 5], normals[k, 6] = normal  # a new entry: no motion yet
    normals[k, 1], normals[k, 2], normals[k, 3] = normal
    table[k, WARM_SLOT_WORDS - 1] = epoch
    table[k, 0] = (key << 1) | (1 if contact else 0)


def contact_filter(m, d, g1, g2):
    ctx = carray(_context(), (WORDS,))
    ma, da = address(m), address(d)
    n = max(g1, g2) + 1
    contype = carray(i32_pointer(_word(ma + ctx[_CONTYPE])), (n,))
    conaff = carray(i32_pointer(_word(ma + ctx[_CONAFF])), (n,))
    if (contype[g1] & conaff[g2]) == 0 and (contype[g2] & conaff[g1]) == 0:
        return 1  # MuJoCo's own bitmask test, which this callback replaces
    gtype = carray(i32_pointer(_word(ma + ctx[_TYPE])), (n,))
    t1, t2 = gtype[g1], gtype[g2]  # in either order: the rows of context.PAIR_TYPES (tests/test_pair_table.py)
    other = t2 if t1 == ELLIPSOID else (t1 if t2 == ELLIPSOID else -1)
    if other != ELLIPSOID and other != SPHERE and other != CAPSULE and other != BOX and other != CYLINDER:
        return 0
    reg = carray(i64_pointer(ctx[REGISTRY_ADDRESS]), (ctx[REGISTRY_ROWS], REGISTRY_COLUMNS))
    slot = _slot(reg, da)
    mode = reg[slot, 2] if slot else 0
    if mode != FILTER and mode != RECORD:
        return 0  # a data ellipsim is not attached to in these modes: MuJoCo's own test, as above
    if mode == FILTER and other != ELLIPSOID and other != SPHERE:
        return 0  # the filter tests context.FILTER_PAIR_TYPES; "record" records every row of PAIR_TYPES
    if mode == RECORD:
        i = atomic_add(reg[slot, 1] + 8 * RECORDED, 1)
        if i < reg[slot, 4]:
            pairs = carray(i32_pointer(reg[slot, 3]), (reg[slot, 4], 2))
            pairs[i, 0] = g1
            pairs[i, 1] = g2
        return 0
    size = carray(f64_pointer(_word(ma + ctx[_SIZE])), (3 * n,))
    margin = carray(f64_pointer(_word(ma + ctx[_MARGIN])), (n,))
    gap = carray(f64_pointer(_word(ma + ctx[_GAP])), (n,))
    enable = carray(i32_pointer(ma + ctx[_ENABLE]), (1,))[0]
    counters = reg[slot, 1]
    if enable & SPECULATIVE:
        # speculative contacts: MuJoCo runs its conservative advancement only for pairs that reach
        # its narrow phase; a pair proven apart now may still meet within the step, so none is
        # discarded (issue 18: a 50 m/s ellipsoid tunnelled through a thin plate otherwise)
        atomic_add(counters + 8 * SEEN, 1)
        atomic_add(counters + 8 * PASSED, 1)
        return 0
    if enable & OVERRIDE:
        total = carray(f64_pointer(ma + ctx[_OMARGIN]), (1,))[0]
    else:
        total = margin[g1] + margin[g2]
    total = max(total + gap[g1] + gap[g2], 0.0)
    total += FILTER_CCD_FACTOR * carray(f64_pointer(ma + ctx[_CCD]), (1,))[0]
    xpos = carray(f64_pointer(_word(da + ctx[_XPOS])), (3 * n,))
    xmat = carray(f64_pointer(_word(da + ctx[_XMAT])), (9 * n,))
    scale = max(size[3 * g1], size[3 * g1 + 1], size[3 * g1 + 2], size[3 * g2], size[3 * g2 + 1], size[3 * g2 + 2])
    grow = 0.5 * total + FILTER_RELATIVE_SLACK * scale
    A = _ellipsoid(xpos, xmat, size, t1, g1, grow)
    B = _ellipsoid(xpos, xmat, size, t2, g2, grow)
    discard = separated_by_axes(A, B)
    atomic_add(counters + 8 * SEEN, 1)
    atomic_add(counters + 8 * (DISCARDED if discard else PASSED), 1)
    return 1 if discard else 0


def narrowphase(m, d, con, g1, g2, margin):
    """Two ellipsoids (or a sphere and an ellipsoid) first against their centre line, which ends most
    calls (772 of the 965 candidate pairs of the settled 16-figure heap); every other call in
    _narrow_pair.  Kept small: with the whole narrow phase in one function its prologue cost ~7 ns a
    call, a quarter of such a pair's 26 ns in the bench's compiled loop (issue 23)."""
    ctx = carray(_context(), (WORDS,))
    ma, da = address(m), address(d)
    reg = carray(i64_pointer(ctx[REGISTRY_ADDRESS]), (ctx[REGISTRY_ROWS], REGISTRY_COLUMNS))
    slot = _slot(reg, da)
    if slot == 0 or reg[slot, 2] != NARROW:
        return _narrow_pair(m, d, con, g1, g2, margin)
    n = max(g1, g2) + 1
    gtype = carray(i32_pointer(_word(ma + ctx[_TYPE])), (n,))
    t1, t2 = gtype[g1], gtype[g2]
    if t2 != ELLIPSOID or (t1 != ELLIPSOID and t1 != SPHERE):
        return _narrow_pair(m, d, con, g1, g2, margin)
    size = carray(f64_pointer(_word(ma + ctx[_SIZE])), (3 * n,))
    xpos = carray(f64_pointer(_word(da + ctx[_XPOS])), (3 * n,))
    xmat = carray(f64_pointer(_word(da + ctx[_XMAT])), (9 * n,))
    grow = 0.5 * max(margin, 0.0)  # most separated pairs (MuJoCo's bounding spheres overlap): before the
    # warm-start table is read, its slot a likely cache miss
    if centre_line_separates(_ellipsoid(xpos, xmat, size, t1, g1, grow), _ellipsoid(xpos, xmat, size, t2, g2, grow)):
        atomic_add(reg[slot, 1] + 8 * SEPARATED, 1)
        return 0
    return _narrow_pair(m, d, con, g1, g2, margin)


@jit
def _narrow_pair(m, d, con, g1, g2, margin):
    """The narrow phase (narrowphase) of a pair not two ellipsoids, or whose centre line did not prove
    them apart."""
    ctx = carray(_context(), (WORDS,))
    ma, da = address(m), address(d)
    n = max(g1, g2) + 1
    gtype = carray(i32_pointer(_word(ma + ctx[_TYPE])), (n,))
    size = carray(f64_pointer(_word(ma + ctx[_SIZE])), (3 * n,))
    xpos = carray(f64_pointer(_word(da + ctx[_XPOS])), (3 * n,))
    xmat = carray(f64_pointer(_word(da + ctx[_XMAT])), (9 * n,))
    reg = carray(i64_pointer(ctx[REGISTRY_ADDRESS]), (ctx[REGISTRY_ROWS], REGISTRY_COLUMNS))
    slot = _slot(reg, da)
    t1, t2 = gtype[g1], gtype[g2]  # the rows of context.PAIR_TYPES, written out (tests/test_pair_table.py)
    if t1 == CAPSULE:
        original = ctx[FALLBACK_CAPSULE]
    elif t2 == BOX:
        original = ctx[FALLBACK_BOX]
    elif t2 == CYLINDER:
        original = ctx[FALLBACK_CYLINDER]
    else:
        original = ctx[FALLBACK_SPHERE] if t1 == SPHERE else ctx[FALLBACK_ELLIPSOID]
    if slot == 0 or reg[slot, 2] != NARROW:  # not attached in this mode: MuJoCo's own function
        return call_collision(original, m, d, con, g1, g2, margin)
    counters = reg[slot, 1]
    if t1 == CAPSULE:  # g1 the capsule, g2 the ellipsoid
        E, K = _ellipsoid(xpos, xmat, size, t2, g2, 0.0), _geom(xpos, xmat, size, g1)
        if capsule.centre_line_bound(E, K) >= margin:  # a direction proves them apart beyond the margin
            atomic_add(counters + 8 * SEPARATED, 1)
            return 0
        _, dist, away, pos, _ = capsule.capsule_ellipsoid(E, K)  # CERTIFIED or ENUMERATED: both proven
        proven = math.isfinite(dist)
        normal = (-away[0], -away[1], -away[2])  # from the capsule (g1) to the ellipsoid (g2)
    elif t2 == BOX:  # g1 the ellipsoid, g2 the box
        E, K = _ellipsoid(xpos, xmat, size, t1, g1, 0.0), _geom(xpos, xmat, size, g2)
        if box.centre_line_bound(E, K) >= margin:
            atomic_add(counters + 8 * SEPARATED, 1)
            return 0
        _, dist, normal, pos, _ = box.box_ellipsoid(E, K)  # CERTIFIED or ENUMERATED: both proven
        proven = math.isfinite(dist)
    elif t2 == CYLINDER:  # g1 the ellipsoid, g2 the cylinder
        E, K = _ellipsoid(xpos, xmat, size, t1, g1, 0.0), _geom(xpos, xmat, size, g2)
        if cylinder.centre_line_bound(E, K) >= margin:
            atomic_add(counters + 8 * SEPARATED, 1)
            return 0
        status, dist, normal, pos, _ = cylinder.cylinder_ellipsoid(E, K)
        proven = status != cylinder.UNPROVEN and math.isfinite(dist)
    else:
        A, B = _ellipsoid(xpos, xmat, size, t1, g1, 0.0), _ellipsoid(xpos, xmat, size, t2, g2, 0.0)
        grow = 0.5 * max(margin, 0.0)
        Ag, Bg = A, B
        if grow > 0.0:
            Ag, Bg = _ellipsoid(xpos, xmat, size, t1, g1, grow), _ellipsoid(xpos, xmat, size, t2, g2, grow)
        # (their centre line: narrowphase)
        # the pair's entry in this data's warm-start table (context.WARM_SLOT_WORDS): its normal of
        # the last call, and whether that call made a contact
        mask = reg[slot, WARM_MASK]
        key, first, k, epoch = (g1 << 32) | g2, 0, -1, 0
        seed, touching = (0.0, 0.0, 0.0), False
        table = carray(i64_pointer(reg[slot, WARM_ADDRESS]), (mask + 1, WARM_SLOT_WORDS))
        normals = carray(f64_pointer(reg[slot, WARM_ADDRESS]), (mask + 1, WARM_SLOT_WORDS))
        if mask:
            t = carray(f64_pointer(da + ctx[_TIME]), (1,))[0]
            epoch = _warm_epoch(counters, t, carray(f64_pointer(ma + ctx[_STEP]), (1,))[0])
            first = _warm_set(g1, g2, mask)
            k = _warm_find(table, first, key, epoch)
            if k >= 0:  # the last normal extrapolated by the one before (smooth motion: 1.0-1.3
                # Newton steps on the bench's settled scenes, 2.0 from the last normal alone)
                last, before = (
                    (normals[k, 1], normals[k, 2], normals[k, 3]),
                    (normals[k, 4], normals[k, 5], normals[k, 6]),
                )
                seed = (2.0 * last[0] - before[0], 2.0 * last[1] - before[1], 2.0 * last[2] - before[2])
                touching = (table[k, 0] & 1) == 1
        if not touching:  # in contact at the last call: most likely still, go straight to Newton
            if bisector_separates_pair(Ag, Bg):
                atomic_add(counters + 8 * SEPARATED, 1)
                return 0
            if k >= 0 and sigma_lower_bound(A, B, seed) >= margin:  # the last normal proves it apart
                atomic_add(counters + 8 * SEPARATED, 1)
                return 0
        status, dist, normal, pos, _ = pair_signed_distance_from(A, B, seed)
        proven = status == GLOBAL
        if mask and proven:
            _warm_store(table, normals, first, k, key, normal, dist < margin, epoch)
        if not proven and math.isfinite(dist):
            # no proof (nearly parallel spheroids, tilted by 1e-12-0.1 rad): MuJoCo's function runs, and
            # the answer is the better of its normal and ellipsim's, sigma evaluated by ellipsim at both
            # (each a lower bound on the signed distance), so never worse than either; counted
            atomic_add(counters + 8 * FALLBACKS, 1)
            made = call_collision(original, m, d, con, g1, g2, margin)
            if made == 0:
                return 0  # MuJoCo makes no contact: none is dropped that it would have made
            c = carray(f64_pointer(address(con)), (_TANGENT + 3,))
            v, nv, pv = contact_at(A, B, (c[_NORMAL], c[_NORMAL + 1], c[_NORMAL + 2]))
            if v > dist:
                dist, normal, pos = v, nv, pv
            if dist >= margin:
                return 0  # ellipsim's lower bound already puts them apart beyond the margin
            c[_DIST] = dist
            c[_POS], c[_POS + 1], c[_POS + 2] = pos
            c[_NORMAL], c[_NORMAL + 1], c[_NORMAL + 2] = normal
            c[_TANGENT], c[_TANGENT + 1], c[_TANGENT + 2] = 0.0, 0.0, 0.0
            return 1
    if not proven:  # no proof that this is the global maximum: MuJoCo's own answer, counted
        atomic_add(counters + 8 * FALLBACKS, 1)
        return call_collision(original, m, d, con, g1, g2, margin)
    if dist >= margin:
        atomic_add(counters + 8 * APART, 1)
        return 0
    c = carray(f64_pointer(address(con)), (_TANGENT + 3,))  # mjPreContact
    c[_DIST] = dist
    c[_POS], c[_POS + 1], c[_POS + 2] = pos
    c[_NORMAL], c[_NORMAL + 1], c[_NORMAL + 2] = normal
    c[_TANGENT], c[_TANGENT + 1], c[_TANGENT + 2] = 0.0, 0.0, 0.0
    atomic_add(counters + 8 * CONTACTS, 1)
    return 1


#: kind -> (Python function, numba signature)
CALLBACKS = {
    "filter": (contact_filter, types.intc(types.voidptr, types.voidptr, types.intc, types.intc)),
    "narrowphase": (
        narrowphase,
        types.intc(types.voidptr, types.voidptr, types.voidptr, types.intc, types.intc, types.float64),
    ),
}


# --- compiling them into self-contained machine code ----------------------------------------------


def _geom_int(builder, ctx, m, field_word, g):
    """IR: ((int*) *(int64*)(m + ctx[field_word]))[g], the int geom array at word `field_word` of
    the context, of mjModel m, at geom g."""
    i64 = ir.IntType(64)
    offset = builder.load(builder.gep(ctx, [ir.Constant(ir.IntType(32), field_word)]))
    field = builder.inttoptr(builder.add(builder.ptrtoint(m, i64), offset), i64.as_pointer())
    array = builder.inttoptr(builder.load(field), ir.IntType(32).as_pointer())
    return builder.load(builder.gep(array, [g]))


def _wrapper_for(kind, pyfunc, original):
    """A replacement for numba's cfunc wrapper (CPUContext.create_cfunc_wrapper) for `pyfunc` only.

    numba's wrapper answers an error status by taking the GIL and calling PyErr_WriteUnraisable,
    which puts numba's C helpers and the Python C API into the object code.  This one answers as
    MuJoCo would without ellipsim: the filter with MuJoCo's bitmask test, the narrow phase by calling
    MuJoCo's original function from the context.  The object then references only the context
    symbol, numba_frexp / numba_ldexp (vec3.unit_scale) and NRT_MemInfo_call_dtor (an unused
    NRT_decref), whatever numba's or Python's version.  (With error_model "numpy" and no bounds
    checks the kernels never return an error status; the path exists because the wrapper must.)
    """

    def create_cfunc_wrapper(library, fndesc, env, call_helper):
        if fndesc.qualname != pyfunc.__qualname__ or fndesc.modname != pyfunc.__module__:
            return original(library, fndesc, env, call_helper)  # a callee compiled on the way
        target = _target_context()
        module = target.create_module("ellipsim_cfunc_wrapper")
        callee = ir.Function(
            module, target.call_conv.get_function_type(fndesc.restype, fndesc.argtypes), fndesc.llvm_func_name
        )
        argtys = [target.get_value_type(ty) for ty in fndesc.argtypes]
        wrapty = ir.FunctionType(target.get_value_type(fndesc.restype), argtys)
        wrapfn = ir.Function(module, wrapty, fndesc.llvm_cfunc_wrapper_name)
        builder = ir.IRBuilder(wrapfn.append_basic_block("entry"))
        status, out = target.call_conv.call_function(
            builder, callee, fndesc.restype, fndesc.argtypes, wrapfn.args, attrs=("noinline",)
        )
        with builder.if_then(status.is_error, likely=False):
            ctx = _declare_context(module)
            m, (g1, g2) = wrapfn.args[0], (wrapfn.args[3:5] if kind == "narrowphase" else wrapfn.args[2:4])
            if kind == "filter":  # discard exactly when MuJoCo's contype/conaffinity test would
                ct1, ct2 = (_geom_int(builder, ctx, m, _CONTYPE, g) for g in (g1, g2))
                ca1, ca2 = (_geom_int(builder, ctx, m, _CONAFF, g) for g in (g1, g2))
                both = builder.or_(builder.and_(ct1, ca2), builder.and_(ct2, ca1))
                builder.ret(
                    builder.zext(builder.icmp_signed("==", both, ir.Constant(ir.IntType(32), 0)), ir.IntType(32))
                )
            else:  # MuJoCo's own function for this pair: the fallback word of its row of PAIR_TYPES
                t1, t2 = _geom_int(builder, ctx, m, _TYPE, g1), _geom_int(builder, ctx, m, _TYPE, g2)
                i32 = ir.IntType(32)
                word = ir.Constant(i32, PAIR_TYPES[0].fallback)
                for row in PAIR_TYPES[1:]:
                    match = builder.and_(
                        builder.icmp_signed("==", t1, ir.Constant(i32, row.type1)),
                        builder.icmp_signed("==", t2, ir.Constant(i32, row.type2)),
                    )
                    word = builder.select(match, ir.Constant(i32, row.fallback), word)
                fn = builder.inttoptr(builder.load(builder.gep(ctx, [word])), _collision_type().as_pointer())
                builder.ret(builder.call(fn, list(wrapfn.args)))
        builder.ret(out)
        library.add_ir_module(module)

    return create_cfunc_wrapper


def _target_context():
    from numba.core.registry import cpu_target

    return cpu_target.target_context


class CompiledCode:
    """A callback compiled in this process: its address, its object code, the symbols the code needs."""

    def __init__(self, kind, cfunc, seconds):
        self.kind, self.seconds, self._cfunc = kind, seconds, cfunc  # the CFunc keeps the code alive
        self.address, self.symbol = cfunc.address, cfunc.native_name
        library = cfunc._library
        self.object_code = library._get_compiled_object()
        module = library._final_module
        undefined = {f.name for f in module.functions if f.is_declaration and not f.name.startswith("llvm.")}
        self.undefined = sorted(undefined | {g.name for g in module.global_variables if g.is_declaration})


def compile_callback(kind, pyfunc=None):
    """Compile callback `kind` ("filter" or "narrowphase") with numba for this process's target
    (NUMBA_CPU_NAME / NUMBA_CPU_FEATURES honoured): a CompiledCode.  pyfunc: another function with
    that callback's signature and wrapper (tests).  ~50 s for the narrow phase, ~2 s for the
    filter, from an empty numba cache on the 2-core VM (ellipsim/app/bench/startup.py)."""
    from numba.core.compiler_lock import global_compiler_lock

    from . import publish

    publish.publish_context()  # numba links the code now: SYMBOL must resolve
    t0 = time.perf_counter()
    default, sig = CALLBACKS[kind]
    pyfunc = pyfunc or default
    cfunc = CFunc(pyfunc, (sig.args, sig.return_type), locals={}, options={"error_model": "numpy", "fastmath": False})
    target = _target_context()
    with global_compiler_lock:  # the replaced wrapper is seen by this compile only
        target.create_cfunc_wrapper = _wrapper_for(kind, pyfunc, target.create_cfunc_wrapper)
        try:
            cfunc.compile()
        finally:
            del target.create_cfunc_wrapper  # the instance attribute: the class's method shows again
    return CompiledCode(kind, cfunc, time.perf_counter() - t0)
