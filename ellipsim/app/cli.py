"""The `ellipsim` command line.

    ellipsim run SCENARIO|MODEL.xml [--steps N] [--mode builtin|filter|narrowphase] [--record FILE.rrd]
                 [--key NAME|INDEX] [--ctrl hold|zero|keyframe] [--[no-]between-frames]
    ellipsim compare SCENARIO|MODEL.xml [--steps N] [--json FILE] [--plot FILE.png] [--key ..] [--ctrl ..]
                 [--[no-]between-frames]
    ellipsim replay MODEL.xml MOTION.npy|.csv [--fps F] [--record FILE.rrd] [--json FILE] [--[no-]between-frames]
    ellipsim fit MESH... [--method thesis|mvee] [--out limbs.xml]
    ellipsim view FILE.rrd
    ellipsim sweep SCENARIO|MODEL.xml --vary KEY=V1,V2,... [--vary ...] [--seeds N] [--steps N] [--mode M]
                   [--record] --out DIR [--backend local|ray] [--workers N]
    ellipsim bench [--quick] [--only SECTION ...] [--out DIR]
    ellipsim list
    ellipsim demo [--pairs N] [--seed S]
    ellipsim --version

SCENARIO is a name from `ellipsim list` or a path to a .toml file; MODEL.xml any MJCF file (its
includes and assets are found relative to it, as MuJoCo does).  A user mistake (unknown scenario,
malformed file, bad argument, a request larger than memory) ends with one line on stderr and exit
status 2; Ctrl-C with one line and status 130, SIGTERM with status 143 (a recording being written is
then not left behind half-written).
"""

import argparse
import json
import math
import os
import signal
import sys
import time

import numpy as np

import ellipsim

from .. import shipped
from .errors import UserError

#: Memory `demo` needs per pair: two validated batches, the generator's draws and the relations
#: (measured: 1.16 GB peak for 1e6 pairs, 0.37 GB for 2e5: 990 bytes per pair).
DEMO_BYTES_PER_PAIR = 1000


