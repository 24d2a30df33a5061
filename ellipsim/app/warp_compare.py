"""`ellipsim compare ... --engine warp`: plain MuJoCo Warp's own contacts, every world, against the exact test.

The scenario runs in N worlds on plain Warp (nothing attached), from per-world layouts as `run --engine
warp` starts them (warp_run.world_states).  At each compared step, every candidate
sphere x ellipsoid and ellipsoid x ellipsoid pair of every world (the model's collision rules, as
ellipsim.warp takes them; capsule pairs are not checked here, as `compare` on MuJoCo C checks none) whose bounding spheres come within margin + gap gets ellipsim's CPU narrow
phase on Warp's float32 poses widened to float64 (proven global maxima, or counted unproven); a pair the
exact test puts within margin + gap that Warp left without a contact is missed, a Warp contact the exact
test does not make is extra; on pairs both have, the distance error (over the pair's smallest
semi-axis) and the normal's angle.  A pair is matched to Warp's contact whichever way round Warp names
its geoms (SAP orders equal types by its sort); pairs Warp skips for sleeping bodies are not asked for;
a step where Warp's candidate or contact buffer overflowed is counted (its misses are the buffer's).
"""

import dataclasses

import mujoco
import numpy as np

from ..core.distance.ellipsoid_pair import signed_distance
from ..core.ellipsoids import Ellipsoids
from . import simulate, warp_run
from .scenario import ScenarioError


@dataclasses.dataclass
class WarpComparison:
    name: str
    nworld: int
    steps: int
    pairs: int  # candidate pairs per world
    checked: int  # (world, step, pair) triples measured exactly
    exact: int  # of which within margin + gap
    missed: list  # (step, world, g1, g2, exact dist) of each miss
    extra: list  # (step, world, g1, g2, Warp's dist, exact dist)
    dist_err: np.ndarray  # per common contact, over r_min
    angle: np.ndarray  # per common contact, degrees
    unproven: int
    overflow_steps: int = 0

    def summary(self, show):
        e = self.dist_err
        lines = [
            f"  Warp's contacts on {self.pairs} ellipsoid pairs per world x {self.nworld} worlds x {self.steps} steps: "
            f"{self.checked} pairs within reach measured exactly, {self.exact} exact contacts",
            f"  missed {len(self.missed)}, extra {len(self.extra)}"
            + (
                f"; on {e.size} common contacts distance error / r_min max {e.max():.1e} (median {np.median(e):.1e}), "
                f"normal max {self.angle.max():.2g} deg"
                if e.size
                else ""
            )
            + (f"; {self.unproven} exact maxima unproven" if self.unproven else ""),
        ]
        if self.overflow_steps:
            lines.append(f"  warning: Warp's candidate or contact buffer overflowed at {self.overflow_steps} steps")
        for kind, rows in (("missed", self.missed), ("extra", self.extra)):
            for row in rows[:show]:
                lines.append(
                    f"    {kind}: step {row[0]}, world {row[1]}, geoms {row[2]} x {row[3]}, " + _dists(kind, row)
                )
            if len(rows) > show:
                lines.append(f"    ... and {len(rows) - show} more {kind}")
        return lines

    def report(self):
        e = self.dist_err
        return dict(
            scenario=self.name,
            engine="warp",
            worlds=self.nworld,
            steps=self.steps,
            pairs_per_world=self.pairs,
            checked=self.checked,
            exact_contacts=self.exact,
            missed=[dict(step=r[0], world=r[1], geoms=[r[2], r[3]], exact_dist=r[4]) for r in self.missed],
            extra=[
                dict(step=r[0], world=r[1], geoms=[r[2], r[3]], warp_dist=r[4], exact_dist=r[5]) for r in self.extra
            ],
            dist_err_max=float(e.max()) if e.size else None,
            normal_err_max_deg=float(self.angle.max()) if e.size else None,
            unproven=self.unproven,
            overflow_steps=self.overflow_steps,
        )


def _dists(kind, row):
    if kind == "missed":
        return f"exact distance {row[4]:.3g} m, no Warp contact"
    return f"Warp distance {row[4]:.3g} m, exact {row[5]:.3g} m"


