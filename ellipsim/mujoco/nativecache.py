"""The callbacks' machine code: cached across processes and loaded without numba.

numba compiles the callbacks (callbacks.py) once per machine and platform (how long: the bench report's
start-up section, bench/results/suite/report.md), and its own cache cannot make a later process fast: a numba cache hit still pays
`import numba` and its target initialisation (0.6 s at best, measured in the start-up prototype: it
imports scipy.linalg), and its keys miss callees in other files and MuJoCo's version.  So after a
compile ellipsim writes the relocatable object code to cache_dir(), and a later process links it
with llvmlite's MCJIT alone (`ExecutionEngine.add_object_file`, 8-17 ms), numba not imported.

`function(kind)` looks in this order:

1. cache_dir()/KIND-KEY.code, KEY a hash of host_key(kind): everything the code depends on -- the
   text of callbacks.py and of every module it imports (kernel_sources()), MuJoCo's version and
   struct layout, numba's, llvmlite's and LLVM's versions, target triple, CPU name and features,
   NUMBA_* settings;
2. prebuilt_dir()/KIND-TRIPLE.code: CPU-generic objects shipped in the package (prebuild.py), used
   when their header holds portable_key(kind) (sources, MuJoCo, triple);
3. a numba compile, announced by one logged warning line (the user waits), saved under 1.

A .code file is one JSON line (the key's parts, the function's symbol, the symbols it needs, a
sha256 over that line's other fields and the object), then the object.  Missing, truncated, another
key, or a needed symbol that does not resolve in this process (finalising would abort inside LLVM):
"not cached", never stale or broken code.  The cache directory holds machine code that ellipsim
runs: the same trust as numba's cache, which unpickles.

Per process, before any function is handed out, the context (context.py) is filled (publish.py): the
offsets of structs.checked_layout(), the registry, and MuJoCo's collision functions as found in
mjCOLLISIONFUNC.
"""

import bisect
import ctypes
import hashlib
import importlib.machinery
import importlib.util
import json
import logging
import os
import pathlib
import re
import sys
import threading

from ..core.cache_root import cache_root
from . import structs
from .context import SYMBOL
from .publish import fill_context, publish_context

KINDS = ("filter", "narrowphase")
FORMAT = 1  # of a .code file; part of every key
PREBUILT_ENV = "ELLIPSIM_PREBUILT_DIR"
NOTICE_PREFIX = "ellipsim: compiling the"
#: for the notice: wall time of a compile from empty caches, rounded from the bench report's start-up
#: section (bench/results/suite/report.md, 'cold' rows; ellipsim/app/bench/startup.py measures it)
COMPILE_SECONDS = {
    "filter": "~3 s",
    "narrowphase": "~3 min",
}
_CTYPES = {
    "filter": ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int, ctypes.c_int),
    "narrowphase": ctypes.CFUNCTYPE(
        ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int, ctypes.c_int, ctypes.c_double
    ),
}
_PACKAGE = pathlib.Path(__file__).resolve().parent.parent  # ellipsim/
_ROOT = "mujoco/callbacks.py"
#: NUMBA_* settings that do not change generated code (all others are part of host_key)
_NUMBA_NEUTRAL = {"NUMBA_CACHE_DIR", "NUMBA_NUM_THREADS", "NUMBA_THREADING_LAYER", "NUMBA_DEBUG_CACHE"}

_log = logging.getLogger(__name__)
_lock = threading.RLock()
_functions = {}  # kind -> Function
_engines = []  # MCJIT engines holding loaded code, kept for the life of the process


class Function:
    """A callback ready to be called by MuJoCo: .address (int) and .ctypes, as numba's CFunc has;
    .origin: "cache", "prebuilt" or "compiled"."""

    def __init__(self, kind, address, origin, keep=None):
        self.kind, self.address, self.origin = kind, address, origin
        self.ctypes = _CTYPES[kind](address)
        self._keep = keep  # a CompiledCode: its numba library holds the code

    def __repr__(self):
        return f"<ellipsim {self.kind} callback at {self.address:#x}, {self.origin}>"


def function(kind):
    """The callback `kind` ("filter" or "narrowphase"), with the context filled: from the cache, a
    prebuilt object, or compiled once (announced on the log with COMPILE_SECONDS)."""
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {KINDS}, got {kind!r}")
    with _lock:
        if kind not in _functions:
            fill_context()
            _functions[kind] = _obtain(kind)
        return _functions[kind]


def _obtain(kind):
    host = host_key(kind)
    path = cache_path(kind, host)
    address = load(path, host)
    if address:
        return Function(kind, address, "cache")
    address = load(prebuilt_path(kind), portable_key(kind))
    if address:
        return Function(kind, address, "prebuilt")
    _log.warning(
        NOTICE_PREFIX + " %s callback for this machine (%s, first run only; cached in %s)",
        kind,
        COMPILE_SECONDS[kind],
        path.parent,
    )
    from . import callbacks

    code = callbacks.compile_callback(kind)
    write(path, host, code)
    return Function(kind, code.address, "compiled", keep=code)


# --- keys ----------------------------------------------------------------------------------------


