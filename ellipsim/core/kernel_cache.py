"""Where the compiled kernels live: numba's per-function cache, keyed on the sources the kernel is
built from, and shipped prebuilt for x86-64 Linux so that a fresh install does not compile.

numba's own cache keys a function's object code on its own file only (a content hash, numba 0.68):
a kernel that inlines a stage of another module (every @stage is inlined) keeps loading the old
code after that module changes.  Here the stamp of every kernel is one digest over the core's
sources (what any kernel can inline: the layers import only the core), the kernel's own file, and
numba's and Python's versions; the index key adds numba's own (signature, target, bytecode).

A kernel looks in this order (KernelCache.load_overload):

1. user_dir(): objects compiled on this machine for its CPU (numba's key: the host CPU's name and
   features), written after every compile;
2. shipped_dir(), the package's kernels/ folder: objects compiled for the platform's baseline CPU
   (NUMBA_CPU_NAME=generic: SSE2 on x86-64) by `python -m ellipsim.app.prebuild`, read-only;
3. a compile, announced once per process on the log (NOTICE) before numba starts.

fastmath is off in every kernel (_jit.py), so generic and host code give bit-identical results
(no FMA contraction either way).
"""

import functools
import hashlib
import logging
import os
import pathlib
import pickle
import platform
import sys
import threading
import zlib

import numba
from numba.core import caching

from .cache_root import cache_root

_PACKAGE = pathlib.Path(__file__).resolve().parents[1]  # ellipsim/
_CORE = _PACKAGE / "core"
#: prebuilt objects shipped in the package (python -m ellipsim.app.prebuild writes them)
SHIPPED = _PACKAGE / "kernels"
#: another folder of prebuilt objects instead of SHIPPED (an empty one: compile, as the bench's cold start)
SHIPPED_ENV = "ELLIPSIM_KERNELS_DIR"
#: numba's target description (triple, CPU name, features) of the shipped objects
GENERIC = ("x86_64-unknown-linux-gnu", "generic", "")
#: where a prebuild writes (the shipped folder); set only by ellipsim.prebuild's child process
BUILD_ENV = "ELLIPSIM_KERNELS_BUILD"
#: the notice before a compile (its time: a command run with ELLIPSIM_KERNELS_DIR an empty folder)
NOTICE = (
    "ellipsim: compiling kernels for this machine as they are first used (first run only, typically 10-60 s "
    "a command; cached in %s)"
)

_log = logging.getLogger("ellipsim")
_announced = threading.Event()


def user_dir():
    """The prebuild's $ELLIPSIM_KERNELS_BUILD, else kernels/ under the user's cache root
    (cache_root.cache_root, which the MuJoCo callbacks' cache shares)."""
    if os.environ.get(BUILD_ENV):
        return pathlib.Path(os.environ[BUILD_ENV])
    return cache_root() / "kernels"


def sources_digest(folder):
    """sha256 over the .py files under folder (relative path and text of each), numba's and
    Python's versions."""
    folder = pathlib.Path(folder)
    h = hashlib.sha256(f"numba {numba.__version__} python {sys.version_info[:2]}".encode())
    for path in sorted(folder.rglob("*.py")):
        h.update(path.relative_to(folder).as_posix().encode() + b"\0" + path.read_bytes() + b"\0")
    return h.hexdigest()


def shipped_dir():
    """$ELLIPSIM_KERNELS_DIR, else SHIPPED."""
    return pathlib.Path(os.environ[SHIPPED_ENV]) if os.environ.get(SHIPPED_ENV) else SHIPPED


@functools.cache
def core_digest():
    """sources_digest of the core: what any kernel may inline (the layers import only the core)."""
    return sources_digest(_CORE)


@functools.cache
def _stamp(py_file):
    """The stamp of a kernel defined in py_file: the core's digest, and py_file's text when it lies
    outside the core (the bench's kernels)."""
    path = pathlib.Path(py_file).resolve()
    if _CORE in path.parents:
        return core_digest()
    return hashlib.sha256(core_digest().encode() + path.read_bytes()).hexdigest()


