"""The compiled core: the _ellipsim extension module, built by `pip install .` from the C++ in this folder
(include/ellipsim/: the header-only core; python/module.cpp: its binding; CMakeLists.txt: the build and its
floating-point flags).

_ellipsim is installed as a top-level module beside the package, so that a source checkout (``python -m
pytest`` puts the checkout's ``ellipsim/`` first on sys.path) uses the module its own sources built.  It
carries the digest of those sources; a module built from other sources (a checkout edited since its last
install) is refused with the command that rebuilds it, never run silently.
"""

import hashlib
import pathlib

FOLDER = pathlib.Path(__file__).resolve().parent
#: what `pip install` compiles the module from (CMakeLists.txt hashes the same files)
PATTERNS = ("include/**/*.hpp", "mujoco/**/*.hpp", "python/**/*.cpp", "python/**/*.hpp", "**/CMakeLists.txt")
REBUILD = "pip install . (or, in a checkout installed for development, pip install -e .)"


def source_digest(folder=FOLDER):
    """sha256 over "<relative path> <sha256 of the file>\\n" for each source, sorted by path: CMake's
    ELLIPSIM_SOURCE_DIGEST."""
    folder = pathlib.Path(folder)
    paths = sorted({p.relative_to(folder).as_posix() for pattern in PATTERNS for p in folder.glob(pattern)})
    manifest = "".join(f"{path} {hashlib.sha256((folder / path).read_bytes()).hexdigest()}\n" for path in paths)
    return hashlib.sha256(manifest.encode()).hexdigest()


def _load():
    try:
        import _ellipsim
    except ImportError as exc:
        raise ImportError(
            f"ellipsim's compiled core (the _ellipsim module) is not installed ({exc}): {REBUILD}"
        ) from None
    if _ellipsim.SOURCE_DIGEST != source_digest():
        raise ImportError(
            f"ellipsim's compiled core at {_ellipsim.__file__} was built from other sources than {FOLDER}: {REBUILD}"
        )
    return _ellipsim


ext = _load()
