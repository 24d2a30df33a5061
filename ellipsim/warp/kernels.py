"""The ellipsoid narrow phase as Warp functions and one kernel over all worlds and pairs (capsule x
ellipsoid, ellipsoid x box and ellipsoid x cylinder pairs go to capsule.py's, box.py's and cylinder.py's
ports of core/pairs; the rest of this docstring is about the ellipsoid and sphere pairs).

A float64 port of core/distance/sphere_newton.py and the shallow-contact proof of
core/distance/ellipsoid_pair.py (the thesis' support-function formulation: the signed distance is the
maximum over unit n of sigma(n) = n.(c_B - c_A) - h_A(n) - h_B(-n), h(n) = |diag(r) R^T n|, Schneider &
Eberly 10.5.2), same operations in the same order, on the float32 poses MuJoCo Warp holds widened to
float64, float32 out.

Reading of a pose (the issue's choice): as the CPU narrow phase reads it.  R_A^T takes the pair into
A's frame (e = R_A^T d, U = R_A^T R_B) and B's support function is |diag(r_B) U^T n|: the float32
geom_xmat widened exactly, used as given, not orthonormalised; so on the same widened poses this kernel
and `ellipsim.signed_distance` compute the same maximum (tests/test_warp.py compares them).

Proofs, as in ellipsoid_pair.pair_signed_distance: a converged Newton run is the global maximum when
sigma > 0 (sigma is concave on the ball) or when the depth is below rho = rolling_radius(A) +
rolling_radius(B).  Deeper pairs, and runs that do not converge, go to the CPU's branch and bound over
the sphere (branch_and_bound.py, a port of core/distance/branch_and_bound.py, bit-identical to it),
seeded with the first run, with ellipsoid_pair._pair's tolerances.  Where it runs out of its budget
(flat or non-isolated maxima, e.g. nearly concentric coaxial spheroids, which the CPU hands to
core/distance/spheroids.py, not ported), the better of its incumbent and 13 Newton runs, status
UNPROVEN, counted (Attachment.counters), never reported as proven.  Any sigma(n) is a lower bound on
the distance, so a pair left without a contact (dist >= margin + gap) is separated beyond margin + gap
whatever the status.

No allocation, no host synchronisation: fixed-size locals only (Warp kernels cannot allocate), one
launch per call, counters by atomics into arrays allocated once at attach.
"""

import numpy as np
import warp as wp

from ..core.tolerances import BB_FRAME_ULPS, BB_MAX_PATCHES, BB_TOL_REL, BB_TOL_ULPS, FIRST_RUN_ITER, NEWTON_MAX_ITER, U
from .box import box_ellipsoid
from .branch_and_bound import GLOBAL as BB_GLOBAL
from .branch_and_bound import SEPARATED_MAX as BB_SEPARATED_MAX
from .branch_and_bound import global_max
from .capsule import capsule_ellipsoid
from .cylinder import cylinder_ellipsoid
from .point_ellipsoid import _max3, _min3
from .sphere_newton import APART, CONVERGED, _unit, newton, sigma

F64 = wp.float64

#: Newton's limits (core/tolerances.py; the step tolerance is sphere_newton.py's).
MAX_ITER = NEWTON_MAX_ITER
FOUR_U = 4.0 * U
BB_TOL_ULPS_U = BB_TOL_ULPS * U
BB_FRAME_ULPS_U = BB_FRAME_ULPS * U

#: MuJoCo's mjtGeom codes of the types the kernel reads.
SPHERE, CAPSULE, ELLIPSOID, CYLINDER, BOX = 2, 3, 4, 5, 6
TYPE_NAMES = ("SPHERE", "CAPSULE", "ELLIPSOID", "CYLINDER", "BOX")

#: Per pair: the maximum proven global, or not (the best of the 13 runs), or proven at least the cutoff
#: (APART: dist is then sigma at some n, a lower bound, not the distance).
GLOBAL, UNPROVEN = 0, 1

