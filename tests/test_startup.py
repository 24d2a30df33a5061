"""Start-up: the callbacks' machine code cached across processes, loaded without numba, shipped
prebuilt, and compiled (with one notice) only when nothing usable is found.

Each scenario runs in a fresh interpreter (STEP below) with its own ELLIPSIM_CACHE_DIR; every one
of them must produce the same trajectory to the bit as a reference computed here, whichever of the
three origins (compiled, cache, prebuilt) its callbacks came from.
"""

import hashlib
import json
import os
import shutil
import subprocess
import sys
import threading

import mujoco
import numpy as np
import pytest

import ellipsim.mujoco as em
from ellipsim.app import scenes
from ellipsim.mujoco import nativecache

NOTICE = "ellipsim: compiling the"
REGENERATE = "python -m ellipsim.mujoco.prebuild"
STEPS = 150

# A fresh interpreter: attach in the modes given, step, report.  `import ellipsim` first: the
# point is what importing and attaching load.
STEP = r"""
import hashlib, json, sys
import mujoco
import ellipsim
model = mujoco.MjModel.from_xml_path(sys.argv[1])
out = {}
for mode in sys.argv[3:]:
    data = mujoco.MjData(model)
    digest = hashlib.sha256()
    with ellipsim.mujoco.attach(model, data, mode=mode) as att:
        for _ in range(int(sys.argv[2])):
            mujoco.mj_step(model, data)
            digest.update(data.qpos.tobytes() + data.qvel.tobytes())
    out[mode] = {"digest": digest.hexdigest(), "counters": att.counters}
from ellipsim.mujoco import nativecache
out["origin"] = {k: f.origin for k, f in nativecache._functions.items()}
out["numba"] = "numba" in sys.modules
out["scipy"] = "scipy" in sys.modules
print(json.dumps(out))
"""


@pytest.fixture(scope="module")
def pile(tmp_path_factory):
    """(path of a pile's MJCF, {mode: trajectory digest} stepped in this process)."""
    path = tmp_path_factory.mktemp("scene") / "pile.xml"
    path.write_text(scenes.pile_xml(30, seed=2))
    model = mujoco.MjModel.from_xml_path(str(path))
    expected = {}
    for mode in em.MODES:
        data = mujoco.MjData(model)
        digest = hashlib.sha256()
        with em.attach(model, data, mode=mode):
            for _ in range(STEPS):
                mujoco.mj_step(model, data)
                digest.update(data.qpos.tobytes() + data.qvel.tobytes())
        expected[mode] = digest.hexdigest()
    return path, expected


def run(pile_path, cache, *modes, prebuilt=None):
    """(report, stderr) of STEP in a fresh interpreter with ELLIPSIM_CACHE_DIR=cache;
    prebuilt: ELLIPSIM_PREBUILT_DIR (None: the shipped objects)."""
    env = dict(os.environ, ELLIPSIM_CACHE_DIR=str(cache))
    env.pop(nativecache.PREBUILT_ENV, None)
    if prebuilt is not None:
        env[nativecache.PREBUILT_ENV] = str(prebuilt)
    proc = subprocess.run(
        [sys.executable, "-c", STEP, str(pile_path), str(STEPS), *modes],
        env=env,
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout), proc.stderr


#: The tests on `compiled`: its callbacks compile from scratch (slow: ~16 s here).
FROM_SCRATCH = pytest.mark.slow


@pytest.fixture(scope="module")
def compiled(pile, tmp_path_factory):
    """A cache dir filled by a process that found neither cache nor prebuilt objects: (dir, report, stderr)."""
    cache, nothing = tmp_path_factory.mktemp("cache"), tmp_path_factory.mktemp("no-prebuilt")
    report, stderr = run(pile[0], cache, *em.MODES, prebuilt=nothing)
    return cache, report, stderr


@FROM_SCRATCH
def test_a_process_without_cache_compiles_once_with_a_notice(pile, compiled):
    cache, report, stderr = compiled
    assert report["origin"] == {"filter": "compiled", "narrowphase": "compiled"}
    notices = [line for line in stderr.splitlines() if line.startswith(NOTICE)]
    assert [n.split()[3] for n in notices] == ["filter", "narrowphase"], stderr  # one line per callback compiled
    assert all("first run only" in n and str(cache) in n for n in notices)
    # the callbacks, and the kernels their compile made (core/kernel_cache.py) in their own folder
    assert sorted(p.name.split("-")[0] for p in cache.iterdir() if p.is_file()) == ["filter", "narrowphase"]
    assert {p.name for p in cache.iterdir() if p.is_dir()} <= {"kernels"}
    for mode in em.MODES:
        assert report[mode]["digest"] == pile[1][mode]


