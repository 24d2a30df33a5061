"""The compiled core: the _ellipsim extension module, built by `pip install .` from the C++ in this folder
(include/ellipsim/: the header-only core; python/module.cpp: its binding; CMakeLists.txt: the build and its
floating-point flags).

_ellipsim is installed as a top-level module beside the package, so that a source checkout (``python -m
pytest`` puts the checkout's ``ellipsim/`` first on sys.path) uses the module its own sources built.  It
carries the digest of those sources; a module built from other sources (a checkout edited since its last
install) is refused with the command that rebuilds it, never run silently.  Its MuJoCo glue reads mjModel and
mjData through the headers of the mujoco it was built against: ellipsim.mujoco refuses to load under another
mujoco (check_mujoco; the core, which never touches MuJoCo, does not import it).
"""

import hashlib
import pathlib

FOLDER = pathlib.Path(__file__).resolve().parent
#: what `pip install` compiles the module from (CMakeLists.txt hashes the same files)
PATTERNS = ("include/**/*.hpp", "mujoco/**/*.hpp", "python/**/*.cpp", "python/**/*.hpp", "**/CMakeLists.txt")
REBUILD = "pip install . (or, in a checkout installed for development, pip install -e .)"


class NativeImportError(ImportError):
    """The compiled core cannot be used as installed (missing, stale, or built against another MuJoCo); its
    message is one line saying what to run.  The command line prints it as an error, not a traceback (it tells
    it by `one_line`, without importing this module, whose import is what failed)."""

    one_line = True


def version_text(number):
    """MuJoCo's version number (mj_version(), mjVERSION_HEADER: 1000000 major + 1000 minor + patch) as text."""
    return f"{number // 1000000}.{number // 1000 % 1000}.{number % 1000}"


def mujoco_mismatch(built, running):
    """None when the glue's headers (`built`) are the running MuJoCo's (`running`), else the one-line reason."""
    if built == running:
        return None
    return (
        f"ellipsim's compiled core was built against MuJoCo {version_text(built)}, but this process runs mujoco "
        f"{version_text(running)} (its structs may differ): pip install mujoco=={version_text(built)}, or rebuild "
        "ellipsim against yours from its source (pip install --no-build-isolation . with scikit-build-core and "
        "nanobind installed)"
    )


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
        raise NativeImportError(
            f"ellipsim's compiled core (the _ellipsim module) is not installed ({exc}): {REBUILD}"
        ) from None
    if _ellipsim.SOURCE_DIGEST != source_digest():
        raise NativeImportError(
            f"ellipsim's compiled core at {_ellipsim.__file__} was built from other sources than {FOLDER}: {REBUILD}"
        )
    return _ellipsim


def check_mujoco():
    """NativeImportError (one line) unless the running mujoco is the one the MuJoCo glue was compiled against."""
    import mujoco

    reason = mujoco_mismatch(ext.mujoco.MUJOCO_VERSION, mujoco.mj_version())
    if reason:
        raise NativeImportError(reason)


ext = _load()
