"""The narrow phase in MuJoCo Warp's kernels: one kernel over all worlds and ellipsim's pairs, whose geometry is
the C++ core's, compiled into it by Warp (wp.func_native): the functions the CPU API and the MuJoCo C callback
run (ellipsim/native/warp/narrowphase.hpp calls them: pair_signed_distance, pairs::capsule, pairs::box,
pairs::cylinder, pairs::polytope (meshes), pairs::height_field, and the certified filters), every certificate and search of theirs, the
spheroid searches included.

Reading of a pose: as the CPU reads it.  MuJoCo Warp's float32 geom_xpos, geom_xmat and geom_size widened exactly
to float64 and used as given (the rotation not orthonormalised), so on the same widened poses this kernel and
`ellipsim.signed_distance` / `shape_distance` run the same operations on the same numbers (tests/test_warp.py
compares them bit for bit on Warp's CPU device; on CUDA, whose double sin, cos, atan and pow may differ from glibc's
in the last bit, the searches that call them may differ from the CPU's by rounding: ellipsim/math.hpp).

Floating point as the proofs assume: every module here compiles with fuse_fp False (no contraction into
multiply-adds on Warp's CPU JIT or NVRTC) and without fast math (Warp's default; config.hpp refuses it).

Per pair: a certified filter first (the centre line of the capsule, box or cylinder, or of two ellipsoids grown by
half the cutoff each), proving it apart beyond margin + gap with nothing computed; for two ellipsoids the first
Newton run then stops at an iterate whose sigma reaches the cutoff (any sigma(n) is a lower bound on the
distance).  Either is APART: no contact.  A height-field pair is the core's whole function, as MuJoCo C's narrow
phase calls it: the cells under the ellipsoid, each prism proven apart by sigma or solved, a contact for each
within margin + gap (up to MuJoCo's 50, into a per-thread buffer, then written one by one).  A mesh pair is
pairs::polytope's polytope_ellipsoid on the mesh's hull (MuJoCo's own, uploaded at attach), cutoff margin + gap
(its walking start's sigma proves a pair apart: APART), its scratch a local array for a hull of up to
narrowphase.hpp's MAX_HULL_VERTICES, stored in the ellipsoid's frame there; a larger hull (up to
MAX_POSED_HULL_VERTICES) runs polytope_ellipsoid_posed, each vertex and normal computed where read (the same
bits), its flags in that array.  Else the signed distance, status GLOBAL, or UNPROVEN where the core's
proof ran out (counted; the best found used, as the CPU API reports it), so a pair left without a contact is
separated beyond margin + gap whatever its status.

No allocation, no host synchronisation: fixed-size locals only (the core allocates nothing), one launch per
call, counters by atomics into arrays allocated once at attach.
"""

from pathlib import Path

import numpy as np
import warp as wp

# the pair table's geom codes and rows (narrowphase.hpp's ROW_*: which core function a pair runs)
from ..pair_table import ROW_BOX, ROW_CAPSULE, ROW_CYLINDER, ROW_ELLIPSOID, ROW_HFIELD, ROW_MESH, SPHERE

F64 = wp.float64

#: Where Warp's compilers find the core: its headers, and the Warp glue (narrowphase.hpp).
NATIVE = Path(__file__).resolve().parent.parent / "native"
INCLUDE_DIRS = [str(NATIVE / "include"), str(NATIVE / "warp")]
_PREAMBLE = "#include <narrowphase.hpp>\n"

#: The Warp module options of every kernel of ellipsim.warp: the core on the include path, in the preamble, its
#: headers hashed into the module's hash (an edited header rebuilds the kernel, not a stale cache), no
#: floating-point contraction, no backward pass.
MODULE_OPTIONS = {
    "extra_build_options": wp.ModuleBuildOptions(
        extra_cpu_include_dirs=INCLUDE_DIRS,
        extra_cuda_include_dirs=INCLUDE_DIRS,
        extra_cpu_preamble=_PREAMBLE,
        extra_cuda_preamble=_PREAMBLE,
        extra_build_dependencies=sorted(str(p) for d in INCLUDE_DIRS for p in Path(d).rglob("*.hpp")),
    ),
    "fuse_fp": False,
    "fast_math": False,
    "enable_backward": False,
}
wp.set_module_options(MODULE_OPTIONS)  # this module's own kernels (_pair_distances)


#: Per pair: the maximum proven global, or not (the best found), or proven beyond the cutoff by a certified
#: filter (APART: no distance computed).  (narrowphase.hpp's GLOBAL, UNPROVEN, APART.)
GLOBAL, UNPROVEN, APART = 0, 1, 2

#: Candidate pairs per thread of the contact kernel (launch: (nworld, ceil(npairs / per thread))), per
#: device kind.  On Warp's CPU device each thread costs ~20-30 ns of its own, and most candidates are
#: culled in a few loads: 16 per thread took the 16-figure heap's launch (16 worlds x 28456 pairs) from
#: 16.3 to 6.0 ms here.  On CUDA one per thread (not measured here: no GPU on this machine).
PAIRS_PER_THREAD = {"cpu": 16, "cuda": 1}

