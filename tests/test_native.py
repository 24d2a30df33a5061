"""The compiled core (ellipsim/native, issue 46): the exact layer's kernels and the module itself.

The float filters (certify, certify_indexed, the contact scale, separated_by_axes, the containment filter)
against the exact integer fallbacks (ext.resolve, ext.resolve_containment) on every stress category of
ellipsim.core.samples and on hypothesis's hard pairs: each filter's decisions are the exact ones; outputs in
range on arbitrary finite floats (no validation: extreme exponents, rotations that are not rotations).  The
exact fallback against the plain-Python Fraction implementations (rational_fallback.py, containment.py) and
its integer arithmetic against Python's int.  Also checked: broadcasting and [lo, hi) ranges, chunked and
threaded calls (the serial call's bits), the build's floating-point contract (no fused multiply-add), the
tolerances (the same values as tolerances.py), the source digest that refuses a stale build, the MuJoCo
version check, and the binding's refusals.
"""

import math
import pathlib
import re
import shutil
import threading
from fractions import Fraction

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from native_checks import assert_same_bits, finite, positive
from scipy.spatial.transform import Rotation as Rot
from strategies import SIGNED_PERMUTATIONS, hard_pair, random_pair

import ellipsim.native as native
from ellipsim import Ellipsoids
from ellipsim.core import samples, threads
from ellipsim.core import tolerances as tol
from ellipsim.core.exact import rational_fallback as rational
from ellipsim.core.exact.containment import contains_exact
from ellipsim.core.relation import OVERLAPPING, SEPARATED, TOUCHING, UNDECIDED

ext = native.ext
RELATIONS = {SEPARATED, TOUCHING, OVERLAPPING, UNDECIDED}
CONTAINMENTS = {0, 1, UNDECIDED}  # NOT_INSIDE, INSIDE (containment.py)

# (kernel, output dtype): the same signature (6 arrays, out, lo, hi).
PAIRWISE = {
    "certify": (ext.certify, np.int8),
    "contact_scales": (ext.contact_scales, np.float64),
    "separated_by_axes": (ext.testing.separated_by_axes, np.bool_),
    "contains": (ext.contains, np.int8),
}
for _cofactor in (False, True):  # the thesis's tests, float64
    for _sturm in (False, True):
        PAIRWISE[f"{'cofactor' if _cofactor else 'rearranged'} {'sturm' if _sturm else 'descartes'}"] = (
            lambda *a, c=_cofactor, s=_sturm: ext.classify_float(*a[:6], c, s, *a[6:]),
            np.int8,
        )


def arrays(a, b):
    return a.centers, a.rotations, a.radii, b.centers, b.rotations, b.radii


def run(name, args, n, lo=0, hi=None):
    """Kernel `name` on out[lo:hi] of an output of n rows filled with 7."""
    kernel, dtype = PAIRWISE[name]
    out = np.full(n, 7, dtype=dtype)
    with np.errstate(all="ignore"):
        kernel(*args, out, lo, n if hi is None else hi)
    return out


def exact(args, n):
    """The exact relation (ext.resolve, tested against the Fractions below) of every pair."""
    out = np.full(n, UNDECIDED, np.int8)
    ext.resolve(*args, out, 0, n)
    return out


def assert_filters_are_exact(args, n):
    """certify's decisions are the exact relation; separated_by_axes proves only separated pairs; the
    contact scale is above 1 for separated pairs and below for overlapping ones (beyond rounding); the
    thesis's float tests answer a relation or UNDECIDED."""
    want = exact(args, n)
    got = run("certify", args, n)
    decided = got != UNDECIDED
    assert_same_bits(got[decided], want[decided], "certify")
    assert not np.any(run("separated_by_axes", args, n) & (want != SEPARATED)), "separated_by_axes"
    s = run("contact_scales", args, n)
    clear = np.abs(s - 1.0) > 1e-9
    assert np.all((s[clear] > 1.0) == (want[clear] == SEPARATED)), "contact_scales"
    for name in PAIRWISE:
        if name.startswith(("cofactor", "rearranged")):
            assert set(run(name, args, n).tolist()) <= RELATIONS, name
    assert set(run("contains", args, n).tolist()) <= CONTAINMENTS
    return want


