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
"mag" as in pair_frame.py; R_p^{-1} n from the cofactor matrix, exact for any invertible R_p; interpolation.py's
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

import math
from enum import IntEnum

import numpy as np

from ...native import ext
from .. import threads
from .._jit import jit, stage
from ..ellipsoids import Ellipsoids, check_parallel
from ..exact.certified_filter import (
    _in_float_range,
    _positive,
    bounding_spheres_apart,
    certify_pair,
    inside_both,
    pencil_positive,
    witness,
)
from ..exact.contact_scale import initial_mu, pw_maximize, pw_value
from ..exact.pair_frame import cofactors, invariants, offset, shape
from ..relation import SEPARATED, UNDECIDED
from ..tolerances import (
    BOUNDING_INFLATION,
    DELTA_R,
    ERR_WITNESS,
    PW_RTOL,
    RODRIGUES_ERR,
    SMALL_BATCH_PAIRS,
    TAU,
    TOI_FALSI_RTOL,
    TOI_FALSI_STEPS,
    TOI_MAX_ORACLE,
    TOI_MAX_STEPS,
    TOI_PROBE,
    TOI_PROBE2,
    TOI_PROBE_REACH,
    TOI_STALL,
    TOI_STALL_LIMIT,
    U,
)
from ..vec3 import cross3, cross3_mag, matvec, norm2, reciprocal
from .impact_derivatives import impact_derivatives
from .interpolation import (
    HALF_TURN_TOL,
    _rotation_vectors,
    matmul,
    rodrigues,
    rodrigues_apply,
    rodrigues_matrix,
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


@stage
def _load3(X, i):
    return (X[i, 0], X[i, 1], X[i, 2])


@stage
def _load9(R, i):
    return (R[i, 0, 0], R[i, 0, 1], R[i, 0, 2], R[i, 1, 0], R[i, 1, 1], R[i, 1, 2], R[i, 2, 0], R[i, 2, 1], R[i, 2, 2])


@stage
def _norm(x):
    return math.sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2])


@stage
def _affine(x, f, y):
    """x + f y."""
    return (x[0] + f * y[0], x[1] + f * y[1], x[2] + f * y[2])


@stage
def _abs3(x):
    return (abs(x[0]), abs(x[1]), abs(x[2]))


@stage
def _scaled_norm(r, x):
    """|D x| for D = diag(r)."""
    return _norm((r[0] * x[0], r[1] * x[1], r[2] * x[2]))


# --- R_p^{-1} n -------------------------------------------------------------------------------


@stage
def _solve_inverse(inv, n):
    """p = R^{-1} n = C^T n / det and eps with |p~ - p|_2 <= eps.

    N_i = sum_j C_ji n_j errs by gamma_5 mN_i; |det~ - det| <= gamma_5 mdet, so |det~ / det - 1| <= xi =
    gamma_5 mdet / (|det~| - gamma_5 mdet); with the division's rounding,
    |p~_i - p_i| <= (gamma_5 mN_i + |N~_i| (xi + 2u)) / (|det~| (1 - xi)), summed as 2-norms.
    """
    C, mC, det, mdet = inv
    N = (C[0] * n[0] + C[3] * n[1] + C[6] * n[2], C[1] * n[0] + C[4] * n[1] + C[7] * n[2],
         C[2] * n[0] + C[5] * n[1] + C[8] * n[2])  # fmt: skip
    a = _abs3(n)
    mN = (mC[0] * a[0] + mC[3] * a[1] + mC[6] * a[2], mC[1] * a[0] + mC[4] * a[1] + mC[7] * a[2],
          mC[2] * a[0] + mC[5] * a[1] + mC[8] * a[2])  # fmt: skip
    ad = abs(det)
    xi = G5 * mdet / (ad - G5 * mdet)
    p = (N[0] / det, N[1] / det, N[2] / det)
    eps = (G5 * _norm(mN) + _norm(N) * (xi + 2.0 * U) * 1.01) / (ad * (1.0 - xi))
    return p, eps * 1.01


# --- the certificate on an interval -----------------------------------------------------------


@stage
def _body_terms(n, inv_p, w, rod, r):
    """For one body: q = E(phi_m)^T R_p^{-1} n, x = w x q, |q| mags, the mag of x, eps_q >= |q~ - q| and
    (c1, c2) >= (|D (w x q)|, |D (w x (w x q))|) for the EXACT q."""
    p, eps_q = _solve_inverse(inv_p, n)
    q = rodrigues_apply(rod, p)
    if rod[2] != 0.0 or rod[1] != 0.0:  # a turn (none: E = I, applied exactly)
        eps_q += (RODRIGUES_ERR + 12.0 * rod[4]) * U * _norm(p) * 1.01
    x = cross3(w, q)
    aq, aw = _abs3(q), _abs3(w)
    mx = cross3_mag(aw, aq)
    y = cross3(w, x)
    my = cross3_mag(aw, _abs3(x))
    rm = max(r[0], r[1], r[2])
    th = _norm(w) * (1.0 + 8.0 * U)
    mxs = mx[0] + mx[1] + mx[2]
    # x~ and y~ = w x x~ err by gamma_2 of their mags (1-norms bound 2-norms); q~ by eps_q
    c1 = _scaled_norm(r, x) * ROUND_UP + rm * (G2 * mxs + th * eps_q)
    c2 = _scaled_norm(r, y) * ROUND_UP + rm * (G2 * (my[0] + my[1] + my[2]) + th * G2 * mxs * 1.01 + th * th * eps_q)
    return q, x, aq, mx, eps_q, c1 * ROUND_UP, c2 * ROUND_UP