#: The counters' slots (Attachment.counters names them).
C_PAIRS, C_CONTACTS, C_UNPROVEN, C_OVERFLOW, C_DEEP, C_FAILED, C_CAPPED = 0, 1, 2, 3, 4, 5, 6
NCOUNTERS = 7

#: A height-field pair's most contacts (MuJoCo's mjMAXCONPAIR; narrowphase.hpp's HFIELD_MAXCON), and the
#: per-thread buffer the core writes them into: row k (dist, normal from the field to the ellipsoid, pos).
HFIELD_MAXCON = 50
HfieldContacts = wp.types.matrix(shape=(HFIELD_MAXCON, 7), dtype=wp.float64)

#: The largest mesh hull the mesh row stores (narrowphase.hpp's MAX_HULL_VERTICES; at most 2 nv - 4 triangles):
#: its per-thread scratch, 6 nv + 3 nf float64 and 2 nv bytes (6.2 kB), is sized for it.  Larger hulls run posed
#: (2 bytes a vertex of that scratch), up to MAX_POSED_HULL_VERTICES; larger still stay with Warp's GJK.
MAX_HULL_VERTICES = 64
MAX_HULL_FACES = 2 * MAX_HULL_VERTICES - 4
MAX_POSED_HULL_VERTICES = 3000
#: The hull table's columns (narrowphase.hpp's HULL_*): nv, ne, nf, then offsets of the vertices and normals into
#: the float64 array, of the edges, faces, adj_start, adj, vface_start, vface into the int32 one.
HULL_COLUMNS = 11


@wp.func_native(
    "ellipsim::warp_glue::warp_pair_contact(row, c1, R1, r1, c2, R2, r2, sphere1, cutoff, status, dist, normal, "
    "pos, deep);"
)
def pair_contact(
    row: int,
    c1: wp.vec3d,
    R1: wp.mat33d,
    r1: wp.vec3d,
    c2: wp.vec3d,
    R2: wp.mat33d,
    r2: wp.vec3d,
    sphere1: int,
    cutoff: wp.float64,
    status: wp.ref[int],
    dist: wp.ref[wp.float64],
    normal: wp.ref[wp.vec3d],
    pos: wp.ref[wp.vec3d],
    deep: wp.ref[int],
):
    """narrowphase.hpp's pair_contact: (status, dist, normal from g1 to g2, pos, deep) of one pair, its geoms as
    Warp's NXN orders them; r1, r2 an ellipsoid's semi-axes ((r, r, r) for a sphere: sphere1) or the capsule's,
    box's or cylinder's geom_size; cutoff -inf for the distance of every pair."""
    ...


@wp.func_native(
    "ellipsim::warp_glue::warp_hfield_contacts(c1, R1, c2, R2, r2, nrow, ncol, size, data, adr, margin, count, out);"
)
def hfield_contacts(
    c1: wp.vec3d,
    R1: wp.mat33d,
    c2: wp.vec3d,
    R2: wp.mat33d,
    r2: wp.vec3d,
    nrow: int,
    ncol: int,
    size: wp.vec4,
    data: wp.array[float],
    adr: int,
    margin: wp.float64,
    count: wp.ref[int],
    out: wp.ref[HfieldContacts],
):
    """narrowphase.hpp's warp_hfield_contacts: the field g1 posed at (c1, R1) (MuJoCo Warp's hfield_nrow, _ncol,
    _size, _data from _adr) and the ellipsoid (c2, R2, r2): pairs::height_field::contacts, every prism within the
    margin in MuJoCo's order, into out's first count rows (count -1: none computed)."""
    ...


@wp.func_native(
    "ellipsim::warp_glue::warp_mesh_contact(c1, R1, r1, c2, R2, table, mesh, real, ints, cutoff, status, dist, "
    "normal, pos, deep);"
)
def mesh_contact(
    c1: wp.vec3d,
    R1: wp.mat33d,
    r1: wp.vec3d,
    c2: wp.vec3d,
    R2: wp.mat33d,
    table: wp.array[int],
    mesh: int,
    real: wp.array[wp.float64],
    ints: wp.array[int],
    cutoff: wp.float64,
    status: wp.ref[int],
    dist: wp.ref[wp.float64],
    normal: wp.ref[wp.vec3d],
    pos: wp.ref[wp.vec3d],
    deep: wp.ref[int],
):
    """narrowphase.hpp's warp_mesh_contact: the ellipsoid g1 (c1, R1, r1) and mesh `mesh`'s hull (row of the hull
    table, into real and ints) posed at (c2, R2): polytope_ellipsoid's (status GLOBAL, APART or -1 for a
    non-finite distance, dist, normal from the ellipsoid to the mesh, pos, deep: ENUMERATED)."""
    ...


@wp.func
def _widen3(v: wp.vec3) -> wp.vec3d:
    return wp.vec3d(F64(v[0]), F64(v[1]), F64(v[2]))


@wp.func
def _widen33(R: wp.mat33) -> wp.mat33d:
    return wp.mat33d(
        F64(R[0, 0]), F64(R[0, 1]), F64(R[0, 2]),
        F64(R[1, 0]), F64(R[1, 1]), F64(R[1, 2]),
        F64(R[2, 0]), F64(R[2, 1]), F64(R[2, 2]),
    )  # fmt: skip