SETS = [
    ("generic", lambda: samples.generic_pairs(600, seed=3)),
    ("near contact", lambda: samples.near_contact_pairs(600, seed=4)),
]
SETS += [(c, lambda c=c: samples.stress_pairs(c, 200, seed=5)) for c in samples.STRESS]


@pytest.mark.parametrize("label, make", SETS, ids=[s[0] for s in SETS])
def test_the_filters_decide_as_the_exact_relation_on_every_sample_set(label, make):
    a, b = make()
    assert_filters_are_exact(arrays(a, b), len(a))


@pytest.mark.parametrize("name", sorted(PAIRWISE))
def test_a_batch_of_one_broadcasts_and_a_range_writes_only_its_slice(name):
    a, b = samples.near_contact_pairs(300, seed=8)
    n = len(a)
    full = run(name, arrays(a, b), n)
    assert_same_bits(run(name, arrays(a[0], b), n), run(name, arrays(a[[0] * n], b), n), f"{name} broadcast a")
    assert_same_bits(run(name, arrays(a, b[5]), n), run(name, arrays(a, b[[5] * n]), n), f"{name} broadcast b")
    out = run(name, arrays(a, b), n, 17, 211)
    _, dtype = PAIRWISE[name]
    assert np.all(out[:17] == dtype(7)) and np.all(out[211:] == dtype(7))  # the rest keeps its fill
    assert_same_bits(out[17:211], full[17:211], f"{name} range")


@settings(max_examples=300, deadline=None)
@given(st.one_of(hard_pair, random_pair()))
def test_hard_pairs_the_filters_decide_as_the_exact_relation(pair):
    a, b = pair
    assert_filters_are_exact(arrays(a, b), 1)


@settings(max_examples=400, deadline=None)
@given(
    st.lists(finite, min_size=6, max_size=6),
    st.lists(st.one_of(finite, st.floats(-1, 1)), min_size=18, max_size=18),
    st.lists(st.one_of(positive, st.floats(0.01, 10)), min_size=6, max_size=6),
)
def test_arbitrary_finite_floats_give_outputs_in_range(c, R, r):
    """Any finite float the kernels may meet (the Python layer validates; the kernels must not fail):
    extreme exponents, subnormal radii, rotations that are not rotations.  Each answers a relation or
    UNDECIDED, the same bits twice."""
    C = np.array(c).reshape(2, 1, 3)
    M = np.array(R).reshape(2, 1, 3, 3)
    S = np.array(r).reshape(2, 1, 3)
    args = (C[0], M[0], S[0], C[1], M[1], S[1])
    for name, (_, dtype) in PAIRWISE.items():
        got = run(name, args, 1)
        assert_same_bits(got, run(name, args, 1), name)
        if dtype == np.int8:
            assert int(got[0]) in (CONTAINMENTS if name == "contains" else RELATIONS), name


def test_certify_indexed_is_certify_on_the_gathered_pairs():
    a, b = samples.near_contact_pairs(500, seed=9)
    batch = Ellipsoids(np.concatenate([a.centers, b.centers]), np.concatenate([a.rotations, b.rotations]),
                       np.concatenate([a.radii, b.radii]))  # fmt: skip
    rng = np.random.default_rng(0)
    first, second = rng.integers(0, 1000, 3000), rng.integers(0, 1000, 3000)
    got = np.full(3000, 7, np.int8)
    ext.certify_indexed(batch.centers, batch.rotations, batch.radii, first, second, got, 0, 3000)
    want = run("certify", arrays(batch[first], batch[second]), 3000)
    np.testing.assert_array_equal(got, want)