@stage
def _margin_lower(s, setup):
    """A certified lower bound of n.d(m + s) - phi_A(s) - phi_B(s) for the exact q's (not yet minus Q).

    Errors (_setup sums the parts that do not depend on phi into E0 + |s| E1): n.d and n.v (their mags,
    already scaled), each phi by gamma_5 of its mag (depth: x [2], s x, q - s x, r (...)) plus gamma_3 of
    itself (the norm), the exact-q deviation r_max eps_q (1 + |s| theta), the final sums gamma_4 of their
    magnitudes, the pose ball and TAU.  1.01 covers the rounding of the bound's own (nonnegative) sums.
    """
    nd, nv, E0, E1, A, B = setup
    pa = _scaled_norm(A[7], _affine(A[0], -s, A[1]))
    pb = _scaled_norm(B[7], _affine(B[0], -s, B[1]))
    return nd + s * nv - pa - pb - (E0 + abs(s) * E1 + (G3 + G4) * (pa + pb)) * 1.01


@stage
def _remainder(S, X):
    """Q(S) = S^2/2 |D W^2 q| + theta^2 S^3/6 |D W q| >= the part of h beyond phi, rounded up."""
    c1, c2, th = X[5], X[6], X[9]
    return (0.5 * S * S * c2 + th * th * S * S * S * c1 / 6.0) * ROUND_UP


@stage
def _certified(lo, S, setup):
    """Margin bound on an interval: lo = min of _margin_lower at its ends, S >= the largest |s| on it."""
    Q = _remainder(S, setup[4]) + _remainder(S, setup[5])
    return lo - Q * (1.0 + 4.0 * U) - G2 * (abs(lo) + Q)


@stage
def _model_root(setup, M0, S_full):
    """Float guess of where the bound falls to zero: M0 + L1 S - Qc S^2, with L1 the margin's slope at 0."""
    nd, nv, E0, E1, A, B = setup
    L1 = nv - E1
    Qc = 0.0
    for X in (A, B):
        q, x, r = X[0], X[1], X[7]
        z = (r[0] * q[0], r[1] * q[1], r[2] * q[2])
        y = (r[0] * x[0], r[1] * x[1], r[2] * x[2])
        ph = _norm(z)
        if ph > 0.0:
            L1 += (z[0] * y[0] + z[1] * y[1] + z[2] * y[2]) / ph  # -d phi/ds = (Dq . Dx) / |Dq|
        Qc += 0.5 * X[6]
    if Qc > 0.0:
        return min(S_full, (L1 + math.sqrt(L1 * L1 + 4.0 * Qc * M0)) / (2.0 * Qc))
    if L1 < 0.0:
        return min(S_full, M0 / -L1)
    return S_full


@stage
def _span_up(a, b):
    """An upper bound of b - a for floats a <= b (exact by Sterbenz when a >= b / 2)."""
    d = b - a
    if a >= 0.5 * b:
        return d
    return d * (1.0 + 4.0 * U)