def _subfolder(py_file):
    """py_file's folder relative to the package (kernels of different modules never share an index)."""
    path = pathlib.Path(py_file).resolve()
    try:
        return path.parent.relative_to(_PACKAGE).parts
    except ValueError:  # a kernel outside the package (a test's): keyed by its folder's hash
        return ("other", hashlib.sha256(str(path.parent).encode()).hexdigest()[:16])


class _Locator(caching._CacheLocator):
    def __init__(self, py_func, py_file):
        self._py_file = py_file
        self._lineno = py_func.__code__.co_firstlineno
        self._cache_path = str(user_dir().joinpath(*_subfolder(py_file)))

    def ensure_cache_path(self):
        os.makedirs(self._cache_path, exist_ok=True)

    def get_cache_path(self):
        return self._cache_path

    def get_source_stamp(self):
        return _stamp(self._py_file)

    def get_disambiguator(self):
        return str(self._lineno)

    @classmethod
    def from_function(cls, py_func, py_file):
        return cls(py_func, py_file) if os.path.exists(py_file) else None


class _Impl(caching.CompileResultCacheImpl):
    _locator_classes = [_Locator]


class _ShippedFile(caching.IndexDataCacheFile):
    """A read-only folder of prebuilt objects: numba's index and data files, the data zlib-compressed
    (compress_shipped) to a third of their size."""

    def _load_data(self, name):
        """The object, or None (a miss: compiled instead) when the file cannot be read back, e.g. a
        checkout where a prebuild is rewriting the folder; never an error for the caller."""
        try:
            with open(self._data_path(name), "rb") as f:
                return pickle.loads(zlib.decompress(f.read()))
        except (OSError, EOFError, zlib.error, pickle.UnpicklingError) as exc:
            _log.debug("shipped kernel %s unreadable (%s): compiling it", name, exc)
            return None

    def save(self, key, data):
        raise OSError("the shipped kernels are read-only")


def compress_shipped(folder):
    """Compress every data file under folder in place (the prebuild's last step); the total bytes."""
    total = 0
    for path in pathlib.Path(folder).rglob("*.nbc"):
        packed = zlib.compress(path.read_bytes(), 9)
        path.write_bytes(packed)
        total += len(packed)
    return total


class KernelCache(caching.FunctionCache):
    """numba's per-function cache with the stamp above, the user's folder first, then the shipped one."""

    _impl_class = _Impl

    def __init__(self, py_func):
        super().__init__(py_func)
        shipped = shipped_dir().joinpath(*_subfolder(self._impl.locator._py_file))
        self._shipped = _ShippedFile(
            cache_path=str(shipped),
            filename_base=self._impl.filename_base,
            source_stamp=_stamp(self._impl.locator._py_file),
        )

    def _load_overload(self, sig, target_context):
        if not self._enabled:
            return None
        sig_key, target, code = self._index_key(sig, target_context.codegen())
        data = self._cache_file.load((sig_key, target, code))
        if data is None and target[0] == GENERIC[0] and not os.environ.get(BUILD_ENV):
            data = self._shipped.load((sig_key, GENERIC, code))
        if data is None:
            if not _announced.is_set():
                _announced.set()
                _log.warning(NOTICE, user_dir())
            return None
        return self._impl.rebuild(target_context, data)

    def _save_overload(self, sig, data):
        try:
            super()._save_overload(sig, data)
        except OSError as exc:  # a read-only home: the kernel still runs, compiled again next time
            _log.info("ellipsim: could not cache a kernel in %s: %s", self._cache_path, exc)


def enable(dispatcher):
    """Give a numba dispatcher (made with cache=False) ellipsim's cache; returns it."""
    dispatcher._cache = KernelCache(dispatcher.py_func)
    return dispatcher


def platform_matches():
    """Whether the shipped objects can run here (x86-64 Linux)."""
    return sys.platform.startswith("linux") and platform.machine() in ("x86_64", "AMD64")
