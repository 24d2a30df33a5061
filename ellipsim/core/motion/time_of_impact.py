"""Continuous collision detection: the first time two moving ellipsoids stop being separated.

The motion is interpolation.py's (centre linear, constant angular velocity along the shortest arc), defined
exactly by the float64 inputs.  time_of_impact returns toi and, per pair, what was proven (`Impact`):

* every real t in [0, toi - TOI_TOL] is separated: a chain of interval certificates covering the whole
  range, each a fixed plane normal n with n.d(t) - h_A(n; t) - h_B(-n; t) > 0 for every t of its
  interval (Schneider & Eberly 11.9.2: separation through support functions).  The bound covers the
  exact motion AND every float pose within rounding of it (the pose ball, below).
* at toi the pair is not separated: CONTACT when the motion itself is proven so (the inputs at t = 0
  and t = 1; elsewhere a point strictly inside both bodies with room for the pose's rounding),
  CONTACT_AT_FLOAT_POSE when only the float pose P(toi), within the pose ball of the motion, is (exact
  classify: touching or overlapping).

The certificate on an interval.  h(n; t) = |D R(t)^{-1} n| is the support function.  With m in [a, b],
q = E(m - tau)^T R_p^{-1} n, s = t - m and W = [w]x:

    R(t)^{-1} n = exp(-s W) q = [q - s W q] + (s - sin(theta s)/theta) W q + ((1 - cos theta s)/theta^2) W^2 q

so h(n; t) <= phi(s) + Q(|s|), phi(s) = |D (q - s W q)| (convex in s), Q(S) = S^2/2 |D W^2 q| +
theta^2 S^3/6 |D W q|.  n.d(t) is affine in t, so n.d - phi_A - phi_B is concave: its minimum over an
interval is at an end, and two evaluations (minus Q at the larger |s|) bound the margin over the whole
interval, to second order in its width.  Every float error is bounded (Higham's gamma_n on an absolute
"mag" as in exact/pair_frame.hpp; R_p^{-1} n from the cofactor matrix, exact for any invertible R_p; interpolation.py's
Rodrigues bound).  The pose ball: the float poses this module classifies have centres within
4.01u (|d_tau| + |Delta_a| + |Delta_b|) of the exact motion's (relative to c_a at t = tau, so the
rounding scales with the pair, not with its distance from the origin) and rotations within DELTA_R.

The search.  (1) Swept bounding spheres (rotation-free) prove the whole motion, or [0, t_in] and
[t_out, 1].  (2) Exact classify at t = 0 when the spheres overlap there.  (3) A sweep from the proven
end a: candidate normals are the centre line and the Perram-Wertheim contact normal (the contact
normal in the limit); a half's first step expands at the middle of the rest, later steps at a; each
normal gives the largest end b whose certificate holds (a model guess, then Illinois regula falsi; the
bound is concave in b - a and every accepted b is checked).  Near a transversal contact this is
conservative advancement with an exact local model (~3 steps).  (4) When the certificate fails within
TOI_PROBE of b, or the sweep stalls, the float pose at a + TOI_PROBE is classified exactly: not
separated ends the search with toi there.  After TOI_STALL_LIMIT stalls the pair is UNRESOLVED.
(5) Instants the certified filter cannot decide are settled exactly (the exact fallback: rational.relation
in integer arithmetic) and fed back to the pair's search as an oracle; the search is deterministic and reruns.

Literature: Choi, Wang, Liu, Tu, Kim, "Continuous collision detection for ellipsoids", IEEE TVCG 15
(2009) answers the same question through the roots of a bivariate characteristic polynomial; the
support-function certificates here are first-order exact and cheap, and need no root isolation in t.
"""

from enum import IntEnum

import numpy as np

from ...native import ext
from .. import threads
from ..ellipsoids import Ellipsoids, check_parallel
from ..tolerances import (
    TOI_MAX_ORACLE,
    U,
)
from .impact_derivatives import impact_derivatives
from .interpolation import (
    rotation_vectors,
)

# Statuses (int8), as `Impact` reports them; NEED_EXACT is internal (the kernel asks for rationals).
NO_CONTACT, CONTACT, CONTACT_AT_FLOAT_POSE, UNRESOLVED = 0, 1, 2, 3
NEED_EXACT = -1