def kernel_sources():
    """{path under ellipsim/: sha256} of callbacks.py and of every ellipsim module it imports at
    module level, transitively: all the compiled code depends on (a jitted function sees only
    module globals)."""
    todo, found = [_ROOT], {}
    while todo:
        rel = todo.pop()
        if rel in found:
            continue
        text = (_PACKAGE / rel).read_text(encoding="utf-8")
        found[rel] = hashlib.sha256(text.encode()).hexdigest()
        todo += _imported_files(rel, text)
    return dict(sorted(found.items()))


# An import statement, multi-line parenthesised names included.  Read line by line, not with `ast`
# (~8 ms a file, 0.1 s for the kernels' 12), erring towards more files: any import outside a
# top-level def or class counts, even inside a top-level if or try.
_IMPORT = re.compile(
    r"^[ \t]*(?:from[ \t]+(\.*)([\w.]*)[ \t]+import[ \t]+(\([^)]*\)|[^\n#;]*)|import[ \t]+([^\n#;]*))", re.M
)
_DEF = re.compile(r"(?:async[ \t]+def|def|class)\b|@")
_TOP = re.compile(r"^[^\s#]", re.M)


def _imported_files(rel, text):
    """Files under ellipsim/ that module `rel` (source `text`) imports outside functions and classes."""
    package = ["ellipsim", *pathlib.PurePosixPath(rel).parts[:-1]]
    tops = [(m.start(), bool(_DEF.match(text, m.start()))) for m in _TOP.finditer(text)]
    starts = [t[0] for t in tops]
    names = []
    for m in _IMPORT.finditer(text):
        k = bisect.bisect_right(starts, m.start()) - 1
        if k >= 0 and tops[k][1]:
            continue  # inside a top-level def or class
        if m.group(4) is not None:  # import a.b, c as d
            names += [item.split()[0].split(".") for item in m.group(4).split(",") if item.strip()]
            continue
        level, dotted = len(m.group(1)), m.group(2)
        base = package[: len(package) - level + 1] if level else []
        module = base + (dotted.split(".") if dotted else [])
        if os.path.isdir(os.path.join(_PACKAGE, *module[1:])):  # `from . import context`: the modules
            items = m.group(3).strip("() \t\n").replace("\n", " ").split(",")
            names += [module + [item.split()[0]] for item in items if item.strip()]
        else:
            names.append(module)
    files = []
    for parts in names:
        if parts[:1] != ["ellipsim"] or len(parts) < 2:
            continue
        for candidate in ("/".join(parts[1:]) + ".py", "/".join(parts[1:]) + "/__init__.py"):
            if os.path.isfile(os.path.join(_PACKAGE, candidate)):
                files.append(candidate)
                break
    return files


def sources_digest():
    """sha256 of kernel_sources()."""
    return hashlib.sha256(json.dumps(kernel_sources()).encode()).hexdigest()


def _numba_version():
    """numba's version, read from its _version.py: neither numba (~0.2 s) nor importlib.metadata
    (~45 ms) is imported."""
    if "numba" in sys.modules:
        return sys.modules["numba"].__version__
    spec = importlib.util.find_spec("numba")
    if spec is None or not spec.origin:
        return "none"
    text = pathlib.Path(spec.origin).with_name("_version.py").read_text(encoding="utf-8")
    found = re.search(r'"version"\s*:\s*"([^"]+)"', text)
    return found.group(1) if found else "sha256 " + hashlib.sha256(text.encode()).hexdigest()


def _target():
    """(triple, CPU name, CPU features) numba compiles for, its NUMBA_CPU_NAME / _FEATURES honoured
    as numba.core.config and codegen read them."""
    import llvmlite.binding as llb

    name = os.environ.get("NUMBA_CPU_NAME") or llb.get_host_cpu_name()
    features = os.environ.get("NUMBA_CPU_FEATURES")
    if features is None:
        features = "" if name.lower() == "generic" else llb.get_host_cpu_features().flatten()
    return llb.get_process_triple(), name, features


def host_key(kind):
    """The parts of the cache key of callback `kind` compiled here (a list of strings)."""
    import llvmlite
    import llvmlite.binding as llb

    numba_env = sorted(f"{k}={v}" for k, v in os.environ.items() if k.startswith("NUMBA_") and k not in _NUMBA_NEUTRAL)
    return [
        f"format {FORMAT}",
        SYMBOL,
        kind,
        sources_digest(),
        structs.layout()["key"],
        "host",
        f"numba {_numba_version()}",
        f"llvmlite {llvmlite.__version__}",
        "llvm {}.{}.{}".format(*llb.llvm_version_info),
        *_target(),
        *numba_env,
    ]


def portable_key(kind):
    """The parts of the key of a prebuilt, CPU-generic object of callback `kind`: what such an object
    depends on.  Its only external symbols are the context, two numba math helpers with C signatures
    and an unreachable NRT destructor (callbacks._wrapper_for), so numba's and Python's versions do
    not matter."""
    import llvmlite.binding as llb

    return [
        f"format {FORMAT}",
        SYMBOL,
        kind,
        sources_digest(),
        structs.layout()["key"],
        "generic",
        llb.get_process_triple(),
    ]


