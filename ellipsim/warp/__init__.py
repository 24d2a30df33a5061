"""ellipsim on MuJoCo Warp: the exact ellipsoid narrow phase in Warp kernels, for all worlds at once.

    import mujoco_warp as mjw, ellipsim.warp
    m = mjw.put_model(mjm)
    with ellipsim.warp.attach(m) as att:
        mjw.step(m, d)            # ellipsim's contacts for the ellipsoid pairs of every world
        print(att.counters)

Needs the warp extra (pip install 'ellipsim[warp]': warp-lang, mujoco-warp 4.0); `import ellipsim`
loads neither.  attachment.py says what is taken from Warp and how, kernels.py what is computed.
"""

try:
    import mujoco_warp as _mjw  # noqa: F401
    import warp as _wp  # noqa: F401
except ImportError as exc:  # one line, naming the extra
    raise ImportError(
        f"ellipsim.warp needs the warp extra: pip install 'ellipsim[warp]' (warp-lang, mujoco-warp 4.0); {exc}"
    ) from None

from .attachment import COUNTER_NAMES, PAIR_TYPES, Attachment, attach, candidate_pairs

__all__ = ["attach", "Attachment", "candidate_pairs", "COUNTER_NAMES", "PAIR_TYPES"]