class _Parser(argparse.ArgumentParser):
    """argparse with a one-line error and exit status 2 (no usage dump)."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


class Terminated(BaseException):
    """SIGTERM arrived: unwinds like KeyboardInterrupt, so that partial outputs are removed."""


def _count(text, *, allow_zero=False):
    """An integer count from the command line: digits, or a float notation of a whole number ("1e6")."""
    what = "a non-negative integer" if allow_zero else "a positive integer"
    try:
        value = int(text.replace("_", ""))
    except ValueError:
        try:
            real = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}") from None
        if not math.isfinite(real) or real != int(real):
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}") from None
        value = int(real)
    if value < 0 or (value == 0 and not allow_zero):
        raise argparse.ArgumentTypeError(f"expected {what}, got {value}")
    return value


def _positive_int(text):
    return _count(text)


def _non_negative_int(text):
    return _count(text, allow_zero=True)


def _positive_real(text):
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}") from None
    if not math.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"expected a positive finite number, got {text!r}")
    return value


def _time(fn):
    t0 = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t0


def install_hint(extra):
    """How to install an extra: `pip install '.[extra]'` in a source checkout, else by package name."""
    root = shipped.source_checkout()
    if root is not None:
        here = os.path.abspath(os.getcwd()) == str(root)
        return f"pip install '.[{extra}]'" + ("" if here else f" (in {root})")
    return f"pip install 'ellipsim[{extra}]'"


class Progress:
    """A progress bar on stderr: redrawn in place on a terminal, a line every 10% otherwise.

    The rate and the time left are shown only once they mean something: measured from WARMUP
    seconds after the start (the first steps pay for compiling kernels and touching memory) over at
    least WARMUP seconds more.
    """

    WARMUP = 1.0  # seconds

    def __init__(self, label, total, stream=None, unit="steps"):
        self.label, self.total, self.unit = label, total, unit
        self.stream = stream or sys.stderr
        self.tty = self.stream.isatty()
        self.t0 = time.perf_counter()
        self.shown = -1.0
        self.anchor = None  # (seconds, done) from which the rate is measured
        self.open = False  # a redrawn line is on the terminal without its newline

    def __call__(self, done, total=None):
        total = total or self.total
        now = time.perf_counter() - self.t0
        if self.anchor is None and now >= self.WARMUP:
            self.anchor = (now, done)
        frac = done / total
        if done < total and (now - self.shown < 0.2 if self.tty else frac * 10 < int(self.shown * 10) + 1):
            return
        self.shown = now if self.tty else frac
        bar = "#" * int(30 * frac)
        line = f"{self.label} [{bar:<30}] {100 * frac:5.1f}% {done}/{total} {self.unit}"
        if self.anchor is not None and now - self.anchor[0] >= self.WARMUP and done > self.anchor[1]:
            rate = (done - self.anchor[1]) / (now - self.anchor[0])
            line += f", {rate:,.0f}/s"
            if done < total:
                line += f", {(total - done) / rate:.0f} s left"
        if self.tty:
            self.stream.write("\r" + line + ("\n" if done >= total else ""))
            self.open = done < total
        else:
            self.stream.write(line + "\n")
        self.stream.flush()

    def close(self):
        """End a line left open on the terminal (before an error message)."""
        if self.open:
            self.stream.write("\n")
            self.stream.flush()
            self.open = False


_progress = []  # bars of this command, closed before an error or interruption is reported


def _bar(label, total, unit="steps"):
    bar = Progress(label, total, unit=unit)
    _progress.append(bar)
    return bar


# --- demo ------------------------------------------------------------------------------------------


def demo(args):
    """Classify a batch of generic pairs with every method; print relations, disagreements, timing."""
    from . import limits

    try:
        limits.check_fits(args.pairs * DEMO_BYTES_PER_PAIR, f"--pairs {args.pairs}")
    except ValueError as exc:
        raise UserError(f"{exc} (about {DEMO_BYTES_PER_PAIR} bytes a pair)") from None

    import ellipsim as es
    from ellipsim.core.certified import certify
    from ellipsim.core.relation import UNDECIDED
    from ellipsim.core.samples import generic_pairs

    methods = [("exact", {})] + [
        (f"{m} {s}", dict(method=m, setup=s)) for m in ("descartes", "sturm") for s in ("rearranged", "cofactor")
    ]
    print(f"ellipsim demo: {args.pairs} random ellipsoid pairs (half colliding, thesis 5.1.1), seed {args.seed}")
    print("  loading kernels (compiled on first use, ~15 s; cached afterwards) ...", flush=True)
    warm = generic_pairs(4, seed=1)
    _, t_compile = _time(lambda: [es.classify(*warm, parallel=p, **kw) for _, kw in methods for p in (False, True)])
    (a, b), t_gen = _time(lambda: generic_pairs(args.pairs, seed=args.seed))
    print(f"  kernels ready in {t_compile:.1f} s; pairs generated in {t_gen:.1f} s")
    truth, rows = None, []
    for name, kw in methods:
        rel, seconds = _time(lambda: es.classify(a, b, parallel=False, **kw))
        truth = rel if truth is None else truth
        counts = np.bincount(rel, minlength=3)
        rows.append((name, *counts, int(np.count_nonzero(rel != truth)), seconds / len(rel) * 1e9))
    header = ("method", "separated", "touching", "overlapping", "wrong", "ns/pair")
    width = max(len(r[0]) for r in rows)
    print()
    print(f"  {header[0]:<{width}}  " + "  ".join(f"{h:>11}" for h in header[1:]))
    for name, sep, touch, over, wrong, ns in rows:
        print(f"  {name:<{width}}  {sep:>11}  {touch:>11}  {over:>11}  {wrong:>11}  {ns:>11.1f}")
    escalated = int(np.count_nonzero(certify(a, b, len(a), False) == UNDECIDED))
    scale = es.contact_scale(a, b)
    print()
    print(f"  exact: {escalated} pairs needed rational arithmetic; 'wrong' counts disagreements with exact")
    print(f"  contact_scale: min {scale.min():.3f}, median {np.median(scale):.3f}, max {scale.max():.3f}")
    print("  timings are single-threaded; `ellipsim bench` measures them properly")
    return 0


# --- scenarios and models --------------------------------------------------------------------------


def _load(args):
    """The Scenario of args.scenario (a name, a .toml or an MJCF .xml), with --key / --ctrl applied."""
    from . import scenario

    return scenario.with_model_options(scenario.load(args.scenario), key=args.key, ctrl=args.ctrl)


def _steps(s, args, check):
    """--steps or the scenario's duration, checked against memory: UserError naming which."""
    steps = args.steps or s.steps
    try:
        check(s, steps)
    except ValueError as exc:
        source = f"--steps {steps}" if args.steps else f"{s.path}: duration {s.duration:g} s ({steps} steps)"
        raise UserError(f"{source}: {exc}") from None
    return steps