#: How one Newton run ended (sphere_newton.py), or APART: stopped at a lower bound beyond the cutoff.
#: (sphere_newton's CONVERGED, NOT_CONVERGED, APART; APART is also the pair status above: 2)
assert (CONVERGED, APART) == (0, GLOBAL + 2)

#: Candidate pairs per thread of the contact kernel (launch: (nworld, ceil(npairs / per thread))), per
#: device kind.  On Warp's CPU device each thread costs ~20-30 ns of its own, and most candidates are
#: culled in a few loads: 16 per thread took the 16-figure heap's launch (16 worlds x 28456 pairs) from
#: 16.3 to 6.0 ms here.  On CUDA one per thread (not measured here: no GPU on this machine).
PAIRS_PER_THREAD = {"cpu": 16, "cuda": 1}

#: The counters' slots (Attachment.counters names them).
C_PAIRS, C_CONTACTS, C_UNPROVEN, C_OVERFLOW, C_DEEP = 0, 1, 2, 3, 4
NCOUNTERS = 5


@wp.func
def _bisector_seed(e: wp.vec3d, a2: wp.vec3d, U: wp.mat33d, rb2: wp.vec3d) -> wp.vec3d:
    """The bisector of Q_A d and Q_B d in A's frame (sphere_newton.bisector_seed)."""
    na = wp.vec3d(e[0] * a2[1] * a2[2], e[1] * a2[0] * a2[2], e[2] * a2[0] * a2[1])
    z = wp.transpose(U) * e
    nb = U * wp.vec3d(z[0] * rb2[1] * rb2[2], z[1] * rb2[0] * rb2[2], z[2] * rb2[0] * rb2[1])
    la = wp.sqrt(wp.dot(na, na))
    lb = wp.sqrt(wp.dot(nb, nb))
    return _unit(na * lb + nb * la)


@wp.func
def _rolling_radius(r: wp.vec3d) -> wp.float64:
    lo = wp.min(r[0], wp.min(r[1], r[2]))
    hi = wp.max(r[0], wp.max(r[1], r[2]))
    return lo * lo / hi


@wp.func
def _rotation_defect(R: wp.mat33d) -> wp.float64:
    """max_ij |(R^T R - I)_ij| (vec3.rotation_defect)."""
    d = F64(0.0)
    for i in range(3):
        for j in range(i, 3):
            v = R[0, i] * R[0, j] + R[1, i] * R[1, j] + R[2, i] * R[2, j]
            if i == j:
                v = v - F64(1.0)
            d = wp.max(d, wp.abs(v))
    return d


@wp.func
def _widen3(v: wp.vec3) -> wp.vec3d:
    return wp.vec3d(F64(v[0]), F64(v[1]), F64(v[2]))


@wp.func
def _radii(geom_type: int, size: wp.vec3) -> wp.vec3d:
    """The semi-axes of an ellipsoid geom, or (r, r, r) for a sphere (size (r, 0, 0))."""
    if geom_type == SPHERE:
        return wp.vec3d(F64(size[0]), F64(size[0]), F64(size[0]))
    return _widen3(size)


@wp.func
def _widen33(R: wp.mat33) -> wp.mat33d:
    return wp.mat33d(
        F64(R[0, 0]), F64(R[0, 1]), F64(R[0, 2]),
        F64(R[1, 0]), F64(R[1, 1]), F64(R[1, 2]),
        F64(R[2, 0]), F64(R[2, 1]), F64(R[2, 2]),
    )  # fmt: skip


@wp.func
def _axis(k: int) -> wp.vec3d:
    """+e_k for k < 3, -e_(k-3) for k from 3 to 5."""
    v = wp.vec3d(F64(0.0), F64(0.0), F64(0.0))
    if k < 3:
        v[k] = F64(1.0)
    else:
        v[k - 3] = F64(-1.0)
    return v