def cache_dir():
    """The compiled callbacks' folder: the user's cache root (core/cache_root.py)."""
    return cache_root()


def prebuilt_dir():
    """$ELLIPSIM_PREBUILT_DIR, else the prebuilt/ folder shipped next to this module."""
    return pathlib.Path(os.environ.get(PREBUILT_ENV) or pathlib.Path(__file__).with_name("prebuilt"))


def cache_path(kind, parts):
    return cache_dir() / f"{kind}-{hashlib.sha256(json.dumps(parts).encode()).hexdigest()[:24]}.code"


def prebuilt_path(kind, directory=None):
    import llvmlite.binding as llb

    return pathlib.Path(directory or prebuilt_dir()) / f"{kind}-{llb.get_process_triple()}.code"


# --- .code files ---------------------------------------------------------------------------------


def _digest(header, obj):
    return hashlib.sha256(json.dumps(header, sort_keys=True).encode() + b"\n" + obj).hexdigest()


def write(path, parts, code):
    """Write CompiledCode `code` under key `parts` to `path` atomically (a concurrent writer of the
    same key writes the same bytes); False when the directory is not writable (the next process then
    compiles again)."""
    header = {"parts": parts, "symbol": code.symbol, "undefined": code.undefined}
    line = json.dumps(dict(header, sha256=_digest(header, code.object_code))).encode()
    tmp = path.with_name(f".{path.name}.{os.getpid()}.{threading.get_ident()}.tmp")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)  # the umask applies, as to any file
        try:
            with os.fdopen(fd, "wb") as f:
                f.write(line + b"\n" + code.object_code)
            os.replace(tmp, path)
        except BaseException:
            os.unlink(tmp)
            raise
    except OSError as exc:
        _log.info("ellipsim: could not write %s: %s", path, exc)
        return False
    return True


def read(path):
    """(header, object code) of a .code file, or None when it is missing or damaged."""
    try:
        line, obj = pathlib.Path(path).read_bytes().split(b"\n", 1)
        header = json.loads(line)
        digest = header.pop("sha256")
    except (OSError, ValueError, KeyError, AttributeError):
        return None
    return (header, obj) if _digest(header, obj) == digest else None


def load(path, parts):
    """The address of the function in the .code file at `path` linked into this process, or None
    when the file is missing, damaged, made under another key, or needs a symbol this process lacks."""
    found = read(path)
    if found is None or found[0].get("parts") != parts:
        return None
    header, obj = found
    import llvmlite.binding as llb

    with _lock:
        publish_context()
        llb.initialize_native_target()
        llb.initialize_native_asmprinter()
        triple, cpu, features = _target()
        machine = llb.Target.from_triple(triple).create_target_machine(
            cpu=cpu, features=features, codemodel="jitdefault"
        )
        engine = llb.create_mcjit_compiler(llb.parse_assembly(""), machine)  # also makes libc/libm resolvable
        if _unresolved(header["undefined"]):
            return None  # finalising would abort the process inside LLVM: compile instead
        engine.add_object_file(llb.ObjectFileRef.from_data(obj))
        engine.finalize_object()
        address = engine.get_function_address(header["symbol"])
        if not address:
            return None
        _engines.append(engine)
    return address


def _unresolved(symbols):
    """The symbols that do not resolve in this process, after publishing numba's C helpers if needed."""
    import llvmlite.binding as llb

    missing = [s for s in symbols if llb.address_of_symbol(s) is None]
    if missing:
        _publish_numba_helpers(missing)
        missing = [s for s in missing if llb.address_of_symbol(s) is None]
    return missing


def _publish_numba_helpers(names):
    """Publish numba's C helpers among `names` (numba_frexp, NRT_MemInfo_call_dtor, ...) as numba does
    when its target initialises (numba.core.base._load_global_helpers, numba.core.runtime.nrt), but
    without importing numba: its two C extension modules are loaded on their own (~1 ms) for their
    address tables."""
    import llvmlite.binding as llb

    spec = importlib.util.find_spec("numba")
    if spec is None or not spec.origin:
        return
    root = pathlib.Path(spec.origin).parent
    tables = (
        ("numba._helperlib", root, lambda n: "numba_" + n),
        ("numba.core.runtime._nrt_python", root / "core" / "runtime", lambda n: n if n.startswith("_") else "NRT_" + n),
    )
    for module_name, folder, c_name in tables:
        try:
            module = sys.modules.get(module_name) or _extension(module_name, folder)
        except (ImportError, OSError):
            continue
        for py_name, address in module.c_helpers.items():
            if c_name(py_name) in names:
                llb.add_symbol(c_name(py_name), address)


def _extension(module_name, folder):
    """C extension module `module_name` loaded from `folder`, not importing its package."""
    stem = module_name.rsplit(".", 1)[1]
    for suffix in importlib.machinery.EXTENSION_SUFFIXES:
        path = folder / (stem + suffix)
        if path.is_file():
            return importlib.util.module_from_spec(importlib.util.spec_from_file_location(module_name, path))
    raise ImportError(f"{module_name} not found in {folder}")
