"""`ellipsim run ... --engine warp`: a scenario in N worlds on MuJoCo Warp, ellipsim attached (ellipsim.warp).

A scenario of figures dropped or laid out by a seed (free roots) starts world w from the layout of seed
+ (w mod SEEDS): the same model, other initial poses; any other scenario starts every world from its one
initial state.  A scenario's controls at the step's time go to every world.  World 0 is mirrored into a MuJoCo C MjData at each recorded frame (qpos copied back,
mj_forward), which is what the frame counts and `--record` see: ellipsim's verdicts on world 0's pose,
beside MuJoCo C's contacts on it.  The Warp contacts per world are counted at the same frames (one
read-back per frame, not per step).
"""

import dataclasses
import time

import mujoco
import numpy as np

from . import simulate
from .scenario import ScenarioError
from .stepping import FrameLoop

#: The modes a scenario runs in on Warp: plain Warp, or ellipsim's narrow phase attached (the contact filter is
#: MuJoCo C's mjcb_contactfilter, which Warp has no counterpart of).
WARP_MODES = ("builtin", "narrowphase")

#: Distinct layout seeds at most (each one a model build on the host).
SEEDS = 64

#: Contact slots per world given to Warp (d.naconmax = worlds x this x ngeom, at least MIN_CONTACTS per
#: world; --nconmax sets it): the 16-figure heap makes ~1 contact per geom, a pile of ellipsoids in a box 2-3.
CONTACTS_PER_GEOM = 4
MIN_CONTACTS = 64


def _warp():
    try:
        import mujoco_warp as mjw
        import warp as wp

        import ellipsim.warp as ew
    except ImportError as exc:
        raise ScenarioError(str(exc).split(";")[0]) from None
    return wp, mjw, ew


def quiet():
    """Warp's start-up banner and per-module load lines off: for the CLI, which owns its process (a
    library call leaves Warp's settings as the user set them)."""
    wp, _, _ = _warp()
    wp.config.quiet = True
    wp.config.log_level = max(wp.config.log_level, wp.LOG_WARNING)  # the "Module ... load" lines


def check_device(device):
    """'cpu' or 'cuda', checked against what Warp sees; ScenarioError otherwise."""
    wp, _, _ = _warp()
    if device not in ("cpu", "cuda"):
        raise ScenarioError(f"--device must be cpu or cuda, got {device!r}")
    if device == "cuda" and wp.get_cuda_device_count() == 0:
        raise ScenarioError("--device cuda: Warp finds no CUDA device here (use --device cpu)")
    return device


def world_states(s, model, data, nworld):
    """(qpos per world (nworld, nq), distinct seeds used): the layouts of seeds s.seed + (w mod SEEDS) for
    a figures scene with free roots (module docstring), else data.qpos in every world (1 seed)."""
    sc = s.scene
    qpos = np.tile(data.qpos, (nworld, 1))
    if sc["kind"] != "figures" or sc["fixed_roots"] or nworld == 1:
        return qpos, 1
    distinct = min(nworld, SEEDS)
    for k in range(1, distinct):
        other = dataclasses.replace(s, scene={**sc, "seed": sc["seed"] + k})
        m2, d2 = simulate.build(other)
        if m2.nq != model.nq or not np.array_equal(m2.geom_size, model.geom_size):
            raise ScenarioError(f"{s.path}: seed {sc['seed'] + k} builds another model; cannot share one on Warp")
        qpos[k::distinct] = d2.qpos
    return qpos, distinct


@dataclasses.dataclass
class Setup:
    """A scenario put on MuJoCo Warp (setup): MuJoCo C's model and data, the controller, Warp's m and d, the
    buffer sizes (naconmax: contacts of all worlds; nconmax, njmax: contacts and constraint rows a world)
    and the layout seeds used."""

    model: object
    data: object
    control: object
    m: object
    d: object
    naconmax: int
    nconmax: int
    njmax: int
    seeds: int


def default_nconmax(model):
    """Contacts a world may hold: CONTACTS_PER_GEOM per geom, at least MIN_CONTACTS."""
    return max(MIN_CONTACTS, CONTACTS_PER_GEOM * model.ngeom)


def default_njmax(model, nconmax):
    """Constraint rows a world may hold: every contact slot with its rows (pyramidal cone: 2 (condim - 1)
    a contact, elliptic: condim; the model's largest condim), a row per limited joint and per dof with
    friction loss, six per equality constraint.  mujoco_warp's own guess (io._default_njmax) is 53 rows
    plus 2.26 nv per height field: the 16-figure heap overflows it on its first contacts."""
    condim = int(max(model.geom_condim.max(initial=3), model.pair_dim.max(initial=3)))
    rows = condim if model.opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC else max(1, 2 * (condim - 1))
    other = int(model.jnt_limited.sum()) + int(np.count_nonzero(model.dof_frictionloss)) + 6 * model.neq
    return nconmax * rows + other