@wp.func
def _sandwich(R: wp.mat33d, w: wp.vec3d) -> wp.mat33d:
    """R diag(w) R^T, symmetric, in vec3.sandwich's order of operations."""
    s00 = R[0, 0] * R[0, 0] * w[0] + R[0, 1] * R[0, 1] * w[1] + R[0, 2] * R[0, 2] * w[2]
    s01 = R[0, 0] * R[1, 0] * w[0] + R[0, 1] * R[1, 1] * w[1] + R[0, 2] * R[1, 2] * w[2]
    s02 = R[0, 0] * R[2, 0] * w[0] + R[0, 1] * R[2, 1] * w[1] + R[0, 2] * R[2, 2] * w[2]
    s11 = R[1, 0] * R[1, 0] * w[0] + R[1, 1] * R[1, 1] * w[1] + R[1, 2] * R[1, 2] * w[2]
    s12 = R[1, 0] * R[2, 0] * w[0] + R[1, 1] * R[2, 1] * w[1] + R[1, 2] * R[2, 2] * w[2]
    s22 = R[2, 0] * R[2, 0] * w[0] + R[2, 1] * R[2, 1] * w[1] + R[2, 2] * R[2, 2] * w[2]
    return wp.mat33d(s00, s01, s02, s01, s11, s12, s02, s12, s22)


@wp.func
def ellipsoid_pair(
    ca: wp.vec3d, Ra: wp.mat33d, ra: wp.vec3d, cb: wp.vec3d, Rb: wp.mat33d, rb: wp.vec3d, cutoff: wp.float64
):
    """(status, dist, normal from A to B, pos, deep) of two ellipsoids in world coordinates, float64
    (ellipsoid_pair.pair_signed_distance's shallow path; module docstring for the rest).  cutoff: where
    sigma at an iterate reaches it the pair is proven at least that far apart and the search stops
    (status APART, dist that lower bound); +inf (1e300) for the distance itself."""
    d = cb - ca
    RaT = wp.transpose(Ra)
    e = RaT * d
    U = RaT * Rb
    a2 = wp.cw_mul(ra, ra)
    rb2 = wp.cw_mul(rb, rb)
    M = _sandwich(U, rb2)
    scale = wp.max(wp.max(ra[0], wp.max(ra[1], ra[2])), wp.max(rb[0], wp.max(rb[1], rb[2])))
    rho = _rolling_radius(ra) + _rolling_radius(rb)
    n, value, run = newton(_bisector_seed(e, a2, U, rb2), e, a2, M, scale, FIRST_RUN_ITER, cutoff)
    status = GLOBAL
    deep = 0
    if run == APART:
        return APART, value, Ra * n, ca, deep
    if not (run == CONVERGED and value >= -rho):
        # deep, or the first run stalled: the CPU's branch and bound over the sphere, seeded with the first
        # run (ellipsoid_pair._pair's tolerances, A's rotation defect included)
        deep = 1
        rmin = wp.min(_min3(ra), _min3(rb))
        S = wp.sqrt(wp.dot(e, e)) + _max3(ra) + _max3(rb)
        delta = _rotation_defect(Ra) + F64(FOUR_U)
        tol = wp.max(F64(BB_TOL_REL) * rmin, (F64(BB_TOL_ULPS_U) + F64(6.0) * delta) * S)
        tol_bb = tol - (F64(BB_FRAME_ULPS_U) + F64(6.0) * delta) * S
        bb, m, v, _count, _runs = global_max(n, value, run == CONVERGED, e, ra, U, rb, M, scale, tol_bb, BB_MAX_PATCHES)
        if bb == BB_GLOBAL or bb == BB_SEPARATED_MAX:
            n = m
            value = v
        else:
            # out of budget (flat or non-isolated maxima: spheroids, whose 1-D and 2-D branch and bounds
            # (core/distance/spheroids.py) are not ported): the better of its incumbent and 13 Newton runs
            # (the bisector and the six axis directions of each body), unproven
            status = UNPROVEN
            best = sigma(m, e, a2, M)
            n = m
            for k in range(12):
                axis = _axis(k % 6)
                if k >= 6:
                    axis = _unit(U * axis)  # B's axes, in A's frame (U is float32-orthonormal only: normalised)
                m2, v2, r2 = newton(axis, e, a2, M, scale, MAX_ITER, cutoff)
                v2 = sigma(m2, e, a2, M)
                if r2 == APART:
                    return APART, v2, Ra * m2, ca, deep
                if v2 > best:
                    best = v2
                    n = m2
            value = best
    # the support points and their midpoint (ellipsoid_pair._contact_at), sigma recomputed at n
    x = wp.cw_mul(ra, n)
    w = wp.transpose(U) * n
    y = wp.cw_mul(rb, w)
    ha = wp.sqrt(wp.dot(x, x))
    hb = wp.sqrt(wp.dot(y, y))
    value = wp.dot(n, e) - ha - hb
    inv = F64(0.5) / (ha * hb)
    ia = hb * inv
    ib = ha * inv
    bp = U * wp.cw_mul(rb, y)
    mid = wp.cw_mul(ra, x) * ia + e * F64(0.5) - bp * ib
    return status, value, Ra * n, ca + Ra * mid, deep