@wp.func
def _size(geom_type: int, size: wp.vec3) -> wp.vec3d:
    """The semi-axes of an ellipsoid geom, (r, r, r) for a sphere (size (r, 0, 0)), else geom_size as it is."""
    if geom_type == SPHERE:
        return wp.vec3d(F64(size[0]), F64(size[0]), F64(size[0]))
    return _widen3(size)


_KERNELS = {}


def contact_kernel(enable_sleep, incremental, per_thread):
    """The kernel over (world, ellipsim pair) for one choice of MuJoCo Warp's sleeping flags (as its
    _nxn_broadphase is specialised) and of pairs per thread; built once per process per choice, shared
    by every attachment (it holds code only; each launch passes its model's arrays)."""
    key = (bool(enable_sleep), bool(incremental), int(per_thread))
    if key in _KERNELS:
        return _KERNELS[key]
    from mujoco_warp._src.collision_core import contact_margin_gap, contact_material_params
    from mujoco_warp._src.math import make_frame
    from mujoco_warp._src.types import ContactType, SleepState, vec5

    @wp.func
    def append_contact(
        dist32: float,
        normal: wp.vec3d,
        pos: wp.vec3d,
        margin: float,
        geoms: wp.vec2i,
        worldid: int,
        condim_in: int,
        friction: vec5,
        solref: wp.vec2,
        solreffriction: wp.vec2,
        solimp: vec5,
        adhesion: float,
        naconmax_in: int,
        contact_dist_out: wp.array[float],
        contact_pos_out: wp.array[wp.vec3],
        contact_frame_out: wp.array[wp.mat33],
        contact_includemargin_out: wp.array[float],
        contact_friction_out: wp.array[vec5],
        contact_solref_out: wp.array[wp.vec2],
        contact_solreffriction_out: wp.array[wp.vec2],
        contact_solimp_out: wp.array[vec5],
        contact_dim_out: wp.array[int],
        contact_geom_out: wp.array[wp.vec2i],
        contact_efc_address_out: wp.array2d[int],
        contact_worldid_out: wp.array[int],
        contact_type_out: wp.array[int],
        contact_geomcollisionid_out: wp.array[int],
        contact_adhesion_out: wp.array[float],
        nacon_out: wp.array[int],
        counters_out: wp.array[wp.int64],
    ):
        # write_contact's semantics (collision_core.py) for a contact within margin + gap, the slot kept to
        # count an overflow: the pair table holds no collision-sensor pair and no excluded one (attachment.py),
        # so a detected contact is a constraint contact, active when dist < margin or adhesive within the gap
        condim = condim_in
        if (adhesion != 0.0) and (dist32 >= margin):
            condim = 1
        cid = wp.atomic_add(nacon_out, 0, 1)
        wp.atomic_add(counters_out, C_CONTACTS, wp.int64(1))
        if cid >= naconmax_in:
            wp.atomic_add(counters_out, C_OVERFLOW, wp.int64(1))
            return
        contact_dist_out[cid] = dist32
        contact_pos_out[cid] = wp.vec3(wp.float32(pos[0]), wp.float32(pos[1]), wp.float32(pos[2]))
        contact_frame_out[cid] = make_frame(
            wp.vec3(wp.float32(normal[0]), wp.float32(normal[1]), wp.float32(normal[2]))
        )
        contact_geom_out[cid] = geoms
        contact_worldid_out[cid] = worldid
        contact_includemargin_out[cid] = margin
        contact_dim_out[cid] = condim
        contact_friction_out[cid] = friction
        contact_solref_out[cid] = solref
        contact_solreffriction_out[cid] = solreffriction
        contact_solimp_out[cid] = solimp
        contact_adhesion_out[cid] = adhesion
        contact_type_out[cid] = int(ContactType.CONSTRAINT)
        contact_geomcollisionid_out[cid] = 0
        for i in range(contact_efc_address_out.shape[1]):
            contact_efc_address_out[cid, i] = -1

    @wp.func
    def hfield_pair(
        p1: wp.vec3d,
        R1: wp.mat33d,
        p2: wp.vec3d,
        R2: wp.mat33d,
        r2: wp.vec3d,
        hid: int,
        margin: float,
        gap: float,
        geoms: wp.vec2i,
        pairid: int,
        worldid: int,
        geom_condim: wp.array[int],
        geom_priority: wp.array[int],
        geom_solmix: wp.array2d[float],
        geom_solref: wp.array2d[wp.vec2],
        geom_solimp: wp.array2d[vec5],
        geom_friction: wp.array2d[wp.vec3],
        geom_adhesion: wp.array2d[float],
        pair_dim: wp.array[int],
        pair_solref: wp.array2d[wp.vec2],
        pair_solreffriction: wp.array2d[wp.vec2],
        pair_solimp: wp.array2d[vec5],
        pair_adhesion: wp.array2d[float],
        pair_friction: wp.array2d[vec5],
        hfield_size: wp.array[wp.vec4],
        hfield_nrow: wp.array[int],
        hfield_ncol: wp.array[int],
        hfield_adr: wp.array[int],
        hfield_data: wp.array[float],
        naconmax_in: int,
        contact_dist_out: wp.array[float],
        contact_pos_out: wp.array[wp.vec3],
        contact_frame_out: wp.array[wp.mat33],
        contact_includemargin_out: wp.array[float],
        contact_friction_out: wp.array[vec5],
        contact_solref_out: wp.array[wp.vec2],
        contact_solreffriction_out: wp.array[wp.vec2],
        contact_solimp_out: wp.array[vec5],
        contact_dim_out: wp.array[int],
        contact_geom_out: wp.array[wp.vec2i],
        contact_efc_address_out: wp.array2d[int],
        contact_worldid_out: wp.array[int],
        contact_type_out: wp.array[int],
        contact_geomcollisionid_out: wp.array[int],
        contact_adhesion_out: wp.array[float],
        nacon_out: wp.array[int],
        counters_out: wp.array[wp.int64],
    ):
        # The height-field row: every prism within margin + gap, up to 50, appended one by one.  A function of
        # its own, so that its buffer (2.8 kB, zeroed where declared) is made only for a field pair: in the
        # kernel's body every thread zeroed it, +40 ns a pair of every other row on Warp's CPU device.
        found = HfieldContacts()
        nfound = wp.int32(0)
        hfield_contacts(
            p1,
            R1,
            p2,
            R2,
            r2,
            hfield_nrow[hid],
            hfield_ncol[hid],
            hfield_size[hid],
            hfield_data,
            hfield_adr[hid],
            F64(margin) + F64(gap),
            nfound,
            found,
        )
        if nfound < 0:  # a degenerate prism or a non-finite pose: no contacts, counted
            wp.atomic_add(counters_out, C_FAILED, wp.int64(1))
            return
        if nfound == 0:
            return
        if nfound == HFIELD_MAXCON:  # its further prisms within the margin made no contact
            wp.atomic_add(counters_out, C_CAPPED, wp.int64(1))
        condim, friction, solref, solreffriction, solimp, adhesion = contact_material_params(
            geom_condim,
            geom_priority,
            geom_solmix,
            geom_solref,
            geom_solimp,
            geom_friction,
            geom_adhesion,
            pair_dim,
            pair_solref,
            pair_solreffriction,
            pair_solimp,
            pair_adhesion,
            pair_friction,
            geoms,
            pairid,
            worldid,
        )
        for i in range(nfound):
            dist32 = wp.float32(found[i, 0])
            if not (dist32 < margin + gap):  # write_contact's test, in float32 as Warp makes it
                continue
            append_contact(
                dist32,
                wp.vec3d(found[i, 1], found[i, 2], found[i, 3]),
                wp.vec3d(found[i, 4], found[i, 5], found[i, 6]),
                margin,
                geoms,
                worldid,
                condim,
                friction,
                solref,
                solreffriction,
                solimp,
                adhesion,
                naconmax_in,
                contact_dist_out,
                contact_pos_out,
                contact_frame_out,
                contact_includemargin_out,
                contact_friction_out,
                contact_solref_out,
                contact_solreffriction_out,
                contact_solimp_out,
                contact_dim_out,
                contact_geom_out,
                contact_efc_address_out,
                contact_worldid_out,
                contact_type_out,
                contact_geomcollisionid_out,
                contact_adhesion_out,
                nacon_out,
                counters_out,
            )

    @wp.kernel(module="unique", module_options=MODULE_OPTIONS)
    def ellipsim_contacts(
        # the attachment's pair table: geoms, pair ids, rows (ellipsim/pair_table.py)
        pair_geom: wp.array[wp.vec2i],
        pair_id: wp.array[wp.vec2i],
        pair_row: wp.array[int],
        # the attachment's mesh hulls (a row of HULL_COLUMNS per mesh id, the arrays it points into)
        hull_table: wp.array[int],
        hull_real: wp.array[wp.float64],
        hull_int: wp.array[int],
        # Model:
        geom_type: wp.array[int],
        geom_bodyid: wp.array[int],
        geom_size: wp.array2d[wp.vec3],
        geom_rbound: wp.array2d[float],
        geom_condim: wp.array[int],
        geom_priority: wp.array[int],
        geom_solmix: wp.array2d[float],
        geom_solref: wp.array2d[wp.vec2],
        geom_solimp: wp.array2d[vec5],
        geom_friction: wp.array2d[wp.vec3],
        geom_margin: wp.array2d[float],
        geom_gap: wp.array2d[float],
        geom_adhesion: wp.array2d[float],
        pair_dim: wp.array[int],
        pair_solref: wp.array2d[wp.vec2],
        pair_solreffriction: wp.array2d[wp.vec2],
        pair_solimp: wp.array2d[vec5],
        pair_margin: wp.array2d[float],
        pair_gap: wp.array2d[float],
        pair_adhesion: wp.array2d[float],
        pair_friction: wp.array2d[vec5],
        geom_dataid: wp.array2d[int],
        hfield_size: wp.array[wp.vec4],
        hfield_nrow: wp.array[int],
        hfield_ncol: wp.array[int],
        hfield_adr: wp.array[int],
        hfield_data: wp.array[float],
        # Data in:
        geom_xpos_in: wp.array2d[wp.vec3],
        geom_xmat_in: wp.array2d[wp.mat33],
        body_awake_in: wp.array2d[int],
        body_awake_prev_in: wp.array2d[int],
        naconmax_in: int,
        # Data out:
        contact_dist_out: wp.array[float],
        contact_pos_out: wp.array[wp.vec3],
        contact_frame_out: wp.array[wp.mat33],
        contact_includemargin_out: wp.array[float],
        contact_friction_out: wp.array[vec5],
        contact_solref_out: wp.array[wp.vec2],
        contact_solreffriction_out: wp.array[wp.vec2],
        contact_solimp_out: wp.array[vec5],
        contact_dim_out: wp.array[int],
        contact_geom_out: wp.array[wp.vec2i],
        contact_efc_address_out: wp.array2d[int],
        contact_worldid_out: wp.array[int],
        contact_type_out: wp.array[int],
        contact_geomcollisionid_out: wp.array[int],
        contact_adhesion_out: wp.array[float],
        nacon_out: wp.array[int],
        # the attachment's counters
        counters_out: wp.array[wp.int64],
    ):
        worldid, t = wp.tid()
        for j in range(wp.static(per_thread)):  # PAIRS_PER_THREAD
            k = t * wp.static(per_thread) + j
            if k >= pair_geom.shape[0]:
                break
            geoms = pair_geom[k]
            g1 = geoms[0]
            g2 = geoms[1]
            pairid = pair_id[k]
            if wp.static(enable_sleep):  # as _nxn_broadphase: pairs of sleeping bodies are skipped
                s1 = body_awake_in[worldid, geom_bodyid[g1]]
                s2 = body_awake_in[worldid, geom_bodyid[g2]]
                if s1 == SleepState.ASLEEP and s2 == SleepState.ASLEEP:
                    continue
                if (s1 == SleepState.ASLEEP and s2 == SleepState.STATIC) or (
                    s2 == SleepState.ASLEEP and s1 == SleepState.STATIC
                ):
                    continue
                if wp.static(incremental):  # only the pairs the first pass skipped
                    w1 = body_awake_prev_in[worldid, geom_bodyid[g1]]
                    w2 = body_awake_prev_in[worldid, geom_bodyid[g2]]
                    skipped = (
                        (w1 == SleepState.ASLEEP and w2 == SleepState.ASLEEP)
                        or (w1 == SleepState.ASLEEP and w2 == SleepState.STATIC)
                        or (w2 == SleepState.ASLEEP and w1 == SleepState.STATIC)
                    )
                    if not skipped:
                        continue
            margin, gap = contact_margin_gap(geom_margin, geom_gap, pair_margin, pair_gap, geoms, pairid[0], worldid)
            # bounding spheres (float32 rbound, a float64 sum): apart beyond margin + gap, no contact possible
            p1 = _widen3(geom_xpos_in[worldid, g1])
            p2 = _widen3(geom_xpos_in[worldid, g2])
            reach = (
                F64(geom_rbound[worldid % geom_rbound.shape[0], g1])
                + F64(geom_rbound[worldid % geom_rbound.shape[0], g2])
                + F64(margin)
                + F64(gap)
            )
            dd = p2 - p1
            if not (wp.dot(dd, dd) <= reach * reach):  # (as Warp's sphere filter: a non-finite pose too)
                continue
            wp.atomic_add(counters_out, C_PAIRS, wp.int64(1))
            sid = worldid % geom_size.shape[0]
            R1 = _widen33(geom_xmat_in[worldid, g1])
            R2 = _widen33(geom_xmat_in[worldid, g2])
            r2 = _size(geom_type[g2], geom_size[sid, g2])
            if pair_row[k] == ROW_HFIELD:  # several contacts (hfield_pair)
                hfield_pair(
                    p1,
                    R1,
                    p2,
                    R2,
                    r2,
                    geom_dataid[worldid % geom_dataid.shape[0], g1],
                    margin,
                    gap,
                    geoms,
                    pairid[0],
                    worldid,
                    geom_condim,
                    geom_priority,
                    geom_solmix,
                    geom_solref,
                    geom_solimp,
                    geom_friction,
                    geom_adhesion,
                    pair_dim,
                    pair_solref,
                    pair_solreffriction,
                    pair_solimp,
                    pair_adhesion,
                    pair_friction,
                    hfield_size,
                    hfield_nrow,
                    hfield_ncol,
                    hfield_adr,
                    hfield_data,
                    naconmax_in,
                    contact_dist_out,
                    contact_pos_out,
                    contact_frame_out,
                    contact_includemargin_out,
                    contact_friction_out,
                    contact_solref_out,
                    contact_solreffriction_out,
                    contact_solimp_out,
                    contact_dim_out,
                    contact_geom_out,
                    contact_efc_address_out,
                    contact_worldid_out,
                    contact_type_out,
                    contact_geomcollisionid_out,
                    contact_adhesion_out,
                    nacon_out,
                    counters_out,
                )
                continue
            # an allowance far above sigma's rounding through M (~u max r_B^2 / h_B, sphere_newton.sigma): past it
            # the pair is proven beyond margin + gap; below it, the distance is computed and Warp's test decides
            cutoff = F64(margin) + F64(gap) + F64(1e-9) * reach
            t1 = geom_type[g1]
            status = wp.int32(0)
            dist = F64(0.0)
            normal = wp.vec3d(F64(0.0), F64(0.0), F64(0.0))
            pos = wp.vec3d(F64(0.0), F64(0.0), F64(0.0))
            deep = wp.int32(0)
            if pair_row[k] == ROW_MESH:  # the mesh g2: its hull, cutoff margin + gap (the core's own allowance)
                mesh_contact(
                    p1,
                    R1,
                    _size(t1, geom_size[sid, g1]),
                    p2,
                    R2,
                    hull_table,
                    geom_dataid[worldid % geom_dataid.shape[0], g2],
                    hull_real,
                    hull_int,
                    F64(margin) + F64(gap),
                    status,
                    dist,
                    normal,
                    pos,
                    deep,
                )
                if status < 0:  # a non-finite distance: no contact, counted
                    wp.atomic_add(counters_out, C_FAILED, wp.int64(1))
                    continue
            else:
                pair_contact(
                    pair_row[k],
                    p1,
                    R1,
                    _size(t1, geom_size[sid, g1]),
                    p2,
                    R2,
                    r2,
                    int(t1 == SPHERE),
                    cutoff,
                    status,
                    dist,
                    normal,
                    pos,
                    deep,
                )
            if status == APART:
                continue  # proven beyond margin + gap: Warp would make no contact either
            if status != GLOBAL:
                wp.atomic_add(counters_out, C_UNPROVEN, wp.int64(1))
            if deep != 0:
                wp.atomic_add(counters_out, C_DEEP, wp.int64(1))
            dist32 = wp.float32(dist)
            if not (dist32 < margin + gap):  # write_contact's test, in float32 as Warp makes it
                continue
            condim, friction, solref, solreffriction, solimp, adhesion = contact_material_params(
                geom_condim,
                geom_priority,
                geom_solmix,
                geom_solref,
                geom_solimp,
                geom_friction,
                geom_adhesion,
                pair_dim,
                pair_solref,
                pair_solreffriction,
                pair_solimp,
                pair_adhesion,
                pair_friction,
                geoms,
                pairid[0],
                worldid,
            )
            append_contact(
                dist32,
                normal,
                pos,
                margin,
                geoms,
                worldid,
                condim,
                friction,
                solref,
                solreffriction,
                solimp,
                adhesion,
                naconmax_in,
                contact_dist_out,
                contact_pos_out,
                contact_frame_out,
                contact_includemargin_out,
                contact_friction_out,
                contact_solref_out,
                contact_solreffriction_out,
                contact_solimp_out,
                contact_dim_out,
                contact_geom_out,
                contact_efc_address_out,
                contact_worldid_out,
                contact_type_out,
                contact_geomcollisionid_out,
                contact_adhesion_out,
                nacon_out,
                counters_out,
            )

    _KERNELS[key] = ellipsim_contacts
    return ellipsim_contacts


