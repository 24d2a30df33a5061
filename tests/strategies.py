"""Hypothesis strategies: random pairs and every hard category the exact test must survive."""

import numpy as np
from hypothesis import strategies as st

from ellipsim import Ellipsoids, contact_scale

SIGNED_PERMUTATIONS = [
    np.array(p, dtype=float) * np.array(s, dtype=float)[:, None]
    for p in (
        [[1, 0, 0], [0, 1, 0], [0, 0, 1]],
        [[0, 1, 0], [0, 0, 1], [1, 0, 0]],
        [[0, 0, 1], [1, 0, 0], [0, 1, 0]],
        [[0, 1, 0], [1, 0, 0], [0, 0, 1]],
        [[1, 0, 0], [0, 0, 1], [0, 1, 0]],
        [[0, 0, 1], [0, 1, 0], [1, 0, 0]],
    )
    for s in ([1, 1, 1], [-1, 1, 1], [1, -1, 1], [1, 1, -1], [-1, -1, 1], [-1, 1, -1], [1, -1, -1], [-1, -1, -1])
]


def one(c, R, r):
    return Ellipsoids(np.asarray(c, float), np.asarray(R, float), np.asarray(r, float))


quaternions = (
    st.tuples(*[st.floats(-1, 1, allow_nan=False) for _ in range(4)])
    .filter(lambda q: sum(x * x for x in q) > 1e-3)
    .map(np.array)
)
radii = st.tuples(*[st.floats(0.1, 2.0) for _ in range(3)]).map(np.array)
centers = st.tuples(*[st.floats(-2.5, 2.5) for _ in range(3)]).map(np.array)
dyadic = st.integers(1, 64).map(lambda k: k / 16.0)  # exactly representable, few bits


@st.composite
def ellipsoid(draw, radius=radii, center=centers):
    return Ellipsoids.from_quaternions(draw(center), draw(quaternions), draw(radius))


@st.composite
def random_pair(draw):
    return draw(ellipsoid()), draw(ellipsoid())


@st.composite
def exact_tangent_pair(draw):
    """Axis-aligned, dyadic sizes, meeting on an axis: the plane x = a0 separates them, they touch.

    A signed permutation (exact in floats) and a dyadic translation move the pair around.
    """
    ra = np.array([draw(dyadic) for _ in range(3)])
    rb = np.array([draw(dyadic) for _ in range(3)])
    P = SIGNED_PERMUTATIONS[draw(st.integers(0, len(SIGNED_PERMUTATIONS) - 1))]
    shift = np.array([draw(st.integers(-64, 64)) / 8.0 for _ in range(3)])
    Qa = SIGNED_PERMUTATIONS[draw(st.integers(0, len(SIGNED_PERMUTATIONS) - 1))]
    Qb = SIGNED_PERMUTATIONS[draw(st.integers(0, len(SIGNED_PERMUTATIONS) - 1))]
    # Axis-aligned ellipsoids written with a signed-permutation rotation are still axis-aligned;
    # rotating the radii with the permutation keeps the extent along x equal to ra[0] and rb[0].
    ca = shift
    cb = shift + P @ np.array([ra[0] + rb[0], 0.0, 0.0])
    Ra = P @ Qa
    Rb = P @ Qb
    ra_local = np.abs(Qa.T) @ ra
    rb_local = np.abs(Qb.T) @ rb
    return one(ca, Ra, ra_local), one(cb, Rb, rb_local)


@st.composite
def pythagorean_spheres(draw):
    """Spheres of dyadic radii whose centres are exactly r_a + r_b apart via a Pythagorean triple."""
    m, n = draw(st.integers(2, 9)), draw(st.integers(1, 8))
    if n >= m:
        m, n = n + 1, m
    a, b, c = m * m - n * n, 2 * m * n, m * m + n * n
    ra = draw(st.integers(1, c - 1))
    scale = 2.0 ** draw(st.integers(-6, 6))
    kind = draw(st.sampled_from(["touch", "apart", "overlap"]))
    rb = c - ra + {"touch": 0, "apart": 1, "overlap": -1}[kind] * 2.0**-40
    I = np.eye(3)
    return one([0, 0, 0], I, [ra * scale] * 3), one([a * scale, b * scale, 0], I, [rb * scale] * 3)