_KERNELS = {}


def contact_kernel(enable_sleep, incremental, per_thread):
    """The kernel over (world, ellipsim pair) for one choice of MuJoCo Warp's sleeping flags (as its
    _nxn_broadphase is specialised) and of pairs per thread; built once per process per choice, shared
    by every attachment (it holds code only; each launch passes its model's arrays)."""
    key = (bool(enable_sleep), bool(incremental), int(per_thread))
    if key in _KERNELS:
        return _KERNELS[key]
    from mujoco_warp._src.collision_core import contact_margin_gap, contact_material_params
    from mujoco_warp._src.math import make_frame
    from mujoco_warp._src.types import ContactType, SleepState, vec5

    @wp.kernel(module="unique", enable_backward=False)
    def ellipsim_contacts(
        # the attachment's pair table
        pair_geom: wp.array[wp.vec2i],
        pair_id: wp.array[wp.vec2i],
        # Model:
        geom_type: wp.array[int],
        geom_bodyid: wp.array[int],
        geom_size: wp.array2d[wp.vec3],
        geom_rbound: wp.array2d[float],
        geom_condim: wp.array[int],
        geom_priority: wp.array[int],
        geom_solmix: wp.array2d[float],
        geom_solref: wp.array2d[wp.vec2],
        geom_solimp: wp.array2d[vec5],
        geom_friction: wp.array2d[wp.vec3],
        geom_margin: wp.array2d[float],
        geom_gap: wp.array2d[float],
        geom_adhesion: wp.array2d[float],
        pair_dim: wp.array[int],
        pair_solref: wp.array2d[wp.vec2],
        pair_solreffriction: wp.array2d[wp.vec2],
        pair_solimp: wp.array2d[vec5],
        pair_margin: wp.array2d[float],
        pair_gap: wp.array2d[float],
        pair_adhesion: wp.array2d[float],
        pair_friction: wp.array2d[vec5],
        # Data in:
        geom_xpos_in: wp.array2d[wp.vec3],
        geom_xmat_in: wp.array2d[wp.mat33],
        body_awake_in: wp.array2d[int],
        body_awake_prev_in: wp.array2d[int],
        naconmax_in: int,
        # Data out:
        contact_dist_out: wp.array[float],
        contact_pos_out: wp.array[wp.vec3],
        contact_frame_out: wp.array[wp.mat33],
        contact_includemargin_out: wp.array[float],
        contact_friction_out: wp.array[vec5],
        contact_solref_out: wp.array[wp.vec2],
        contact_solreffriction_out: wp.array[wp.vec2],
        contact_solimp_out: wp.array[vec5],
        contact_dim_out: wp.array[int],
        contact_geom_out: wp.array[wp.vec2i],
        contact_efc_address_out: wp.array2d[int],
        contact_worldid_out: wp.array[int],
        contact_type_out: wp.array[int],
        contact_geomcollisionid_out: wp.array[int],
        contact_adhesion_out: wp.array[float],
        nacon_out: wp.array[int],
        # the attachment's counters
        counters_out: wp.array[wp.int64],
    ):
        worldid, t = wp.tid()
        for j in range(wp.static(per_thread)):  # PAIRS_PER_THREAD
            k = t * wp.static(per_thread) + j
            if k >= pair_geom.shape[0]:
                break
            geoms = pair_geom[k]
            g1 = geoms[0]
            g2 = geoms[1]
            pairid = pair_id[k]
            if wp.static(enable_sleep):  # as _nxn_broadphase: pairs of sleeping bodies are skipped
                s1 = body_awake_in[worldid, geom_bodyid[g1]]
                s2 = body_awake_in[worldid, geom_bodyid[g2]]
                if s1 == SleepState.ASLEEP and s2 == SleepState.ASLEEP:
                    continue
                if (s1 == SleepState.ASLEEP and s2 == SleepState.STATIC) or (
                    s2 == SleepState.ASLEEP and s1 == SleepState.STATIC
                ):
                    continue
                if wp.static(incremental):  # only the pairs the first pass skipped
                    w1 = body_awake_prev_in[worldid, geom_bodyid[g1]]
                    w2 = body_awake_prev_in[worldid, geom_bodyid[g2]]
                    skipped = (
                        (w1 == SleepState.ASLEEP and w2 == SleepState.ASLEEP)
                        or (w1 == SleepState.ASLEEP and w2 == SleepState.STATIC)
                        or (w2 == SleepState.ASLEEP and w1 == SleepState.STATIC)
                    )
                    if not skipped:
                        continue
            margin, gap = contact_margin_gap(geom_margin, geom_gap, pair_margin, pair_gap, geoms, pairid[0], worldid)
            # bounding spheres (float32 rbound, a float64 sum): apart beyond margin + gap, no contact possible
            p1 = _widen3(geom_xpos_in[worldid, g1])
            p2 = _widen3(geom_xpos_in[worldid, g2])
            reach = (
                F64(geom_rbound[worldid % geom_rbound.shape[0], g1])
                + F64(geom_rbound[worldid % geom_rbound.shape[0], g2])
                + F64(margin)
                + F64(gap)
            )
            dd = p2 - p1
            if not (wp.dot(dd, dd) <= reach * reach):  # (as Warp's sphere filter: a non-finite pose too)
                continue
            wp.atomic_add(counters_out, C_PAIRS, wp.int64(1))
            sid = worldid % geom_size.shape[0]
            # an allowance far above sigma's rounding through M (~u max r_B^2 / h_B, sphere_newton.sigma): past it
            # the pair is proven beyond margin + gap; below it, the distance is computed and Warp's test decides
            cutoff = F64(margin) + F64(gap) + F64(1e-9) * reach
            R1 = _widen33(geom_xmat_in[worldid, g1])
            R2 = _widen33(geom_xmat_in[worldid, g2])
            status = 0
            dist = F64(0.0)
            normal = wp.vec3d(F64(0.0), F64(0.0), F64(0.0))
            pos = wp.vec3d(F64(0.0), F64(0.0), F64(0.0))
            deep = 0
            if geom_type[g1] == CAPSULE:  # g1 the capsule, g2 the ellipsoid: the normal from g1 flipped
                size1 = geom_size[sid, g1]
                status, dist, normal, pos, deep = capsule_ellipsoid(
                    p2, R2, _widen3(geom_size[sid, g2]), p1, R1, F64(size1[0]), F64(size1[1]), cutoff
                )
                normal = -normal
            elif geom_type[g2] == BOX:  # g1 the ellipsoid, g2 the box
                status, dist, normal, pos, deep = box_ellipsoid(
                    p1, R1, _widen3(geom_size[sid, g1]), p2, R2, _widen3(geom_size[sid, g2]), cutoff
                )
            elif geom_type[g2] == CYLINDER:  # g1 the ellipsoid, g2 the cylinder
                size2 = geom_size[sid, g2]
                status, dist, normal, pos, deep = cylinder_ellipsoid(
                    p1, R1, _widen3(geom_size[sid, g1]), p2, R2, F64(size2[0]), F64(size2[1]), cutoff
                )
            else:
                status, dist, normal, pos, deep = ellipsoid_pair(
                    p1,
                    R1,
                    _radii(geom_type[g1], geom_size[sid, g1]),
                    p2,
                    R2,
                    _radii(geom_type[g2], geom_size[sid, g2]),
                    cutoff,
                )
            if status == APART:
                continue  # proven beyond margin + gap: Warp would make no contact either
            if status != GLOBAL:
                wp.atomic_add(counters_out, C_UNPROVEN, wp.int64(1))
            if deep != 0:
                wp.atomic_add(counters_out, C_DEEP, wp.int64(1))
            dist32 = wp.float32(dist)
            if not (dist32 < margin + gap):  # write_contact's test, in float32 as Warp makes it
                continue
            condim, friction, solref, solreffriction, solimp, adhesion = contact_material_params(
                geom_condim,
                geom_priority,
                geom_solmix,
                geom_solref,
                geom_solimp,
                geom_friction,
                geom_adhesion,
                pair_dim,
                pair_solref,
                pair_solreffriction,
                pair_solimp,
                pair_adhesion,
                pair_friction,
                geoms,
                pairid[0],
                worldid,
            )
            # write_contact's semantics (collision_core.py), the slot kept to count an overflow: the pair
            # table holds no collision-sensor pair and no excluded one (attachment.py), so a detected contact
            # is a constraint contact, active when dist < margin or adhesive within the gap
            if (adhesion != 0.0) and (dist32 >= margin):
                condim = 1
            cid = wp.atomic_add(nacon_out, 0, 1)
            wp.atomic_add(counters_out, C_CONTACTS, wp.int64(1))
            if cid >= naconmax_in:
                wp.atomic_add(counters_out, C_OVERFLOW, wp.int64(1))
                continue
            contact_dist_out[cid] = dist32
            contact_pos_out[cid] = wp.vec3(wp.float32(pos[0]), wp.float32(pos[1]), wp.float32(pos[2]))
            contact_frame_out[cid] = make_frame(
                wp.vec3(wp.float32(normal[0]), wp.float32(normal[1]), wp.float32(normal[2]))
            )
            contact_geom_out[cid] = geoms
            contact_worldid_out[cid] = worldid
            contact_includemargin_out[cid] = margin
            contact_dim_out[cid] = condim
            contact_friction_out[cid] = friction
            contact_solref_out[cid] = solref
            contact_solreffriction_out[cid] = solreffriction
            contact_solimp_out[cid] = solimp
            contact_adhesion_out[cid] = adhesion
            contact_type_out[cid] = int(ContactType.CONSTRAINT)
            contact_geomcollisionid_out[cid] = 0
            for i in range(contact_efc_address_out.shape[1]):
                contact_efc_address_out[cid, i] = -1

    _KERNELS[key] = ellipsim_contacts
    return ellipsim_contacts