@wp.kernel
def _pair_distances(
    row: int,
    sphere1: int,
    cutoff: wp.float64,
    c1: wp.array[wp.vec3],
    R1: wp.array[wp.mat33],
    s1: wp.array[wp.vec3],
    c2: wp.array[wp.vec3],
    R2: wp.array[wp.mat33],
    s2: wp.array[wp.vec3],
    dist: wp.array[wp.float64],
    normal: wp.array[wp.vec3d],
    pos: wp.array[wp.vec3d],
    status: wp.array[int],
):
    i = wp.tid()
    st = wp.int32(0)
    v = F64(0.0)
    nrm = wp.vec3d(F64(0.0), F64(0.0), F64(0.0))
    p = wp.vec3d(F64(0.0), F64(0.0), F64(0.0))
    deep = wp.int32(0)
    pair_contact(
        row,
        _widen3(c1[i]),
        _widen33(R1[i]),
        _widen3(s1[i]),
        _widen3(c2[i]),
        _widen33(R2[i]),
        _widen3(s2[i]),
        sphere1,
        cutoff,
        st,
        v,
        nrm,
        p,
        deep,
    )
    dist[i] = v
    normal[i] = nrm
    pos[i] = p
    status[i] = st


def pair_distances(ca, Ra, ra, cb, Rb, rb, device="cpu", cutoff=-np.inf):
    """The kernel's signed distance of float32 ellipsoid poses (n, 3), (n, 3, 3), (n, 3) each, in float64
    before the float32 rounding the contact kernel applies: (dist, normal, pos, status) as numpy arrays.
    cutoff: as the contact kernel's margin + gap (a pair proven beyond it is APART, dist 0 or a lower bound).
    For tests and the bench (one launch over the n pairs); the MuJoCo Warp path is attach()."""
    return _distances(ROW_ELLIPSOID, (ca, Ra, ra, cb, Rb, rb), device, cutoff=cutoff)


