"""The `ellipsim` command line.

    ellipsim run SCENARIO [--steps N] [--mode builtin|filter|narrowphase] [--record FILE.rrd]
    ellipsim compare SCENARIO [--steps N] [--json FILE] [--plot FILE.png]
    ellipsim view FILE.rrd
    ellipsim bench [--quick] [--out DIR]
    ellipsim list
    ellipsim demo [--pairs N] [--seed S]

SCENARIO is a name from `ellipsim list` or a path to a .toml file.  A user mistake (unknown
scenario, malformed file, bad argument) ends with one line on stderr and exit status 2.
"""

import argparse
import json
import os
import sys
import time

import numpy as np

from ellipsim.core.tolerances import NEAR_TANGENT


class _Parser(argparse.ArgumentParser):
    """argparse with a one-line error and exit status 2 (no usage dump)."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


class UserError(Exception):
    """A mistake in what the user asked for: reported in one line, exit status 2."""


def _positive_int(text):
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}") from None
    if value <= 0:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {value}")
    return value


def _non_negative_int(text):
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a non-negative integer, got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected a non-negative integer, got {value}")
    return value


def _time(fn):
    t0 = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t0


class Progress:
    """A progress bar on stderr: redrawn in place on a terminal, a line every 10% otherwise."""

    def __init__(self, label, total, stream=None):
        self.label, self.total = label, total
        self.stream = stream or sys.stderr
        self.tty = self.stream.isatty()
        self.t0 = time.perf_counter()
        self.shown = -1.0

    def __call__(self, done, total=None):
        total = total or self.total
        now = time.perf_counter() - self.t0
        frac = done / total
        if done < total and (now - self.shown < 0.2 if self.tty else frac * 10 < int(self.shown * 10) + 1):
            return
        self.shown = now if self.tty else frac
        rate = done / max(now, 1e-9)
        eta = (total - done) / max(rate, 1e-9)
        bar = "#" * int(30 * frac)
        line = f"{self.label} [{bar:<30}] {100 * frac:5.1f}% {done}/{total} steps, {rate:,.0f}/s, {eta:.0f} s left"
        if self.tty:
            self.stream.write("\r" + line + ("\n" if done >= total else ""))
        else:
            self.stream.write(line + "\n")
        self.stream.flush()


# --- demo ------------------------------------------------------------------------------------------


def demo(args):
    """Classify a batch of generic pairs with every method; print relations, disagreements, timing."""
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
    print("  timings are single-threaded; bench/bench_classify.py measures them properly")
    return 0


# --- scenarios -------------------------------------------------------------------------------------


def _load(name):
    from ellipsim.app import scenario

    try:
        return scenario.load(name)
    except scenario.ScenarioError as exc:
        raise UserError(str(exc)) from None


def _simulated(fn, *args, **kwargs):
    """fn(*args, **kwargs), a scenario's run or validation: a scene the model builder refuses
    (ScenarioError, raised before any step) is a user mistake."""
    from ellipsim.app import scenario

    try:
        return fn(*args, **kwargs)
    except scenario.ScenarioError as exc:
        raise UserError(str(exc)) from None


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
    return UserError(f"{option}: cannot write {path!r}: {exc.strerror or exc}")


def list_scenarios(args):
    from ellipsim.app import scenario

    for name in scenario.available():
        s = scenario.load(name)
        kind = "kinematic" if s.kinematic else s.mode
        print(f"{name:<12} {s.duration:g} s, {kind:<11} {s.description}")
    return 0


def run(args):
    """Simulate a scenario, print a summary, optionally save a rerun recording."""
    from ellipsim.app import simulate

    s = _load(args.scenario)
    if args.record:
        _check_output(args.record, ".rrd", "--record")
    steps = args.steps or s.steps
    mode = args.mode or s.mode
    what = "kinematic replay" if s.kinematic else f"mode {mode}"
    print(f"{s.name}: {s.description}")
    print(f"  {steps} steps of {s.timestep:g} s ({steps * s.timestep:g} s simulated), {what}", flush=True)
    result = _simulated(simulate.run, s, steps=steps, mode=mode, progress=Progress(f"  {s.name}", steps))
    tr = result.frames
    rate = steps / max(result.seconds, 1e-9)
    print(f"  wall time {result.seconds:.2f} s: {rate:,.0f} steps/s ({rate * s.timestep:.2f}x real time)")
    print(
        f"  contacts per step (all geoms): mean {result.mujoco_contacts.mean():.1f}, max {result.mujoco_contacts.max()}"
    )
    print(
        f"  ellipsoid pairs over {len(tr.times)} recorded frames: MuJoCo contacts mean {tr.builtin_counts.mean():.1f} "
        f"(max {tr.builtin_counts.max()}), ellipsim overlaps mean {tr.ellipsim_counts.mean():.1f} "
        f"(max {tr.ellipsim_counts.max()})"
    )
    c = result.counters
    if "seen" in c:
        share = c["discarded"] / max(c["seen"], 1)
        print(f"  filter: {c['seen']} pairs tested, {c['discarded']} skipped ({share:.0%}), {c['passed']} passed to MuJoCo")
    elif "calls" in c:
        print(
            f"  narrow phase: {c['calls']} pairs, {c['separated']} certified apart, {c['contacts']} contacts, "
            f"{c['fallbacks']} fallbacks to MuJoCo"
        )
    if args.record:
        from ellipsim.app import record

        try:
            record.save(args.record, tr)
            size = os.path.getsize(args.record)
        except ValueError as exc:
            raise UserError(str(exc)) from None
        except OSError as exc:
            raise _write_error("--record", args.record, exc) from None
        except RuntimeError as exc:  # rerun reports a file it cannot create as a RuntimeError
            if "Failed to create file" not in str(exc):
                raise
            raise UserError(f"--record: cannot write {args.record!r}: {exc}") from None
        print(f"  recording: {args.record} ({len(tr.times)} frames, {size / 1e6:.1f} MB); view it with: ellipsim view {args.record}")
    return 0


def _compare_summary(validation):
    """Per-frame and total counts, and the disagreements split into missed / extra / near-tangent."""
    counts = validation.counts
    builtin = counts[:, 0] + counts[:, 2]
    ours = counts[:, 0] + counts[:, 3]
    missed, extra, near = [], [], []
    for d in validation.disagreements:
        if abs(d.geom_distance) < NEAR_TANGENT:
            near.append(d)
        elif d.mujoco_contact:
            missed.append(d)
        else:
            extra.append(d)
    return builtin, ours, missed, extra, near


def compare(args):
    """MuJoCo's built-in contacts against ellipsim's exact verdicts, per frame and in total."""
    from ellipsim.app import simulate

    s = _load(args.scenario)
    if args.json:
        _check_output(args.json, ".json", "--json")
    if args.plot:
        _check_output(args.plot, ".png", "--plot")
        _matplotlib()
    steps = args.steps or s.steps
    print(f"{s.name}: {s.description}")
    print(f"  comparing MuJoCo's built-in detection with ellipsim over {steps} steps", flush=True)
    v, model = _simulated(simulate.validation, s, steps, progress=Progress(f"  {s.name}", steps))
    builtin, ours, missed, extra, near = _compare_summary(v)
    agree = int(v.counts[:, 0].sum() + v.counts[:, 1].sum())
    pairs = int(v.counts.sum())
    print(f"  candidate ellipsoid pairs: {pairs} over {steps} steps; agreement {agree}/{pairs} ({agree / max(pairs, 1):.4%})")
    print(f"  in contact per frame: MuJoCo mean {builtin.mean():.2f} (max {builtin.max()}), ellipsim mean {ours.mean():.2f} (max {ours.max()})")
    print(f"  totals: MuJoCo {builtin.sum()}, ellipsim {ours.sum()}")
    print(
        f"  disagreements: {len(missed)} missed (MuJoCo contact, ellipsim separated), {len(extra)} extra "
        f"(ellipsim overlapping, no MuJoCo contact), {len(near)} within {NEAR_TANGENT:g} m of touching"
    )
    for d in (missed + extra + near)[: args.show]:
        print(
            f"    step {d.step}: {d.names[0]} / {d.names[1]}: MuJoCo {'contact' if d.mujoco_contact else 'none'}, "
            f"ellipsim {d.relation}, contact_scale {d.contact_scale:.9f}, mj_geomDistance {d.geom_distance:.3g}; "
            f"right: {d.right} ({d.reason})"
        )
    if args.json:
        report = {
            "scenario": s.name, "steps": steps,
            "builtin_contacts": int(builtin.sum()), "ellipsim_overlaps": int(ours.sum()),
            "missed": len(missed), "extra": len(extra), "near_tangent": len(near), "agreement": agree, "pairs": pairs,
            "per_frame": {"builtin_contacts": builtin.tolist(), "ellipsim_overlaps": ours.tolist(),
                          "both": v.counts[:, 0].tolist(), "neither": v.counts[:, 1].tolist(),
                          "mujoco_only": v.counts[:, 2].tolist(), "ellipsim_only": v.counts[:, 3].tolist()},
            "disagreements": [
                {"step": d.step, "geoms": list(d.names), "kind": kind, "mujoco_contact": d.mujoco_contact,
                 "mujoco_dist": None if d.mujoco_dist != d.mujoco_dist else d.mujoco_dist, "relation": d.relation,
                 "contact_scale": d.contact_scale, "geom_distance": d.geom_distance, "right": d.right, "reason": d.reason}
                for kind, ds in (("missed", missed), ("extra", extra), ("near_tangent", near)) for d in ds
            ],
        }  # fmt: skip
        try:
            with open(args.json, "w") as f:
                json.dump(report, f, indent=1)
        except OSError as exc:
            raise _write_error("--json", args.json, exc) from None
        print(f"  report: {args.json}")
    if args.plot:
        _plot_compare(args.plot, s, builtin, ours, missed + extra, near)
        print(f"  plot: {args.plot}")
    return 0


def _matplotlib():
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise UserError("plots need matplotlib: pip install 'ellipsim[plot]'") from None
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
        raise UserError("ellipsim bench needs matplotlib and mpmath: pip install '.[bench]'") from None
    from ellipsim.app import bench as suite

    print(f"ellipsim bench{' --quick' if args.quick else ''}: writing {args.out}/report.md and plots", flush=True)
    path, seconds = suite.run(args.out, quick=args.quick, only=args.only)
    print(f"  done in {seconds:.0f} s: {path}")
    return 0


def view(args):
    from ellipsim.app import record

    try:
        return record.view(args.file)
    except ValueError as exc:
        raise UserError(str(exc)) from None


# --- entry point -----------------------------------------------------------------------------------


def main(argv=None):
    parser = _Parser(
        prog="ellipsim",
        description="Exact, fast ellipsoid collision detection for MuJoCo figures with oval limbs.",
        epilog="examples: ellipsim run handshake --record handshake.rrd ; ellipsim compare pile --json pile.json",
    )
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    p = sub.add_parser("run", help="simulate a scenario; print steps/s, contacts, pairs tested/skipped")
    p.add_argument("scenario", help="a name from `ellipsim list`, or a path to a .toml file")
    p.add_argument("--steps", type=_positive_int, help="steps to run (default: the scenario's duration)")
    p.add_argument("--mode", choices=("builtin", "filter", "narrowphase"), help="collision detection (default: the scenario's)")
    p.add_argument("--record", metavar="FILE.rrd", help="save a rerun recording")
    p.set_defaults(run=run)

    p = sub.add_parser("compare", help="MuJoCo's built-in contacts vs ellipsim's exact verdicts, per frame and in total")
    p.add_argument("scenario", help="a name from `ellipsim list`, or a path to a .toml file")
    p.add_argument("--steps", type=_positive_int, help="steps to compare (default: the scenario's duration)")
    p.add_argument("--json", metavar="FILE.json", help="write the counts and every disagreement as JSON")
    p.add_argument("--plot", metavar="FILE.png", help="plot the per-frame counts (needs the 'plot' extra)")
    p.add_argument("--show", type=_non_negative_int, default=10, help="disagreements to print (default 10)")
    p.set_defaults(run=compare)

    p = sub.add_parser("view", help="open a recording in the rerun viewer (or say how)")
    p.add_argument("file", metavar="FILE.rrd")
    p.set_defaults(run=view)

    p = sub.add_parser("bench", help="time against error, numerical stress, scaling, thesis Table 1: report + plots")
    p.add_argument("--quick", action="store_true", help="smaller sets: under 5 minutes on 2 cores")
    p.add_argument("--out", default="bench-report", metavar="DIR", help="output directory (default bench-report)")
    p.add_argument("--only", nargs="+", choices=("accuracy", "stress", "scaling", "table1", "mujoco"), metavar="SECTION",
                   help="run only these sections: accuracy, stress, scaling, table1, mujoco")
    p.set_defaults(run=bench)

    p = sub.add_parser("list", help="list the scenarios shipped with ellipsim")
    p.set_defaults(run=list_scenarios)

    p = sub.add_parser("demo", help="classify a random batch of pairs, print a summary table and timing")
    p.add_argument("--pairs", type=_positive_int, default=100_000, help="number of pairs (default 100000)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.set_defaults(run=demo)

    args = parser.parse_args(argv)
    try:
        return args.run(args)
    except UserError as exc:
        print(f"ellipsim: error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # `ellipsim ... | head`: the reader left, nothing to report
        sys.stderr.close()
        return 0


if __name__ == "__main__":
    sys.exit(main())
