"""`ellipsim compare ... --engine warp`: plain MuJoCo Warp's own contacts, every world, against the exact test.

The scenario runs in N worlds on plain Warp (nothing attached), from per-world layouts as `run --engine
warp` starts them (warp_run.world_states).  At each compared step, every candidate pair of a type
ellipsim judges (an ellipsoid with an ellipsoid, sphere, capsule, box, cylinder, convex mesh or height field:
the model's collision rules, as ellipsim.warp takes them) of every world whose bounding spheres come within the pair's margin
gets the exact verdicts of mujoco.validate.judge_contacts on Warp's float32 poses widened to float64:
the same one margin rule (a contact below the pair's margin on both sides) and the same words as
`compare` on MuJoCo C (mujoco_extra, mujoco_missed, near_tangent, normal_off; "mujoco" is the engine,
here MuJoCo Warp), judged against Warp's ccd_tolerance.  On pairs both have, the distance error (over
the pair's smallest size) and the normal's angle.  A pair is matched to Warp's contact whichever way
round Warp names its geoms (SAP orders equal types by its sort); pairs Warp skips for sleeping bodies
are not asked for; a step where Warp's candidate or contact buffer overflowed is counted and explained
(its misses are the buffer's: raise --nconmax / --njmax).
"""

import dataclasses

import mujoco
import numpy as np

from ..mujoco.geoms import pair_gaps, pair_margins
from ..mujoco.judge import KEYS, NORMAL_OFF_DEG
from ..mujoco.validate import KIND_MEANINGS, KINDS, Names, judge_contacts
from . import simulate, warp_run
from .comparison import COUNTERS, disagreement_json, line
from .scenario import ScenarioError


@dataclasses.dataclass
class WarpComparison:
    name: str
    nworld: int
    steps: int
    pairs: int  # candidate pairs per world
    counts: np.ndarray  # (T, 4) COLUMNS of mujoco.Validation per pair type, summed over worlds and steps
    disagreements: list  # (world, mujoco.validate.Disagreement)
    dist_err: np.ndarray  # per common contact, over the pair's smallest size
    angle: np.ndarray  # per common contact, degrees
    unproven: int
    overflow_steps: int = 0
    overflow: str = ""  # why, when Warp's buffers overflowed

    def counters(self, column=None):
        """The comparison.COUNTERS of pair type `column` (None: all)."""
        rows = self.counts if column is None else self.counts[column : column + 1]
        both, neither, warp_only, exact_only = (int(x) for x in rows.sum(axis=0))
        mine = [d for _, d in self.disagreements if column is None or d.pair_type == KEYS[column]]
        out = {
            "pairs": both + neither + warp_only + exact_only,
            "agreement": both + neither,
            "mujoco_contacts": both + warp_only,
            "ellipsim_contacts": both + exact_only,
            **{kind: sum(d.kind == kind for d in mine) for kind in KINDS},
            "undetermined": sum(d.right == "undetermined" for d in mine),
        }
        assert tuple(out) == COUNTERS
        return out

    def summary(self, show):
        e = self.dist_err
        t = self.counters()
        lines = [
            f"  Warp's contacts on {self.pairs} candidate pairs per world (every type ellipsim judges) x {self.nworld} "
            f"worlds x {self.steps} steps: {t['pairs']} pairs within reach judged exactly, contacts Warp "
            f"{t['mujoco_contacts']} / exact {t['ellipsim_contacts']}",
            "  "
            + ", ".join(f"{t[kind]} {kind}" for kind in KINDS)
            + (
                f"; on {e.size} common contacts distance error / smallest size max {e.max():.1e} (median "
                f"{np.median(e):.1e}), normal max {self.angle.max():.2g} deg"
                if e.size
                else ""
            )
            + (f"; {self.unproven} exact maxima unproven" if self.unproven else ""),
            "  by pair type:",
        ]
        none = []
        for k, key in enumerate(KEYS):
            c = self.counters(k)
            if c["pairs"] == 0:
                none.append(key)
                continue
            lines.append(
                f"    {key}: {c['pairs']} pairs, contacts Warp {c['mujoco_contacts']} / exact {c['ellipsim_contacts']}; "
                + ", ".join(f"{c[kind]} {kind}" for kind in KINDS)
            )
        if none:
            lines.append(f"    no candidate pairs: {', '.join(none)}")
        if self.overflow_steps:
            lines.append(f"  warning: Warp's buffers overflowed {self.overflow}")
        if self.disagreements:
            lines.append("  disagreements (" + "; ".join(f"{k}: {m}" for k, m in KIND_MEANINGS.items()) + "):")
        for w, d in self.disagreements[:show]:
            lines.append("    " + line(d, "Warp", world=w))
        if len(self.disagreements) > show:
            lines.append(f"    ... and {len(self.disagreements) - show} more (--show N, or --json)")
        return lines

    def report(self):
        e = self.dist_err
        return dict(
            scenario=self.name,
            engine="warp",
            worlds=self.nworld,
            steps=self.steps,
            pairs_per_world=self.pairs,
            **self.counters(),
            normal_off_deg=NORMAL_OFF_DEG,
            by_pair_type={key: self.counters(k) for k, key in enumerate(KEYS)},
            disagreements=[disagreement_json(d, world=w) for w, d in self.disagreements],
            dist_err_max=float(e.max()) if e.size else None,
            normal_err_max_deg=float(self.angle.max()) if e.size else None,
            unproven=self.unproven,
            overflow_steps=self.overflow_steps,
            overflow=self.overflow or None,
        )


