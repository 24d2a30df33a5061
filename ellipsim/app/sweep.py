"""Sweeps: many variants of one scenario, one row of results.csv each, on this machine or on Ray.

    rows = sweep("pile", vary={"scene.figures": [2, 4, 8], "mode": ["builtin", "narrowphase"]},
                 seeds=3, steps=500, out="sweeps/pile")              # backend="ray" for a cluster

A variant is the scenario's TOML table with dotted keys set (`scene.figures = 4`, `timestep =
0.001`), validated exactly as a file is (scenario.from_table); every variant is validated before
any runs.  `--seeds N` runs each with scene.seed (and control.seed, for controls that draw from
one) = 0 .. N-1.  A variant's id is a hash of its validated scenario and step count, so that the
same variant has the same id in every sweep; it ends its .rrd's name (after the scenario and the varied
values: recording_name) and is that recording's id.

Each variant runs two passes of `steps` steps from the same initial state:

1. plain MuJoCo under mujoco.validate (simulate.validation): every candidate pair of a type
   ellipsim judges (an ellipsoid with an ellipsoid, sphere, capsule, box, cylinder, convex mesh or height
   field) at every step,
   MuJoCo's contact against the exact test, one margin rule on both sides.  Columns pairs,
   mujoco_contacts, ellipsim_contacts, mujoco_extra, mujoco_missed, near_tangent, normal_off: they
   compare MuJoCo's own detection with the exact one, so they come from plain MuJoCo whatever the
   mode (in narrowphase mode those contacts are ellipsim's own: nothing left to compare).
2. the scenario's mode (builtin, filter or narrowphase; a kinematic scenario replays its poses),
   stepped as `ellipsim run` does and recorded with --record.  Columns steps_per_second
   (stepping alone), fallbacks (narrowphase), mujoco_warnings, deepest_penetration (exact, at
   the frames a run records: RECORD_FPS per simulated second).

wall_seconds (the whole variant) and steps_per_second are timings; every other column is the same
on every backend and every re-run (MuJoCo and the exact test are deterministic, the scenes seeded).
Rows are appended to DIR/results.csv as variants finish and sorted into variant order at the
end; a re-run of the same sweep skips the variants whose rows are there (resume after a crash)
and runs again those whose row is an error.  A variant that fails is a row with its error.

Backends: "local", a pool of processes on this machine (spawned: forking a process that runs
threads, ellipsim's pool or MuJoCo's, is unsafe), and "ray" (`import ray` only there), which connects to
RAY_ADDRESS or starts a local Ray instance and runs the variants as streaming tasks of several
variants each.  A variant's batch calls run on one thread (core.threads.limit): the workers share
the cores.
"""

import collections
import collections.abc
import contextlib
import copy
import csv
import dataclasses
import glob
import hashlib
import itertools
import json
import math
import multiprocessing
import os
import re
import signal
import time
import tomllib
from concurrent import futures
from concurrent.futures.process import BrokenProcessPool

import numpy as np

from ..core import threads
from ..mujoco.validate import KIND_MEANINGS, KINDS
from . import scenario as scenarios
from .comparison import counters
from .errors import UserError
from .mjcf import one_line

BACKENDS = ("local", "ray")
RESULTS = "results.csv"
PLOT = "sweep.png"

#: Ray tasks per worker slot: each task runs its share of the variants one after the other and
#: streams a row per variant.  Measured on the 2-core VM (Ray 2.60, medians of 7): an empty task's
#: round trip 1.4-1.5 ms (0.6-0.7 ms a task with 500 in flight); a streaming task of one small
#: variant (tumble, 30 steps: 18 ms in-process) 2.9-4.5 ms more than in-process, each further
#: variant of the same task 1.5 ms more.  With at most TASKS_PER_SLOT tasks a slot, the sweep pays
#: ~4 x 4 ms of task overhead a slot whatever its size; several tasks a slot balance the load when
#: variants differ in size (dealt round robin, so the big ones of a product spread over tasks).
TASKS_PER_SLOT = 4

