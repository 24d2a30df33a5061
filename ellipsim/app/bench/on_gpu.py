"""The GPU check of ellipsim on MuJoCo Warp (bench/gpu.sh runs it): accuracy, then scenes at 1 to 4096 worlds.

1. Accuracy of attached and plain Warp against ellipsim's CPU answer on the same float32 poses (the warp
   section's pair set, on_warp.accuracy: five pair types, deep to beyond the margin, at the origin and 100 m
   away): contacts missed and extra, the largest distance error over the pair's smallest semi-axis and normal
   error, unproven maxima.
2. The 16-figure heap and the 100-ellipsoid pile, settled by MuJoCo C, at each world count, plain Warp and
   ellipsim attached: mjw.step and mjw.collision each captured in a CUDA graph (on CUDA; called directly on the
   CPU device, which does not capture) and timed over `--launches` launches between events, after one warm-up
   launch: world-steps per second, and the collision stage's milliseconds per step.  Warp's buffers as `ellipsim
   run --engine warp` sizes them (warp_run.default_nconmax, default_njmax: no contact or row dropped).  Goals (issue 47): the
   collision stage >= 2x faster than plain Warp's at 4096 worlds, mjw.step >= 1.2x on the pile.

Everything it runs is installed already (the project's wheel, warp-lang, mujoco, mujoco-warp); Warp compiles its
kernels on first use, as everywhere.  Progress on stderr, results on stdout (markdown) and in --out.
"""

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from .. import scenes
from .common import say, settled

SCENES = {
    "16 figures in a heap": lambda: scenes.scene_xml(16, layout="pile", seed=1),
    "pile of 100 ellipsoids": lambda: scenes.pile_xml(100, seed=1),
}
GOALS = {"collision": 2.0, "step on the pile": 1.2}


def _timer(wp, device):
    """fn -> seconds for one call of fn: CUDA events on a GPU (the work queued by fn, nothing of the host's),
    the wall clock around fn and a synchronize on the CPU device."""
    if wp.get_device(device).is_cuda:

        def timed(fn):
            start, end = wp.Event(enable_timing=True), wp.Event(enable_timing=True)
            wp.record_event(start)
            fn()
            wp.record_event(end)
            return wp.get_event_elapsed_time(start, end) / 1000.0

        return timed

    def timed(fn):
        t0 = time.perf_counter()
        fn()
        wp.synchronize_device(device)
        return time.perf_counter() - t0

    return timed


def _graph(wp, device, fn):
    """fn as one launch: its CUDA graph, captured after a warm-up call (which compiles its kernels); fn itself
    on the CPU device."""
    fn()
    if not wp.get_device(device).is_cuda:
        return fn
    with wp.ScopedCapture(device=device) as capture:
        fn()
    return lambda: wp.capture_launch(capture.graph)


def scene_rows(worlds, launches, device):
    import mujoco_warp as mjw
    import warp as wp

    import ellipsim.warp as ew

    from ..warp_run import default_nconmax, default_njmax

    timed = _timer(wp, device)
    rows = []
    for name, make in SCENES.items():
        model, data, _ = settled(make(), 1000)
        nconmax = default_nconmax(model)  # Warp's buffers as `ellipsim run --engine warp` sizes them
        njmax = max(default_njmax(model, nconmax), data.nefc)
        for nworld in worlds:
            say(f"gpu check: {name}, {nworld} worlds ...")
            t0 = time.perf_counter()
            out = dict(scene=name, nworld=nworld)
            for mode in ("plain", "attached"):
                with wp.ScopedDevice(device):
                    m = mjw.put_model(model)
                    d = mjw.put_data(model, data, nworld=nworld, naconmax=nworld * nconmax, njmax=njmax)
                    att = ew.attach(m) if mode == "attached" else None
                    step = _graph(wp, device, lambda m=m, d=d: mjw.step(m, d))
                    collide = _graph(wp, device, lambda m=m, d=d: mjw.collision(m, d))
                    t_step = np.median([timed(step) for _ in range(launches)])
                    t_coll = np.median([timed(collide) for _ in range(launches)])
                    out[mode] = dict(
                        step_s=float(t_step),
                        collision_s=float(t_coll),
                        world_steps_per_s=float(nworld / t_step),
                        contacts=int(d.nacon.numpy()[0]),
                        overflow=int(d.nacon.numpy()[0]) > d.naconmax,
                        counters=att.counters if att else None,
                    )
                    if att:
                        att.detach()
            out["collision_speedup"] = out["plain"]["collision_s"] / out["attached"]["collision_s"]
            out["step_speedup"] = out["plain"]["step_s"] / out["attached"]["step_s"]
            out["seconds"] = time.perf_counter() - t0
            rows.append(out)
    return rows


def accuracy_rows(pairs, device):
    from . import on_warp

    return on_warp.accuracy({"warp_pairs": pairs}, device)