def test_chunks_on_threads_and_concurrent_callers_get_the_serial_bits():
    a, b = samples.near_contact_pairs(20000, seed=10)
    args = arrays(a, b)
    serial = np.empty(len(a))
    ext.contact_scales(*args, serial, 0, len(a))
    chunked = np.empty(len(a))
    with threads.limit(2):
        threads.run(ext.contact_scales, len(a), True, *args, chunked)
    np.testing.assert_array_equal(chunked.view(np.int64), serial.view(np.int64))
    outs = [np.empty(len(a)) for _ in range(4)]
    workers = [threading.Thread(target=ext.contact_scales, args=(*args, out, 0, len(a))) for out in outs]
    for w in workers:
        w.start()
    for w in workers:
        w.join()
    for out in outs:
        np.testing.assert_array_equal(out.view(np.int64), serial.view(np.int64))


def test_no_fused_multiply_add():
    """(1 + 2^-30)(1 - 2^-30) - 1 is -2^-60 exactly; rounded after the product (the proofs' model) it is 0.
    A build that contracts a * b + c into one fused multiply-add returns -2^-60."""
    a, b = 1.0 + 2.0**-30, 1.0 - 2.0**-30
    assert a * b == 1.0  # Python rounds each operation
    assert ext.testing.multiply_add(a, b, -1.0) == 0.0


def test_the_tolerances_are_tolerances_py():
    header = (native.FOLDER / "include" / "ellipsim" / "tolerances.hpp").read_text()
    declared = set(re.findall(r"^constexpr (?:double|int) ([A-Z][A-Z0-9_]*) =", header, re.M))
    constants = ext.testing.TOLERANCES
    assert set(constants) == declared and len(declared) > 60  # every constant of the header, bound
    for name, value in constants.items():
        assert getattr(tol, name) == value and type(getattr(tol, name)) is type(value), name


def test_the_module_is_built_from_these_sources_and_a_change_is_seen(tmp_path):
    assert ext.SOURCE_DIGEST == native.source_digest()
    copy = tmp_path / "native"
    shutil.copytree(native.FOLDER, copy, ignore=shutil.ignore_patterns("__pycache__", "*.py"))
    assert native.source_digest(copy) == ext.SOURCE_DIGEST
    header = copy / "include" / "ellipsim" / "exact" / "certified_filter.hpp"
    header.write_text(header.read_text() + "\n")
    assert native.source_digest(copy) != ext.SOURCE_DIGEST
    (copy / "include" / "ellipsim" / "exact" / "certified_filter.hpp").unlink()
    assert native.source_digest(copy) != ext.SOURCE_DIGEST


def test_a_stale_module_is_refused_with_the_rebuild_command(monkeypatch):
    monkeypatch.setattr(native, "source_digest", lambda folder=None: "0" * 64)
    with pytest.raises(native.NativeImportError, match=r"built from other sources than .*pip install"):
        native._load()


def test_a_module_built_against_another_mujoco_is_refused_in_one_line(monkeypatch):
    assert native.mujoco_mismatch(ext.mujoco.MUJOCO_VERSION, mujoco.mj_version()) is None  # this install's
    assert native.version_text(4000001) == "4.0.1" and native.version_text(12034005) == "12.34.5"
    monkeypatch.setattr(mujoco, "mj_version", lambda: 4001000)
    native._load()  # the core does not touch MuJoCo: loading the module does not check
    with pytest.raises(native.NativeImportError) as caught:
        native.check_mujoco()
    message = str(caught.value)
    assert "\n" not in message and caught.value.one_line
    assert message.startswith(
        f"ellipsim's compiled core was built against MuJoCo {native.version_text(ext.mujoco.MUJOCO_VERSION)}, "
    )
    assert "this process runs mujoco 4.1.0" in message and "pip install --no-build-isolation ." in message
    assert f"pip install mujoco=={native.version_text(ext.mujoco.MUJOCO_VERSION)}, or rebuild" in message