#: What each column of results.csv holds (also written to DIR/columns.json).
COLUMNS = {
    "variant": "id: hash of the variant's validated scenario and steps; its recording's id, ending its .rrd's name",
    "scenario": "the scenario's (or model's) file name, without .toml or .xml",
    "seed": "scene.seed (and control.seed) of the run (with --seeds)",
    "mode": "collision detection of the mode pass (builtin, filter, narrowphase; kinematic: poses replayed)",
    "steps": "steps of each pass",
    "wall_seconds": "TIMING: wall time of the whole variant in its worker (building, both passes, recording)",
    "steps_per_second": "TIMING, mode pass: steps per second of stepping alone",
    "pairs": "plain-MuJoCo pass: candidate pairs of every type ellipsim judges (MuJoCo's broad phase), summed over the steps",
    "mujoco_contacts": "plain-MuJoCo pass: candidate pairs on which MuJoCo made a contact (dist < margin), summed",
    "ellipsim_contacts": "plain-MuJoCo pass: candidate pairs the exact test puts in contact (signed distance < margin), summed",
    "mujoco_extra": f"plain-MuJoCo pass: {KIND_MEANINGS['mujoco_extra']}",
    "mujoco_missed": f"plain-MuJoCo pass: {KIND_MEANINGS['mujoco_missed']}",
    "near_tangent": f"plain-MuJoCo pass: {KIND_MEANINGS['near_tangent']}",
    "normal_off": f"plain-MuJoCo pass: {KIND_MEANINGS['normal_off']}",
    "fallbacks": "mode pass: pairs the narrow phase handed back to MuJoCo's function (empty in other modes)",
    "mujoco_warnings": "mode pass: MuJoCo's warnings (unstable simulation, contact buffer full, ...)",
    "deepest_penetration": "mode pass: deepest penetration of a pair ellipsim judges, metres (exact signed distance, recorded frames)",
    "error": "why the variant failed (empty when it ran)",
}
#: the plain-MuJoCo pass's columns: comparison.COUNTERS but the agreement and the undetermined
_COMPARED = ("pairs", "mujoco_contacts", "ellipsim_contacts", *KINDS)
_METRICS = (
    "steps",
    "wall_seconds",
    "steps_per_second",
    *_COMPARED,
    "fallbacks",
    "mujoco_warnings",
    "deepest_penetration",
    "error",
)
_FLOATS = {"wall_seconds", "steps_per_second", "deepest_penetration"}
_STRINGS = {"variant", "scenario", "mode", "error"}
#: Columns that differ between runs of the same variant.
TIMING = ("wall_seconds", "steps_per_second")

_KEY = re.compile(r"[A-Za-z0-9_-]+(\.[A-Za-z0-9_-]+)*")


class SweepError(UserError):
    """A sweep that cannot run; the message starts with the argument it is about (the command line's
    option of that name: `ellipsim sweep` writes it as --vary, --seeds, ...)."""

    cli_prefix = "--"


@dataclasses.dataclass(frozen=True)
class Variant:
    """One run of a sweep: the scenario's table with its values set, as read from `path`."""

    id: str
    values: dict  # varied key -> value, and "seed" with seeds
    table: dict  # the scenario's TOML table with the values set
    path: str  # the scenario file (errors name it; relative paths start from its folder)
    steps: int
    mode: str  # the scenario's mode, or "kinematic"
    record: str = None  # .rrd path, or None

    @property
    def scenario(self):
        """The scenario's name: its file's, without .toml or .xml (as scenario.from_table names it)."""
        base = os.path.basename(self.path)
        return os.path.splitext(base)[0] if base.endswith((".toml", ".xml")) else base


# --- values and variants -----------------------------------------------------------------------


def format_value(value):
    """A TOML value as written on the command line and in results.csv (strings bare)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, list | tuple):
        return "[" + ", ".join(format_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k} = {format_value(v)}" for k, v in value.items()) + "}"
    return str(value)


def parse_value(text):
    """A value of --vary: a TOML literal (2, 0.002, true, "text", [0, 0, -9.81]), else a number
    as Python writes it (.5), else the text itself (builtin)."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        pass
    try:
        number = float(text)
    except ValueError:
        return text
    return number if math.isfinite(number) else text


def _split(text):
    """`text` split at the commas outside brackets, braces and quotes."""
    parts, depth, quote, start = [], 0, None, 0
    for i, ch in enumerate(text):
        if quote:
            quote = None if ch == quote else quote
        elif ch in "\"'":
            quote = ch
        elif ch in "[{":
            depth += 1
        elif ch in "]}":
            depth -= 1
        elif ch == "," and depth == 0:
            parts.append(text[start:i])
            start = i + 1
    return parts + [text[start:]]


def parse_vary(text):
    """(key, values) of a --vary argument "KEY=V1,V2,..."; SweepError naming it when malformed."""
    key, sep, rest = text.partition("=")
    key = key.strip()
    if not sep or not key:
        raise SweepError(f"vary {text!r}: expected KEY=V1,V2,... (e.g. scene.figures=2,4,8)")
    values = []
    for k, part in enumerate(_split(rest)):
        if not part.strip():
            raise SweepError(f"vary {text!r}: value {k + 1} is empty")
        values.append(parse_value(part.strip()))
    return key, values


def _canonical(value):
    return json.dumps(value, sort_keys=True, separators=(",", ":"), default=list)


def _assign(table, key, value):
    """Set the dotted `key` of `table` (a copy) to `value`, making the tables on the way."""
    node, parts = table, key.split(".")
    for i, part in enumerate(parts[:-1]):
        node = node.setdefault(part, {})
        if not isinstance(node, dict):
            raise SweepError(f"vary {key}: '{'.'.join(parts[: i + 1])}' is {node!r}, not a table")
    node[parts[-1]] = copy.deepcopy(value)


