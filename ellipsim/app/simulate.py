"""Running a scenario: build its model, drive it (or pose it, when kinematic), decide its frames.

`run` steps a scenario through a stepping.FrameLoop, a frame every 1/RECORD_FPS simulated seconds
(ellipsim's exact verdicts, a chunk of frames at a time, each decided chunk to an optional
record.Recorder); for a kinematic scenario, whose every step is a frame, it also finds the contacts
that begin and end between two frames (mujoco.between).  It keeps a few counts per frame (and, with keep=True, the ellipsoids' centres and
states), so its memory does not grow with the number of steps beyond that.  `validation` steps the
scenario under mujoco.validate (MuJoCo's contacts against the exact test, pair by pair).
"""

import contextlib
import dataclasses
import os

import mujoco
import numpy as np

from ..mujoco.attachment import attach
from ..mujoco.validate import contacts_disabled, validate
from . import capture, limits, mjcf, scenes
from .control import Controller
from .scenario import MODES, Scenario, ScenarioError
from .stepping import FrameLoop

RECORD_FPS = 60.0  # frames per simulated second kept for recording and comparison

#: Bytes a run keeps per recorded frame: time and four counts (8 bytes each).
BYTES_PER_FRAME = 40
#: Bytes `validation` keeps per step: four pair counts and the contact count (8 bytes each).
BYTES_PER_VALIDATED_STEP = 40


def _label(s):
    """How errors name the scenario's scene: its file, and the [scene] table for a TOML scenario."""
    direct = s.scene["kind"] == "mjcf" and os.path.abspath(s.path) == s.scene["path"]
    return s.path if direct else f"{s.path}: [scene]"


def build(s):
    """(model, data) of a scenario with its timestep and gravity, at the initial state, data.ctrl
    holding it (an MJCF model: its keyframe or default pose, controls per its scene's ctrl).

    A scene the model builder refuses (e.g. a spacing too small for the layout, more figures than
    memory allows) or a model MuJoCo refuses raises ScenarioError naming the file.
    """
    sc = s.scene
    label = _label(s)
    try:
        if sc["kind"] == "mjcf":
            model = mjcf.load_model(sc["path"])
        else:
            if sc["kind"] == "figures":
                _check_figures(sc["figures"])
                xml = scenes.scene_xml(
                    sc["figures"],
                    layout=sc["layout"],
                    spacing=sc["spacing"],
                    seed=sc["seed"],
                    drop_height=sc["drop_height"],
                    floor=sc["floor"],
                    fixed_roots=sc["fixed_roots"],
                    terrain=sc.get("terrain", False),
                    props=sc.get("props", 0),
                )
            else:
                xml = scenes.pile_xml(sc["ellipsoids"], seed=sc["seed"], bin_half_width=sc["bin_half_width"])
            model = mujoco.MjModel.from_xml_string(xml)
        model.opt.timestep = s.timestep
        if s.gravity:
            model.opt.gravity[:] = s.gravity
        data = mjcf.make_data(model, label)
        if sc["kind"] == "mjcf":
            key = mjcf.keyframe(model, sc["key"], label)
            mjcf.start(model, data, key, sc["ctrl"], label)
    except mjcf.ModelError as exc:
        text = str(exc)
        if sc["kind"] == "mjcf" and text.startswith(sc["path"] + ":") and label == s.path:
            text = label + text[len(sc["path"]) :]  # the file as the user gave it
        raise ScenarioError(text if text.startswith(label) else f"{label} {text}") from None
    except ValueError as exc:
        raise ScenarioError(f"{label} {exc}") from None
    return model, data


def _check_figures(n):
    """ValueError when MuJoCo's arena for n figures (scenes.scene_memory) exceeds the memory available."""
    need = scenes.scene_memory(n)
    available = limits.available_memory()
    if available is not None and need > available:
        most = 1
        while scenes.scene_memory(2 * most) <= available:
            most *= 2
        step = most
        while step > 1:  # the largest count that fits, by bisection
            step //= 2
            if scenes.scene_memory(most + step) <= available:
                most += step
        raise ValueError(
            f"figures = {n} needs {limits.gigabytes(need)} of MuJoCo arena (its broad phase takes "
            f"{scenes.ARENA_PER_BODY_PAIR} bytes per pair of the model's {len(scenes.LIMBS) * n + 1} bodies), more than "
            f"the {limits.gigabytes(available)} of memory available: at most {most} figures here"
        )