def compare(s, *, steps, nworld, device="cpu", progress=None, recorder=None):
    """Step scenario s in nworld worlds on plain MuJoCo Warp and check its contacts (module docstring).
    recorder : an optional record.Recorder for world 0 (compare_record.CompareRecording with Warp's
    contacts and poses; its closing is the caller's; on Ctrl-C or SIGTERM the steps so far are sent)."""
    wp, mjw, ew = warp_run._warp()
    if s.kinematic:
        raise ScenarioError(f"{s.path}: a kinematic scenario (keyframed poses) has nothing to step on Warp")
    simulate.check_steps(s, steps)
    model, _, control, m, d, naconmax, _ = warp_run.setup(s, nworld, device)
    with wp.ScopedDevice(device):
        pairs, pairid = ew.candidate_pairs(m, pair_ids=True)
    ellipsoids = np.all(np.isin(model.geom_type[pairs], (2, 4)), axis=1)  # as `compare` on MuJoCo C
    pairs, pairid = pairs[ellipsoids], pairid[ellipsoids]
    if recorder is None:
        return _run(s, model, control, m, d, pairs, pairid, steps, nworld, naconmax, device, progress)
    from .compare_record import CompareRecording

    observer = CompareRecording(recorder, model, s.name, engine="Warp")
    return observer.run(
        lambda: _run(s, model, control, m, d, pairs, pairid, steps, nworld, naconmax, device, progress, observer)
    )


def _run(s, model, control, m, d, pairs, pairid, steps, nworld, naconmax, device, progress, observer=None):
    wp, mjw, _ = warp_run._warp()
    g1, g2 = pairs[:, 0], pairs[:, 1]
    sphere = model.geom_type == 2
    radii = np.where(sphere[:, None], model.geom_size[:, :1], model.geom_size).astype(np.float32)
    rbound = radii.max(1)
    # margin + gap as Warp takes them (collision_core.contact_margin_gap): an explicit pair's own, else the sums
    explicit = pairid[:, 0]
    own = np.maximum(explicit, 0)
    sums = model.geom_margin[g1] + model.geom_margin[g2] + model.geom_gap[g1] + model.geom_gap[g2]
    pair_sums = model.pair_margin[own] + model.pair_gap[own] if model.npair else np.zeros(len(pairs))
    limit = np.where(explicit >= 0, pair_sums, sums).astype(np.float32)
    reach = rbound[g1] + rbound[g2] + limit
    sleep = bool(model.opt.enableflags & mujoco.mjtEnableBit.mjENBL_SLEEP)
    asleep, static = int(mujoco.mjtSleepState.mjS_ASLEEP), int(mujoco.mjtSleepState.mjS_STATIC)
    b1, b2 = model.geom_bodyid[g1], model.geom_bodyid[g2]
    overflow = 0
    missed, extra, errs, angles = [], [], [], []
    checked = exact_n = unproven = 0
    ngeom = model.ngeom
    keys = np.minimum(g1, g2).astype(np.int64) * ngeom + np.maximum(g1, g2)  # a pair whichever way round
    order = np.argsort(keys)
    rmin = np.minimum(radii[g1].min(1), radii[g2].min(1))
    wide = lambda x: x.astype(np.float64)  # noqa: E731
    mirror = mujoco.MjData(model) if observer is not None else None
    with wp.ScopedDevice(device):
        for k in range(steps):
            warp_run.send_controls(d, model, control, k * s.timestep)
            mjw.step(m, d)
            xpos, xmat = d.geom_xpos.numpy(), d.geom_xmat.numpy()
            n = min(int(d.nacon.numpy()[0]), naconmax)
            cw, cg, cd, cf = (
                a.numpy()[:n] for a in (d.contact.worldid, d.contact.geom, d.contact.dist, d.contact.frame)
            )
            first = (len(missed), len(extra))  # this step's, for the recording of world 0
            if observer is not None:
                zero = cw == 0
                world0 = (cg[zero], cd[zero], d.contact.pos.numpy()[:n][zero], cf[zero, 0])
            # Warp's contacts on the candidate pairs, per (world, pair): distance and normal (from pairs[:, 0])
            ckey = np.minimum(cg[:, 0], cg[:, 1]).astype(np.int64) * ngeom + np.maximum(cg[:, 0], cg[:, 1])
            at = np.minimum(np.searchsorted(keys, ckey, sorter=order), len(keys) - 1) if len(keys) else ckey * 0
            hit = (keys[order[at]] == ckey) if len(keys) else np.zeros(n, bool)
            pk, cw = order[at[hit]], cw[hit]
            flip = cg[hit, 0] != g1[pk]  # named the other way round: normal reversed
            wdist = np.full((nworld, len(pairs)), np.nan)
            wnormal = np.zeros((nworld, len(pairs), 3))
            wdist[cw, pk] = cd[hit]
            wnormal[cw, pk] = np.where(flip[:, None], -cf[hit, 0], cf[hit, 0])
            overflow += int(d.nacon.numpy()[0]) > naconmax or int(d.ncollision.numpy()[0]) > naconmax
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
                dist, normal, pos, status = signed_distance(
                    Ellipsoids(wide(xpos[w, g1[sel]]), wide(xmat[w, g1[sel]]), wide(radii[g1[sel]])),
                    Ellipsoids(wide(xpos[w, g2[sel]]), wide(xmat[w, g2[sel]]), wide(radii[g2[sel]])),
                )
                checked += sel.size
                unproven += int(np.count_nonzero(status))
                want = dist < limit[sel]
                got = ~np.isnan(wdist[w, sel])
                exact_n += int(want.sum())
                for j in np.flatnonzero(want & ~got):
                    p = sel[j]
                    missed.append((k, w, int(g1[p]), int(g2[p]), float(dist[j]), normal[j], pos[j], None))
                for j in np.flatnonzero(got & ~want):
                    p = sel[j]
                    extra.append(
                        (
                            k,
                            w,
                            int(g1[p]),
                            int(g2[p]),
                            float(wdist[w, p]),
                            float(dist[j]),
                            normal[j],
                            pos[j],
                            wnormal[w, p],
                        )
                    )
                both = np.flatnonzero(got & want)
                p = sel[both]
                errs.append(np.abs(wdist[w, p] - dist[both]) / rmin[p])
                na, nb = wnormal[w, p], normal[both]
                angles.append(np.degrees(np.arctan2(np.linalg.norm(np.cross(na, nb), axis=1), (na * nb).sum(1))))
            if observer is not None:
                _observe(observer, model, mirror, d, k, (k + 1) * s.timestep, world0, missed, extra, first)
            if progress:
                progress(k + 1, steps)
    return WarpComparison(
        s.name,
        nworld,
        steps,
        len(pairs),
        checked,
        exact_n,
        missed,
        extra,
        np.concatenate(errs) if errs else np.zeros(0),
        np.concatenate(angles) if angles else np.zeros(0),
        unproven,
        overflow,
    )