def compare(s, *, steps, nworld, device="cpu", progress=None, recorder=None, nconmax=None, njmax=None, started=None):
    """Step scenario s in nworld worlds on plain MuJoCo Warp and check its contacts (module docstring).
    recorder : an optional record.Recorder for world 0 (compare_record.CompareRecording with Warp's
    contacts and poses; its closing is the caller's; on Ctrl-C or SIGTERM the steps so far are sent).
    nconmax, njmax : contacts and constraint rows per world (warp_run.setup's defaults); started : optional
    callable(), called once the model is built."""
    wp, mjw, ew = warp_run._warp()
    if s.kinematic:
        raise ScenarioError(f"{s.path}: a kinematic scenario (keyframed poses) has nothing to step on Warp")
    simulate.check_steps(s, steps)
    setup = warp_run.setup(s, nworld, device, nconmax=nconmax, njmax=njmax)
    if started is not None:
        started()
    with wp.ScopedDevice(device):
        pairs, pairid = ew.candidate_pairs(setup.m, pair_ids=True)
    pairs = np.sort(pairs, axis=1).astype(np.int64)  # g1 < g2, as the judge and the reports take them
    if recorder is None:
        return _run(s, setup, pairs, pairid, steps, nworld, device, progress)
    from .compare_record import CompareRecording

    observer = CompareRecording(recorder, setup.model, s.name, engine="Warp")
    return observer.run(lambda: _run(s, setup, pairs, pairid, steps, nworld, device, progress, observer))