def _distances(row, arrays, device, flip=False, cutoff=-np.inf):
    arrays = [np.ascontiguousarray(x, dtype=np.float32) for x in arrays]
    n = len(arrays[0])
    for x, shape in zip(arrays, ((3,), (3, 3), (3,)) * 2):
        if x.shape != (n, *shape):
            raise ValueError(f"pose arrays must be (n, 3), (n, 3, 3), (n, 3) for one n, got {x.shape}")
    if flip:  # the glue's capsule row reads the capsule as g1
        arrays = arrays[3:] + arrays[:3]
    types = (wp.vec3, wp.mat33, wp.vec3) * 2
    inputs = [wp.array(x, dtype=t, device=device) for x, t in zip(arrays, types)]
    dist = wp.empty(n, dtype=wp.float64, device=device)
    normal = wp.empty(n, dtype=wp.vec3d, device=device)
    pos = wp.empty(n, dtype=wp.vec3d, device=device)
    status = wp.empty(n, dtype=int, device=device)
    wp.launch(
        _pair_distances,
        dim=n,
        inputs=[row, 0, float(cutoff), *inputs],
        outputs=[dist, normal, pos, status],
        device=device,
    )
    normal = normal.numpy()
    return dist.numpy(), -normal if flip else normal, pos.numpy(), status.numpy()


