"""What the commands share: argument types, the progress bar, loading a scenario, checking and writing
output files, recording, the scene header, the options of MJCF models and of the contacts between frames."""

import argparse
import json
import math
import os
import sys
import time

from ... import shipped
from ..errors import STOPS, UserError


class Parser(argparse.ArgumentParser):
    """argparse with a one-line error and exit status 2 (no usage dump)."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def count(text, *, allow_zero=False):
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


def positive_int(text):
    return count(text)


def non_negative_int(text):
    return count(text, allow_zero=True)


def positive_real(text):
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}") from None
    if not math.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"expected a positive finite number, got {text!r}")
    return value


def install_hint(extra):
    """How to install an extra: `pip install '.[extra]'` in a source checkout, else by package name."""
    root = shipped.source_checkout()
    if root is not None:
        here = os.path.abspath(os.getcwd()) == str(root)
        return f"pip install '.[{extra}]'" + ("" if here else f" (in {root})")
    return f"pip install 'ellipsim[{extra}]'"


class Progress:
    """A progress bar on stderr: redrawn in place on a terminal; otherwise (a log, a pipe) a line at
    the first step, then every INTERVAL seconds of wall time and at the end, each with the time
    elapsed.

    The rate and the time left are shown only once they mean something: measured from WARMUP
    seconds after the start (the first steps pay for compiling kernels and touching memory) over at
    least WARMUP seconds more.  `done` is the count of the last call.
    """

    WARMUP = 1.0  # seconds
    INTERVAL = 15.0  # seconds between two lines without a terminal: a log shows life, not a line a step

    def __init__(self, label, total, stream=None, unit="steps"):
        self.label, self.total, self.unit = label, total, unit
        self.stream = stream or sys.stderr
        self.tty = self.stream.isatty()
        self.t0 = time.perf_counter()
        self.shown = None  # when the last line was drawn (seconds from t0)
        self.anchor = None  # (seconds, done) from which the rate is measured
        self.open = False  # a redrawn line is on the terminal without its newline
        self.done = 0

    def __call__(self, done, total=None):
        self.done = done
        total = total or self.total
        now = time.perf_counter() - self.t0
        if self.anchor is None and now >= self.WARMUP:
            self.anchor = (now, done)
        frac = done / total
        if done < total and self.shown is not None and now - self.shown < (0.2 if self.tty else self.INTERVAL):
            return
        self.shown = now
        bar = "#" * int(30 * frac)
        line = f"{self.label} [{bar:<30}] {100 * frac:5.1f}% {done}/{total} {self.unit}"
        if not self.tty:
            line += f" in {now:.0f} s"
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


progress_bars = []  # bars of this command, closed before an error or interruption is reported


def bar(label, total, unit="steps"):
    bar = Progress(label, total, unit=unit)
    progress_bars.append(bar)
    return bar


def end_lines():
    for bar in progress_bars:
        bar.close()
    sys.stdout.flush()


def load_scenario(args):
    """The Scenario of args.scenario (a name, a .toml or an MJCF .xml), with --key / --ctrl applied."""
    from .. import scenario

    return scenario.with_model_options(scenario.load(args.scenario), key=args.key, ctrl=args.ctrl)


def steps_of(s, args, check):
    """--steps or the scenario's duration, checked against memory: UserError naming which."""
    steps = args.steps or s.steps
    try:
        check(s, steps)
    except ValueError as exc:
        source = f"--steps {steps}" if args.steps else f"{s.path}: duration {s.duration:g} s ({steps} steps)"
        raise UserError(f"{source}: {exc}") from None
    return steps


def check_output(path, suffix, option):
    """The output file's name must end in `suffix`, not be a directory, and its folder must be one we
    can write in, or be missing under one (made_parents makes it when the file is written): checked
    before running."""
    if not path.endswith(suffix):
        raise UserError(f"{option} must name a {suffix} file, got {path!r}")
    if os.path.isdir(path):
        raise UserError(f"{option}: {path!r} is a directory, not a {suffix} file")
    existing = existing_ancestor(os.path.dirname(os.path.abspath(path)))
    if not os.path.isdir(existing):
        raise UserError(f"{option}: {existing!r} is not a directory (in {path!r})")
    if not os.access(existing, os.W_OK | os.X_OK) or (os.path.exists(path) and not os.access(path, os.W_OK)):
        raise UserError(f"{option}: cannot write {path!r} (permission denied)")