def test_the_command_line_says_an_unusable_core_in_one_line_without_a_traceback(monkeypatch, capsys):
    from ellipsim.app import cli
    from ellipsim.app.cli import scenarios

    def unusable(args):
        raise native.NativeImportError(native.mujoco_mismatch(4000001, 4001000))

    monkeypatch.setattr(scenarios, "list_scenarios", unusable)
    assert cli.main(["list"]) == 1
    err = capsys.readouterr().err
    assert err == f"ellipsim: error: {native.mujoco_mismatch(4000001, 4001000)}\n"
    monkeypatch.setattr(scenarios, "list_scenarios", lambda args: __import__("no_such_module_here"))
    with pytest.raises(ModuleNotFoundError):  # any other ImportError is a bug: its traceback stays
        cli.main(["list"])


def test_the_binding_refuses_what_the_python_layer_never_passes():
    a, b = samples.generic_pairs(10, seed=1)
    out = np.empty(10, np.int8)
    with pytest.raises(IndexError, match="range"):
        ext.certify(*arrays(a, b), out, 0, 11)
    with pytest.raises(IndexError, match="range"):
        ext.certify(*arrays(a, b), out, 5, 4)
    with pytest.raises(IndexError, match="batches"):
        ext.certify(*arrays(a[:4], b), out, 0, 10)
    with pytest.raises(TypeError):  # no silent copy: a strided or float32 array is not taken
        ext.certify(a.centers[::-1], *arrays(a, b)[1:], out, 0, 10)
    with pytest.raises(TypeError):
        ext.certify(*arrays(a, b), np.empty(10, np.int16), 0, 10)
    with pytest.raises(IndexError, match="index"):
        ext.certify_indexed(a.centers, a.rotations, a.radii, np.arange(10), np.full(10, 10), out, 0, 10)
    assert pathlib.Path(ext.__file__).name.startswith("_ellipsim")


# --- the exact fallback: integer arithmetic against Python's int and Fraction ------------------------------

big = st.integers(min_value=-(2**2000), max_value=2**2000)


@settings(max_examples=400, deadline=None)
@given(st.one_of(big, st.integers(-(2**70), 2**70)), st.one_of(big, st.integers(-(2**70), 2**70)))
def test_integer_arithmetic_is_pythons(a, b):
    op = ext.testing.integer_op
    assert op("+", a, b) == a + b and op("-", a, b) == a - b and op("*", a, b) == a * b
    if b:
        assert op("divexact", a * b, b) == a
        assert op("//", a, b) == abs(a) // abs(b) and op("%", a, b) == abs(a) % abs(b)  # of the magnitudes
    assert op("<<", a, 131) == a << 131
    assert op("gcd", a, b) == math.gcd(a, b) and op("gcd", a * b, b * 3) == math.gcd(a * b, b * 3)


@settings(max_examples=400, deadline=None)
@given(
    st.lists(st.integers(-6, 6), min_size=1, max_size=6),
    st.lists(st.integers(-9, 9), min_size=0, max_size=3),
    st.sampled_from([1, -1, 2, -3]),
)
def test_distinct_positive_roots_is_the_fraction_sturm(roots, extra, lead):
    """Polynomials with repeated, zero, negative and complex roots: the subresultant Sturm count is the
    Fraction one (rational_fallback.py)."""
    p = [lead]
    for r in roots:
        p = [x - r * y for x, y in zip(p + [0], [0] + p)]
    q = [1, *extra]
    prod = [sum(p[i] * q[k - i] for i in range(len(p)) if 0 <= k - i < len(q)) for k in range(len(p) + len(q) - 1)]
    got = ext.testing.distinct_positive_roots(prod)
    if prod[-1] == 0:
        assert got == -1
    else:
        assert got == rational.distinct_positive_roots([Fraction(c) for c in prod])