#: The pair kinds of _distances' kernel (the second body is the ellipsoid's partner).
KIND_ELLIPSOID, KIND_CAPSULE, KIND_BOX, KIND_CYLINDER = 0, 1, 2, 3


@wp.kernel(enable_backward=False)
def _pair_distances(
    kind: int,
    ca: wp.array[wp.vec3],
    Ra: wp.array[wp.mat33],
    ra: wp.array[wp.vec3],
    cb: wp.array[wp.vec3],
    Rb: wp.array[wp.mat33],
    rb: wp.array[wp.vec3],
    dist: wp.array[wp.float64],
    normal: wp.array[wp.vec3d],
    pos: wp.array[wp.vec3d],
    status: wp.array[int],
):
    i = wp.tid()
    A = _widen3(ca[i])
    RA = _widen33(Ra[i])
    B = _widen3(cb[i])
    RB = _widen33(Rb[i])
    size = rb[i]
    st = 0
    v = F64(0.0)
    nrm = wp.vec3d(F64(0.0), F64(0.0), F64(0.0))
    p = wp.vec3d(F64(0.0), F64(0.0), F64(0.0))
    extra = 0
    if kind == KIND_CAPSULE:
        st, v, nrm, p, extra = capsule_ellipsoid(A, RA, _widen3(ra[i]), B, RB, F64(size[0]), F64(size[1]), F64(1e300))
    elif kind == KIND_BOX:
        st, v, nrm, p, extra = box_ellipsoid(A, RA, _widen3(ra[i]), B, RB, _widen3(size), F64(1e300))
    elif kind == KIND_CYLINDER:
        st, v, nrm, p, extra = cylinder_ellipsoid(A, RA, _widen3(ra[i]), B, RB, F64(size[0]), F64(size[1]), F64(1e300))
    else:
        st, v, nrm, p, extra = ellipsoid_pair(A, RA, _widen3(ra[i]), B, RB, _widen3(size), F64(1e300))
    dist[i] = v
    normal[i] = nrm
    pos[i] = p
    status[i] = st