def report(acc, rows, device, worlds):
    L = [f"# ellipsim on MuJoCo Warp: the GPU check ({device})", ""]
    if acc:
        L += [
            "## Accuracy against ellipsim's CPU answer on the same float32 poses",
            "",
            "| pair | method | exact contacts | missed | extra | max distance error / r_min | max normal error (deg) "
            "| unproven |",
            "|---|---|---:|---:|---:|---:|---:|---:|",
        ]
        from .on_warp import PAIR_NAMES

        for kind in dict.fromkeys(a["kind"] for a in acc):
            for method in dict.fromkeys(a["method"] for a in acc):
                sel = [a for a in acc if a["kind"] == kind and a["method"] == method]
                un = [a["unproven"] for a in sel if a["unproven"] is not None]
                L.append(
                    f"| {PAIR_NAMES[kind]} | {method} | {sum(a['exact'] for a in sel)} | "
                    f"{sum(a['mujoco_missed'] for a in sel)} | {sum(a['mujoco_extra'] for a in sel)} | "
                    f"{max(a['err'] for a in sel):.1e} | {max(a['angle'] for a in sel):.1e} | "
                    f"{sum(un) if un else '-'} |"
                )
        L.append("")
    L += [
        "## Scenes: world-steps per second and the collision stage",
        "",
        "| scene | worlds | mjw.step plain / attached (world-steps/s) | step speed-up | collision per step plain / "
        "attached (ms) | collision speed-up | contacts plain / attached | unproven / evaluated pairs |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        p, a = r["plain"], r["attached"]
        c = a["counters"]
        L.append(
            f"| {r['scene']} | {r['nworld']} | {p['world_steps_per_s']:.3g} / {a['world_steps_per_s']:.3g} | "
            f"{r['step_speedup']:.2f}x | {p['collision_s'] * 1e3:.3f} / {a['collision_s'] * 1e3:.3f} | "
            f"{r['collision_speedup']:.2f}x | {p['contacts']} / {a['contacts']} | {c['unproven']} / {c['pairs']} |"
        )
    top = max(worlds)
    L += ["", f"Goals at {top} worlds (issue 47):"]
    for r in rows:
        if r["nworld"] == top:
            L.append(
                f"- {r['scene']}: collision {r['collision_speedup']:.2f}x (goal >= {GOALS['collision']}x: "
                f"{'met' if r['collision_speedup'] >= GOALS['collision'] else 'not met'})"
            )
            if "pile" in r["scene"]:
                ok = r["step_speedup"] >= GOALS["step on the pile"]
                L.append(
                    f"- {r['scene']}: mjw.step {r['step_speedup']:.2f}x (goal >= {GOALS['step on the pile']}x: "
                    f"{'met' if ok else 'not met'})"
                )
    L.append("")
    return L


def _worlds(text):
    try:
        worlds = [int(w) for w in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"--worlds must be comma-separated counts, got {text!r}") from None
    if not worlds or min(worlds) < 1:
        raise argparse.ArgumentTypeError(f"--worlds must be counts >= 1, got {text!r}")
    return worlds


def _positive(text):
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a whole number >= 1, got {text!r}")
    return value


def main(argv=None):
    parser = argparse.ArgumentParser(prog="bench/gpu.sh", description=__doc__.split("\n\n")[0])
    parser.add_argument("--device", default="cuda", help="Warp device (default cuda; cpu for a small check here)")
    parser.add_argument("--worlds", type=_worlds, default=[1, 64, 1024, 4096], help="world counts, e.g. 1,64,1024,4096")
    parser.add_argument("--pairs", type=_positive, default=200, help="pairs per accuracy row (default 200)")
    parser.add_argument("--launches", type=_positive, default=20, help="timed launches per measure (default 20)")
    parser.add_argument("--skip-accuracy", action="store_true", help="only the scenes")
    parser.add_argument("--out", type=Path, default=None, help="also write report.md and results.json here")
    args = parser.parse_args(argv)
    import warp as wp

    wp.config.quiet = True
    wp.init()
    try:
        device = wp.get_device(args.device)
    except (RuntimeError, ValueError):
        parser.exit(2, f"bench/gpu.sh: error: --device {args.device!r}: Warp finds no such device here\n")
    from .. import warp_run

    warp_run.quiet()
    t0 = time.perf_counter()
    say(f"gpu check on {device.alias} ({getattr(device, 'name', '')}) ...")
    acc = [] if args.skip_accuracy else accuracy_rows(args.pairs, device.alias)
    say(f"gpu check: accuracy done in {time.perf_counter() - t0:.0f} s")
    rows = scene_rows(args.worlds, args.launches, device.alias)
    lines = report(acc, rows, f"{device.alias}: {getattr(device, 'name', '')}", args.worlds)
    lines.append(f"{time.perf_counter() - t0:.0f} s in all.")
    print("\n".join(lines))
    if args.out:
        args.out.mkdir(parents=True, exist_ok=True)
        (args.out / "report.md").write_text("\n".join(lines) + "\n")
        (args.out / "results.json").write_text(json.dumps(dict(accuracy=acc, scenes=rows), indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