def _check_output(path, suffix, option):
    """The output file's name must end in `suffix`, not be a directory, and its directory must exist
    and be writable: checked before running."""
    if not path.endswith(suffix):
        raise UserError(f"{option} must name a {suffix} file, got {path!r}")
    if os.path.isdir(path):
        raise UserError(f"{option}: {path!r} is a directory, not a {suffix} file")
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        raise UserError(f"{option}: directory {folder!r} does not exist")
    if not os.access(folder, os.W_OK | os.X_OK) or (os.path.exists(path) and not os.access(path, os.W_OK)):
        raise UserError(f"{option}: cannot write {path!r} (permission denied)")


def _write_error(option, path, exc):
    """UserError of an output file that could not be written after all."""
    return UserError(f"{option}: cannot write {path!r}: {getattr(exc, 'strerror', None) or exc}")


def _write_json(path, report):
    """Write `report` to `path` through a partial file renamed when complete (none is left behind)."""
    partial = f"{path}.part"
    try:
        with open(partial, "w") as f:
            json.dump(report, f, indent=1)
        os.replace(partial, path)
    except OSError as exc:
        raise _write_error("--json", path, exc) from None
    finally:
        if os.path.exists(partial):
            os.remove(partial)


def _recorder(path):
    """A record.Recorder for --record (ValueError on a bad path is a user mistake)."""
    from . import record

    try:
        return record.Recorder(path)
    except ValueError as exc:
        raise UserError(f"--record: {exc}") from None


def _recorded(recorder, fn, *args, **kwargs):
    """fn(*args, recorder=recorder, **kwargs), then the recording completed and moved into place;
    on any error or interruption the partial file is removed.  Returns (fn's result, size in bytes)."""
    if recorder is None:
        return fn(*args, **kwargs), 0
    try:
        with recorder:
            result = fn(*args, recorder=recorder, **kwargs)
        return result, os.path.getsize(recorder.path)
    except OSError as exc:
        raise _write_error("--record", recorder.path, exc) from None


def list_scenarios(args):
    from . import scenario

    for name in scenario.available():
        s = scenario.load(name)
        kind = "kinematic" if s.kinematic else s.mode
        print(f"{name:<12} {s.duration:g} s, {kind:<11} {s.description}")
    print("any MJCF model runs too: ellipsim run path/to/model.xml [--key NAME|INDEX] [--ctrl hold|zero|keyframe]")
    return 0


#: From this many figures on, say before building that MuJoCo's compile will take a while: its
#: parser and compiler take time quadratic in the bodies (measured on the 2-core VM: 27 s for 500
#: figures, 92-170 s for 1000; ellipsim's own scene building is linear, 1.2 s and 1.6 s).
BIG_SCENE = 200


def _header(s):
    print(f"{s.name}: {s.description}")
    if s.scene["kind"] == "figures" and s.scene["figures"] >= BIG_SCENE:
        from ..mujoco.scenes import LIMBS

        n = s.scene["figures"]
        print(f"  {n} figures: {len(LIMBS) * n + 1} bodies for MuJoCo to compile, in time that grows with their square "
              "(500 figures: ~30 s on 2 cores) ...", flush=True)
    if s.scene["kind"] == "mjcf":
        sc = s.scene
        start = "default pose" if sc["key"] is None else f"keyframe {sc['key']!r}"
        print(f"  from its {start}, actuators: {sc['ctrl']}")


def run(args):
    """Simulate a scenario or model, print a summary, optionally save a rerun recording."""
    from . import simulate

    s = _load(args)
    if args.record:
        _check_output(args.record, ".rrd", "--record")
    steps = _steps(s, args, simulate.check_steps)
    mode = args.mode or s.mode
    what = "kinematic replay" if s.kinematic else f"mode {mode}"
    _header(s)
    print(f"  {steps} steps of {s.timestep:g} s ({steps * s.timestep:g} s simulated), {what}", flush=True)
    recorder = _recorder(args.record) if args.record else None
    t0 = time.perf_counter()
    result, size = _recorded(recorder, simulate.run, s, steps=steps, mode=mode, progress=_bar(f"  {s.name}", steps),
                             between=_between(args))
    wall = time.perf_counter() - t0
    print("\n".join(result.summary(wall, recording=recorder is not None, between_asked=bool(args.between_frames),
                                    show=BETWEEN_SHOWN)))
    if recorder:
        print(f"  recording: {args.record} ({len(result.frames.times)} frames, {size / 1e6:.1f} MB); view it with: ellipsim view {args.record}")
    return 0