def _observe(observer, model, mirror, d, step, time, contacts, missed, extra, first):
    """Hand world 0's step to a compare_record.CompareRecording: its poses as Warp holds them (float32,
    widened) in a MuJoCo C MjData, Warp's contacts, and its missed and extra pairs of the step (from
    index `first` of each list) as mujoco.validate.Disagreement."""
    from ..mujoco.validate import Disagreement

    mirror.qpos[:] = d.qpos.numpy()[0]
    mirror.time = time
    mujoco.mj_kinematics(model, mirror)
    mirror.xpos[:], mirror.xquat[:] = d.xpos.numpy()[0], d.xquat.numpy()[0]
    mirror.geom_xpos[:], mirror.geom_xmat[:] = d.geom_xpos.numpy()[0], d.geom_xmat.numpy()[0].reshape(-1, 9)
    names = observer.names.geoms
    found, kinds = [], []
    for kind, rows in (("missed", missed[first[0] :]), ("extra", extra[first[1] :])):
        for row in rows:
            if row[1] != 0:
                continue
            g1, g2 = row[2], row[3]
            exact, normal, pos = (row[4], row[5], row[6]) if kind == "missed" else (row[5], row[6], row[7])
            warp_normal = None if kind == "missed" else tuple(float(x) for x in row[8])
            warp_pos = None
            if kind == "extra":
                geom, _, at, _ = contacts
                on = np.flatnonzero(
                    ((geom[:, 0] == g1) & (geom[:, 1] == g2)) | ((geom[:, 0] == g2) & (geom[:, 1] == g1))
                )
                warp_pos = tuple(float(x) for x in at[on[0]]) if len(on) else None
            reason = (
                f"exact distance {exact:.6g} m within margin + gap; Warp made no contact"
                if kind == "missed"
                else f"Warp's contact at dist {row[4]:.6g} m; the exact distance {exact:.6g} m is beyond margin + gap"
            )
            found.append(
                Disagreement(
                    step=step,
                    geom1=g1,
                    geom2=g2,
                    names=(names[g1], names[g2]),
                    mujoco_contact=kind == "extra",
                    mujoco_dist=row[4] if kind == "extra" else float("nan"),
                    relation="overlapping" if exact < 0 else "separated",
                    contact_scale=float("nan"),
                    geom_distance=float("nan"),
                    right="ellipsim",
                    reason=reason,
                    signed_distance=exact,
                    mujoco_pos=warp_pos,
                    mujoco_normal=warp_normal,
                    ellipsim_pos=tuple(float(x) for x in pos),
                    ellipsim_normal=tuple(float(x) for x in normal),
                )
            )
            kinds.append(kind)
    observer(model, mirror, step, found, kinds, contacts)