@stage
def _largest_end(a, m, end, setup, quick):
    """(b, fail): the largest float b in [m, end] found whose certificate on [a, b] holds for the normal
    expanded at m (a <= m), and the smallest end seen to fail; (a, a) when [a, m] itself fails.

    Tries the whole rest (only that when `quick`), then a model guess, then Illinois regula falsi on
    the concave bound; every accepted b is certified.
    """
    M0 = _margin_lower(0.0, setup)
    slo = 0.0
    Mmin = M0
    if m > a:
        slo = _span_up(a, m)
        Mmin = min(M0, _margin_lower(-slo, setup))
    L0 = _certified(Mmin, slo, setup)
    if not L0 > 0.0:
        return a, a
    S = _span_up(m, end)
    L_hi = _certified(min(Mmin, _margin_lower(S, setup)), max(slo, S), setup)
    if L_hi > 0.0:
        return end, end
    if quick:
        return m, end
    best = m
    lo_s, lo_L, hi_s, hi_L = 0.0, L0, S, L_hi
    g = 0.95 * _model_root(setup, L0, S)
    if 0.0 < g < S:
        b = min(m + g, end)
        if b > m:
            Sc = _span_up(m, b)
            Lc = _certified(min(Mmin, _margin_lower(Sc, setup)), max(slo, Sc), setup)
            if Lc > 0.0:
                best = b
                lo_s, lo_L = Sc, Lc
                b2 = min(m + 1.25 * g, end)
                S2 = _span_up(m, b2)
                L2 = _certified(min(Mmin, _margin_lower(S2, setup)), max(slo, S2), setup)
                if L2 > 0.0:
                    best = b2
                    lo_s, lo_L = S2, L2
                elif S2 < hi_s:
                    hi_s, hi_L = S2, L2
            else:
                hi_s, hi_L = Sc, Lc
    side = 0
    for _ in range(TOI_FALSI_STEPS):
        if hi_s - lo_s <= TOI_FALSI_RTOL * max(lo_s, slo):
            break
        c = lo_s + 0.999 * lo_L * (hi_s - lo_s) / (lo_L - hi_L)
        b = min(m + c, end)
        if not b > m:
            break
        Sc = _span_up(m, b)
        Lc = _certified(min(Mmin, _margin_lower(Sc, setup)), max(slo, Sc), setup)
        if Lc > 0.0:
            best = b
            lo_s, lo_L = Sc, Lc
            if side == -1:
                hi_L *= 0.5
            side = -1
        else:
            hi_s, hi_L = Sc, Lc
            if side == 1:
                lo_L *= 0.5
            side = 1
    return best, m + hi_s


@stage
def _setup(n, m, ctx):
    """Everything the certificate needs for the plane normal n expanded at the float time m of the half
    described by ctx (whose rotations rod_a, rod_b are evaluated at m)."""
    piece, rod_a, rod_b, half = ctx
    inv_a, inv_b, wa, wb, ra, rb, rma, rmb, tha, thb = half[:10]
    d_tau, md_tau, v, mv, ball = half[10:15]
    phi = m - float(piece)
    an = _abs3(n)
    ap = abs(phi)
    d = _affine(d_tau, phi, v)
    nd = n[0] * d[0] + n[1] * d[1] + n[2] * d[2]
    m_nd = G8 * (an[0] * (md_tau[0] + ap * mv[0]) + an[1] * (md_tau[1] + ap * mv[1]) + an[2] * (md_tau[2] + ap * mv[2]))
    nv = n[0] * v[0] + n[1] * v[1] + n[2] * v[2]
    m_nv = G6 * (an[0] * mv[0] + an[1] * mv[1] + an[2] * mv[2])
    A = _body_terms(n, inv_a, wa, rod_a, ra) + (ra, rma, tha)
    B = _body_terms(n, inv_b, wb, rod_b, rb) + (rb, rmb, thb)
    # _margin_lower's error terms that do not depend on phi: E0 + |s| E1 (mags of phi: r . (|q| + |s| mx))
    ma0 = ra[0] * A[2][0] + ra[1] * A[2][1] + ra[2] * A[2][2] + rb[0] * B[2][0] + rb[1] * B[2][1] + rb[2] * B[2][2]
    ma1 = ra[0] * A[3][0] + ra[1] * A[3][1] + ra[2] * A[3][2] + rb[0] * B[3][0] + rb[1] * B[3][1] + rb[2] * B[3][2]
    E0 = m_nd + G5 * ma0 + rma * A[4] + rmb * B[4] + G4 * abs(nd) + ball * _norm(n) * (1.0 + 4.0 * U) + TAU
    E1 = m_nv + G5 * ma1 + rma * A[4] * tha + rmb * B[4] * thb + G4 * abs(nv)
    return nd, nv, E0, E1, A, B


@stage
def _ctx_at(m, piece, half):
    """The half's constants with the rotations evaluated at the time m."""
    phi = m - float(piece)
    return piece, rodrigues(half[2], phi), rodrigues(half[3], phi), half


# --- poses and the exact relation at an instant ------------------------------------------------


@stage
def _pose(piece, t, Ra_p, Rb_p, rod_a, rod_b, da, db, d_tau):
    """The float pose at t on a half (piece 0: origin c_a0, tau = 0; piece 1: origin c_a1, tau = 1): centre
    of A phi Delta_a, of B d_tau + phi Delta_b, rotations fl(R_p E~(phi)), phi = t - tau (exact)."""
    phi = t - float(piece)
    ca = (phi * da[0], phi * da[1], phi * da[2])
    return ca, matmul(Ra_p, rodrigues_matrix(rod_a)), _affine(d_tau, phi, db), matmul(Rb_p, rodrigues_matrix(rod_b))