class Impact(IntEnum):
    """What time_of_impact proved about each pair (int8 codes, with return_status=True)."""

    NO_CONTACT = NO_CONTACT  #: toi = inf: separated at every t in [0, 1] (exact motion and float poses)
    CONTACT = CONTACT  #: separated on [0, toi - TOI_TOL]; the motion itself is not separated at toi
    #: separated on [0, toi - TOI_TOL]; the float pose P(toi), within ~5e-14 of the pair's size of the
    #: motion, is touching or overlapping (exact classify): the motion is at least that close to touching
    CONTACT_AT_FLOAT_POSE = CONTACT_AT_FLOAT_POSE
    #: separated on [0, toi]; just after toi the pair comes within float64 resolution of touching (a
    #: grazing contact, a near miss within ~1e-14 of its size, an approach slower than ~1e-5 size per
    #: unit time): whether it touches is not decided, so treat it as a possible contact at toi
    UNRESOLVED = UNRESOLVED


def _g(n):
    """gamma_n with 1% for the rounding of the bound itself."""
    return n * U / (1.0 - n * U) * 1.01


G2, G3, G4, G5, G6, G8 = _g(2), _g(3), _g(4), _g(5), _g(6), _g(8)
ROUND_UP = 1.0 + 2.0**-40  # a few roundings of a nonnegative bound, upwards


# --- tuples -----------------------------------------------------------------------------------


# --- R_p^{-1} n -------------------------------------------------------------------------------


# --- the certificate on an interval -----------------------------------------------------------


# --- poses and the exact relation at an instant ------------------------------------------------


# --- the search ---------------------------------------------------------------------------------


def float_poses(arrays, idx, t):
    """(ca, Ra, ra, cb, Rb, rb) arrays of the float poses of pairs idx at times t, as the kernel builds
    them; `arrays` as _check returns them."""
    k = len(idx)
    out = (
        np.empty((k, 3)),
        np.empty((k, 3, 3)),
        np.empty((k, 3)),
        np.empty((k, 3)),
        np.empty((k, 3, 3)),
        np.empty((k, 3)),
    )
    ext.float_poses(*arrays, np.asarray(idx, dtype=np.int64), np.asarray(t, dtype=np.float64), *out)
    return out


def _check_motion(x0, x1, name):
    """Validate one body's two batches; return its (n, 3) rotation vectors."""
    n0, n1 = name + "0", name + "1"
    for nm, value in ((n0, x0), (n1, x1)):
        if not isinstance(value, Ellipsoids):
            raise ValueError(f"{nm} must be an ellipsim.Ellipsoids batch, got {type(value).__name__}")
    if len(x0) != len(x1):
        raise ValueError(
            f"{n0} and {n1} must have the same length (one body at t = 0 and t = 1), got {len(x0)} and {len(x1)}"
        )
    bad = np.flatnonzero(np.any(x0.radii != x1.radii, axis=1))
    if len(bad):
        i = int(bad[0])
        raise ValueError(
            f"{n1}.radii[{i}] must equal {n0}.radii[{i}] (a rigid motion keeps its semi-axes), "
            f"got {x1.radii[i].tolist()} and {x0.radii[i].tolist()}"
        )
    return rotation_vectors(x0, x1, n0, n1)


def _check(a0, a1, b0, b1):
    """The kernels' argument tuples, the pair count and the per-body rotation vectors."""
    wa = _check_motion(a0, a1, "a")
    wb = _check_motion(b0, b1, "b")
    na, nb = len(a0), len(b0)
    if na != nb and na != 1 and nb != 1:
        raise ValueError(f"a0 and b0 must have the same length or one of them length 1, got {na} and {nb}")
    n = 0 if na == 0 or nb == 0 else max(na, nb)
    arrays = (
        (a0.centers, a0.rotations, a0.radii),
        (a1.centers, a1.rotations, wa),
        (b0.centers, b0.rotations, b0.radii),
        (b1.centers, b1.rotations, wb),
    )
    return arrays, n