def controller(model, data, s):
    """The scenario's Controller about data.ctrl (build's held controls); ScenarioError naming the
    file when the control does not fit the model."""
    try:
        return Controller(model, s.control, base=data.ctrl.copy())
    except ValueError as exc:
        raise ScenarioError(f"{s.path}: [control] {exc}") from None


@dataclasses.dataclass
class FrameCounts:
    """Per recorded frame (F,): time (s), the pairs ellipsim judges in contact (dist < margin) by MuJoCo
    and by ellipsim, ellipsoid pairs ellipsim finds exactly touching, all of MuJoCo's contacts; and the
    first two per pair type, (F, T) (mujoco.judge.KEYS)."""

    times: np.ndarray
    builtin_counts: np.ndarray
    ellipsim_counts: np.ndarray
    touching_counts: np.ndarray
    contact_counts: np.ndarray
    builtin_by_type: np.ndarray
    ellipsim_by_type: np.ndarray

    @classmethod
    def of(cls, frames):
        """The counts of a trajectory.Frames (what a run keeps of a chunk: not its poses)."""
        return cls(*(getattr(frames, field.name) for field in dataclasses.fields(cls)))

    @classmethod
    def concatenate(cls, parts):
        """One FrameCounts of consecutive ones."""
        return cls(*(np.concatenate([getattr(p, f.name) for p in parts]) for f in dataclasses.fields(cls)))


@dataclasses.dataclass
class Kept:
    """The ellipsoids of every recorded frame, kept by run(..., keep=True): geom_names (g,),
    centers (F, g, 3) metres, state (F, g) int8 (0 free, 1 touching, 2 overlapping)."""

    geom_names: list
    centers: np.ndarray
    state: np.ndarray


@dataclasses.dataclass
class Run:
    """What `run` returns.

    seconds : wall time of stepping alone (mj_step or the kinematic poses, and copying frames out)
    analysis_seconds : wall time of ellipsim's verdicts on the recorded frames (broad phase, classify)
    record_seconds : wall time of sending frames to the recording
    between : the contacts between two frames of a kinematic scenario, as capture.describe_events
        dicts in time order (None when not looked for); between_candidates : pairs time_of_impact
        decided; between_seconds : its share of analysis_seconds
    """

    scenario: Scenario
    mode: str
    steps: int
    seconds: float
    analysis_seconds: float
    record_seconds: float
    frames: FrameCounts
    counters: dict  # ellipsim's per-data counters (filter or narrowphase), or {}
    contacts_mean: float  # all of MuJoCo's contacts per step
    contacts_max: int
    kept: Kept = None
    between: list = None
    between_candidates: int = 0
    between_seconds: float = 0.0
    contacts_disabled: bool = False  # the model disables contacts (validate.contacts_disabled)

    def summary(self, wall, *, recording=False, between_asked=False, show=10):
        """The lines `ellipsim run` prints after running: stepping rate, the other costs out of `wall`
        (seconds, the whole run), contacts, ellipsim's counters, `show` contacts between frames at
        most; recording: a recording was written; between_asked: --between-frames was given."""
        s, fr, c = self.scenario, self.frames, self.counters
        rate = self.steps / max(self.seconds, 1e-9)
        stepper = "mj_forward per keyframed pose" if s.kinematic else f"mj_step, {self.mode}"
        rest = wall - self.seconds - self.analysis_seconds - self.record_seconds
        lines = [
            f"  stepping: {self.seconds:.2f} s for {self.steps} steps, {rate:,.0f} steps/s ({rate * s.timestep:.2f}x real time; "
            f"{stepper}, copying frames out included)",
            f"  not in that: model build and kernel loading {rest:.2f} s, "
            f"ellipsim's verdicts on {len(fr.times)} frames {self.analysis_seconds:.2f} s"
            + (f", recording {self.record_seconds:.2f} s" if recording else ""),
            f"  contacts per step (all geoms): mean {self.contacts_mean:.1f}, max {self.contacts_max}"
            + (
                '; none: the model disables contacts (<option><flag contact="disable"/>)'
                if self.contacts_disabled
                else ""
            ),
        ]
        if len(fr.times):
            lines += contact_lines(fr, len(fr.times))
        if "seen" in c:
            share = c["discarded"] / max(c["seen"], 1)
            lines.append(
                f"  filter: {c['seen']} pairs tested, {c['discarded']} skipped ({share:.0%}), {c['passed']} passed to MuJoCo"
            )
        elif "calls" in c:
            lines.append(
                f"  narrow phase: {c['calls']} pairs = {c['separated']} certified apart + {c['apart']} measured beyond "
                f"the margin + {c['contacts']} contacts + {c['fallbacks']} fallbacks to MuJoCo"
            )
            if c["capped"]:
                lines.append(
                    f"  {c['capped']} height-field pairs made MuJoCo's most contacts (mjMAXCONPAIR, 50): "
                    "prisms beyond those made none"
                )
        if self.between is not None:
            lines += capture.between_lines(self.between, self.between_candidates, self.between_seconds, show, "frames")
        elif between_asked:
            lines.append(
                "  contacts between frames: not looked for (a dynamic scenario; `ellipsim compare` checks every step)"
            )
        return lines