@stage
def _contact_normal(ca, Ra, ra, cb, Rb, rb, mu0):
    """The Perram-Wertheim contact normal at a pose (pointing from A to B): the normal of A where A and B,
    scaled about their centres by sqrt(F), touch.  A float candidate only; (0, 0, 0) when undefined."""
    e, me = offset(ca, Ra, ra, cb)
    ee = norm2(e)
    if ee == 0.0:
        return (0.0, 0.0, 0.0), 0.0
    W, mW, alpha, _ = shape(Ra, ra, Rb, reciprocal(rb), True)
    v = matvec(W, e)
    inv, _ = invariants(W, mW, e, me, v, v)
    if inv[3] == 0.0 or inv[2] == 0.0:
        return (0.0, 0.0, 0.0), 0.0
    mu = pw_maximize(inv, alpha, mu0 if mu0 > 0.0 else initial_mu(ee, inv[3] / alpha, alpha), 1e-10)
    y = witness(mu, W, e, v, inv)
    return matvec(Ra, (y[0] / ra[0], y[1] / ra[1], y[2] / ra[2])), mu  # R_a D_a^{-1} y: the gradient of q_A


@stage
def _witness_relation(ca, Ra, ra, cb, Rb, rb, mu0, kappa_a, kappa_b):
    """The relation at a float pose near contact from one warm-started Perram-Wertheim solve: CONTACT
    when its point y lies strictly inside both bodies with room kappa for the pose's rounding,
    CONTACT_AT_FLOAT_POSE when inside both float bodies only, SEPARATED when f(mu) > 0 (certified_filter.py's
    certificates), UNDECIDED when none holds (then certify_pair's full search decides).

    Room: for an exact pose (c, R) near the float (c~, R~), sqrt q(x) <= sqrt q~(x) + (||R - R~|| |x - c~| +
    ||R|| |c - c~|) / r_min with |x - c~| <= r_max (1 + 2e-6) where sqrt q~ <= 1: kappa (_pair_data) is that.
    In A's frame sqrt q~_A(x) = |y| and q~_B(x) = |W_c (y - e)|^2 / alpha exactly, so |y| < 1 - kappa_a and
    |W_c (y - e)|^2 < alpha (1 - kappa_b)^2, certified, put x strictly inside both exact bodies.
    """
    d = (cb[0] - ca[0], cb[1] - ca[1], cb[2] - ca[2])
    dd = norm2(d)
    if dd == 0.0:  # concentric: the common centre is inside both, with room unless kappa >= 1
        return CONTACT if kappa_a < 1.0 and kappa_b < 1.0 else CONTACT_AT_FLOAT_POSE
    if bounding_spheres_apart(ra, rb, dd):
        return SEPARATED
    if not _in_float_range(ra, rb):
        return UNDECIDED
    e, me = offset(ca, Ra, ra, cb)
    W, mW, alpha, malpha = shape(Ra, ra, Rb, reciprocal(rb), True)
    v, mv = matvec(W, e), matvec(mW, me)
    inv, minv = invariants(W, mW, e, me, v, mv)
    if not (inv[2] > 0.0 and inv[3] > 0.0):
        return UNDECIDED
    mu = pw_maximize(inv, alpha, mu0 if mu0 > 0.0 else initial_mu(norm2(e), inv[3] / alpha, alpha), PW_RTOL)
    if pw_value(mu, inv, alpha) > 1.0:
        return SEPARATED if pencil_positive(mu, inv, minv, alpha, malpha) else UNDECIDED
    y = witness(mu, W, e, v, inv)
    fa, fb = 1.0 - (kappa_a + 4.0 * U), 1.0 - (kappa_b + 4.0 * U)
    if fa > 0.5 and fb > 0.5:
        yy = norm2(y)
        u = (y[0] - e[0], y[1] - e[1], y[2] - e[2])
        mu_ = (abs(y[0]) + me[0], abs(y[1]) + me[1], abs(y[2]) + me[2])
        if _positive(fa * fa - yy, fa * fa + yy, ERR_WITNESS) and _positive(
            alpha * (fb * fb) - norm2(matvec(W, u)), malpha * (fb * fb) + norm2(matvec(mW, mu_)), ERR_WITNESS
        ):
            return CONTACT
    return CONTACT_AT_FLOAT_POSE if inside_both(y, W, mW, e, me, alpha, malpha) else UNDECIDED


@stage
def _lookup(t, ot, orel, ocount):
    """The exact relation at t from the pair's oracle, or UNDECIDED."""
    for j in range(ocount):
        if ot[j] == t:
            return orel[j]
    return UNDECIDED


@stage
def _pose_at(t, pair):
    """(ca, Ra, ra, cb, Rb, rb): the inputs at t = 0 and t = 1, elsewhere the float pose of the half t is on
    (unit-scaled, centres relative to c_a at tau)."""
    if t == 0.0:
        return pair[0], pair[1], pair[8], pair[4], pair[5], pair[9]
    if t == 1.0:
        return pair[2], pair[3], pair[8], pair[6], pair[7], pair[9]
    piece = 0 if t <= 0.5 else 1
    half = pair[13][0] if piece == 0 else pair[13][1]
    phi = t - float(piece)
    ca, Ra, cb, Rb = _pose(
        piece,
        t,
        pair[1] if piece == 0 else pair[3],
        pair[5] if piece == 0 else pair[7],
        rodrigues(pair[10], phi),
        rodrigues(pair[11], phi),
        half[15],
        half[16],
        half[10],
    )
    return ca, Ra, half[4], cb, Rb, half[5]


