"""`ellipsim demo`: a random batch of generic pairs (thesis 5.1.1) classified by every method, the
exact test as the truth; the result renders its own table."""

import dataclasses
import time

import numpy as np

#: The methods compared: the exact test, then the thesis's uncertified tests on both set-ups.
METHODS = (("exact", {}),) + tuple(
    (f"{m} {s}", dict(method=m, setup=s)) for m in ("descartes", "sturm") for s in ("rearranged", "cofactor")
)


def _timed(fn):
    t0 = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t0


@dataclasses.dataclass(frozen=True)
class DemoResult:
    pairs: int
    seed: int
    compile_seconds: float  # loading (or compiling) the kernels on 4 warm-up pairs
    generate_seconds: float
    #: (method, separated, touching, overlapping, wrong against exact, ns per pair)
    rows: tuple
    escalated: int  # pairs the certified filter left to rational arithmetic
    scale_min: float
    scale_median: float
    scale_max: float

    def summary_lines(self):
        """The table and notes `ellipsim demo` prints after its progress lines."""
        header = ("method", "separated", "touching", "overlapping", "wrong", "ns/pair")
        width = max(len(r[0]) for r in self.rows)
        lines = ["", f"  {header[0]:<{width}}  " + "  ".join(f"{h:>11}" for h in header[1:])]
        for name, sep, touch, over, wrong, ns in self.rows:
            lines.append(f"  {name:<{width}}  {sep:>11}  {touch:>11}  {over:>11}  {wrong:>11}  {ns:>11.1f}")
        lines += [
            "",
            f"  exact: {self.escalated} pairs needed rational arithmetic; 'wrong' counts disagreements with exact",
            f"  contact_scale: min {self.scale_min:.3f}, median {self.scale_median:.3f}, max {self.scale_max:.3f}",
            "  timings are single-threaded; `ellipsim bench` measures them properly",
        ]
        return lines


def run_demo(pairs, seed, *, say=print):
    """Classify `pairs` generic pairs (seed `seed`) with every method of METHODS; `say` gets the
    progress lines (the kernels' loading is announced before it starts)."""
    import ellipsim as es
    from ellipsim.core.exact.certified_filter import certify
    from ellipsim.core.relation import UNDECIDED
    from ellipsim.core.samples import generic_pairs

    say(f"ellipsim demo: {pairs} random ellipsoid pairs (half colliding, thesis 5.1.1), seed {seed}")
    say("  loading kernels ...")
    warm = generic_pairs(4, seed=1)
    _, t_compile = _timed(lambda: [es.classify(*warm, parallel=p, **kw) for _, kw in METHODS for p in (False, True)])
    (a, b), t_gen = _timed(lambda: generic_pairs(pairs, seed=seed))
    say(f"  kernels ready in {t_compile:.1f} s; pairs generated in {t_gen:.1f} s")
    truth, rows = None, []
    for name, kw in METHODS:
        rel, seconds = _timed(lambda: es.classify(a, b, parallel=False, **kw))
        truth = rel if truth is None else truth
        counts = np.bincount(rel, minlength=3)
        rows.append((name, *(int(c) for c in counts), int(np.count_nonzero(rel != truth)), seconds / len(rel) * 1e9))
    escalated = int(np.count_nonzero(certify(a, b, len(a), False) == UNDECIDED))
    scale = es.contact_scale(a, b)
    return DemoResult(
        pairs, seed, t_compile, t_gen, tuple(rows), escalated,
        float(scale.min()), float(np.median(scale)), float(scale.max()),
    )  # fmt: skip