def assert_exact_relation_is_the_fraction_one(a, b):
    n = len(a)
    got = np.full(n, UNDECIDED, np.int8)
    ext.resolve(*arrays(a, b), got, 0, n)
    for i in range(n):
        pair = (a.centers[i], a.rotations[i], a.radii[i], b.centers[i], b.rotations[i], b.radii[i])
        assert got[i] == rational.relation(*pair), i
        # the integer pencil h(nu) is c f(nu / s) for the Fraction pencil f, some c, s > 0
        h = [Fraction(x) for x in ext.testing.pencil_polynomial(*(x[i : i + 1] for x in arrays(a, b)))]
        f = rational.pencil_coefficients(*pair)
        ratios = [hk / fk for hk, fk in zip(h, f) if fk]
        assert all(r > 0 for r in ratios) and [k for k in range(5) if h[k]] == [k for k in range(5) if f[k]]
        steps = [h[k + 1] * f[k] / (h[k] * f[k + 1]) for k in range(4) if f[k] and f[k + 1]]
        assert len(set(steps)) <= 1 and all(s > 0 for s in steps)


@pytest.mark.parametrize("category", samples.STRESS)
def test_the_exact_relation_is_the_fraction_one_on_every_stress_category(category):
    assert_exact_relation_is_the_fraction_one(*samples.stress_pairs(category, 12, seed=6))


@settings(max_examples=60, deadline=None)
@given(hard_pair)
def test_the_exact_relation_is_the_fraction_one_on_hard_pairs(pair):
    assert_exact_relation_is_the_fraction_one(*pair)


@settings(max_examples=60, deadline=None)
@given(
    st.lists(finite, min_size=6, max_size=6),
    st.lists(st.one_of(finite, st.floats(-1, 1)), min_size=18, max_size=18),
    st.lists(st.one_of(positive, st.floats(0.01, 10)), min_size=6, max_size=6),
)
def test_the_exact_relation_is_the_fraction_one_on_any_floats(c, R, r):
    """Extreme exponents (subnormal to 1e308 in one pair) and matrices that are not rotations: the
    integer scaling keeps everything exact; a singular matrix is refused as the Fraction version does."""
    C, M, S = np.array(c).reshape(2, 1, 3), np.array(R).reshape(2, 1, 3, 3), np.array(r).reshape(2, 1, 3)
    pair = (C[0, 0], M[0, 0], S[0, 0], C[1, 0], M[1, 0], S[1, 0])
    try:
        want = rational.relation(*pair)
    except ValueError:  # a singular rotation of A: the pencil's constant term is zero
        got = np.full(1, UNDECIDED, np.int8)
        with pytest.raises(ValueError, match="singular"):
            ext.resolve(*(C[0], M[0], S[0], C[1], M[1], S[1]), got, 0, 1)
        return
    got = np.full(1, UNDECIDED, np.int8)
    ext.resolve(*(C[0], M[0], S[0], C[1], M[1], S[1]), got, 0, 1)
    assert got[0] == want


def test_resolve_touches_only_undecided_entries():
    a, b = samples.stress_pairs("spheres", 30, seed=1)
    out = np.array([UNDECIDED, 5] * 15, np.int8)
    ext.resolve(*arrays(a, b), out, 0, 30)
    assert np.all(out[1::2] == 5)
    for i in range(0, 30, 2):
        assert out[i] == rational.relation(
            a.centers[i], a.rotations[i], a.radii[i], b.centers[i], b.rotations[i], b.radii[i]
        )


# --- containment: the float filter bit for bit, the exact fallback against the Fraction one ----------------