@stage
def _probe(t, pair, mu0, ot, orel, ocount):
    """What the pose at t proves: CONTACT (the motion is not separated), CONTACT_AT_FLOAT_POSE (the float
    pose is not separated), SEPARATED (the float pose is) or UNDECIDED (needs rationals).  mu0 warm-starts
    the Perram-Wertheim solve (0: none)."""
    ca, Ra, ra, cb, Rb, rb = _pose_at(t, pair)
    ends = t == 0.0 or t == 1.0  # the inputs themselves: the motion there
    if not ends:
        rel = _witness_relation(ca, Ra, ra, cb, Rb, rb, mu0, pair[14][0], pair[14][1])
        if rel != UNDECIDED:
            return rel
    rel = certify_pair((ca, Ra, ra), (cb, Rb, rb))
    if rel == UNDECIDED:
        rel = _lookup(t, ot, orel, ocount)
    if rel == UNDECIDED or rel == SEPARATED:
        return rel
    return CONTACT if ends else CONTACT_AT_FLOAT_POSE


# --- the search ---------------------------------------------------------------------------------


@stage
def _spheres_apart_on(n, t_lo, t_hi, d0, d1, v, rho, ball):
    """n.d(t) > rho |n| (bounding spheres, rotation-free) for every t in [t_lo, t_hi]: n.d(t) is affine,
    so its two end values decide; d(t) = d0 + t v on [0, 1/2] and d1 - (1 - t) v on [1/2, 1] (the same
    exact function), each end evaluated from the nearer end point."""
    nn = _norm(n)
    if not nn > 0.0:
        return False
    an = _abs3(n)
    worst = math.inf
    for t in (t_lo, t_hi):
        dt, ph = (d0, t) if t <= 0.5 else (d1, t - 1.0)
        x = _affine(dt, ph, v)
        val = n[0] * x[0] + n[1] * x[1] + n[2] * x[2]
        err = G8 * (an[0] * (abs(dt[0]) + abs(ph) * abs(v[0])) + an[1] * (abs(dt[1]) + abs(ph) * abs(v[1]))
                    + an[2] * (abs(dt[2]) + abs(ph) * abs(v[2])))  # fmt: skip
        worst = min(worst, val - err)
    return worst - rho * nn * (1.0 + 8.0 * U) > ball * nn * (1.0 + 4.0 * U) + TAU


@stage
def _pair_data(ca0, Ra0, ca1, Ra1, ra, wa, cb0, Rb0, cb1, Rb1, rb, wb):
    """Per-pair constants: the pair scaled to unit size by a power of two (exact; t is unchanged), the
    relative centres, and per half (tau = 0, 1) the constants of the certificate and the pose ball."""
    m = max(ra[0], ra[1], ra[2], rb[0], rb[1], rb[2])
    p = 1.0
    if not (2.0**-51 <= m < 2.0**50):
        p = math.ldexp(1.0, -math.frexp(m)[1])
    ra_s = (ra[0] * p, ra[1] * p, ra[2] * p)
    rb_s = (rb[0] * p, rb[1] * p, rb[2] * p)
    da = ((ca1[0] - ca0[0]) * p, (ca1[1] - ca0[1]) * p, (ca1[2] - ca0[2]) * p)
    db = ((cb1[0] - cb0[0]) * p, (cb1[1] - cb0[1]) * p, (cb1[2] - cb0[2]) * p)
    d0 = ((cb0[0] - ca0[0]) * p, (cb0[1] - ca0[1]) * p, (cb0[2] - ca0[2]) * p)
    d1 = ((cb1[0] - ca1[0]) * p, (cb1[1] - ca1[1]) * p, (cb1[2] - ca1[2]) * p)
    v = (db[0] - da[0], db[1] - da[1], db[2] - da[2])
    mv = (abs(da[0]) + abs(db[0]), abs(da[1]) + abs(db[1]), abs(da[2]) + abs(db[2]))
    rma, rmb = max(ra_s[0], ra_s[1], ra_s[2]), max(rb_s[0], rb_s[1], rb_s[2])
    tha, thb = _norm(wa) * (1.0 + 8.0 * U), _norm(wb) * (1.0 + 8.0 * U)
    # the pose ball: rotations within DELTA_R (exactly R_p for a body that does not turn), centres
    # within 4.01u (|d_tau| + |Delta_a| + |Delta_b|) of the exact motion's
    dra = DELTA_R if tha > 0.0 else 0.0
    drb = DELTA_R if thb > 0.0 else 0.0
    turn = 1.00001 * (dra * rma + drb * rmb)
    ec0 = 4.01 * U * (_norm(d0) + _norm(da) + _norm(db))
    ec1 = 4.01 * U * (_norm(d1) + _norm(da) + _norm(db))
    half0 = (
        cofactors(Ra0),
        cofactors(Rb0),
        wa,
        wb,
        ra_s,
        rb_s,
        rma,
        rmb,
        tha,
        thb,
        d0,
        _abs3(d0),
        v,
        mv,
        ec0 + turn,
        da,
        db,
    )
    half1 = (
        cofactors(Ra1),
        cofactors(Rb1),
        wa,
        wb,
        ra_s,
        rb_s,
        rma,
        rmb,
        tha,
        thb,
        d1,
        _abs3(d1),
        v,
        mv,
        ec1 + turn,
        da,
        db,
    )
    # _witness_relation's room per body: (DELTA_R r_max (1 + 1e-5) + 1.00001 |c - c~|) / r_min, rounded up
    ec = max(ec0, ec1) * 1.00001
    ka = (dra * rma * (1.00001) + ec) / min(ra_s[0], ra_s[1], ra_s[2]) * 1.01
    kb = (drb * rmb * (1.00001) + ec) / min(rb_s[0], rb_s[1], rb_s[2]) * 1.01
    swept = (
        d0,
        d1,
        v,
        (rma + rmb) * BOUNDING_INFLATION,
        4.01 * U * (_norm(d0) + _norm(d1) + _norm(da) + _norm(db)) + turn,
    )
    return (ca0, Ra0, ca1, Ra1, cb0, Rb0, cb1, Rb1, ra, rb, wa, wb, p, (half0, half1), (ka, kb)), swept