def capsule_distances(ce, Re, ra, ck, Rk, rk, device="cpu"):
    """As pair_distances for ellipsoids (ce, Re, ra) and capsules (ck, Rk, rk: MuJoCo's geom_size,
    (radius, half-length, unused)); the normal from the ellipsoid to the capsule."""
    return _distances(ROW_CAPSULE, (ce, Re, ra, ck, Rk, rk), device, flip=True)


def box_distances(ce, Re, ra, ck, Rk, rk, device="cpu"):
    """As pair_distances for ellipsoids (ce, Re, ra) and boxes (ck, Rk, rk: half-sizes); the normal from
    the ellipsoid to the box."""
    return _distances(ROW_BOX, (ce, Re, ra, ck, Rk, rk), device)


def cylinder_distances(ce, Re, ra, ck, Rk, rk, device="cpu"):
    """As pair_distances for ellipsoids (ce, Re, ra) and cylinders (ck, Rk, rk: MuJoCo's geom_size,
    (radius, half-length, unused)); the normal from the ellipsoid to the cylinder."""
    return _distances(ROW_CYLINDER, (ce, Re, ra, ck, Rk, rk), device)


@wp.kernel
def _hfield_pairs(
    cf: wp.array[wp.vec3],
    Rf: wp.array[wp.mat33],
    ce: wp.array[wp.vec3],
    Re: wp.array[wp.mat33],
    re: wp.array[wp.vec3],
    nrow: int,
    ncol: int,
    size: wp.vec4,
    data: wp.array[float],
    margin: wp.float64,
    count: wp.array[int],
    out: wp.array3d[wp.float64],
):
    i = wp.tid()
    found = HfieldContacts()
    n = wp.int32(0)
    hfield_contacts(
        _widen3(cf[i]),
        _widen33(Rf[i]),
        _widen3(ce[i]),
        _widen33(Re[i]),
        _widen3(re[i]),
        nrow,
        ncol,
        size,
        data,
        0,
        margin,
        n,
        found,
    )
    count[i] = n
    for k in range(n):
        for j in range(7):
            out[i, k, j] = found[k, j]