@FROM_SCRATCH
def test_next_process_loads_the_cache_without_numba(pile, compiled):
    cache, _, _ = compiled
    before = {p.name: p.stat().st_mtime_ns for p in cache.iterdir()}
    report, stderr = run(pile[0], cache, "narrowphase", "filter", prebuilt=cache / "none")
    assert stderr == ""
    assert report["origin"] == {"filter": "cache", "narrowphase": "cache"}
    assert not report["numba"] and not report["scipy"]
    for mode in em.MODES:
        assert report[mode]["digest"] == pile[1][mode]
    assert report["narrowphase"]["counters"]["contacts"] > 500 and report["narrowphase"]["counters"]["fallbacks"] == 0
    assert report["filter"]["counters"]["discarded"] > 500
    assert {p.name: p.stat().st_mtime_ns for p in cache.iterdir()} == before  # read, not rewritten


@FROM_SCRATCH
def test_only_the_modes_callback_is_loaded(pile, compiled):
    report, stderr = run(pile[0], compiled[0], "filter", prebuilt=compiled[0] / "none")
    assert report["origin"] == {"filter": "cache"} and stderr == ""


def _damage(blob, damage):
    if damage == "truncated":
        return blob[: len(blob) - 100]
    if damage == "object byte":
        return blob[:-500] + bytes([blob[-500] ^ 0x10]) + blob[-499:]
    if damage == "header":
        return blob.replace(b'"symbol": "cfunc.', b'"symbol": "cfunx.', 1)
    return b""


@FROM_SCRATCH
@pytest.mark.parametrize("damage", ["object byte", "empty"])
def test_a_damaged_cache_file_is_compiled_again_with_the_notice(pile, compiled, tmp_path, damage):
    cache = tmp_path / "cache"
    shutil.copytree(compiled[0], cache)
    (path,) = cache.glob("filter-*.code")
    path.write_bytes(_damage(path.read_bytes(), damage))
    report, stderr = run(pile[0], cache, "filter", prebuilt=tmp_path / "none")
    assert report["origin"] == {"filter": "compiled"}
    assert stderr.startswith(f"{NOTICE} filter callback") and len(stderr.splitlines()) == 1
    assert report["filter"]["digest"] == pile[1]["filter"]
    assert nativecache.read(path) is not None  # written again, whole


def test_a_fresh_install_loads_the_shipped_objects(pile, tmp_path):
    report, stderr = run(pile[0], tmp_path / "empty-cache", *em.MODES)
    assert stderr == ""
    assert report["origin"] == {"filter": "prebuilt", "narrowphase": "prebuilt"}
    assert not report["numba"]
    for mode in em.MODES:
        assert report[mode]["digest"] == pile[1][mode]
    assert not (tmp_path / "empty-cache").exists()  # nothing compiled, nothing written


def test_shipped_objects_match_the_kernel_sources():
    """Fails after any change to callbacks.py or a module it imports until the objects are rebuilt."""
    shipped = sorted(nativecache.prebuilt_dir().glob("*.code"))
    for kind in nativecache.KINDS:
        path = nativecache.prebuilt_path(kind)
        found = nativecache.read(path)
        assert found is not None, (
            f"{path} is missing or damaged: run `{REGENERATE}` and commit ellipsim/mujoco/prebuilt/"
        )
        assert found[0]["parts"] == nativecache.portable_key(kind), (
            f"{path.name} was built from other sources or for another MuJoCo: run `{REGENERATE}` and commit "
            "ellipsim/mujoco/prebuilt/"
        )
    digest = nativecache.sources_digest()
    for path in shipped:  # objects of other platforms too
        header = nativecache.read(path)[0]
        assert digest in header["parts"], f"{path.name} is stale: rebuild it on its platform with `{REGENERATE}`"


