"""Raw access to mjModel / mjData fields from compiled callbacks.

A MuJoCo callback receives only `const mjModel*` and `mjData*`.  To read geom arrays from any
(model, data) we need the byte offsets of their pointer fields inside the structs.  They are fixed
for a given libmujoco build, so `layout()` finds them once per process on probe models: a pointer
field is the word holding the array's own address (checked on two models); an mjOption scalar is
found by writing a sentinel into a probe model and scanning for it.  Nothing is hard-coded, and a
layout that does not verify raises instead of reading the wrong memory.
"""

import ctypes
import functools

import mujoco
from numba import types
from numba.extending import intrinsic

MODEL_ARRAYS = ("geom_type", "geom_contype", "geom_conaffinity", "geom_size", "geom_margin", "geom_gap")
DATA_ARRAYS = ("geom_xpos", "geom_xmat")

_PROBE = """<mujoco><worldbody>
  <body><freejoint/><geom type="ellipsoid" size=".1 .2 .3" margin=".01" gap=".002"/></body>
  <body pos="1 0 0"><freejoint/><geom type="sphere" size=".2" contype="3" conaffinity="5"/></body>
  <geom type="box" size=".1 .1 .1" pos="0 2 0"/>
</worldbody></mujoco>"""

_SCAN_LIMIT = 1 << 22  # bytes: the structs are far smaller; a missing field stops here


def _scan_words(base, fmt, wanted):
    """Offsets (multiples of the word size) of the first occurrence of each wanted value."""
    size = ctypes.sizeof(fmt)
    found = {}
    for off in range(0, _SCAN_LIMIT, size):
        value = fmt.from_address(base + off).value
        if value in wanted and wanted[value] not in found:
            found[wanted[value]] = off
            if len(found) == len(wanted):
                return found
    missing = sorted(set(wanted.values()) - set(found))
    raise RuntimeError(f"mujoco {mujoco.__version__}: fields {missing} not found in the struct")


def _pointer_offsets(obj, names):
    return _scan_words(obj._address, ctypes.c_uint64, {getattr(obj, n).ctypes.data: n for n in names})


@functools.cache
def layout():
    """Byte offsets of the fields the callbacks read: {name: offset} for mjModel and mjData fields."""
    m1 = mujoco.MjModel.from_xml_string(_PROBE)
    m2 = mujoco.MjModel.from_xml_string(_PROBE.replace(".1 .2 .3", ".3 .2 .1"))
    d1, d2 = mujoco.MjData(m1), mujoco.MjData(m2)
    model = _pointer_offsets(m1, MODEL_ARRAYS)
    data = _pointer_offsets(d1, DATA_ARRAYS)
    if model != _pointer_offsets(m2, MODEL_ARRAYS) or data != _pointer_offsets(d2, DATA_ARRAYS):
        raise RuntimeError(f"mujoco {mujoco.__version__}: struct layout differs between two models")
    m1.opt.ccd_tolerance = 1.2345678912345679e-77
    m1.opt.o_margin = 9.8765432198765432e-77
    m1.opt.enableflags = 0x5A5A3C3C
    model.update(
        _scan_words(m1._address, ctypes.c_double, {m1.opt.ccd_tolerance: "opt.ccd_tolerance", m1.opt.o_margin: "opt.o_margin"})
    )
    model.update(_scan_words(m1._address, ctypes.c_int32, {0x5A5A3C3C: "opt.enableflags"}))
    return {"model": model, "data": data}


# --- numba intrinsics: turn addresses into typed pointers ---------------------------------------


@intrinsic
def address(typingctx, ptr):
    """The integer address of a void pointer."""

    def codegen(context, builder, signature, args):
        return builder.ptrtoint(args[0], context.get_value_type(types.intp))

    return types.intp(types.voidptr), codegen


def _pointer_intrinsic(numba_type):
    @intrinsic
    def pointer(typingctx, addr):
        ptr_type = types.CPointer(numba_type)

        def codegen(context, builder, signature, args):
            return builder.inttoptr(args[0], context.get_value_type(ptr_type))

        return ptr_type(types.intp), codegen

    return pointer


f64_pointer = _pointer_intrinsic(types.float64)
i32_pointer = _pointer_intrinsic(types.int32)
i64_pointer = _pointer_intrinsic(types.int64)



@intrinsic
def atomic_add(typingctx, addr, value):
    """*(int64*)addr += value, atomically (MuJoCo may run one data's narrow phase on several threads)."""

    def codegen(context, builder, signature, args):
        from llvmlite import ir

        ptr = builder.inttoptr(args[0], ir.PointerType(ir.IntType(64)))
        return builder.atomic_rmw("add", ptr, args[1], "monotonic")

    return types.int64(types.intp, types.int64), codegen


def mujoco_library():
    """The libmujoco the bindings loaded (dlopen of the same path returns the same handle)."""
    import glob
    import os

    paths = sorted(glob.glob(os.path.join(os.path.dirname(mujoco.__file__), "libmujoco.so*")))
    if not paths:
        raise RuntimeError(f"libmujoco not found next to {mujoco.__file__}")
    return ctypes.CDLL(paths[0])


def collision_table():
    """MuJoCo's mjCOLLISIONFUNC[type1][type2] as a flat ctypes array of function pointers."""
    n = int(mujoco.mjtGeom.mjNGEOMTYPES)
    return (ctypes.c_void_p * (n * n)).in_dll(mujoco_library(), "mjCOLLISIONFUNC"), n