def contact_lines(fr, frames, unit="recorded frames"):
    """The summary's lines on contacts of the pairs ellipsim judges over `frames` frames of a FrameCounts
    (or anything with builtin_by_type and ellipsim_by_type (F, T)): one for all, one per pair type present."""
    from ..mujoco.judge import KEYS

    theirs, ours = np.asarray(fr.builtin_by_type), np.asarray(fr.ellipsim_by_type)
    lines = [
        f"  pairs in contact (distance < margin) over {frames} {unit}, every pair type ellipsim judges: MuJoCo "
        f"mean {theirs.sum(axis=1).mean():.2f} (max {theirs.sum(axis=1).max()}), ellipsim mean "
        f"{ours.sum(axis=1).mean():.2f} (max {ours.sum(axis=1).max()}); `ellipsim compare` judges each pair"
    ]
    for k, key in enumerate(KEYS):
        if theirs[:, k].any() or ours[:, k].any():
            lines.append(
                f"    {key}: MuJoCo mean {theirs[:, k].mean():.2f} (max {theirs[:, k].max()}), ellipsim mean "
                f"{ours[:, k].mean():.2f} (max {ours[:, k].max()})"
            )
    if not (theirs.any() or ours.any()):
        lines.append("    no pair of a type ellipsim judges came into contact")
    return lines


def recorded_frames(s, steps):
    """How many frames `run` records in `steps` steps of scenario `s`."""
    every = record_every(s)
    return (steps + every - 1) // every


def record_every(s):
    """Steps between two frames `run` records: 1 for a kinematic scenario, else 1/RECORD_FPS seconds."""
    return 1 if s.kinematic else max(1, int(round(1.0 / (RECORD_FPS * s.timestep))))


def check_steps(s, steps):
    """ValueError when `steps` is not a positive int or the counts `run` keeps for it would not fit
    in the memory available."""
    if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or steps < 1:
        raise ValueError(f"steps must be a positive integer, got {steps!r}")
    frames = recorded_frames(s, steps)
    limits.check_fits(frames * BYTES_PER_FRAME, f"{steps} steps ({frames} recorded frames of counts)")


def advance(model, data, s, control, k):
    """Step k of scenario s: a kinematic scenario's pose at k * timestep from its keyframes, then
    forward kinematics and MuJoCo's collision; any other, the controls at data.time and one mj_step."""
    if s.kinematic:
        t = k * s.timestep
        data.qpos[control.qadr] = control(t)
        data.time = t
        mujoco.mj_forward(model, data)
    else:
        data.ctrl[:] = control(data.time)
        mujoco.mj_step(model, data)