def variant_id(s, steps):
    """12 hex digits of SHA-256 over the validated scenario `s` (all but its name, file and
    description) and the steps: equal for equal variants whatever table or file they came from."""
    spec = {k: v for k, v in dataclasses.asdict(s).items() if k not in ("name", "path", "description")}
    return hashlib.sha256(_canonical({"scenario": spec, "steps": steps}).encode()).hexdigest()[:12]


def plan(scenario, vary=None, *, seeds=None, steps=None, mode=None, record_dir=None):
    """The variants of a sweep, every one validated; SweepError (or ScenarioError for the scenario
    itself) naming the argument and the value before anything runs.

    scenario : a name from scenarios/, a .toml path or an MJCF .xml path
    vary : {dotted TOML key: [values]}; the variants are the cartesian product, last key fastest
    seeds : run each variant with scene.seed (and control.seed) = 0 .. seeds-1
    steps : steps per pass (default: each variant's duration / timestep)
    mode : the collision mode of every variant (a key `mode` in vary varies it instead)
    record_dir : folder of the variants' .rrd files, or None
    """
    from . import limits, simulate

    vary = dict(vary or {})
    base, path = scenarios.source_table(scenario)
    path = os.path.abspath(path)  # workers may run in another folder (Ray's do)
    for key, values in vary.items():
        if not isinstance(key, str) or not _KEY.fullmatch(key):
            raise SweepError(f"vary {key!r}: KEY must be a dotted TOML key such as scene.figures or timestep")
        if isinstance(values, str | bytes | dict) or not isinstance(values, collections.abc.Iterable):
            raise SweepError(f"vary {key}: expected a list of values, got {values!r}")
        values = vary[key] = list(values)
        if not values:
            raise SweepError(f"vary {key}: no values")
        seen = {}
        for v in values:
            if _canonical(v) in seen:
                raise SweepError(f"vary {key}={format_value(v)}: the value is given twice")
            seen[_canonical(v)] = v
    if mode is not None:
        if mode not in scenarios.MODES:
            raise SweepError(f"mode must be one of {scenarios.MODES}, got {mode!r}")
        if "mode" in vary:
            raise SweepError("mode: given both as mode and in vary; keep one")
        base["mode"] = mode
    if seeds is not None:
        if isinstance(seeds, bool) or not isinstance(seeds, int | np.integer) or seeds < 1:
            raise SweepError(f"seeds must be a positive integer, got {seeds!r}")
        for key in ("scene.seed", "control.seed"):
            if key in vary:
                raise SweepError(f"seeds: {key} is also in vary; keep one")
    if steps is not None and (isinstance(steps, bool) or not isinstance(steps, int | np.integer) or steps < 1):
        raise SweepError(f"steps must be a positive integer, got {steps!r}")

    def validated(table, label):
        try:
            return scenarios.from_table(table, path)
        except scenarios.ScenarioError as exc:
            raise SweepError(f"{label}: {exc}") from None

    for key, values in vary.items():  # each value alone first: an error names the value that causes it
        for value in values:
            table = copy.deepcopy(base)
            _assign(table, key, value)
            validated(table, f"vary {key}={format_value(value)}")
    out, ids = [], {}
    for combo in itertools.product(*vary.values()):
        values = dict(zip(vary, combo))
        table = copy.deepcopy(base)
        for key, value in values.items():
            _assign(table, key, value)
        label = f"vary {_describe(values)}" if values else "scenario"
        for seed in range(seeds) if seeds else [None]:
            t = table
            if seed is not None:
                t = copy.deepcopy(table)
                s = validated(t, label)
                if s.scene["kind"] == "mjcf":
                    raise SweepError(f"seeds: {s.name} builds an mjcf scene, which has no seed")
                _assign(t, "scene.seed", seed)
                if s.control["kind"] in scenarios.SEEDED_CONTROLS:
                    _assign(t, "control.seed", seed)
            s = validated(t, label if seed is None else f"{label}, seed {seed}")
            n = steps or s.steps
            try:
                simulate.check_steps(s, n)
                limits.check_fits(n * simulate.BYTES_PER_VALIDATED_STEP, f"{n} steps of pair counts")
            except ValueError as exc:
                raise SweepError(f"steps {n} ({_describe(values)}): {exc}") from None
            vid = variant_id(s, n)
            row_values = values | ({"seed": seed} if seed is not None else {})
            if vid in ids:
                raise SweepError(f"vary: {_describe(ids[vid])} and {_describe(row_values)} are the same scenario")
            ids[vid] = row_values
            rrd = None
            if record_dir is not None:
                rrd = os.path.join(os.path.abspath(record_dir), recording_name(os.path.basename(path), row_values, vid))
            out.append(Variant(vid, row_values, t, path, n, "kinematic" if s.kinematic else s.mode, rrd))
    return out