#: Contacts between frames `ellipsim run` prints at most.
BETWEEN_SHOWN = 10


def compare(args):
    """MuJoCo's built-in contacts against ellipsim's exact verdicts, per frame and in total."""
    from . import simulate
    from .comparison import Comparison

    s = _load(args)
    if args.json:
        _check_output(args.json, ".json", "--json")
    if args.plot:
        _check_output(args.plot, ".png", "--plot")
        _matplotlib()
    steps = _steps(s, args, _check_validation)
    _header(s)
    print(f"  comparing MuJoCo's built-in detection with ellipsim over {steps} steps", flush=True)
    v, model = simulate.validation(s, steps, progress=_bar(f"  {s.name}", steps), between=_between(args))
    result = Comparison.of(s.name, v, model)
    print("\n".join(result.summary(args.show)))
    if args.json:
        _write_json(args.json, result.report())
        print(f"  report: {args.json}")
    if args.plot:
        _plot_compare(args.plot, s, result.builtin, result.ours, result.missed + result.extra, result.near)
        print(f"  plot: {args.plot}")
    return 0


def _check_validation(s, steps):
    """ValueError when the counts `validation` keeps for `steps` steps would not fit in memory."""
    from . import limits, simulate

    limits.check_fits(steps * simulate.BYTES_PER_VALIDATED_STEP, f"{steps} steps of pair counts")


def _matplotlib():
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise UserError(f"plots need matplotlib: {install_hint('plot')}") from None
    return plt


def _plot_compare(path, s, builtin, ours, disagree, near):
    plt = _matplotlib()
    t = np.arange(len(builtin)) * s.timestep
    fig, ax = plt.subplots(figsize=(9, 3.6), constrained_layout=True)
    ax.step(t, builtin, where="post", label="MuJoCo built-in contacts", lw=1.4)
    ax.step(t, ours, where="post", label="ellipsim overlapping pairs (exact)", lw=1.0, ls="--")
    for ds, marker, label in ((disagree, "x", "disagreement"), (near, ".", "near-tangent disagreement")):
        if ds:
            ax.plot([d.step * s.timestep for d in ds], [builtin[d.step] for d in ds], marker, ls="none", label=label)
    ax.set_xlabel("simulated time [s]")
    ax.set_ylabel("ellipsoid pairs in contact")
    ax.set_title(f"{s.name}: MuJoCo vs ellipsim, per step")
    ax.legend(loc="best", fontsize=8)
    try:
        fig.savefig(path, dpi=120)
    except OSError as exc:
        raise _write_error("--plot", path, exc) from None
    finally:
        plt.close(fig)


# --- replay ----------------------------------------------------------------------------------------


def replay(args):
    """Play a motion (qpos per frame) on a model: which frames make its ellipsoid geoms touch or overlap."""
    from . import mjcf, replay as rp

    for path, option in ((args.record, "--record"), (args.json, "--json")):
        if path:
            _check_output(path, ".rrd" if option == "--record" else ".json", option)
    model = mjcf.load_model(args.model)
    layout = rp.qpos_layout(model)
    motion = rp.load_motion(args.motion, model.nq, layout=layout)
    name = os.path.splitext(os.path.basename(args.model))[0]
    F = len(motion)
    print(f"{name}: {F} frames of qpos (nq = {model.nq}: {layout}) at {args.fps:g} fps ({F / args.fps:.2f} s) from {args.motion}")
    recorder = _recorder(args.record) if args.record else None
    result, size = _recorded(recorder, rp.replay, model, motion, fps=args.fps, name=name,
                             progress=_bar(f"  {name}", F, unit="frames"), between=_between(args))  # fmt: skip
    print("\n".join(result.summary(args.show)))
    if args.json:
        _write_json(args.json, result.report(args.model, args.motion, model.nq))
        print(f"  report: {args.json}")
    if recorder:
        print(f"  recording: {args.record} ({F} frames, {size / 1e6:.1f} MB); view it with: ellipsim view {args.record}")
    return 0