def setup(s, nworld, device, *, nconmax=None, njmax=None):
    """A Setup: scenario s built (simulate.build) and put on Warp in nworld worlds from world_states, with
    nconmax contacts and njmax constraint rows a world (default_nconmax, default_njmax when None), Warp's
    own overflow prints off (m.opt.warn_overflow: overflows are counted and explained instead, overflow())."""
    wp, mjw, _ = _warp()
    model, data = simulate.build(s)
    control = simulate.controller(model, data, s)
    mujoco.mj_forward(model, data)
    qpos, seeds = world_states(s, model, data, nworld)
    nconmax = max(default_nconmax(model), data.ncon) if nconmax is None else int(nconmax)
    njmax = max(default_njmax(model, nconmax), data.nefc) if njmax is None else int(njmax)
    # the initial state must fit (mujoco_warp's put_data refuses it otherwise, with a traceback)
    if nconmax < data.ncon:
        raise ScenarioError(f"nconmax (--nconmax) {nconmax} is below the {data.ncon} contacts of the initial state")
    if njmax < data.nefc:
        raise ScenarioError(f"njmax (--njmax) {njmax} is below the {data.nefc} constraint rows of the initial state")
    naconmax = nworld * nconmax
    with wp.ScopedDevice(device):
        m = mjw.put_model(model)
        m.opt.warn_overflow = 0
        d = put_worlds(model, data, qpos, naconmax, njmax)
    return Setup(model, data, control, m, d, naconmax, nconmax, njmax, seeds)


def put_worlds(model, data, qpos, naconmax, njmax=None):
    """A mujoco_warp Data of data's state in len(qpos) worlds, world w at qpos[w] (the current device)."""
    _, mjw, _ = _warp()
    d = mjw.put_data(model, data, nworld=len(qpos), naconmax=naconmax, njmax=njmax)
    d.qpos.assign(np.asarray(qpos, np.float32))
    return d


def overflow(d, setup):
    """Why Warp's buffers overflowed since the last call, one line ('' when they did not); clears d.overflow.
    Contacts past naconmax and constraint rows past njmax are lost for that step."""
    _, mjw, _ = _warp()
    flags = int(np.bitwise_or.reduce(d.overflow.numpy(), initial=0))
    if not flags:
        return ""
    d.overflow.zero_()
    kinds = mjw.OverflowType
    why = []
    if flags & (kinds.BROADPHASE | kinds.NARROWPHASE):
        why.append(f"contacts past naconmax {setup.naconmax} ({setup.nconmax} a world: raise --nconmax) were dropped")
    if flags & kinds.NEFC:
        why.append(f"constraint rows past njmax {setup.njmax} a world (raise --njmax) were dropped")
    if flags & kinds.HFIELD:  # Warp's own field collider (a geom ellipsim does not take: a mesh, a box...)
        why.append(
            "Warp's height-field collider met more than 50 prisms for a pair it handles itself (not an ellipsoid's): "
            "those prisms got no contact (a coarser field, or smaller geoms on it)"
        )
    other = flags & ~int(kinds.BROADPHASE | kinds.NARROWPHASE | kinds.NEFC | kinds.HFIELD)
    if other:
        why.append(f"another of Warp's buffers overflowed ({kinds(other)!r})")
    return "; ".join(why)


def send_controls(d, model, control, t):
    """The scenario's controls at time t to every world (nothing for a model without actuators)."""
    if model.nu:
        ctrl = np.asarray(control(t), np.float32)
        d.ctrl.assign(np.broadcast_to(ctrl, (d.nworld, ctrl.size)))