def time_of_impact(a0, a1, b0, b1, *, parallel=None, return_status=False, derivatives=False):
    """First t in [0, 1] at which a(t) and b(t) are not separated; inf when separated for all t in [0, 1].

    a0, a1 : Ellipsoids, body A at t = 0 and t = 1 (equal length, equal semi-axes); likewise b0, b1.
        A batch of length 1 broadcasts against the other body's.
    Motion: centres linear, rotation R0 exp(t log(R0^T R1)), constant angular velocity along the shortest
        arc (interpolation.py); a turn within 1e-6 rad of a half turn is a ValueError.
    parallel : run on all cores; default: when there are at least PARALLEL_MIN_PAIRS pairs.
    returns : (n,) float64 toi; with return_status=True also (n,) int8 `Impact` codes (the pair's status
        says what was proven).  Every real t in [0, toi - 1e-9] is proven separated ([0, toi] for
        UNRESOLVED), so the first contact t* is later than toi - 1e-9; CONTACT proves the motion not
        separated at toi (t* <= toi), CONTACT_AT_FLOAT_POSE the float pose there.  toi = 0 when the inputs
        at t = 0 are not separated; inf (NO_CONTACT) when no t in [0, 1] is in contact.  Contacts that
        begin and end between t = 0 and t = 1 (tunnelling) are found.  1e-9 is tolerances.TOI_TOL.

    derivatives : also return (last) impact_derivatives.ImpactDerivatives: d t* / d (each body's centre and
        rotation vector at t = 0 and t = 1) of the first contact t* (within 1e-9 of toi), where it is
        transversal, and a status per pair saying why not elsewhere (impact_derivatives.py)

    The reversed motion is the same motion (w flips sign exactly): 1 - time_of_impact(a1, a0, b1, b0) is
    the end of the last contact.  For consecutive frames, index one validated batch per frame by the
    candidate pairs (`frame[k][ia]`, no re-validation) and concatenate the steps into one call.
    """
    if not isinstance(derivatives, (bool, np.bool_)):
        raise ValueError(f"derivatives must be True or False, got {derivatives!r}")
    if derivatives:
        toi, status = time_of_impact(a0, a1, b0, b1, parallel=parallel, return_status=True)
        wa, wb = rotation_vectors(a0, a1, "a0", "a1"), rotation_vectors(b0, b1, "b0", "b1")
        contact = (status == CONTACT) | (status == CONTACT_AT_FLOAT_POSE)
        der = impact_derivatives(a0, a1, b0, b1, toi, contact, wa, wb)
        return (toi, status, der) if return_status else (toi, der)
    if (  # a small batch in one compiled call (serial whatever `parallel` says: below 2 CHUNK_MIN_PAIRS)
        (parallel is None or parallel is False or parallel is True)
        and type(a0) is Ellipsoids
        and type(a1) is Ellipsoids
        and type(b0) is Ellipsoids
        and type(b1) is Ellipsoids
    ):
        done, out, status = ext.toi_small(
            a0.centers,
            a0.rotations,
            a0.radii,
            a1.centers,
            a1.rotations,
            a1.radii,
            b0.centers,
            b0.rotations,
            b0.radii,
            b1.centers,
            b1.rotations,
            b1.radii,
        )
        if done:
            return (out, status) if return_status else out
    arrays, n = _check(a0, a1, b0, b1)
    parallel = check_parallel(parallel, n)
    out, status, t_exact = np.empty(n), np.empty(n, dtype=np.int8), np.empty(n)
    steps = np.empty(n, dtype=np.int64)
    OT = np.zeros((n, TOI_MAX_ORACLE))
    OR = np.zeros((n, TOI_MAX_ORACLE), dtype=np.int8)
    OC = np.zeros(n, dtype=np.int64)
    threads.run(ext.toi, n, parallel, *arrays, np.arange(n), OT, OR, OC, out, status, t_exact, steps)
    _resolve_exact(arrays, OT, OR, OC, out, status, t_exact, steps)
    if return_status:
        return out, status
    return out


def _resolve_exact(arrays, OT, OR, OC, out, status, t_exact, steps):
    """Pairs whose search asked for the exact relation at an instant: compute it exactly (the C++ exact
    fallback, rational_fallback.py's relation) at the float pose, add it to the pair's oracle, and rerun
    the (deterministic) search of the pair until it asks no more (UNRESOLVED once its oracle is full)."""
    ext.resolve_exact(*arrays, OT, OR, OC, out, status, t_exact, steps, 0, len(status))