@stage
def _swept_spheres(swept):
    """(proven whole, t_in, t_out): rotation-free planes from the swept bounding spheres.  n = d at the
    closest approach proves the whole motion; otherwise n = d(t_in) proves [0, t_in] (|d| decreases
    there, so n.d(t) >= |d(t_in)|^2), n = d(t_out) proves [t_out, 1]."""
    d0, d1, v, rho, ball = swept
    vv = norm2(v)
    tc = 0.0
    if vv > 0.0:
        tc = min(1.0, max(0.0, -(d0[0] * v[0] + d0[1] * v[1] + d0[2] * v[2]) / vv))
    nc = _affine(d0, tc, v)
    if _spheres_apart_on(nc, 0.0, 1.0, d0, d1, v, rho, ball):
        return True, 1.0, 1.0
    t_in, t_out = 0.0, 1.0
    if vv > 0.0:
        r2 = (rho * (1.0 + 1e-6)) ** 2 - norm2(nc)  # |d0 + t v| = rho (1 + 1e-6) at tc -+ sqrt(r2 / vv)
        if r2 > 0.0:
            h = math.sqrt(r2 / vv)
            if tc - h > 0.0:
                cand = (tc - h) * (1.0 - 1e-9)
                if _spheres_apart_on(_affine(d0, cand, v), 0.0, cand, d0, d1, v, rho, ball):
                    t_in = cand
            if tc + h < 1.0:
                cand = 1.0 - (1.0 - (tc + h)) * (1.0 - 1e-9)
                if _spheres_apart_on(_affine(d0, cand, v), cand, 1.0, d0, d1, v, rho, ball):
                    t_out = cand
    return False, t_in, t_out


@stage
def _good(a, b, end):
    """A step that reached the end of the half, or a quarter of the rest (and more than TOI_STALL)."""
    return b == end or (b - a >= TOI_STALL and b - a >= 0.25 * (end - a))


@stage
def _step(a, piece, end, first, carry, n_carry, pw_first, mu_last, pair):
    """One sweep step from the proven end a on a half: (b, fail, normal used, pw_first, mu_last).

    Candidates, in order, until one reaches the end of the half or a quarter of the rest: the normal
    that carried the first half (second half only); on a half's first step, the centre line and then the
    contact normal at the middle of the rest (the centre line tried over the whole rest only); then the
    contact normal and the centre line at a (the one that did better last first).  One call site per
    stage, so that numba inlines each once.
    """
    Ra_p, Rb_p = (pair[1], pair[5]) if piece == 0 else (pair[3], pair[7])
    half = pair[13][0] if piece == 0 else pair[13][1]
    ra, rb, d_tau, v, da, db = half[4], half[5], half[10], half[12], half[15], half[16]
    ctx_a = _ctx_at(a, piece, half)
    use_mid = first and end - a > 1e-3
    mid = a + 0.5 * (end - a) if use_mid else a
    ctx_m = _ctx_at(mid, piece, half) if use_mid else ctx_a
    b, fail = a, end
    n_best = (0.0, 0.0, 0.0)
    for k in range(5):
        if k == 0 and not carry:
            continue
        if (k == 1 or k == 2) and not use_mid:
            continue
        if k >= 3 and _good(a, b, end):
            break
        m, ctx = (mid, ctx_m) if k == 1 or k == 2 else (a, ctx_a)
        use_pw = k == 2 or (k >= 3 and (k == 3) == pw_first)
        if k == 0:
            n = n_carry
        elif use_pw:
            ca, Ra, cb, Rb = _pose(piece, m, Ra_p, Rb_p, ctx[1], ctx[2], da, db, d_tau)
            n, mu = _contact_normal(ca, Ra, ra, cb, Rb, rb, mu_last if k >= 3 else 0.0)
            if k >= 3:
                mu_last = mu
        else:
            n = _affine(d_tau, m - float(piece), v)
        if not _norm(n) > 0.0:
            continue
        bk, fk = _largest_end(a, m, end, _setup(n, m, ctx), k == 1)
        if bk > b:
            b, fail, n_best = bk, fk, n
            if k >= 3:
                pw_first = use_pw
        if k <= 2 and b == end:
            break
        if k >= 3 and use_pw and bk - a >= TOI_STALL and fk - bk <= 0.1 * (bk - a):
            break  # the contact normal's bound is tight at b: a contact ahead, not a poor normal
    return b, fail, n_best, pw_first, mu_last