# --- fit -------------------------------------------------------------------------------------------


def fit(args):
    """Bounding ellipsoids of meshes, printed to a sensible precision and optionally written as MJCF."""
    from . import fit as fitting

    if args.out:
        _check_output(args.out, ".xml", "--out")
    names = [os.path.splitext(os.path.basename(p))[0] or "limb" for p in args.meshes]
    if len(set(names)) != len(names):
        names = [f"{n}_{i}" for i, n in enumerate(names)]
    limbs = []
    for name, path in zip(names, args.meshes):
        try:
            limbs.append(fitting.fit_limb(name, path, method=args.method, digits=args.digits))
        except ValueError as exc:
            raise UserError(str(exc)) from None
    print(f"bounding ellipsoids ({args.method}), {args.digits} significant digits, every vertex inside as written:")
    width = max(len(n) for n in names)
    print(f"  {'mesh':<{width}}  {'centre (pos)':<30} {'quaternion (w x y z)':<36} {'semi-axes (size)':<30} volume / hull")
    for limb in limbs:
        print(f"  {limb.name:<{width}}  {limb.pos:<30} {limb.quat:<36} {limb.size:<30} {limb.volume_ratio:.3f}")
    if args.out:
        try:
            with open(args.out, "w") as f:
                f.write(fitting.limbs_xml(limbs, method=args.method))
        except OSError as exc:
            raise _write_error("--out", args.out, exc) from None
        print(f"  MJCF: {args.out} (<include file=\"{os.path.basename(args.out)}\"/> adds the geoms to a worldbody)")
    return 0


# --- sweep -----------------------------------------------------------------------------------------


def sweep(args):
    """Many variants of a scenario: DIR/results.csv (a row each), DIR/sweep.png, optional recordings."""
    from . import scenario, sweep as sw

    vary = {}
    for text in args.vary:
        key, values = sw.parse_vary(text)
        if key in vary:
            raise UserError(f"--vary {key}: given twice; put all its values in one --vary")
        vary[key] = values
    sw.check_out(args.out)
    if args.backend == "ray":
        try:
            import ray  # noqa: F401
        except ImportError:
            raise UserError(f"--backend ray needs Ray: {install_hint('ray')}") from None
    variants = sw.plan(args.scenario, vary, seeds=args.seeds, steps=args.steps, mode=args.mode,
                       record_dir=args.out if args.record else None)  # fmt: skip
    done = sw.already_done(variants, args.out)
    plot = sw.plot_available()
    s = scenario.from_table(variants[0].table, variants[0].path)
    _header(s)
    shape = " x ".join([f"{len(v)} {k}" for k, v in vary.items()] + ([f"{args.seeds} seeds"] if args.seeds else []))
    steps = sorted({v.steps for v in variants})
    todo = len(variants) - len(done)
    where = (f"{min(args.workers or os.cpu_count() or 1, todo)} local processes" if args.backend == "local" else
             f"Ray at {os.environ['RAY_ADDRESS']}" if os.environ.get("RAY_ADDRESS") else "a local Ray instance")  # fmt: skip
    print(f"  sweep: {len(variants)} variants ({shape or 'the scenario alone'}), "
          f"{steps[0] if len(steps) == 1 else f'{steps[0]}-{steps[-1]}'} steps each (twice: plain MuJoCo validated, then the mode)"
          + (f"; {len(done)} already in {os.path.join(args.out, sw.RESULTS)}" if done else "")
          + (f"; running {todo} on {where}" if todo else ""), flush=True)  # fmt: skip
    bar = _bar("  variants", max(todo, 1), unit="variants")
    try:
        rows = sw.sweep(args.scenario, vary, seeds=args.seeds, steps=args.steps, mode=args.mode, out=args.out,
                        backend=args.backend, workers=args.workers, record=args.record, plot=plot, progress=bar)  # fmt: skip
    except OSError as exc:
        raise _write_error("--out", args.out, exc) from None
    print("\n".join(sw.rows_table(rows, list(variants[0].values))))
    print(f"  results: {os.path.join(args.out, sw.RESULTS)} (columns: {os.path.join(args.out, 'columns.json')})")
    if plot:
        print(f"  plot: {os.path.join(args.out, sw.PLOT)}")
    else:
        print(f"  no plot: it needs matplotlib: {install_hint('plot')}")
    if args.record:
        print(f"  recordings: {os.path.join(args.out, '<variant>.rrd')}; view one with: ellipsim view {os.path.join(args.out, rows[0]['variant'] + '.rrd')}")
    failed = [r for r in rows if r["error"]]
    if failed:
        _end_lines()
        print(f"ellipsim: {len(failed)} of {len(rows)} variants failed (their rows hold the error), "
              f"e.g. {failed[0]['variant']}: {failed[0]['error']}", file=sys.stderr)  # fmt: skip
        return 1
    return 0