def run(s, *, steps=None, mode=None, progress=None, recorder=None, keep=False, between=False, started=None):
    """Simulate a scenario (or replay it, when kinematic); returns a Run.

    steps : number of steps (default: the scenario's duration); mode : overrides the scenario's.
    progress : optional callable(step, steps).
    recorder : optional record.Recorder; it is begun with the model's geometry and sent every chunk
        of frames (closing it is the caller's).
    keep : also keep the ellipsoids' centres and states of every recorded frame (Run.kept).
    between : a kinematic scenario: also find the contacts that begin and end between two frames, on
        each ellipsoid's interpolated motion (core.motion.interpolation, not the keyframes' joint interpolation);
        the recording gets a marker at each one's first contact.  Ignored for a dynamic scenario
        (its frames are 1/RECORD_FPS apart, many steps).
    started : optional callable(), called once the model is built, before the first step.
    ScenarioError for a scene or model that cannot be built or run (MuJoCo out of memory included).
    """
    mode = mode or s.mode
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
    steps = s.steps if steps is None else steps
    check_steps(s, steps)
    model, data = build(s)
    control = controller(model, data, s)
    if started is not None:
        started()
    between = bool(between and s.kinematic)
    chunks, kept = [], []

    def on_chunk(chunk):
        f = chunk.frames
        chunks.append(FrameCounts.of(f))
        if keep:
            kept.append((chunk.centers[:, loop.buffer.round_at].copy(), f.state))

    loop = FrameLoop(model, recorder=recorder, title=s.name, on_chunk=on_chunk, between=between)
    ncon_sum, ncon_max = 0, 0

    def step(k):
        nonlocal ncon_sum, ncon_max
        try:
            advance(model, data, s, control, k)
        except mujoco.FatalError as exc:
            raise ScenarioError(f"{_label(s)} MuJoCo stopped at step {k}: {mjcf.one_line(exc)}") from None
        ncon_sum += data.ncon
        ncon_max = max(ncon_max, data.ncon)

    att = attach(model, data, mode=mode) if mode != "builtin" and not s.kinematic else None
    with att if att else contextlib.nullcontext():  # attached before the loop's timer: attaching compiles
        loop.run(data, steps, step, every=record_every(s), progress=progress)
    frames = FrameCounts.concatenate(chunks)
    kept_frames = None
    if keep:
        centers, state = (np.concatenate(parts) for parts in zip(*kept))
        kept_frames = Kept([loop.names.geoms[g] for g in loop.buffer.ellipsoid_ids], centers, state)
    events = loop.events()
    return Run(
        s,
        mode,
        steps,
        loop.seconds,
        loop.analysis_seconds,
        loop.record_seconds,
        frames,
        att.counters if att else {},
        ncon_sum / steps,
        int(ncon_max),
        kept_frames,
        capture.describe_events(events, loop.buffer.ellipsoid_ids, loop.names) if between else None,
        loop.buffer.between.candidates if between else 0,
        loop.buffer.between_seconds,
        contacts_disabled(model),
    )


def validation(s, steps=None, progress=None, between=False, recorder=None, started=None):
    """mujoco.validate on the scenario: its model, its controls (or keyframed poses), `steps` steps;
    between: also the ellipsoid pairs that pass through each other within one step; recorder: an
    optional record.Recorder, begun here and sent every step (compare_record.CompareRecording; its
    closing is the caller's; on Ctrl-C or SIGTERM the steps so far are sent first); started : optional
    callable(), called once the model is built."""
    steps = s.steps if steps is None else steps
    if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or steps < 1:
        raise ValueError(f"steps must be a positive integer, got {steps!r}")
    limits.check_fits(steps * BYTES_PER_VALIDATED_STEP, f"{steps} steps of pair counts")
    model, data = build(s)
    control = controller(model, data, s)
    if started is not None:
        started()
    if s.kinematic:

        def pose(m, d, k):
            d.time = k * s.timestep
            d.qpos[control.qadr] = control(d.time)

        step, advance = pose, False
    else:

        def step(m, d, k):
            d.ctrl[:] = control(d.time)

        advance = True
    observer = None
    if recorder is not None:
        from .compare_record import CompareRecording

        observer = CompareRecording(recorder, model, s.name)
        recorder.between_checked = bool(between)
    call = lambda: validate(  # noqa: E731
        model, data, steps, control=step, advance=advance, progress=progress, between=between, observer=observer
    )
    try:
        v = call() if observer is None else observer.run(call)
    except mujoco.FatalError as exc:
        raise ScenarioError(f"{_label(s)} MuJoCo stopped: {mjcf.one_line(exc)}") from None
    if observer is not None and v.passed_through is not None:
        capture.record_events(recorder, v.passed_through, v.ellipsoid_ids, observer.names)
    return v, model