def recording_name(scenario_file, values, vid):
    """The .rrd file name of a variant: its scenario, varied values and seed, then its id (what makes it
    unique), e.g. pile_scene.figures=4_mode=narrowphase_seed=1_3b86c8cdbaf3.rrd; characters a file name
    should not hold become '-'."""
    base = os.path.splitext(scenario_file)[0] if scenario_file.endswith((".toml", ".xml")) else scenario_file
    parts = [base, *(f"{k}={format_value(v)}" for k, v in values.items()), vid]
    return re.sub(r"[^A-Za-z0-9._=+-]", "-", "_".join(parts)) + ".rrd"


def _describe(values):
    return ", ".join(f"{k}={format_value(v)}" for k, v in values.items()) or "the scenario"


def columns(variants):
    """The columns of results.csv for these variants: id, varied keys, seed, mode, steps, metrics."""
    keys = list(variants[0].values) if variants else []
    return ["variant", "scenario", *keys, *(["mode"] if "mode" not in keys else []), *_METRICS]


# --- one variant ---------------------------------------------------------------------------------


def run_variant(variant):
    """The row of one variant (a dict of COLUMNS' values): both passes, or its error."""
    row = {
        "variant": variant.id,
        "scenario": variant.scenario,
        **variant.values,
        "mode": variant.mode,
        "steps": variant.steps,
    }
    row.update(dict.fromkeys(_METRICS[1:]))
    t0 = time.perf_counter()
    try:
        with threads.limit(1):  # the workers of a sweep share the cores
            row.update(_measure(variant))
    except Exception as exc:  # a failed variant is a row with its error, not a lost sweep
        row["error"] = f"{type(exc).__name__}: {one_line(exc) or 'no message'}"
    row["wall_seconds"] = time.perf_counter() - t0
    return row


def _measure(variant):
    from . import simulate

    s = scenarios.from_table(variant.table, variant.path)
    validation, _ = simulate.validation(s, variant.steps)
    c = counters(validation)
    out = {key: c[key] for key in _COMPARED}
    if variant.record is None:
        return out | _mode_pass(s, variant, None)
    from .record import Recorder

    recorder = Recorder(variant.record)
    recorder.recording_id = variant.id  # before begin(), which opens the stream with it
    with recorder:
        return out | _mode_pass(s, variant, recorder)


def _mode_pass(s, variant, recorder):
    """Step scenario `s` in its mode as simulate.run does (a stepping.FrameLoop), its FrameBuffer
    also measuring the depth of every overlapping pair (simulate.run keeps counts only)."""
    import mujoco

    from ..mujoco.attachment import attach
    from . import simulate
    from .stepping import FrameLoop

    model, data = simulate.build(s)
    control = simulate.controller(model, data, s)
    deepest = 0.0

    def on_chunk(chunk):
        nonlocal deepest
        if np.any(chunk.depth >= 0):
            deepest = max(deepest, float(np.nanmax(chunk.depth)))

    title = f"{s.name} {_describe(variant.values)} [{variant.id}]"
    loop = FrameLoop(model, recorder=recorder, title=title, on_chunk=on_chunk, depth=True)

    def step(k):
        try:
            simulate.advance(model, data, s, control, k)
        except mujoco.FatalError as exc:
            raise scenarios.ScenarioError(f"MuJoCo stopped at step {k} of the {s.mode} pass: {one_line(exc)}") from None

    att = attach(model, data, mode=s.mode) if s.mode != "builtin" and not s.kinematic else None
    with att if att else contextlib.nullcontext():
        loop.run(data, variant.steps, step, every=simulate.record_every(s))  # the frames `ellipsim run` records
    fallbacks = att.counters.get("fallbacks", 0) if s.mode == "narrowphase" and att else None
    return {
        "steps_per_second": variant.steps / max(loop.seconds, 1e-9),
        "fallbacks": fallbacks,
        "mujoco_warnings": int(data.warning.number.sum()),
        "deepest_penetration": deepest,
    }


# --- backends ------------------------------------------------------------------------------------


#: Seconds a stopped worker has to end before it is killed.
STOP_SECONDS = 5.0