# --- bench and view --------------------------------------------------------------------------------


def bench(args):
    """The benchmark suite (ellipsim/app/bench/): writes DIR/report.md and PNG plots."""
    if os.path.exists(args.out) and not os.path.isdir(args.out):
        raise UserError(f"--out {args.out!r} exists and is not a directory")
    if not os.path.isdir(os.path.dirname(os.path.abspath(args.out))):
        raise UserError(f"--out: parent directory of {args.out!r} does not exist")
    try:
        __import__("matplotlib")
        __import__("mpmath")
    except ImportError:
        raise UserError(f"ellipsim bench needs matplotlib and mpmath: {install_hint('bench')}") from None
    from ellipsim.app import bench as suite

    unknown = [name for name in args.only or () if name not in suite.SECTIONS]
    if unknown:
        raise UserError(f"--only: unknown section {unknown[0]!r}; the sections are {', '.join(suite.SECTIONS)}")
    print(f"ellipsim bench{' --quick' if args.quick else ''}: writing {args.out}/report.md and plots", flush=True)
    path, seconds = suite.run(args.out, quick=args.quick, only=args.only)
    print(f"  done in {seconds:.0f} s: {path}")
    return 0


def view(args):
    from . import record

    try:
        return record.view(args.file)
    except ValueError as exc:
        raise UserError(str(exc)) from None


# --- entry point -----------------------------------------------------------------------------------


def _model_options(p):
    p.add_argument("--key", metavar="NAME|INDEX", help="an MJCF model's keyframe to start from (default: its default pose)")
    p.add_argument("--ctrl", choices=("hold", "zero", "keyframe"),
                   help="an MJCF model's actuators: hold the initial pose (default), zero, or the keyframe's ctrl")


#: Whether the contacts between frames (steps) are looked for unless --between-frames or
#: --no-between-frames says.  On: measured on 2 cores (in-process replay, 16 figures, 2000 frames,
#: gentle and violent sinusoidal hinge motions, min of 3), they add 2-7% and 5-14% to `replay` (0.69
#: -> 0.71 s, 1.01 -> 1.09-1.15 s; checked in the background while frames are posed; on one core 15-20%
#: and 46-51%; before the capsule broad phase: 61-68% and 92-109%), 4-5% to `compare pile` (4.52 ->
#: 4.68 s; before: 45%) and 11% to `compare crowd` (3.91 -> 4.35 s; before: 35%).
BETWEEN_DEFAULT = True


def _between_option(p, what):
    """--between-frames / --no-between-frames; args.between_frames is None when neither is given."""
    p.add_argument("--between-frames", action=argparse.BooleanOptionalAction, default=None,
                   help=f"{what} (continuous collision detection; default: {'on' if BETWEEN_DEFAULT else 'off'})")


def _between(args):
    return BETWEEN_DEFAULT if args.between_frames is None else args.between_frames