def containment_pairs(n, seed):
    """B near A's inside: shrunk or grown about an interior point by 1 -+ 2^-k (k = 10 ... 40), rotated a
    little or not, or small and centred inside; then exactly internally tangent dyadic pairs."""
    rng = np.random.default_rng(seed)
    ra = rng.uniform(0.5, 2, (n, 3))
    Ra = Rot.random(n, random_state=rng).as_matrix()
    ca = rng.uniform(-2, 2, (n, 3))
    p = ca + np.einsum("nij,nj->ni", Ra, ra * rng.uniform(-0.3, 0.3, (n, 3)))
    s = 1.0 + rng.choice([-1.0, 1.0], n) * 2.0 ** -rng.integers(10, 41, n)
    turn = Rot.from_rotvec(rng.normal(size=(n, 3)) * rng.choice([0.0, 1e-6, 1e-3], n)[:, None]).as_matrix()
    kind = np.arange(n) % 3
    rb = np.where((kind == 2)[:, None], ra.min(1)[:, None] * rng.uniform(0.1, 1.0, (n, 3)), ra * s[:, None])
    cb = np.where((kind == 2)[:, None], ca + np.einsum("nij,nj->ni", Ra, ra * rng.uniform(-0.6, 0.6, (n, 3))),
                  p + s[:, None] * (ca - p))  # fmt: skip
    Rb = np.where((kind == 1)[:, None, None], Ra @ turn, Ra)
    a, b = Ellipsoids(ca, Ra, ra), Ellipsoids(cb, Rb, rb)
    # exactly internally tangent (tests/test_containment.py): B touches A at (a0, 0, 0) from inside
    C1, R1, r1, C2, R2, r2 = [], [], [], [], [], []
    for _ in range(n // 4):
        ax = rng.integers(4, 33, 3) / 8.0
        b0 = rng.integers(1, int(ax[0] * 8) + 1) / 8.0
        bk = [max(np.floor(min(ax[k] * np.sqrt(b0 / ax[0]), ax[k]) * 8) / 8.0, 1 / 16) for k in (1, 2)]
        P = SIGNED_PERMUTATIONS[rng.integers(len(SIGNED_PERMUTATIONS))]
        shift = rng.integers(-16, 17, 3) / 4.0
        C1.append(shift), R1.append(P), r1.append(ax)
        C2.append(shift + P @ np.array([ax[0] - b0 + rng.choice([0.0, 2.0**-30]), 0, 0])), R2.append(P)
        r2.append([b0, *bk])
    t1, t2 = Ellipsoids(np.array(C1), np.array(R1), np.array(r1)), Ellipsoids(np.array(C2), np.array(R2), np.array(r2))
    return (
        Ellipsoids(np.concatenate([a.centers, t1.centers]), np.concatenate([a.rotations, t1.rotations]),
                   np.concatenate([a.radii, t1.radii])),
        Ellipsoids(np.concatenate([b.centers, t2.centers]), np.concatenate([b.rotations, t2.rotations]),
                   np.concatenate([b.radii, t2.radii])),
    )  # fmt: skip


CONTAIN_SETS = [("near containment", lambda: containment_pairs(300, 11))]
CONTAIN_SETS += [(label, lambda make=make: tuple(x[:60] for x in make())) for label, make in SETS]


@pytest.mark.parametrize("label, make", CONTAIN_SETS, ids=[s[0] for s in CONTAIN_SETS])
def test_the_containment_filter_decides_as_the_exact_fallback(label, make):
    """Both ways round: the filter's decisions are ext.resolve_containment's (tested against the Fraction
    fallback below)."""
    a, b = make()
    n = len(a)
    for x, y in ((a, b), (b, a)):
        filt = run("contains", arrays(x, y), n)
        want = np.full(n, UNDECIDED, np.int8)
        ext.resolve_containment(*arrays(x, y), want, 0, n)
        decided = filt != UNDECIDED
        np.testing.assert_array_equal(filt[decided], want[decided])
        assert set(want.tolist()) <= {0, 1}


def test_exact_containment_is_the_fraction_one():
    """Every pair of a near-containment set decided exactly (not only those the filter leaves), both ways,
    against containment.py's Fraction fallback; the filter's own decisions agree with it too."""
    a, b = containment_pairs(60, 12)
    for x, y in ((a, b), (b, a)):
        n = len(x)
        exact = np.full(n, UNDECIDED, np.int8)
        ext.resolve_containment(*arrays(x, y), exact, 0, n)
        want = [contains_exact(x.centers[i], x.rotations[i], x.radii[i], y.centers[i], y.rotations[i], y.radii[i])
                for i in range(n)]  # fmt: skip
        np.testing.assert_array_equal(exact, want)
        filt = np.empty(n, np.int8)
        ext.contains(*arrays(x, y), filt, 0, n)
        decided = filt != UNDECIDED
        np.testing.assert_array_equal(filt[decided], exact[decided])
    assert 0 < np.count_nonzero(filt == UNDECIDED)  # the exactly tangent pairs reach the fallback


@settings(max_examples=40, deadline=None)
@given(hard_pair)
def test_exact_containment_is_the_fraction_one_on_hard_pairs(pair):
    a, b = pair
    for x, y in ((a, b), (b, a)):
        exact = np.full(1, UNDECIDED, np.int8)
        ext.resolve_containment(*arrays(x, y), exact, 0, 1)
        assert exact[0] == contains_exact(x.centers[0], x.rotations[0], x.radii[0], y.centers[0], y.rotations[0],
                                          y.radii[0])  # fmt: skip


# --- the constants the Python layer and the Warp glue read, against the C++ core's ----------------------

_LITERAL = re.compile(r"\b([A-Z][A-Z0-9_]*)\s*=\s*(-?(?:0x[0-9a-fA-F.]+p-?[0-9]+|[0-9][0-9.eE+-]*))\s*[,;]")


def _header_constants(header):
    """{NAME: value} of the literal `constexpr` constants of a header (hex floats included)."""
    found = {}
    for line in header.read_text().splitlines():
        if "constexpr" not in line:
            continue
        for name, text in _LITERAL.findall(line.split("//")[0]):
            found[name] = float.fromhex(text) if "0x" in text else float(text)
    return found


def test_every_constant_a_python_module_repeats_is_its_headers():
    """A core module's numeric constant with a literal twin in its header (include/ellipsim/<folder>/<module>.hpp)
    has its value: the Python layer and ellipsim.warp read the Python copies, the kernels the header's."""
    import importlib

    include = pathlib.Path(native.FOLDER) / "include" / "ellipsim"
    compared = 0
    for header in sorted(include.glob("*/*.hpp")):
        name = f"ellipsim.core.{header.parent.name}.{header.stem}"
        try:
            module = importlib.import_module(name)
        except ModuleNotFoundError:
            continue
        for constant, value in _header_constants(header).items():
            ours = getattr(module, constant, None)
            if isinstance(ours, (int, float)) and not isinstance(ours, bool):
                assert float(ours) == value, f"{name}.{constant}: {ours!r} in Python, {value!r} in {header.name}"
                compared += 1
    assert compared >= 40


def test_the_bound_constants_are_the_python_modules():
    from ellipsim.core.distance import branch_and_bound, derivatives, ellipsoid_pair, sphere_newton, spheroids, status
    from ellipsim.core.pairs import box, capsule, cylinder
    from ellipsim.core.pairs import derivatives as pair_derivatives

    T = ext.testing
    for table, module in ((T.CYLINDER_CONSTANTS, cylinder), (T.CAPSULE_CONSTANTS, capsule), (T.BOX_CONSTANTS, box)):
        for name, value in table.items():
            assert getattr(module, name) == value, (module.__name__, name)
    modules = dict(
        sphere_newton=sphere_newton,
        branch_and_bound=branch_and_bound,
        spheroids=spheroids,
        ellipsoid_pair=ellipsoid_pair,
        derivatives=derivatives,
    )
    for key, value in {**T.DISTANCE_CONSTANTS, **T.DISTANCE_CODES}.items():
        owner, name = key.split(".")
        module = modules.get(owner)
        got = getattr(module, name) if module else getattr(getattr(status, owner), name)
        assert got == value, key
    for name, value in T.PAIR_DERIVATIVE_CODES.items():
        assert getattr(pair_derivatives, name) == value, name
    np.testing.assert_array_equal(np.array(T.rho_table()), np.asarray(branch_and_bound.RHO_TABLE))