def pair_distances(ca, Ra, ra, cb, Rb, rb, device="cpu"):
    """The kernel's signed distance of float32 ellipsoid poses (n, 3), (n, 3, 3), (n, 3) each, in float64
    before the float32 rounding the contact kernel applies: (dist, normal, pos, status) as numpy arrays.
    For tests and the bench (one launch over the n pairs); the MuJoCo Warp path is attach()."""
    return _distances(KIND_ELLIPSOID, (ca, Ra, ra, cb, Rb, rb), device)


def _distances(kind, arrays, device):
    arrays = [np.ascontiguousarray(x, dtype=np.float32) for x in arrays]
    n = len(arrays[0])
    for x, shape in zip(arrays, ((3,), (3, 3), (3,)) * 2):
        if x.shape != (n, *shape):
            raise ValueError(f"pose arrays must be (n, 3), (n, 3, 3), (n, 3) for one n, got {x.shape}")
    types = (wp.vec3, wp.mat33, wp.vec3) * 2
    inputs = [wp.array(x, dtype=t, device=device) for x, t in zip(arrays, types)]
    dist = wp.empty(n, dtype=wp.float64, device=device)
    normal = wp.empty(n, dtype=wp.vec3d, device=device)
    pos = wp.empty(n, dtype=wp.vec3d, device=device)
    status = wp.empty(n, dtype=int, device=device)
    wp.launch(_pair_distances, dim=n, inputs=[kind, *inputs], outputs=[dist, normal, pos, status], device=device)
    return dist.numpy(), normal.numpy(), pos.numpy(), status.numpy()


def capsule_distances(ce, Re, ra, ck, Rk, rk, device="cpu"):
    """As pair_distances for ellipsoids (ce, Re, ra) and capsules (ck, Rk, rk: MuJoCo's geom_size,
    (radius, half-length, unused)); the normal from the ellipsoid to the capsule."""
    return _distances(KIND_CAPSULE, (ce, Re, ra, ck, Rk, rk), device)


def box_distances(ce, Re, ra, ck, Rk, rk, device="cpu"):
    """As pair_distances for ellipsoids (ce, Re, ra) and boxes (ck, Rk, rk: half-sizes); the normal from
    the ellipsoid to the box."""
    return _distances(KIND_BOX, (ce, Re, ra, ck, Rk, rk), device)


def cylinder_distances(ce, Re, ra, ck, Rk, rk, device="cpu"):
    """As pair_distances for ellipsoids (ce, Re, ra) and cylinders (ck, Rk, rk: MuJoCo's geom_size,
    (radius, half-length, unused)); the normal from the ellipsoid to the cylinder."""
    return _distances(KIND_CYLINDER, (ce, Re, ra, ck, Rk, rk), device)