def parser():
    p0 = _Parser(
        prog="ellipsim",
        description="Exact, fast ellipsoid collision detection for MuJoCo figures with oval limbs.",
        epilog="examples: ellipsim run handshake --record handshake.rrd ; ellipsim run model.xml --key stand ; "
        "ellipsim replay model.xml walk.npy --json walk.json ; ellipsim compare pile --json pile.json",
    )
    p0.add_argument("--version", action="version", version=f"ellipsim {ellipsim.__version__}")
    sub = p0.add_subparsers(dest="command", required=True, parser_class=_Parser)

    p = sub.add_parser("run", help="simulate a scenario or an MJCF model; print steps/s, contacts, pairs tested/skipped")
    p.add_argument("scenario", help="a name from `ellipsim list`, a path to a .toml file, or an MJCF .xml model")
    p.add_argument("--steps", type=_positive_int, help="steps to run (default: the scenario's duration; a model: 2 s)")
    p.add_argument("--mode", choices=("builtin", "filter", "narrowphase"), help="collision detection (default: the scenario's)")
    p.add_argument("--record", metavar="FILE.rrd", help="save a rerun recording")
    _between_option(p, "a kinematic scenario: also find pairs separated at two consecutive frames that touch in "
                    "between, on the interpolated motion")
    _model_options(p)
    p.set_defaults(run=run)

    p = sub.add_parser("compare", help="MuJoCo's built-in contacts vs ellipsim's exact verdicts, per frame and in total")
    p.add_argument("scenario", help="a name from `ellipsim list`, a path to a .toml file, or an MJCF .xml model")
    p.add_argument("--steps", type=_positive_int, help="steps to compare (default: the scenario's duration)")
    p.add_argument("--json", metavar="FILE.json", help="write the counts and every disagreement as JSON")
    p.add_argument("--plot", metavar="FILE.png", help="plot the per-frame counts (needs the 'plot' extra)")
    p.add_argument("--show", type=_non_negative_int, default=10, help="disagreements (and pairs passed through each other) to print (default 10)")
    _between_option(p, "also find ellipsoid pairs separated at two consecutive steps that touch in between (passed "
                    "through each other within one step), on the interpolated motion")
    _model_options(p)
    p.set_defaults(run=compare)

    p = sub.add_parser("replay", help="play a motion (qpos per frame) on a model: which frames make limbs intersect",
                       epilog="example: ellipsim replay fly.xml flight.npy --fps 60 --record flight.rrd --json flight.json")
    p.add_argument("model", metavar="MODEL.xml", help="an MJCF model")
    p.add_argument("motion", metavar="MOTION", help="qpos per frame: a .npy array or a .csv file of shape (frames, nq)")
    p.add_argument("--fps", type=_positive_real, default=30.0, help="frames per second of the motion (default 30)")
    p.add_argument("--record", metavar="FILE.rrd", help="save a rerun recording")
    p.add_argument("--json", metavar="FILE.json", help="write per-frame counts and every touching or overlapping pair")
    p.add_argument("--show", type=_non_negative_int, default=10, help="body pairs and contacts between frames to print (default 10)")
    _between_option(p, "also find pairs separated at two consecutive frames that touch in between, on the "
                    "interpolated motion")
    p.set_defaults(run=replay)

    p = sub.add_parser("fit", help="bounding ellipsoids of meshes (.obj .stl .ply .off .glb .gltf), as MJCF geoms",
                       epilog="example: ellipsim fit forearm.stl hand.stl --method mvee --out limbs.xml")
    p.add_argument("meshes", nargs="+", metavar="MESH", help="mesh files, one ellipsoid each (named after the file)")
    p.add_argument("--method", choices=("thesis", "mvee"), default="thesis",
                   help="thesis: covariance of the convex hull (default); mvee: minimum-volume enclosing ellipsoid")
    p.add_argument("--out", metavar="FILE.xml", help="write the ellipsoids as MJCF geoms")
    p.add_argument("--digits", type=_positive_int, default=6, help="significant digits of the numbers (default 6)")
    p.set_defaults(run=fit)

    p = sub.add_parser(
        "sweep", help="many variants of a scenario (cartesian product of --vary lists, seeds): a CSV row each, a plot",
        epilog="example: ellipsim sweep pile --vary scene.figures=2,4,8 --vary mode=builtin,narrowphase --seeds 3 "
        "--steps 500 --out sweeps/pile ; on a Ray cluster: RAY_ADDRESS=head:6379 ellipsim sweep ... --backend ray. "
        "Each variant steps plain MuJoCo validated against the exact test (contacts, missed, extra), then its mode "
        "(steps/s, fallbacks, deepest penetration); DIR/columns.json says what each column holds. A re-run into the "
        "same DIR skips the variants already in results.csv. Exit status 1 when a variant failed (its row says why).",
    )  # fmt: skip
    p.add_argument("scenario", help="a name from `ellipsim list`, a path to a .toml file, or an MJCF .xml model")
    p.add_argument("--vary", action="append", default=[], metavar="KEY=V1,V2,...",
                   help="a TOML key of the scenario (scene.figures, timestep, mode, control.amplitude, ...) and its values; "
                   "repeat for more keys (values are TOML: 2, 0.001, true, \"text\", [0, 0, -9.81]; bare words are text)")
    p.add_argument("--seeds", type=_positive_int, metavar="N", help="run each variant with scene.seed (and control.seed) = 0 .. N-1")
    p.add_argument("--steps", type=_positive_int, metavar="N", help="steps of each pass (default: each variant's duration)")
    p.add_argument("--mode", choices=("builtin", "filter", "narrowphase"), help="collision detection of every variant")
    p.add_argument("--record", action="store_true", help="write DIR/<variant>.rrd per variant (its recording id)")
    p.add_argument("--out", required=True, metavar="DIR", help="output directory (made if missing; a re-run resumes it)")
    p.add_argument("--backend", choices=("local", "ray"), default="local",
                   help="local: processes on this machine (default); ray: RAY_ADDRESS's cluster or a local Ray instance")
    p.add_argument("--workers", type=_positive_int, metavar="N",
                   help="processes (local, default: the CPUs; 1 runs in this process) or Ray tasks at a time")
    p.set_defaults(run=sweep)

    p = sub.add_parser("view", help="open a recording in the rerun viewer (or say how)")
    p.add_argument("file", metavar="FILE.rrd")
    p.set_defaults(run=view)

    p = sub.add_parser("bench", help="time against error, numerical stress, scaling, thesis Table 1: report + plots")
    p.add_argument("--quick", action="store_true", help="smaller sets: under 5 minutes on 2 cores")
    p.add_argument("--out", default="bench-report", metavar="DIR", help="output directory (default bench-report)")
    # the sections are ellipsim/app/bench's SECTIONS, checked once the suite is imported (not at start-up)
    p.add_argument("--only", nargs="+", metavar="SECTION",
                   help="run only these sections of the suite (accuracy, stress, ...: a name it does not have lists them)")
    p.set_defaults(run=bench)

    p = sub.add_parser("list", help="list the scenarios shipped with ellipsim")
    p.set_defaults(run=list_scenarios)

    p = sub.add_parser("demo", help="classify a random batch of pairs, print a summary table and timing")
    p.add_argument("--pairs", type=_positive_int, default=100_000, help="number of pairs (default 100000)")
    p.add_argument("--seed", type=_non_negative_int, default=0, help="random seed, >= 0 (default 0)")
    p.set_defaults(run=demo)
    return p0