def _ignore_sigint():
    """Initializer of the local pool's workers: Ctrl-C is the parent's to handle (it stops them)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _died(variant, how):
    row = {
        "variant": variant.id,
        "scenario": variant.scenario,
        **variant.values,
        "mode": variant.mode,
        "steps": variant.steps,
    }
    row.update(dict.fromkeys(_METRICS[1:]))
    row["error"] = f"WorkerDied: {how}"
    return row


def _run_local(todo, workers, emit, run=run_variant):
    """The variants in a pool of `workers` processes (this process when 1); emit(row) as each ends.

    A worker that dies (out of memory, a crash in native code) breaks the pool and every variant it
    was running; those run again one at a time, and one that kills its worker alone is an error row.
    run : the function of a variant (a test's stand-in)
    """
    if workers == 1:
        for v in todo:
            emit(run(v))
        return
    # spawn: fresh interpreters (forking a process that runs threads, ellipsim's pool or MuJoCo's, is unsafe)
    context = multiprocessing.get_context("spawn")
    queue, alone = collections.deque(todo), collections.deque()
    first = True
    while queue or alone:
        pool = futures.ProcessPoolExecutor(
            min(workers, len(queue) + len(alone)), mp_context=context, initializer=_ignore_sigint
        )
        if first:  # a worker that cannot even start is no variant's fault
            first = False
            try:
                pool.submit(os.getpid).result()
            except BrokenProcessPool:
                pool.shutdown(wait=True)
                raise RuntimeError(
                    "the local backend's worker processes could not start (their error is above); a script read "
                    "from standard input cannot start them: run it from a file, or use workers=1"
                ) from None
            except BaseException:
                _stop(pool)
                raise
        running, lost, broken = {}, [], False

        def submit(source, solo):
            v = source.popleft()
            try:
                running[pool.submit(run, v)] = (v, solo)
            except BrokenProcessPool:  # broke since the last wait: the running variants say which
                source.appendleft(v)
                return False
            return True

        try:
            while (queue or alone or running) and not broken:
                if alone:
                    broken = not running and not submit(alone, True)
                else:
                    while queue and len(running) < workers and not broken:
                        broken = not submit(queue, False)
                done, _ = futures.wait(running, return_when=futures.FIRST_COMPLETED)
                for f in done:
                    v, solo = running.pop(f)
                    try:
                        row = f.result()
                    except BrokenProcessPool:
                        lost.append((v, solo))
                        continue
                    emit(row)
                broken = broken or bool(lost)
            lost += running.values()  # a broken pool fails all it was running
        except BaseException:
            _stop(pool)
            raise
        pool.shutdown(wait=not broken, cancel_futures=True)
        for v, solo in lost:
            if solo:
                emit(
                    _died(
                        v, "its worker process died while running it alone (out of memory, or a crash in native code)"
                    )
                )
            else:
                alone.append(v)


def _stop(pool):
    """End the pool's workers now (Ctrl-C, SIGTERM): no new variant, SIGTERM to the running ones
    (the sweep removes their partial recordings), SIGKILL after STOP_SECONDS."""
    processes = list((getattr(pool, "_processes", None) or {}).values())  # the pool has no public list
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        process.terminate()
    deadline = time.monotonic() + STOP_SECONDS
    for process in processes:
        process.join(max(0.0, deadline - time.monotonic()))
        if process.is_alive():
            process.kill()
    pool.shutdown(wait=True)


def _ray_batch(batch, run=run_variant):
    """A Ray task: the rows of a batch of variants, streamed one by one as each ends."""
    for v in batch:
        yield run(v)


def batches(todo, slots):
    """`todo` dealt round robin into min(len, TASKS_PER_SLOT * slots) batches."""
    n = min(len(todo), TASKS_PER_SLOT * max(int(slots), 1))
    return [todo[i::n] for i in range(n)] if n else []


def _run_ray(todo, workers, emit, run=run_variant):
    """The variants as Ray tasks of several variants each, streaming their rows, at most `workers`
    tasks at a time (default: the cluster's CPUs): on the cluster of RAY_ADDRESS, on the one this
    process is already connected to, or on a local Ray instance of `workers` CPUs started (and
    stopped) here.  A task whose worker dies makes its running variant an error row; the rest of
    its batch goes on in a new task.  run : the function of a variant (a test's stand-in)."""
    import ray

    started = not ray.is_initialized()
    if started:
        address = os.environ.get("RAY_ADDRESS") or None
        options = {} if address else {"num_cpus": workers, "include_dashboard": False}
        ray.init(address=address, **options)
    gens = {}
    try:
        slots = workers or max(int(ray.cluster_resources().get("CPU", 1)), 1)
        task = ray.remote(num_cpus=1, max_retries=0)(_ray_batch)
        waiting = collections.deque(collections.deque(b) for b in batches(todo, slots))
        while gens or waiting:
            while waiting and len(gens) < slots:
                batch = waiting.popleft()
                gens[task.remote(list(batch), run)] = batch
            ready, _ = ray.wait(list(gens), num_returns=1)
            for g in ready:
                rest = gens[g]
                try:
                    row = ray.get(next(g))
                except StopIteration:
                    del gens[g]
                    continue
                except ray.exceptions.RayError as exc:  # the worker died (a variant's own errors are rows)
                    del gens[g]
                    emit(_died(rest.popleft(), f"its Ray worker died while running it: {one_line(exc)[:300]}"))
                    if rest:
                        waiting.appendleft(rest)
                    continue
                rest.popleft()
                emit(row)
    except BaseException:
        for g in gens:
            with contextlib.suppress(Exception):
                ray.cancel(g, force=True)
        raise
    finally:
        if started:
            ray.shutdown()


# --- results.csv -----------------------------------------------------------------------------------


def _cell(value):
    if value is None:
        return ""
    if isinstance(value, float) and not isinstance(value, bool):
        return repr(value)
    return format_value(value)


def _format_row(row):
    """A row's values as the text results.csv holds (timings rounded: they are noise below that)."""
    out = {k: _cell(v) for k, v in row.items()}
    if row.get("wall_seconds") is not None:
        out["wall_seconds"] = f"{row['wall_seconds']:.4f}"
    if row.get("steps_per_second") is not None:
        out["steps_per_second"] = f"{row['steps_per_second']:.1f}"
    return out


def _parse_row(text, variant):
    """A row of results.csv back as values: the metrics parsed, the varied values the variant's."""
    row = {"variant": variant.id, "scenario": text.get("scenario") or None, **variant.values}
    for key in ("mode", *_METRICS):
        cell = text.get(key, "")
        if key in _STRINGS:
            row[key] = cell or None
        elif cell == "":
            row[key] = None
        else:
            row[key] = float(cell) if key in _FLOATS else int(cell)
    return row


class _Results:
    """DIR/results.csv: the rows already there, and new ones appended (flushed) as they come.

    A file of other columns is another sweep's: SweepError.  A row with the wrong number of
    fields (a line cut short by a crash) is dropped.
    """

    def __init__(self, path, header):
        self.path, self.header = path, header
        self.rows = {}  # id -> {column: text}, in file order
        if os.path.exists(path):
            try:
                with open(path, newline="") as f:
                    lines = list(csv.reader(f))
            except (OSError, UnicodeDecodeError, csv.Error) as exc:
                raise SweepError(f"out: cannot read {path!r}: {getattr(exc, 'strerror', None) or exc}") from None
            if lines and lines[0] != header:
                raise SweepError(
                    f"out: {path!r} holds the results of another sweep (columns {', '.join(lines[0])}); "
                    "choose another output directory"
                )
            for fields in lines[1:]:
                if len(fields) == len(header):
                    self.rows[fields[0]] = dict(zip(header, fields))

    def done(self, vid):
        row = self.rows.get(vid)
        return row is not None and row["error"] == ""

    def rewrite(self, order=()):
        """Write the file again through a partial file: the rows of `order` first, in that order."""
        rank = {vid: k for k, vid in enumerate(order)}
        rows = sorted(self.rows.values(), key=lambda r: rank.get(r["variant"], len(rank)))
        partial = f"{self.path}.part"
        try:
            with open(partial, "w", newline="") as f:
                w = csv.DictWriter(f, self.header, lineterminator="\n")
                w.writeheader()
                w.writerows(rows)
            os.replace(partial, self.path)
        finally:
            if os.path.exists(partial):
                os.remove(partial)

    def drop(self, ids):
        for vid in ids:
            self.rows.pop(vid, None)

    def append(self, row):
        self.rows[row["variant"]] = row
        with open(self.path, "a", newline="") as f:
            csv.DictWriter(f, self.header, lineterminator="\n").writerow(row)


# --- the sweep -----------------------------------------------------------------------------------


def already_done(variants, out):
    """Ids of the variants whose rows in out/results.csv are complete (an error row is run again);
    SweepError when that file holds another sweep's columns."""
    path = os.path.join(os.fspath(out), RESULTS)
    if not variants or not os.path.exists(path):
        return set()
    results = _Results(path, columns(variants))
    return {v.id for v in variants if results.done(v.id)}


def check_out(out):
    """SweepError when `out` cannot be the output directory (made if missing, with its missing parents)."""
    out = os.fspath(out)
    if os.path.exists(out) and not os.path.isdir(out):
        raise SweepError(f"out {out!r} exists and is not a directory")
    target = os.path.abspath(out)
    while not os.path.exists(target) and os.path.dirname(target) != target:  # the nearest folder that exists
        target = os.path.dirname(target)
    if not os.path.isdir(target):
        raise SweepError(f"out: {target!r} is not a directory (in {out!r})")
    if not os.access(target, os.W_OK | os.X_OK):
        raise SweepError(f"out: cannot write in {os.path.abspath(target)!r} (permission denied)")


def plot_available():
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        return False
    return True


def sweep(
    scenario,
    vary=None,
    *,
    seeds=None,
    steps=None,
    mode=None,
    out=None,
    backend="local",
    workers=None,
    record=False,
    plot=True,
    progress=None,
):
    """Run every variant of `scenario` (see plan) and return their rows, in variant order.

    out : folder for results.csv, sweep.png, columns.json and the .rrd files (made if missing);
        rows already in its results.csv are not run again.  None: nothing is written.
    backend : "local" (processes on this machine) or "ray" (RAY_ADDRESS, or a local Ray instance)
    workers : processes (local; default os.cpu_count(), 1 runs in this process), or Ray tasks at a
        time (default: the cluster's CPUs; the CPUs of a local Ray instance)
    record : write a .rrd per variant in out (recording_name: scenario, values, id), its recording id the variant id
    plot : draw out/sweep.png (needs matplotlib: the 'plot' extra)
    progress : optional callable(done, total) over the variants to run
    Returns a list of dicts, one per variant, keys `columns(plan(...))`: the varied values, seed,
    mode, steps, then the metrics (COLUMNS; None where empty).  SweepError (a ValueError) names a
    bad argument before anything runs; ImportError names the extra a backend or the plot needs.
    """
    if backend not in BACKENDS:
        raise SweepError(f"backend must be one of {BACKENDS}, got {backend!r}")
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int | np.integer) or workers < 1):
        raise SweepError(f"workers must be a positive integer, got {workers!r}")
    if out is None and record:
        raise SweepError("record: recordings need an output directory (out)")
    if out is not None:
        check_out(out)
    if out is not None and plot and not plot_available():
        raise ImportError("sweep's plot needs matplotlib: pip install 'ellipsim[plot]' (or plot=False)")
    if backend == "ray":
        try:
            import ray  # noqa: F401
        except ImportError:
            raise ImportError("backend 'ray' needs Ray: pip install 'ellipsim[ray]'") from None
    variants = plan(scenario, vary, seeds=seeds, steps=steps, mode=mode, record_dir=out if record else None)
    header = columns(variants)
    results = None
    if out is not None:
        os.makedirs(out, exist_ok=True)
        results = _Results(os.path.join(out, RESULTS), header)
        retry = [v.id for v in variants if v.id in results.rows and not results.done(v.id)]
        results.drop(retry)
        results.rewrite()  # the header, without the rows to run again
        with open(os.path.join(out, "columns.json"), "w") as f:
            json.dump({k: COLUMNS[k] for k in header if k in COLUMNS}, f, indent=1)
    todo = [v for v in variants if results is None or not results.done(v.id)]
    fresh = {}

    def emit(row):
        text = _format_row(row)
        fresh[row["variant"]] = text
        if results is not None:
            results.append(text)
        if progress is not None:
            progress(len(fresh), len(todo))

    if workers is None and backend == "local":
        workers = os.cpu_count() or 1
    try:
        if todo:
            if backend == "local":
                _run_local(todo, min(workers, len(todo)), emit)
            else:
                _run_ray(todo, workers, emit)
    finally:
        if out is not None:
            for v in todo:  # recordings left half-written by a worker that was stopped
                name = os.path.basename(v.record) if v.record else f"{v.id}.rrd"
                for part in glob.glob(os.path.join(glob.escape(os.path.abspath(out)), f".{glob.escape(name)}.*.part")):
                    os.remove(part)
            results.rewrite([v.id for v in variants])
    rows = [_parse_row(fresh[v.id] if v.id in fresh else results.rows[v.id], v) for v in variants]
    if out is not None and plot:
        plot_rows(
            rows,
            list(variants[0].values),
            os.path.join(out, PLOT),
            title=f"{variants[0].scenario}: {len(rows)} variants",
        )
    return rows


#: Rows of a sweep `rows_table` shows at most (results.csv has them all).
ROWS_SHOWN = 40


def rows_table(rows, keys):
    """The lines `ellipsim sweep` prints of its rows: a column per varied key in `keys` and per
    metric (the first ROWS_SHOWN rows; a failed row ends with its error)."""

    def cell(value, fmt="{}"):
        return "" if value is None else fmt.format(value)

    head = [
        "variant",
        *keys,
        "steps/s",
        "pairs",
        "MuJoCo",
        "exact",
        "extra",
        "missed",
        "near",
        "normal_off",
        "fallbacks",
        "deepest mm",
    ]
    table = [
        [
            r["variant"],
            *(format_value(r[k]) for k in keys),
            cell(r["steps_per_second"], "{:,.0f}"),
            cell(r["pairs"]),
            cell(r["mujoco_contacts"]),
            cell(r["ellipsim_contacts"]),
            cell(r["mujoco_extra"]),
            cell(r["mujoco_missed"]),
            cell(r["near_tangent"]),
            cell(r["normal_off"]),
            cell(r["fallbacks"]),
            cell(None if r["deepest_penetration"] is None else r["deepest_penetration"] * 1000, "{:.3g}"),
        ]
        + ([f"failed: {r['error']}"] if r["error"] else [])
        for r in rows[:ROWS_SHOWN]
    ]
    width = [max(len(str(row[k])) for row in [head, *table] if k < len(row)) for k in range(len(head))]
    lines = ["  " + "  ".join(f"{h:>{w}}" for h, w in zip(head, width))]
    for row in table:
        lines.append(
            "  " + "  ".join(f"{c:>{w}}" for c, w in zip(row, width)) + ("  " + row[-1] if len(row) > len(head) else "")
        )
    if len(rows) > ROWS_SHOWN:
        lines.append(f"  ... and {len(rows) - ROWS_SHOWN} more")
    return lines


# --- the plot --------------------------------------------------------------------------------------


_STYLE = {"-": "solid", "--": "dashed", ":": "dotted", "-.": "dash-dot"}


def _number(value):
    return isinstance(value, int | float) and not isinstance(value, bool)


def plot_rows(rows, keys, path, *, title="sweep"):
    """sweep.png: four panels against the first varied key (numeric: an axis; else categories), a
    line per combination of the other keys, seeds as mean with a min-max bar: MuJoCo's contacts
    and the exact test's contacts, the disagreements, steps/s, the deepest penetration."""
    import matplotlib
    import matplotlib.ticker
    from matplotlib.figure import Figure  # no pyplot: no backend or global figure state touched

    axis_keys = [k for k in keys if k != "seed"]
    xkey = axis_keys[0] if axis_keys else ("seed" if "seed" in keys else None)
    others = [k for k in axis_keys if k != xkey]
    ok = [r for r in rows if r["error"] is None]
    xs = list(dict.fromkeys(format_value(r[xkey]) if xkey else "" for r in rows))
    numeric = xkey is not None and all(_number(r[xkey]) for r in rows)
    position = {x: k for k, x in enumerate(xs)}
    series = collections.defaultdict(lambda: collections.defaultdict(list))
    for r in ok:
        label = ", ".join(f"{k}={format_value(r[k])}" for k in others)
        series[label][format_value(r[xkey]) if xkey else ""].append(r)

    def x_of(text, rs):
        return rs[0][xkey] if numeric else position[text]

    panels = (
        (
            "pairs in contact (distance < margin), all steps (plain MuJoCo pass)",
            (("mujoco_contacts", "-", "MuJoCo"), ("ellipsim_contacts", "--", "exact")),
        ),
        (
            "disagreements with the exact test (plain MuJoCo pass)",
            (
                ("mujoco_extra", "-", "mujoco_extra"),
                ("mujoco_missed", "--", "mujoco_missed"),
                ("near_tangent", ":", "near_tangent"),
                ("normal_off", "-.", "normal_off"),
            ),
        ),
        ("steps per second (mode pass)", (("steps_per_second", "-", None),)),
        ("deepest penetration, mm (mode pass)", (("deepest_penetration", "-", None),)),
    )
    fig = Figure(figsize=(11, 7), layout="constrained")
    axes = fig.subplots(2, 2, sharex=True)
    colours = matplotlib.rcParams["axes.prop_cycle"].by_key()["color"]
    for ax, (name, columns_) in zip(axes.ravel(), panels):
        for c, (label, points) in enumerate(sorted(series.items())):
            order = sorted(points.items(), key=lambda item: x_of(*item))
            x = [x_of(t, rs) for t, rs in order]
            for n, (column, style, what) in enumerate(columns_):
                scale = 1000.0 if column == "deepest_penetration" else 1.0
                vals = [[r[column] * scale for r in rs if r[column] is not None] for _, rs in order]
                keep = [k for k, v in enumerate(vals) if v]
                if not keep:
                    continue
                mean = np.array([np.mean(vals[k]) for k in keep])
                lo = mean - np.array([min(vals[k]) for k in keep])
                hi = np.array([max(vals[k]) for k in keep]) - mean
                text = (label or None) if n == 0 else None  # the series once; the styles are in the title
                if len(series) == 1:
                    text = what
                ax.errorbar(
                    [x[k] for k in keep],
                    mean,
                    yerr=[lo, hi],
                    fmt="o",
                    ls=style if numeric else "none",
                    color=colours[c % len(colours)],
                    mfc="none" if style != "-" else None,
                    capsize=3,
                    label=text,
                    ms=5,
                    lw=1.2,
                )
        styles = ", ".join(f"{what} {_STYLE[style]}" for _, style, what in columns_ if what)
        ax.set_title(name + (f"\n{styles}" if styles and len(series) > 1 else ""), fontsize=9)
        ax.grid(alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7, loc="best")
    for ax in axes[1]:
        ax.set_xlabel(xkey or "")
        if not numeric:
            ax.set_xticks(range(len(xs)), xs, rotation=30 if max(map(len, xs), default=0) > 6 else 0, fontsize=8)
        elif all(r[xkey] > 0 for r in rows) and max(r[xkey] for r in rows) >= 10 * min(r[xkey] for r in rows):
            ax.set_xscale("log")
        elif all(isinstance(r[xkey], int) for r in rows):
            ax.xaxis.set_major_locator(matplotlib.ticker.MaxNLocator(integer=True))
    failed = len(rows) - len(ok)
    fig.suptitle(
        title
        + (f" ({failed} failed: see results.csv)" if failed else "")
        + ("; seeds: mean, bars min-max" if "seed" in keys and xkey != "seed" else ""),
        fontsize=10,
    )
    fig.savefig(path, dpi=110)
    return path
