"""The glue's one table of pair types (context.PAIR_TYPES) against the code that uses it (the C++ callbacks
included), and the Python-side glue modules load no numba (no import cycle anywhere: tests/test_layout.py)."""

import ctypes
import pathlib
import re
import subprocess
import sys

import mujoco
import numpy as np
import pytest

import ellipsim.mujoco as em
from ellipsim.core.tolerances import DIST_TOL
from ellipsim.mujoco import attachment, context, geoms, judge, publish
from ellipsim.mujoco.context import FILTER_PAIR_TYPES, PAIR_TYPES, RECORDED
from ellipsim.native import ext

TYPES = {
    "plane": int(mujoco.mjtGeom.mjGEOM_PLANE),
    "hfield": context.HFIELD,
    "sphere": context.SPHERE,
    "capsule": context.CAPSULE,
    "ellipsoid": context.ELLIPSOID,
    "cylinder": context.CYLINDER,
    "box": context.BOX,
    "mesh": context.MESH,
}
SIZES = {"sphere": ".12", "capsule": ".08 .15", "ellipsoid": ".1 .15 .2", "cylinder": ".1 .15", "box": ".1 .12 .14"}
NAMES = {v: k for k, v in TYPES.items()}
#: the assets of the mesh and height-field geoms: a convex mesh of 12 points, a 6 x 6 field 0.6 m square
_POINTS = np.random.default_rng(0).normal(size=(12, 3)) * 0.1
ASSETS = (
    f'<asset><mesh name="prop" vertex="{" ".join(f"{x:.5f}" for x in _POINTS.ravel())}"/>'
    '<hfield name="ground" nrow="6" ncol="6" size=".3 .3 .1 .05" '
    f'elevation="{" ".join(f"{x:.3f}" for x in np.random.default_rng(1).uniform(0, 1, 36))}"/></asset>'
)


def geom_xml(t, pos, attrs=""):
    """A geom of type `t` (a name of TYPES) at pos: its size, or its mesh or height field."""
    shape = {"mesh": 'mesh="prop"', "hfield": 'hfield="ground"'}.get(t, f'size="{SIZES.get(t, "5 5 .1")}"')
    return f'<geom type="{t}" {shape} pos="{pos}" {attrs}/>'


NATIVE = pathlib.Path(__file__).resolve().parents[1] / "ellipsim" / "native"
NARROW_T = ctypes.CFUNCTYPE(
    ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int, ctypes.c_int, ctypes.c_double
)
FILTER_T = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int, ctypes.c_int)