def _terminate(signum, frame):
    raise Terminated()


def main(argv=None):
    args = parser().parse_args(argv)
    previous = None
    try:
        previous = signal.signal(signal.SIGTERM, _terminate)  # this process is the command: unwind on SIGTERM
    except ValueError:  # not the main thread (main() called from a thread): leave signals alone
        pass
    _progress.clear()
    try:
        return args.run(args)
    except UserError as exc:  # errors.UserError: the scenario's, model's, motion's, sweep's errors too
        _end_lines()
        print(f"ellipsim: error: {exc.cli_prefix}{exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        _end_lines()
        print("ellipsim: interrupted", file=sys.stderr)
        return 130
    except Terminated:
        _end_lines()
        print("ellipsim: terminated", file=sys.stderr)
        return 143
    except BrokenPipeError:  # `ellipsim ... | head`: the reader left, nothing to report
        sys.stderr.close()
        return 0
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def script():
    """The `ellipsim` command and `python -m ellipsim`: main(), then exit with its status.  After
    Ctrl-C or SIGTERM (status 130, 143) the one-line reason is the command's last word: standard
    error is pointed at the null device before the interpreter's teardown, where the threads of a
    stopped worker pool can still print (an EBADF on a closed pipe, seen once in CI on
    `ellipsim sweep --workers 2`).  Cleanup (atexit, the pool's semaphores) runs as usual."""
    code = main()
    if code in (130, 143):
        sys.stdout.flush()
        sys.stderr.flush()
        null = os.open(os.devnull, os.O_WRONLY)
        os.dup2(null, 2)
        os.close(null)
    return code


def _end_lines():
    for bar in _progress:
        bar.close()
    sys.stdout.flush()


if __name__ == "__main__":
    sys.exit(script())