def hfield_pair_contacts(ce, Re, re, cf, Rf, elevation, size, margin=0.0, device="cpu"):
    """The contact kernel's height-field row on float32 poses: ellipsoids (ce, Re, re) (n, 3), (n, 3, 3), (n, 3)
    and the field (elevation (nrow, ncol), size (x, y, z, base), float32 as MuJoCo Warp holds them) posed at
    (cf, Rf), every prism within `margin` (float64, as the kernel's margin + gap) in float64 before the kernel's
    float32 rounding: (count (n,), dist (n, 50), normal (n, 50, 3) from the field to the ellipsoid, pos (n, 50, 3))
    as core.pairs.height_field.hfield_contacts returns them (rows past count NaN).  For tests and the bench."""
    arrays = [np.ascontiguousarray(x, dtype=np.float32) for x in (cf, Rf, ce, Re, re)]
    n = len(arrays[0])
    for x, shape in zip(arrays, ((3,), (3, 3), (3,), (3, 3), (3,))):
        if x.shape != (n, *shape):
            raise ValueError(f"pose arrays must be (n, 3), (n, 3, 3), (n, 3) for one n, got {x.shape}")
    e = np.ascontiguousarray(elevation, dtype=np.float32)
    inputs = [wp.array(x, dtype=t, device=device) for x, t in zip(arrays, (wp.vec3, wp.mat33) * 2 + (wp.vec3,))]
    count = wp.empty(n, dtype=int, device=device)
    out = wp.array(np.full((n, HFIELD_MAXCON, 7), np.nan), dtype=wp.float64, device=device)
    size = wp.vec4(*(float(np.float32(v)) for v in size))
    data = wp.array(e.ravel(), dtype=float, device=device)
    wp.launch(
        _hfield_pairs,
        dim=n,
        inputs=[*inputs, e.shape[0], e.shape[1], size, data, float(margin)],
        outputs=[count, out],
        device=device,
    )
    out = out.numpy()
    return count.numpy(), out[:, :, 0], out[:, :, 1:4], out[:, :, 4:7]