@jit
def toi_pair(ca0, Ra0, ca1, Ra1, ra, wa, cb0, Rb0, cb1, Rb1, rb, wb, ot, orel, ocount):
    """(toi, status, t_exact, steps) for one pair; status NEED_EXACT asks for the exact relation at the
    float pose at t_exact (then rerun with it in the oracle ot, orel[:ocount])."""
    pair, swept = _pair_data(ca0, Ra0, ca1, Ra1, ra, wa, cb0, Rb0, cb1, Rb1, rb, wb)
    whole, t_in, t_out = _swept_spheres(swept)
    if whole:
        return math.inf, NO_CONTACT, 0.0, 0
    if t_in == 0.0:  # the bounding spheres meet at t = 0: classify the inputs
        rel = _probe(0.0, pair, 0.0, ot, orel, ocount)
        if rel == UNDECIDED:
            return 0.0, NEED_EXACT, 0.0, 0
        if rel != SEPARATED:
            return 0.0, rel, 0.0, 0
    stalls = 0
    steps = 1
    pw_first = True  # the contact normal usually reaches farther than the centre line
    carry = False
    first = True
    n_carry = (0.0, 0.0, 0.0)
    mu_last = 0.0
    a = t_in
    while a < t_out:
        piece = 0 if a < 0.5 else 1
        end = min(0.5 if piece == 0 else 1.0, t_out)
        steps += 1
        if steps > TOI_MAX_STEPS:
            return a, UNRESOLVED, 0.0, steps
        b, fail, n_best, pw_first, mu_last = _step(a, piece, end, first, carry, n_carry, pw_first, mu_last, pair)
        first = False
        carry = b == end and piece == 0 and end == 0.5
        if carry:
            n_carry = n_best
        if b == end or (b - a >= TOI_STALL and (fail - b > TOI_PROBE or b - a > TOI_PROBE_REACH)):
            a = b
            stalls = 0
            continue
        # Stalled, or the certificate fails within TOI_PROBE of b near a: a contact (or a near-touch
        # float64 cannot resolve) within reach; probe the pose just beyond the proven end.
        stalled = b - a < TOI_STALL
        a = b
        probe = min(a + TOI_PROBE, 1.0)
        rel = _probe(probe, pair, mu_last, ot, orel, ocount)
        if rel == UNDECIDED:
            # within rounding of touching: a deeper pose, still within TOI_TOL of the proven end, usually
            # settles it in floats; otherwise the exact relation at the first probe is needed
            probe2 = min(a + TOI_PROBE2, 1.0)
            rel2 = _probe(probe2, pair, mu_last, ot, orel, ocount)
            if rel2 == CONTACT or rel2 == CONTACT_AT_FLOAT_POSE:
                return probe2, rel2, 0.0, steps
            return a, NEED_EXACT, probe, steps
        if rel != SEPARATED:
            return probe, rel, 0.0, steps
        if stalled:
            stalls += 1
            if stalls >= TOI_STALL_LIMIT:
                return a, UNRESOLVED, 0.0, steps
        else:
            stalls = 0
    return math.inf, NO_CONTACT, 0.0, steps


@stage
def _loads(A0, A1, B0, B1, ia, ib):
    """Pair (ia, ib)'s twelve tuples: centre, rotation, centre, rotation, radii, w for A, then for B."""
    return (
        _load3(A0[0], ia),
        _load9(A0[1], ia),
        _load3(A1[0], ia),
        _load9(A1[1], ia),
        _load3(A0[2], ia),
        _load3(A1[2], ia),
        _load3(B0[0], ib),
        _load9(B0[1], ib),
        _load3(B1[0], ib),
        _load9(B1[1], ib),
        _load3(B0[2], ib),
        _load3(B1[2], ib),
    )


@stage
def load_pair(A0, A1, B0, B1, ia, ib):
    """_pair_data of pair (ia, ib) of the kernels' argument tuples (_check): (pair, swept)."""
    x = _loads(A0, A1, B0, B1, ia, ib)
    return _pair_data(x[0], x[1], x[2], x[3], x[4], x[5], x[6], x[7], x[8], x[9], x[10], x[11])