@pytest.mark.parametrize("module", ["context", "publish", "attachment", "geoms", "compare", "validate"])
def test_the_glue_loads_neither_numba_nor_llvmlite(module):
    code = (
        f"import sys, ellipsim.mujoco.{module}\n"
        "print(' '.join(sorted(m for m in sys.modules if m.split('.')[0] in ('numba', 'llvmlite'))))\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert proc.stdout.split() == []


def test_rows_are_in_mujocos_order_and_name_distinct_words():
    pairs = [(row.type1, row.type2) for row in PAIR_TYPES]
    assert all(t1 <= t2 for t1, t2 in pairs) and len(set(pairs)) == len(pairs)
    fallbacks = [context.FALLBACK_WORDS[row.key] for row in PAIR_TYPES]
    used = {context.REGISTRY_ADDRESS, context.REGISTRY_ROWS, context.MARK_STACK, context.FREE_STACK}
    used |= {context.STACK_ALLOC_NUM}
    assert len(set(fallbacks)) == len(fallbacks) and not set(fallbacks) & used
    assert all(0 <= w < context.WORDS for w in fallbacks)
    assert [row.name for row in PAIR_TYPES] == [f"{NAMES[row.type1]} x {NAMES[row.type2]}" for row in PAIR_TYPES]
    narrow = (NATIVE / "mujoco" / "narrowphase.hpp").read_text()
    for row in PAIR_TYPES:  # the header of each row is compiled into the narrow phase
        assert (NATIVE / "include" / "ellipsim" / f"{row.kernel}.hpp").is_file(), row.kernel
        assert f"#include <ellipsim/{row.kernel}.hpp>" in narrow, row.kernel


def test_the_cpp_context_has_pythons_numbers():
    """ellipsim/native/mujoco/context.hpp and context.py: the same words, columns, modes and counters."""
    header = (NATIVE / "mujoco" / "context.hpp").read_text()
    declared = dict(re.findall(r"\b([A-Z_]+) = (-?[0-9.]+)", header))
    for name in (
        "REGISTRY_ADDRESS", "REGISTRY_ROWS", "FALLBACK_ELLIPSOID", "FALLBACK_SPHERE", "FALLBACK_CAPSULE",
        "FALLBACK_BOX", "FALLBACK_CYLINDER", "FALLBACK_MESH", "FALLBACK_HFIELD", "MARK_STACK", "FREE_STACK",
        "STACK_ALLOC_NUM", "REGISTRY_COLUMNS", "WARM_ADDRESS", "WARM_MASK", "HULLS", "HULL_WORDS", "FILTER", "RECORD",
        "NARROW", "SEEN", "DISCARDED", "PASSED", "RECORDED", "SEPARATED", "CONTACTS", "APART", "FALLBACKS",
        "WARM_TIME", "WARM_EPOCH", "WARM_SLOT_WORDS", "WARM_JUMP",
    ):  # fmt: skip
        assert float(declared[name]) == getattr(context, name), name


def test_context_holds_mujocos_function_of_every_row():
    publish.fill_context()
    assert attachment._state["table"] is None  # nothing attached: the table holds MuJoCo's own functions
    table, n = publish.collision_table()
    for row in PAIR_TYPES:
        assert context.CONTEXT[context.FALLBACK_WORDS[row.key]] == table[row.type1 * n + row.type2], row.name


def _model(types, spacing=1.0, extra=""):
    """A model of world geoms of `types` (names of TYPES), one every `spacing` metres along x."""
    geoms_xml = "".join(
        geom_xml(t, f"{i * spacing} 0 {-1 if t == 'plane' else 0}", f'name="g{i}"') for i, t in enumerate(types)
    )
    return mujoco.MjModel.from_xml_string(f"<mujoco>{ASSETS}<worldbody>{geoms_xml}</worldbody>{extra}</mujoco>")


def test_every_row_and_no_other_entry_is_installed_and_restored():
    model = _model(["ellipsoid", "sphere", "capsule", "cylinder", "box", "mesh", "hfield", "ellipsoid"])
    table, n = publish.collision_table()
    before = list(table)
    rows = {(row.type1, row.type2) for row in PAIR_TYPES}
    with em.attach(model, mujoco.MjData(model), mode="narrowphase") as att:
        assert att.installed
        fn = ext.mujoco.NARROWPHASE
        for t1 in range(n):
            for t2 in range(n):
                want = fn if (t1, t2) in rows else before[t1 * n + t2]
                assert table[t1 * n + t2] == want, (t1, t2)
    assert list(table) == before


@pytest.mark.parametrize("a", ["sphere", "capsule", "ellipsoid", "cylinder", "box", "mesh"])
@pytest.mark.parametrize("b", ["sphere", "capsule", "ellipsoid", "cylinder", "box", "hfield"])
def test_a_model_is_handled_exactly_when_a_row_covers_its_pair(a, b):
    t = tuple(sorted((TYPES[a], TYPES[b])))
    model = _model([a, b])
    assert attachment.ellipsoid_pair_possible(model, "narrowphase") == (t in {(r.type1, r.type2) for r in PAIR_TYPES})
    assert attachment.ellipsoid_pair_possible(model, "filter") == (t in {(r.type1, r.type2) for r in FILTER_PAIR_TYPES})
    paired = _model([a, b], extra='<contact><pair geom1="g1" geom2="g0"/></contact>')
    for g in range(2):
        paired.geom_contype[g] = paired.geom_conaffinity[g] = 0
    assert attachment.ellipsoid_pair_possible(paired, "narrowphase") == (t in {(r.type1, r.type2) for r in PAIR_TYPES})
    assert len(attachment.explicit_pairs(paired)) == (t in {(r.type1, r.type2) for r in PAIR_TYPES})
    assert len(geoms.explicit_pairs(paired)) == (t in {(r.type1, r.type2) for r in PAIR_TYPES})


def test_warm_start_slots_count_the_types_of_the_warm_rows():
    warm = {t for row in PAIR_TYPES if row.warm for t in (row.type1, row.type2)}
    for name in ("sphere", "capsule", "ellipsoid", "cylinder", "box", "mesh", "hfield"):
        model = _model([name] * 8)
        expected = 8 * attachment.WARM_SLOTS_PER_GEOM if TYPES[name] in warm else attachment.WARM_SLOTS_MIN
        assert attachment.warm_slots(model) == expected, name


def test_the_recorder_covers_every_row_and_the_filter_its_rows_in_either_order():
    """The compiled filter in mode "record" records a pair exactly when a row of PAIR_TYPES (either order)
    says ellipsim judges it (judge.judged says the same); in mode "filter" it tests (counts as seen)
    exactly the pairs of FILTER_PAIR_TYPES (the geoms overlap: it discards none)."""
    names = ["plane", "hfield", "sphere", "capsule", "ellipsoid", "cylinder", "box", "mesh", "ellipsoid"]
    model = _model(names, spacing=0.015)  # every pair overlapping: the filter discards none
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    rows = {(r.type1, r.type2) for r in PAIR_TYPES}
    filtered = {(r.type1, r.type2) for r in FILTER_PAIR_TYPES}
    fn = FILTER_T(ext.mujoco.FILTER)
    for mode, counter, want_rows in (("record", RECORDED, rows), ("filter", context.SEEN, filtered)):
        with attachment.Attachment(model, data, mode, capacity=64) as att:
            for g1 in range(len(names)):
                for g2 in range(len(names)):
                    if g1 == g2:
                        continue
                    before = int(att._counters[counter])
                    assert fn(model._address, data._address, g1, g2) == 0
                    counted = int(att._counters[counter]) - before
                    want = tuple(sorted((int(model.geom_type[g1]), int(model.geom_type[g2])))) in want_rows
                    assert counted == want, (mode, names[g1], names[g2])
                    if mode == "record":
                        assert bool(judge.judged(model, np.array([g1]), np.array([g2]))[0]) == want


def _row_model():
    """Each row's pair, overlapping, 2 m from the next pair: (model, [(g1, g2) per row])."""
    body = []
    for k, row in enumerate(PAIR_TYPES):
        for j, t in enumerate((row.type1, row.type2)):
            name = NAMES[t]
            pos = f"{2 * k + 0.15 * j} {0.04 * j} {0.03 * j}"
            body.append(geom_xml(name, pos, "" if name == "hfield" else f'euler="{20 * j} {35 * j} {10 + 15 * j}"'))
    model = mujoco.MjModel.from_xml_string(f"<mujoco>{ASSETS}<worldbody>{''.join(body)}</worldbody></mujoco>")
    model.opt.ccd_tolerance, model.opt.ccd_iterations = 1e-10, 1000  # MuJoCo's side run tight
    return model, [(2 * k, 2 * k + 1) for k in range(len(PAIR_TYPES))]


class _Markers:
    """Stand-ins for MuJoCo's functions in the context's fallback words: the one of row k writes
    1000 + k as the contact's dist; the words are put back on exit."""

    def __enter__(self):
        proto = NARROW_T
        self._keep, self._saved = [], context.CONTEXT.copy()
        for k, row in enumerate(PAIR_TYPES):

            def marker(m, d, con, g1, g2, margin, k=k):
                ctypes.cast(con, ctypes.POINTER(ctypes.c_double))[0] = 1000.0 + k
                return 1

            self._keep.append(proto(marker))
            context.CONTEXT[context.FALLBACK_WORDS[row.key]] = ctypes.cast(self._keep[-1], ctypes.c_void_p).value
        return self

    def __exit__(self, *exc):
        context.CONTEXT[:] = self._saved
        return False


def _call(fn, model, data, g1, g2):
    con = np.zeros(50 * 10)  # mjMAXCONPAIR mjPreContacts (dist, pos, normal, tangent)
    return fn(model._address, data._address, con.ctypes.data, g1, g2, 0.0), con


def test_the_narrow_phase_falls_back_through_each_rows_word():
    """A data not attached gets MuJoCo's function from its row's context word."""
    model, pairs = _row_model()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    fn = NARROW_T(ext.mujoco.NARROWPHASE)
    with _Markers():
        for k, (g1, g2) in enumerate(pairs):
            made, con = _call(fn, model, data, g1, g2)
            assert made == 1 and con[0] == 1000 + k, PAIR_TYPES[k].name


def test_the_narrow_phase_computes_and_counts_every_row():
    """Attached, each row's pair gets one counted call and the contacts of MuJoCo's function run tight
    (ccd_tolerance 1e-10), each within DIST_TOL: the row's kernel ran on the geoms in its order."""
    model, pairs = _row_model()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    table, n = publish.collision_table()
    theirs = {row: NARROW_T(table[row.type1 * n + row.type2]) for row in PAIR_TYPES}
    fn = NARROW_T(ext.mujoco.NARROWPHASE)
    with em.attach(model, data, mode="narrowphase") as att:
        for row, (g1, g2) in zip(PAIR_TYPES, pairs):
            calls = att.counters["calls"]
            made, ours = _call(fn, model, data, g1, g2)
            assert att.counters["calls"] == calls + 1, row.name
            want_made, want = _call(theirs[row], model, data, g1, g2)
            assert made == want_made >= 1, row.name  # a height field: one per prism the ellipsoid overlaps
            for k in range(made):
                assert abs(ours[10 * k] - want[10 * k]) <= DIST_TOL, (
                    f"{row.name}: dist {ours[10 * k]} vs {want[10 * k]}"
                )
            assert ours[0 : 10 * made : 10].min() < -0.01, row.name  # overlapping by more than 1 cm


def test_both_engines_read_one_table_whose_codes_are_their_enums_and_rows_the_warp_glues():
    """ellipsim/pair_table.py: MuJoCo's mjtGeom and MuJoCo Warp's GeomType give its type codes; ellipsim.warp
    takes exactly its pairs and runs each row's function (narrowphase.hpp's ROW_* constants, checked in the
    header's text); ellipsim.mujoco's tables are the same object."""
    from mujoco_warp._src import types as mjw_types

    from ellipsim import pair_table as pair_types
    from ellipsim.warp import attachment as warp_attachment

    for code, name in pair_types.TYPE_NAMES.items():
        assert int(getattr(mujoco.mjtGeom, f"mjGEOM_{name.upper()}")) == code
        assert int(getattr(mjw_types.GeomType, name.upper())) == code
    assert context.PAIR_TYPES is pair_types.PAIR_TYPES
    # ellipsim.warp takes the rows marked for it: every row (a mesh's hull over the mesh row's size: attach's)
    assert warp_attachment.PAIR_TYPES is pair_types.WARP_PAIR_TYPES
    assert [r.key for r in PAIR_TYPES if not r.warp] == []
    header = (NATIVE / "warp" / "narrowphase.hpp").read_text()
    rows = dict(re.findall(r"ROW_(\w+) = (\d+)", re.search(r"constexpr int (ROW_[^;]+);", header).group(1)))
    for row in pair_types.WARP_PAIR_TYPES:
        kind = row.kernel.split("/")[1].split("_")[0].upper()  # ellipsoid_pair -> ELLIPSOID, capsule -> CAPSULE
        kind = {"HEIGHT": "HFIELD", "POLYTOPE": "MESH"}.get(kind, kind)  # height_field -> HFIELD, polytope -> MESH
        assert int(rows[kind]) == row.row == getattr(pair_types, f"ROW_{kind}"), row.name
        assert f"#include <ellipsim/{row.kernel}.hpp>" in header, row.kernel
    geom = np.array(
        [pair_types.SPHERE, pair_types.CAPSULE, pair_types.ELLIPSOID, pair_types.CYLINDER, pair_types.BOX, 0,
         pair_types.MESH, pair_types.HFIELD]
    )  # fmt: skip
    pairs = np.array([(i, j) for i in range(8) for j in range(i + 1, 8)] + [(2, 2)], np.int32)
    every = np.ones(len(geom), bool)
    take, ordered, rows_taken = warp_attachment._selection(geom, pairs, np.full((len(pairs), 2), -1), every)
    got = {(int(geom[a]), int(geom[b]), int(r)) for (a, b), r in zip(ordered, rows_taken)}
    want = {(r.type1, r.type2, r.row) for r in pair_types.WARP_PAIR_TYPES if r.type1 != r.type2}
    want |= {(pair_types.ELLIPSOID,) * 2 + (0,)}
    assert got == want and take.sum() == len(want)
    # a mesh geom not taken (its hull over the mesh row's size): its pairs stay with Warp
    take, ordered, rows_taken = warp_attachment._selection(
        geom, pairs, np.full((len(pairs), 2), -1), geom != pair_types.MESH
    )
    assert pair_types.ROW_MESH not in set(rows_taken) and take.sum() == len(want) - 1