@st.composite
def spheroid_pair(draw):
    """Spheres and coaxial spheroids: the pencil has repeated (negative) roots."""
    P = SIGNED_PERMUTATIONS[draw(st.integers(0, len(SIGNED_PERMUTATIONS) - 1))]
    a0, a1, b0, b1 = (draw(dyadic) for _ in range(4))
    if draw(st.booleans()):  # spheres
        a1, b1 = a0, b0
    offset = draw(st.integers(0, 8 * 64)) / 16.0  # along the common axis P e_x
    return one([0, 0, 0], P, [a0, a1, a1]), one(P @ np.array([offset, 0.0, 0.0]), P, [b0, b1, b1])


@st.composite
def identical_or_contained(draw):
    a = draw(ellipsoid())
    kind = draw(st.sampled_from(["same", "half", "touch_inside", "small_inside"]))
    if kind == "same":
        return a, a
    if kind == "half":
        return a, Ellipsoids(a.centers, a.rotations, a.radii * 0.5)
    if kind == "touch_inside":  # internally tangent spheres: overlapping
        r = draw(dyadic)
        return one([0, 0, 0], np.eye(3), [2 * r] * 3), one([r, 0, 0], np.eye(3), [r] * 3)
    return a, Ellipsoids(a.centers + 0.01 * a.radii.min(), a.rotations, a.radii * 0.01)


@st.composite
def near_tangent_pair(draw, gaps=(1e-1, 1e-3, 1e-6, 1e-9, 1e-12, 1e-14, 1e-15)):
    """A random pair moved along its centre line until the PW scale is 1 +- gap."""
    a, b = draw(random_pair())
    gap = draw(st.sampled_from(gaps)) * draw(st.sampled_from([-1.0, 1.0]))
    return move_to_scale(a, b, 1.0 + gap)


def move_to_scale(a, b, target):
    """b translated along c_b - c_a so that contact_scale(a, b) is about `target`."""
    d = b.centers[0] - a.centers[0]
    if not np.any(d):
        d = np.array([1e-3, 0.0, 0.0])
        b = Ellipsoids(a.centers + d, b.rotations, b.radii)
    for _ in range(60):  # contact_scale is monotone in the offset along a ray: bisect on the factor
        s = contact_scale(a, b)[0]
        if abs(s - target) <= 1e-16 * target:
            break
        t = target / s
        b = Ellipsoids(a.centers + d * t, b.rotations, b.radii)
        d = b.centers[0] - a.centers[0]
    return a, b


@st.composite
def extreme_pair(draw):
    """Aspect ratio up to 1e4, offsets up to 1e7 from the origin, sizes 1e-6 and 1e6, near tangency."""
    kind = draw(st.sampled_from(["aspect", "offset", "small", "large"]))
    gap = draw(st.sampled_from([1e-3, 1e-9, 1e-15])) * draw(st.sampled_from([-1.0, 1.0]))
    if kind == "aspect":
        big = 10.0 ** draw(st.integers(2, 4))
        ra = np.array([big, 1.0, 1.0]) * draw(st.floats(0.5, 2.0))
        rb = np.array([1.0, 1.0 / big, 1.0]) * draw(st.floats(0.5, 2.0))
        a = Ellipsoids.from_quaternions(draw(centers), draw(quaternions), ra)
        b = Ellipsoids.from_quaternions(draw(centers) * big, draw(quaternions), rb)
        return move_to_scale(a, b, 1.0 + gap)
    a, b = move_to_scale(*draw(random_pair()), 1.0 + gap)
    if kind == "offset":
        shift = np.array([draw(st.floats(-1, 1)) for _ in range(3)]) * 10.0 ** draw(st.integers(3, 7))
        return (
            Ellipsoids(a.centers + shift, a.rotations, a.radii),
            Ellipsoids(b.centers + shift, b.rotations, b.radii),
        )
    f = 1e-6 if kind == "small" else 1e6
    return (Ellipsoids(a.centers * f, a.rotations, a.radii * f), Ellipsoids(b.centers * f, b.rotations, b.radii * f))


hard_pair = st.one_of(
    exact_tangent_pair(),
    pythagorean_spheres(),
    spheroid_pair(),
    identical_or_contained(),
    near_tangent_pair(),
    extreme_pair(),
)