def existing_ancestor(folder):
    """`folder` (absolute) if it exists, else its nearest ancestor that does."""
    while not os.path.exists(folder) and os.path.dirname(folder) != folder:
        folder = os.path.dirname(folder)
    return folder


def made_parents(path, option):
    """Make the missing folders of the output file `path` (as --help says: "made if missing")."""
    try:
        os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    except OSError as exc:
        raise write_error(option, path, exc) from None


def write_error(option, path, exc):
    """UserError of an output file that could not be written after all."""
    return UserError(f"{option}: cannot write {path!r}: {getattr(exc, 'strerror', None) or exc}")


def json_text(value, indent=0):
    """`value` as JSON text a reader can scan: a dict a key per line, a list of dicts a dict per line
    (each on one line), any other list on one line (a per-step array of 1500 numbers is one line,
    not 1500)."""
    pad = " " * indent
    if isinstance(value, dict) and value:
        items = (f"{pad} {json.dumps(str(k))}: {json_text(v, indent + 1)}" for k, v in value.items())
        return "{\n" + ",\n".join(items) + f"\n{pad}}}"
    if isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
        items = (f"{pad} {json.dumps(v, separators=(', ', ': '))}" for v in value)
        return "[\n" + ",\n".join(items) + f"\n{pad}]"
    return json.dumps(value, separators=(",", ":"))


def write_json(path, report):
    """Write `report` (json_text) to `path` through a partial file renamed when complete (none is
    left behind); the missing folders of `path` are made."""
    partial = f"{path}.part"
    made_parents(path, "--json")
    try:
        with open(partial, "w") as f:
            f.write(json_text(report) + "\n")
        os.replace(partial, path)
    except OSError as exc:
        raise write_error("--json", path, exc) from None
    finally:
        if os.path.exists(partial):
            os.remove(partial)


def model_and_motion(p):
    """The positional MODEL.xml and MOTION of the commands that take a motion (replay, fix)."""
    p.add_argument("model", metavar="MODEL.xml", help="an MJCF model")
    p.add_argument("motion", metavar="MOTION", help="qpos per frame: a .npy array or a .csv file of shape (frames, nq)")


def record_options(p, help="save a rerun recording"):
    """--record FILE.rrd and how it draws: --labels, --colors."""
    p.add_argument("--record", metavar="FILE.rrd", help=help)
    p.add_argument(
        "--labels", action="store_true", help="with --record: draw every geom's name (default: on hover and selection)"
    )
    p.add_argument(
        "--colors",
        choices=("figure", "mjcf"),
        help="with --record: a hue per figure (kinematic tree; the default for ellipsim's scenes) or the model's "
        "own colours, its materials' textures as their mean colour (the default for an MJCF model)",
    )


def recorder_for(path, args=None, scene="mjcf"):
    """A record.Recorder for --record that keeps its frames on Ctrl-C or SIGTERM (ValueError on a
    bad path is a user mistake), drawn as args.labels and args.colors say (colours: the default of the
    `scene` kind, record.DEFAULT_COLORS, when not given); the missing folders of `path` are made."""
    from .. import record

    made_parents(path, "--record")
    labels, colors = (getattr(args, "labels", False), getattr(args, "colors", None)) if args else (False, None)
    colors = colors or record.DEFAULT_COLORS.get(scene, "mjcf")
    try:
        return record.Recorder(path, keep_partial=True, labels=labels, colors=colors)
    except ValueError as exc:
        raise UserError(f"--record: {exc}") from None


#: What a stopped command kept, said after "ellipsim: interrupted" / "terminated" (cleared per command).
stop_notes = []


def recorded(recorder, fn, *args, **kwargs):
    """fn(*args, recorder=recorder, **kwargs), then the recording completed and moved into place;
    on an error the partial file is removed, on Ctrl-C or SIGTERM the frames recorded so far are
    kept (record.Recorder keep_partial) and stop_notes says where and how many, and at which step of
    kwargs["progress"] (a Progress) it stopped.  Returns (fn's result, size in bytes)."""
    if recorder is None:
        return fn(*args, **kwargs), 0
    try:
        with recorder:
            result = fn(*args, recorder=recorder, **kwargs)
        return result, os.path.getsize(recorder.path)
    except OSError as exc:
        raise write_error("--record", recorder.path, exc) from None
    except STOPS:
        if recorder.kept:
            progress = kwargs.get("progress")
            where = f"at {progress.unit.removesuffix('s')} {progress.done}/{progress.total}; " if progress else ""
            stop_notes.append(f"{where}recording of {recorder.kept} frames kept in {recorder.path}")
        raise