def hull_arrays(hulls, device="cpu"):
    """The mesh row's hull table for `hulls` (one per mesh id: a core.pairs.hull.Hull, or None for a mesh the
    attachment does not take, nv 0), each hull's adjacency built by the core's one builder (ext.hull_adjacency,
    as MuJoCo C's attach builds it): (table (nmesh * HULL_COLUMNS) int32, real float64, ints int32) Warp arrays
    on `device` (never empty: Warp takes no zero-size pointer for granted)."""
    from ..native import ext

    table = np.zeros((max(len(hulls), 1), HULL_COLUMNS), np.int32)
    real, ints = [np.zeros(1)], [np.zeros(1, np.int32)]
    nreal, nint = 1, 1
    for mesh, hull in enumerate(hulls):
        if hull is None:
            continue
        v, e, n, f = (np.ascontiguousarray(x) for x in hull)
        if len(v) > MAX_POSED_HULL_VERTICES:
            raise ValueError(f"mesh {mesh}'s hull has {len(v)} vertices: over the mesh row's {MAX_POSED_HULL_VERTICES}")
        adjacency = [np.empty(k, np.int32) for k in (len(v) + 1, 2 * len(e), len(v) + 1, 3 * len(f))]
        ext.hull_adjacency(v, e, n, f, *adjacency)
        offsets = []
        for x in (v, n):
            offsets.append(nreal)
            real.append(np.ravel(x).astype(np.float64))
            nreal += real[-1].size
        for x in (e, f, *adjacency):
            offsets.append(nint)
            ints.append(np.ravel(x).astype(np.int32))
            nint += ints[-1].size
        table[mesh] = (len(v), len(e), len(f), *offsets)
    return (
        wp.array(table.ravel(), dtype=int, device=device),
        wp.array(np.concatenate(real), dtype=wp.float64, device=device),
        wp.array(np.concatenate(ints), dtype=int, device=device),
    )


@wp.kernel
def _mesh_pairs(
    ce: wp.array[wp.vec3],
    Re: wp.array[wp.mat33],
    re: wp.array[wp.vec3],
    cm: wp.array[wp.vec3],
    Rm: wp.array[wp.mat33],
    table: wp.array[int],
    real: wp.array[wp.float64],
    ints: wp.array[int],
    cutoff: wp.float64,
    dist: wp.array[wp.float64],
    normal: wp.array[wp.vec3d],
    pos: wp.array[wp.vec3d],
    status: wp.array[int],
    deep: wp.array[int],
):
    i = wp.tid()
    st = wp.int32(0)
    v = F64(0.0)
    nrm = wp.vec3d(F64(0.0), F64(0.0), F64(0.0))
    p = wp.vec3d(F64(0.0), F64(0.0), F64(0.0))
    dp = wp.int32(0)
    mesh_contact(
        _widen3(ce[i]),
        _widen33(Re[i]),
        _widen3(re[i]),
        _widen3(cm[i]),
        _widen33(Rm[i]),
        table,
        0,
        real,
        ints,
        cutoff,
        st,
        v,
        nrm,
        p,
        dp,
    )
    dist[i] = v
    normal[i] = nrm
    pos[i] = p
    status[i] = st
    deep[i] = dp


def mesh_distances(ce, Re, re, cm, Rm, hull, cutoff=np.inf, device="cpu"):
    """The contact kernel's mesh row on float32 poses: ellipsoids (ce, Re, re) (n, 3), (n, 3, 3), (n, 3) and one
    hull (core.pairs.hull.Hull, its vertices float64 in the mesh's frame) posed at (cm, Rm), in float64 before the
    kernel's float32 rounding: (dist, normal from the ellipsoid to the mesh, pos, status GLOBAL / APART / -1, deep)
    as numpy arrays.  cutoff: as the kernel's margin + gap (inf: every pair's distance).  For tests and the bench."""
    arrays = [np.ascontiguousarray(x, dtype=np.float32) for x in (ce, Re, re, cm, Rm)]
    n = len(arrays[0])
    for x, shape in zip(arrays, ((3,), (3, 3), (3,), (3,), (3, 3))):
        if x.shape != (n, *shape):
            raise ValueError(f"pose arrays must be (n, 3), (n, 3, 3), (n, 3) for one n, got {x.shape}")
    inputs = [
        wp.array(x, dtype=t, device=device) for x, t in zip(arrays, (wp.vec3, wp.mat33, wp.vec3, wp.vec3, wp.mat33))
    ]
    outputs = [wp.empty(n, dtype=t, device=device) for t in (wp.float64, wp.vec3d, wp.vec3d, int, int)]
    wp.launch(
        _mesh_pairs,
        dim=n,
        inputs=[*inputs, *hull_arrays([hull], device), float(cutoff)],
        outputs=outputs,
        device=device,
    )
    return tuple(x.numpy() for x in outputs)