@dataclasses.dataclass
class WarpRun:
    """What `run` returns: stepping wall time, steps, worlds, per-frame Warp contacts per world (F, N),
    world 0's frame counts (simulate.FrameCounts), the attachment's counters, overflowed steps."""

    scenario: object
    mode: str
    steps: int
    nworld: int
    device: str
    seconds: float
    contacts: np.ndarray
    frames: simulate.FrameCounts
    counters: dict
    overflow_frames: int
    seeds: int = 1
    overflow: str = ""  # why (warp_run.overflow), the first time

    def summary(self):
        rate = self.steps / max(self.seconds, 1e-9)
        c = self.contacts
        who = "ellipsim attached" if self.mode != "builtin" else "plain Warp"
        lines = [
            f"  worlds: {self.seeds} layout seeds" if self.seeds > 1 else "  worlds: one initial state, copied",
            f"  stepping on Warp ({self.device}, {who}): {self.seconds:.2f} s for {self.steps} steps x {self.nworld} worlds, "
            f"{rate:,.0f} steps/s per world, {rate * self.nworld:,.0f} world-steps/s in total",
            f"  Warp contacts per world at {len(c)} frames: mean {c.mean():.1f} over all worlds, per world "
            + ", ".join(f"{x:.1f}" for x in c.mean(0)[:8])
            + (f", ... ({self.nworld} worlds)" if self.nworld > 8 else ""),
        ]
        fr = self.frames
        if len(fr.times):
            lines += [
                x.replace("over ", "of world 0 (mirrored in MuJoCo C: its contacts) over ", 1)
                for x in simulate.contact_lines(fr, len(fr.times))
            ]
        if self.counters:
            k = self.counters
            lines.append(
                f"  ellipsim on Warp: {k['pairs']} pairs evaluated, {k['contacts']} contacts, {k['unproven']} unproven "
                f"maxima, {k['overflow']} contacts over naconmax"
                + (f", {k['failed']} height-field or mesh pairs failed (no contacts)" if k.get("failed") else "")
            )
        if self.overflow_frames:
            lines.append(f"  warning: Warp's buffers overflowed at {self.overflow_frames} frames: {self.overflow}")
        return lines


def run(
    s, *, steps, nworld, device="cpu", mode=None, progress=None, recorder=None, nconmax=None, njmax=None, started=None
):
    """Step scenario s in nworld worlds on MuJoCo Warp (module docstring); returns a WarpRun.
    nconmax, njmax : contacts and constraint rows a world (setup's defaults when None); started : optional
    callable(), called once the model is built."""
    mode = mode or s.mode
    if mode not in WARP_MODES:
        raise ValueError(f"mode must be one of {', '.join(WARP_MODES)} on Warp (filter is MuJoCo C's), got {mode!r}")
    wp, mjw, ew = _warp()
    if s.kinematic:
        raise ScenarioError(f"{s.path}: a kinematic scenario (keyframed poses) has nothing to step on Warp")
    if isinstance(nworld, bool) or not isinstance(nworld, int) or nworld < 1:
        raise ValueError(f"nworld must be a positive integer, got {nworld!r}")
    simulate.check_steps(s, steps)
    every = simulate.record_every(s)
    chunks, counts, overflowed, why = [], [], 0, ""

    def on_chunk(chunk):
        chunks.append(simulate.FrameCounts.of(chunk.frames))

    put = setup(s, nworld, device, nconmax=nconmax, njmax=njmax)
    if started is not None:
        started()
    model, data, control, m, d, naconmax, seeds = (
        put.model,
        put.data,
        put.control,
        put.m,
        put.d,
        put.naconmax,
        put.seeds,
    )
    mirror = mujoco.MjData(model)
    start = d.qpos.numpy()
    with wp.ScopedDevice(device):
        att = ew.attach(m) if mode != "builtin" else None
        mjw.step(m, d)  # compiles (minutes on a first CPU run), before the loop's timer
        d = put_worlds(model, data, start, naconmax, put.njmax)  # the initial state again
        if att:
            att.reset_counters()
        loop = FrameLoop(model, recorder=recorder, title=s.name, on_chunk=on_chunk)

        frame_seconds = 0.0

        def step(k):
            nonlocal overflowed, why, frame_seconds
            send_controls(d, model, control, k * s.timestep)
            mjw.step(m, d)
            if k % every == 0:
                wp.synchronize()
                t_frame = time.perf_counter()
                n = int(d.nacon.numpy()[0])
                lost = overflow(d, put)
                overflowed += bool(lost)
                why = why or lost
                w = d.contact.worldid.numpy()[: min(n, naconmax)]
                counts.append(np.bincount(w, minlength=nworld))
                mirror.qpos[:] = d.qpos.numpy()[0]
                mirror.time = (k + 1) * s.timestep
                mujoco.mj_forward(model, mirror)
                frame_seconds += time.perf_counter() - t_frame

        loop.run(mirror, steps, step, every=every, progress=progress)
        wp.synchronize()
        # the loop's stepping time less each frame's read-back and world 0's mirror: Warp's steps alone
        seconds = loop.seconds - frame_seconds
        counters = att.counters if att else {}
        if att:
            att.detach()
    frames = simulate.FrameCounts.concatenate(chunks)
    return WarpRun(s, mode, steps, nworld, device, seconds, np.array(counts), frames, counters, overflowed, seeds, why)