#: From this many figures on, say before building that MuJoCo's compile will take a while: its
#: parser and compiler take time quadratic in the bodies (measured on the 2-core VM: 27 s for 500
#: figures, 92-170 s for 1000; ellipsim's own scene building is linear, 1.2 s and 1.6 s).
BIG_SCENE = 200


def header(s, *more):
    """What a command says of scenario `s` before it runs: its name and description, where an MJCF model
    starts, and `more` lines.  Returns a callable that prints them, to be called once the model is built
    (a model MuJoCo refuses is then one error line, with no header before it); only a big figure scene's
    name and warning that MuJoCo's compile takes a while are printed at once, before the build."""
    lines = [f"{s.name}: {s.description}"]
    if s.scene["kind"] == "figures" and s.scene["figures"] >= BIG_SCENE:
        from ..scenes import LIMBS

        n = s.scene["figures"]
        lines.append(
            f"  {n} figures: {len(LIMBS) * n + 1} bodies for MuJoCo to compile, in time that grows with their square "
            "(500 figures: ~30 s on 2 cores) ..."
        )
        print("\n".join(lines), flush=True)
        lines = []
    if s.scene["kind"] == "mjcf":
        sc = s.scene
        start = "default pose" if sc["key"] is None else f"keyframe {sc['key']!r}"
        lines.append(f"  from its {start}, actuators: {sc['ctrl']}")
    lines += more
    pending = [lines]

    def started():
        if pending:
            print("\n".join(pending.pop()), flush=True)

    return started


def engine_options(p, what):
    """--engine mujoco|warp, --worlds N, --device cpu|cuda; `what`: what --engine warp does."""
    p.add_argument("--engine", choices=("mujoco", "warp"), default="mujoco", help=f"MuJoCo C (default) or {what}")
    p.add_argument("--worlds", type=positive_int, help="--engine warp: worlds stepped at once (default 1)")
    p.add_argument("--device", choices=("cpu", "cuda"), help="--engine warp: Warp's device (default cpu)")
    p.add_argument(
        "--nconmax",
        type=positive_int,
        help="--engine warp: contacts a world may hold (default 4 per geom, at least 64); an overflow is reported",
    )
    p.add_argument(
        "--njmax",
        type=positive_int,
        help="--engine warp: constraint rows a world may hold (default: every contact slot's rows, limits, "
        "equalities); an overflow is reported",
    )


def check_engine(args):
    """UserError for --worlds, --device, --nconmax or --njmax without --engine warp."""
    given = [f"--{k}" for k in ("worlds", "device", "nconmax", "njmax") if getattr(args, k, None) is not None]
    if args.engine != "warp" and given:
        raise UserError(f"{' and '.join(given)} {'is' if len(given) == 1 else 'are'} for --engine warp")


def model_options(p):
    p.add_argument(
        "--key", metavar="NAME|INDEX", help="an MJCF model's keyframe to start from (default: its default pose)"
    )
    p.add_argument(
        "--ctrl",
        choices=("hold", "zero", "keyframe"),
        help="an MJCF model's actuators: hold the initial pose (default), zero, or the keyframe's ctrl",
    )


#: Whether the contacts between frames (steps) are looked for unless --between-frames or
#: --no-between-frames says.  On: measured on 2 cores (in-process replay, 16 figures, 2000 frames,
#: gentle and violent sinusoidal hinge motions, min of 3), they add 2-7% and 5-14% to `replay` (0.69
#: -> 0.71 s, 1.01 -> 1.09-1.15 s; checked in the background while frames are posed; on one core 15-20%
#: and 46-51%; before the capsule broad phase: 61-68% and 92-109%), 4-5% to `compare pile` (4.52 ->
#: 4.68 s; before: 45%) and 11% to `compare crowd` (3.91 -> 4.35 s; before: 35%).
BETWEEN_DEFAULT = True


def between_option(p, what):
    """--between-frames / --no-between-frames; args.between_frames is None when neither is given."""
    p.add_argument(
        "--between-frames",
        action=argparse.BooleanOptionalAction,
        default=None,
        help=f"{what} (continuous collision detection; default: {'on' if BETWEEN_DEFAULT else 'off'})",
    )


def between(args):
    return BETWEEN_DEFAULT if args.between_frames is None else args.between_frames