@stage
def _run_pair(i, A0, A1, B0, B1, sa, sb, OT, OR, OC, out, status, t_exact, steps):
    Ca0, Ra0, ra = A0
    Ca1, Ra1, Wa = A1
    Cb0, Rb0, rb = B0
    Cb1, Rb1, Wb = B1
    ia, ib = i * sa, i * sb
    out[i], status[i], t_exact[i], steps[i] = toi_pair(
        _load3(Ca0, ia),
        _load9(Ra0, ia),
        _load3(Ca1, ia),
        _load9(Ra1, ia),
        _load3(ra, ia),
        _load3(Wa, ia),
        _load3(Cb0, ib),
        _load9(Rb0, ib),
        _load3(Cb1, ib),
        _load9(Rb1, ib),
        _load3(rb, ib),
        _load3(Wb, ib),
        OT[i],
        OR[i],
        OC[i],
    )


@jit
def _toi(A0, A1, B0, B1, idx, OT, OR, OC, out, status, t_exact, steps, lo, hi):
    sa, sb = int(A0[0].shape[0] > 1), int(B0[0].shape[0] > 1)  # stride 0 broadcasts a batch of one
    for k in range(lo, hi):
        _run_pair(idx[k], A0, A1, B0, B1, sa, sb, OT, OR, OC, out, status, t_exact, steps)


@jit
def _float_poses(A0, A1, B0, B1, idx, t, CA, RA, ra_out, CB, RB, rb_out):
    """The float poses the kernel classifies at t[k] for pair idx[k] (unit-scaled, A's centre relative
    to c_a at tau; the inputs themselves at t = 0 and 1), for the rational fallback and the tests."""
    sa, sb = int(A0[0].shape[0] > 1), int(B0[0].shape[0] > 1)
    for k in range(idx.shape[0]):
        i = idx[k]
        ia, ib = i * sa, i * sb
        ca, Ra, ra, cb, Rb, rb = _pose_at(t[k], load_pair(A0, A1, B0, B1, ia, ib)[0])
        for j in range(3):
            CA[k, j], CB[k, j], ra_out[k, j], rb_out[k, j] = ca[j], cb[j], ra[j], rb[j]
            for l in range(3):
                RA[k, j, l], RB[k, j, l] = Ra[3 * j + l], Rb[3 * j + l]


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


@jit
def _rigid_turns(r0, r1, R0, R1):
    """_check_motion's tests of one body in compiled code: its (n, 3) rotation vectors and whether it
    passes them (equal semi-axes, no turn within HALF_TURN_TOL of a half turn)."""
    n = r0.shape[0]
    w, angle = np.empty((n, 3)), np.empty(n)
    for i in range(n):
        for j in range(3):
            if r0[i, j] != r1[i, j]:
                return False, w
    _rotation_vectors(R0, R1, w, angle)
    for i in range(n):
        if math.pi - angle[i] < HALF_TURN_TOL:
            return False, w
    return True, w


@jit
def _toi_small(Ca0, Ra0, ra0, Ca1, Ra1, ra1, Cb0, Rb0, rb0, Cb1, Rb1, rb1):
    """time_of_impact of a small batch in one compiled call (issue 20: numpy's checks and allocations
    cost ~10x the kernel on one pair): (done, toi, status).  done is False, and nothing computed, unless
    the bodies' lengths make 1 to SMALL_BATCH_PAIRS pairs, and False when a check fails or a pair asks
    for the exact relation: time_of_impact's general path then reports or resolves it."""
    na, nb = Ca0.shape[0], Cb0.shape[0]
    n = max(na, nb)
    if (
        na != Ca1.shape[0]
        or nb != Cb1.shape[0]
        or min(na, nb) == 0
        or n > SMALL_BATCH_PAIRS
        or (na != nb and min(na, nb) != 1)
    ):
        return False, np.empty(0), np.empty(0, dtype=np.int8)
    out, status = np.empty(n), np.empty(n, dtype=np.int8)
    ok, wa = _rigid_turns(ra0, ra1, Ra0, Ra1)
    if not ok:
        return False, out, status
    ok, wb = _rigid_turns(rb0, rb1, Rb0, Rb1)
    if not ok:
        return False, out, status
    OT = np.zeros((n, TOI_MAX_ORACLE))
    OR = np.zeros((n, TOI_MAX_ORACLE), dtype=np.int8)
    OC = np.zeros(n, dtype=np.int64)
    t_exact, steps = np.empty(n), np.empty(n, dtype=np.int64)
    arrays = ((Ca0, Ra0, ra0), (Ca1, Ra1, wa), (Cb0, Rb0, rb0), (Cb1, Rb1, wb))
    _toi(*arrays, np.arange(n), OT, OR, OC, out, status, t_exact, steps, 0, n)
    for i in range(n):
        if status[i] == NEED_EXACT:
            return False, out, status
    return True, out, status


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