def _run(s, setup, pairs, pairid, steps, nworld, device, progress, observer=None):
    wp, mjw, _ = warp_run._warp()
    model, control, m, d = setup.model, setup.control, setup.m, setup.d
    naconmax = setup.naconmax
    g1, g2 = pairs[:, 0], pairs[:, 1]
    margin, gap = pair_margins(model, pairs), pair_gaps(model, pairs)
    explicit = pairid[:, 0] >= 0
    reach = model.geom_rbound[g1] + model.geom_rbound[g2] + np.maximum(margin, 0.0)
    smallest = np.minimum(_smallest_size(model, g1), _smallest_size(model, g2))
    sleep = bool(model.opt.enableflags & mujoco.mjtEnableBit.mjENBL_SLEEP)
    asleep, static = int(mujoco.mjtSleepState.mjS_ASLEEP), int(mujoco.mjtSleepState.mjS_STATIC)
    b1, b2 = model.geom_bodyid[g1], model.geom_bodyid[g2]
    names = Names.of(model)
    T = len(KEYS)
    counts = np.zeros((T, 4), dtype=np.int64)
    overflow, overflow_why = 0, ""
    disagreements, errs, angles = [], [], []
    unproven = 0
    ngeom = model.ngeom
    keys = g1 * ngeom + g2  # sorted: candidate_pairs lists the pairs in the filtered table's order
    order = np.argsort(keys)
    ccd = float(model.opt.ccd_tolerance)
    mirror = mujoco.MjData(model) if observer is not None else None
    with wp.ScopedDevice(device):
        for k in range(steps):
            warp_run.send_controls(d, model, control, k * s.timestep)
            mjw.step(m, d)
            xpos, xmat = d.geom_xpos.numpy().astype(np.float64), d.geom_xmat.numpy().astype(np.float64)
            n = min(int(d.nacon.numpy()[0]), naconmax)
            cw, cg, cd, cf, cp = (
                a.numpy()[:n]
                for a in (d.contact.worldid, d.contact.geom, d.contact.dist, d.contact.frame, d.contact.pos)
            )
            first = len(disagreements)  # this step's, for the recording of world 0
            if observer is not None:
                zero = cw == 0
                world0 = (cg[zero], cd[zero], cp[zero], cf[zero, 0])
            # Warp's contact on each candidate pair, per (world, pair): distance, normal (from g1), point
            ckey = np.minimum(cg[:, 0], cg[:, 1]).astype(np.int64) * ngeom + np.maximum(cg[:, 0], cg[:, 1])
            at = np.minimum(np.searchsorted(keys, ckey, sorter=order), len(keys) - 1) if len(keys) else ckey * 0
            hit = (keys[order[at]] == ckey) if len(keys) else np.zeros(n, bool)
            pk, world = order[at[hit]], cw[hit]
            flip = cg[hit, 0] != g1[pk]  # named the other way round: normal reversed
            wdist = np.full((nworld, len(pairs)), np.nan)
            wnormal = np.full((nworld, len(pairs), 3), np.nan)
            wpos = np.full((nworld, len(pairs), 3), np.nan)
            # several contacts on a pair: the one with the smallest dist (written last after a sort)
            sort = np.argsort(-cd[hit], kind="stable")
            wdist[world[sort], pk[sort]] = cd[hit][sort]
            wnormal[world[sort], pk[sort]] = np.where(flip[:, None], -cf[hit, 0], cf[hit, 0])[sort]
            wpos[world[sort], pk[sort]] = cp[hit][sort]
            lost = warp_run.overflow(d, setup)
            if lost:
                overflow += 1
                overflow_why = overflow_why or f"at step {k} and {{more}}: {lost}"
            awake = d.body_awake.numpy() if sleep else None
            for w in range(nworld):
                ok = np.linalg.norm(xpos[w, g2] - xpos[w, g1], axis=1) <= reach
                if sleep:  # the pairs Warp's broad phase skips (_nxn_broadphase)
                    s1, s2 = awake[w, b1], awake[w, b2]
                    skip = (s1 == asleep) & ((s2 == asleep) | (s2 == static)) | (s2 == asleep) & (s1 == static)
                    ok &= ~skip
                sel = np.flatnonzero(ok | ~np.isnan(wdist[w]))
                if sel.size == 0:
                    continue
                p = pairs[sel]
                engine = (wdist[w, sel], wnormal[w, sel], wpos[w, sel])
                judged = judge_contacts(
                    model,
                    k,
                    p,
                    xpos[w][p],
                    xmat[w][p].reshape(-1, 2, 3, 3),
                    margin[sel],
                    gap[sel],
                    explicit[sel],
                    engine,
                    names,
                    ccd_tolerance=ccd,
                    who="Warp",
                )
                counts += judged.by_type
                v = judged.verdicts
                unproven += int(np.count_nonzero(np.isfinite(v.dist) & ~v.proven))
                disagreements += [(w, x) for x in judged.disagreements]
                both = np.flatnonzero((engine[0] < margin[sel]) & v.within)
                errs.append(np.abs(engine[0][both] - v.dist[both]) / smallest[sel[both]])
                na, nb = engine[1][both], v.normal[both]
                angles.append(np.degrees(np.arctan2(np.linalg.norm(np.cross(na, nb), axis=1), (na * nb).sum(1))))
            if observer is not None:
                _observe(observer, model, mirror, d, k, (k + 1) * s.timestep, world0, disagreements[first:])
            if progress:
                progress(k + 1, steps)
    if overflow:
        overflow_why = overflow_why.replace("{more}", f"{overflow - 1} more steps")
    return WarpComparison(
        s.name,
        nworld,
        steps,
        len(pairs),
        counts,
        disagreements,
        np.concatenate(errs) if errs else np.zeros(0),
        np.concatenate(angles) if angles else np.zeros(0),
        unproven,
        overflow,
        overflow_why,
    )


def _smallest_size(model, geoms):
    """(k,) the smallest size of each geom: an ellipsoid's or box's smallest semi-axis or half-size, a
    sphere's radius, the smaller of a capsule's or cylinder's radius and half-length."""
    size, t = model.geom_size[geoms], model.geom_type[geoms]
    out = size.min(axis=1)
    out[t == mujoco.mjtGeom.mjGEOM_SPHERE] = size[t == mujoco.mjtGeom.mjGEOM_SPHERE, 0]
    two = (t == mujoco.mjtGeom.mjGEOM_CAPSULE) | (t == mujoco.mjtGeom.mjGEOM_CYLINDER)
    out[two] = size[two, :2].min(axis=1)
    return out


def _observe(observer, model, mirror, d, step, time, contacts, found):
    """Hand world 0's step to a compare_record.CompareRecording: its poses as Warp holds them (float32,
    widened) in a MuJoCo C MjData, Warp's contacts, and the step's disagreements of world 0."""
    mirror.qpos[:] = d.qpos.numpy()[0]
    mirror.time = time
    mujoco.mj_kinematics(model, mirror)
    mirror.xpos[:], mirror.xquat[:] = d.xpos.numpy()[0], d.xquat.numpy()[0]
    mirror.geom_xpos[:], mirror.geom_xmat[:] = d.geom_xpos.numpy()[0], d.geom_xmat.numpy()[0].reshape(-1, 9)
    if model.ntendon:
        mujoco.mj_tendon(model, mirror)  # the tendons' paths, for the recording
    observer(model, mirror, step, [x for w, x in found if w == 0], None, contacts)
