"""The README as a new user reads it: exactly two fenced command blocks (the main job, the tests), at
most 400 lines, and the library example runs as pasted."""

import contextlib
import io
import pathlib
import re

import numpy as np

README = pathlib.Path(__file__).parents[1] / "README.md"


def test_two_fenced_blocks_and_at_most_400_lines():
    text = README.read_text()
    blocks = re.findall(r"^```bash\n(.*?)^```", text, flags=re.S | re.M)
    assert text.count("```") == 4 and len(blocks) == 2
    assert "pip install .\n" in blocks[0] and "ellipsim run handshake" in blocks[0]
    assert "pip install '.[test]'" in blocks[1] and "python -m pytest" in blocks[1]
    assert len(text.splitlines()) <= 400
    assert text.index("## Scenarios and commands") < text.index("## Use as a library") < text.index("## Layout")


def library_block():
    """The indented code under "## Use as a library", dedented."""
    text = README.read_text().split("## Use as a library", 1)[1]
    lines = []
    for line in text.splitlines()[1:]:
        if line.startswith("    ") or (not line.strip() and lines):
            lines.append(line[4:])
        elif lines:
            break
    return "\n".join(lines)


def test_the_library_example_runs_as_pasted():
    code = library_block()
    assert "ellipsim.mujoco.distance_jacobian" in code and "import ellipsim as es" in code
    out = io.StringIO()
    namespace = {}
    with contextlib.redirect_stdout(out):
        exec(compile(code, "README.md", "exec"), namespace)  # noqa: S102 - the README's own example
    printed = out.getvalue().splitlines()
    assert printed[0] == "[1]"  # touching, as the comment says
    assert abs(namespace["toi"][0] - 0.25) < 1e-8 and namespace["impact"][0] == namespace["es"].Impact.CONTACT
    assert namespace["att"].counters["calls"] > 0
    assert np.isfinite(namespace["dist"]).all()