def test_shipped_objects_are_installed_with_the_package(tmp_path):
    code = (
        "import importlib.resources as r, ellipsim\n"
        "print(sorted(p.name for p in (r.files('ellipsim.mujoco') / 'prebuilt').iterdir() if p.name.endswith('.code')))\n"
    )
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    proc = subprocess.run(
        [sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300
    )
    assert proc.returncode == 0, proc.stderr
    assert eval(proc.stdout) == sorted(p.name for p in nativecache.prebuilt_dir().glob("*.code"))


def test_kernel_sources_follow_module_level_imports():
    sources = nativecache.kernel_sources()
    assert {
        "mujoco/callbacks.py",
        "mujoco/context.py",
        "core/distance/ellipsoid_pair.py",
        "core/exact/certified_filter.py",
        "core/vec3.py",
        "core/_jit.py",
        "core/tolerances.py",
    } <= set(sources)
    # the loader, the layout and the Python side are not compiled in: editing them keeps the objects
    assert not {"mujoco/nativecache.py", "mujoco/structs.py", "mujoco/attachment.py", "core/exact/classify.py"} & set(
        sources
    )
    text = "\n".join(
        [
            "import os",
            "from . import context",
            "from ..core import vec3",
            "from ..core.distance.ellipsoid_pair import (",
            "    a,",
            "    b,",
            ")",
            "if True:",
            "    from ..core.exact import pair_frame",
            "def f():",
            "    from . import structs",
            "class C:",
            "    from ..core import classify",
            "x = 1",
        ]
    )
    files = nativecache._imported_files("mujoco/callbacks.py", text)
    assert sorted(set(files)) == [
        "core/distance/ellipsoid_pair.py",
        "core/exact/pair_frame.py",
        "core/vec3.py",
        "mujoco/context.py",
    ]


def test_load_refuses_damaged_or_foreign_files(tmp_path):
    kind = "filter"
    parts = nativecache.portable_key(kind)
    header, obj = nativecache.read(nativecache.prebuilt_path(kind))
    assert nativecache.load(nativecache.prebuilt_path(kind), parts)  # the shipped object links here

    class Code:
        symbol, undefined, object_code = header["symbol"], header["undefined"], obj

    path = tmp_path / "f.code"
    assert nativecache.write(path, parts, Code)
    assert nativecache.load(path, parts)
    assert nativecache.load(path, parts[:-1] + ["another-triple"]) is None  # another key
    Code.undefined = header["undefined"] + ["ellipsim_no_such_symbol"]  # would abort inside LLVM
    assert nativecache.write(path, parts, Code)
    assert nativecache.load(path, parts) is None
    assert nativecache.load(tmp_path / "missing.code", parts) is None
    path.write_bytes(b"not a code file")
    assert nativecache.read(path) is None and nativecache.load(path, parts) is None
    Code.undefined = header["undefined"]
    assert nativecache.write(path, parts, Code)
    whole = path.read_bytes()
    for damage in ("truncated", "object byte", "header", "empty"):
        path.write_bytes(_damage(whole, damage))
        assert nativecache.read(path) is None, damage
        assert nativecache.load(path, parts) is None, damage


def test_functions_from_several_threads_are_one_and_the_context_is_filled():
    got, start = [], threading.Barrier(6)

    def work(kind):
        start.wait()
        got.append(nativecache.function(kind))

    threads = [threading.Thread(target=work, args=(kind,)) for kind in nativecache.KINDS * 3]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len({id(f) for f in got}) == 2
    import llvmlite.binding as llb

    from ellipsim.mujoco import context, structs

    assert llb.address_of_symbol(context.SYMBOL) == context.CONTEXT.ctypes.data
    lay = structs.layout()
    assert [context.CONTEXT[w] for w in context.MODEL_WORDS.values()] == [lay["model"][k] for k in context.MODEL_WORDS]
    assert [context.CONTEXT[w] for w in context.DATA_WORDS.values()] == [lay["data"][k] for k in context.DATA_WORDS]
    assert context.CONTEXT[context.REGISTRY_ADDRESS] == context.REGISTRY.ctypes.data
    with pytest.raises(ValueError, match="kind must be one of .*, got 'gjk'"):
        nativecache.function("gjk")


def test_prebuild_usage(monkeypatch, capsys):
    from ellipsim.mujoco import prebuild

    assert prebuild.main(["a", "b"]) == 2
    assert "usage: python -m ellipsim.mujoco.prebuild [OUTDIR]" in capsys.readouterr().err
    monkeypatch.delenv("NUMBA_CPU_NAME", raising=False)
    with pytest.raises(RuntimeError, match="NUMBA_CPU_NAME=generic"):
        prebuild.build("unused")


@pytest.mark.slow  # the benchmark suite's start-up section
def test_bench_section_reports_each_origin():
    from ellipsim.app.bench import startup

    size = {"startup_cold": 0, "startup_rounds": 1, "startup_modes": ("filter",), "startup_first_runs": 1}
    runs = startup.measure(size)
    firsts = runs["first runs"]  # the README's first command, twice on fresh caches
    assert list(firsts) == ["run handshake --record"]
    first, second, compiled = firsts["run handshake --record"]
    assert 0 < first and 0 < second and not compiled  # the shipped kernels and callbacks load
    assert sorted(k for k in runs if k != "first runs") == [
        ("MuJoCo alone", "none"),
        ("prebuilt", "filter"),
        ("warm", "filter"),
    ]
    assert [r["origin"] for r in runs[("warm", "filter")]] == ["cache"]
    assert [r["origin"] for r in runs[("prebuilt", "filter")]] == ["prebuilt"]
    assert not any(r["numba"] or r["notice"] for k, rs in runs.items() if k != "first runs" for r in rs)
    for rs in (rs for k, rs in runs.items() if k != "first runs"):
        assert all(0 < r["part"] <= r["wall"] and 0 < r["cpu"] for r in rs)
    lines = startup.write(runs, None, None, None)
    assert lines[0] == "## 6. Start-up"
    rows = [line for line in lines if line.startswith("| warm ") or line.startswith("| prebuilt ")]
    assert any(line.startswith("| `ellipsim run handshake --record` |") and "| no |" in line for line in lines)
    assert [row.split("|")[9].strip() for row in rows] == ["cache", "prebuilt"]


def failing_narrowphase(m, d, con, g1, g2, margin):
    """A narrow phase whose kernel always raises (test_capsule uses it too)."""
    if g1 >= 0:  # always; a function without a return would not be typed intc
        raise RuntimeError("no contact")
    return 0


def test_an_error_status_answers_as_mujoco_would():
    """The wrapper's error path (callbacks._wrapper_for), driven by kernels that always raise: the
    filter gives MuJoCo's bitmask verdict, the narrow phase MuJoCo's own contact."""
    from ellipsim.mujoco import callbacks, structs

    def failing_filter(m, d, g1, g2):
        if g1 >= 0:  # always; a function without a return would not be typed intc
            raise RuntimeError("no verdict")
        return 0

    nativecache.fill_context()
    filt = callbacks.compile_callback("filter", failing_filter)
    narrow = callbacks.compile_callback("narrowphase", failing_narrowphase)
    model = mujoco.MjModel.from_xml_string("""<mujoco><worldbody>
      <geom type="ellipsoid" size=".1 .2 .3"/><geom type="ellipsoid" size=".1 .2 .3" pos=".15 .02 0"/>
      <geom type="sphere" size=".1" pos="0 0 .35"/>
      <geom type="ellipsoid" size=".1 .2 .3" pos="5 0 0" contype="2" conaffinity="2"/>
      <geom type="box" size=".1 .1 .1" pos="0 3 0" contype="4" conaffinity="1"/>
    </worldbody></mujoco>""")
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    ffn = nativecache._CTYPES["filter"](filt.address)
    assert [ffn(model._address, data._address, 0, g) for g in (1, 2, 3, 4)] == [0, 0, 1, 0]
    assert ffn(model._address, data._address, 3, 4) == 1
    table, n = structs.collision_table()
    ours = nativecache._CTYPES["narrowphase"](narrow.address)
    for g1, g2 in ((0, 1), (2, 0)):  # ellipsoid x ellipsoid, sphere x ellipsoid
        theirs = nativecache._CTYPES["narrowphase"](table[model.geom_type[g1] * n + model.geom_type[g2]])
        got, want = np.zeros(64), np.zeros(64)
        assert ours(model._address, data._address, got.ctypes.data, g1, g2, 0.0) == 1
        assert theirs(model._address, data._address, want.ctypes.data, g1, g2, 0.0) == 1
        np.testing.assert_array_equal(got[:10], want[:10])  # mjPreContact: dist, pos, normal, tangent
