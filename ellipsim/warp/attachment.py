"""attach(m): ellipsim's ellipsoid contacts inside MuJoCo Warp's collision, for one model instance.

MuJoCo Warp has no collider registration; it has one per-model hook, m.callback.contactfilter(m, d),
called at the end of collision_driver.collision with all of d writable.  An attachment

* takes its pairs away from the built-in narrow phase by editing this model's own pair tables
  (nxn_geom_pair_filtered / nxn_pairid_filtered for the NXN broad phase, entry 0 of nxn_pairid set to
  -2 for the SAP ones, geom_pair_type_count so no kernel is built for a type left without pairs, where
  that changes nothing else: _counts_without); no
  module global of mujoco_warp is touched, so other models run plain Warp bit for bit;
* in the hook, launches one kernel (kernels.py) over all worlds and its pairs that appends their
  contacts to d.contact with write_contact's semantics (after the built-in ones, so the contact
  order differs from plain Warp's: compare contacts as a set);
* on detach, puts the tables and the previous hook back as they were.

Sleeping: collision() runs twice per step when sleeping is on, the second time with awake_prev (the
incremental pass, which must only add the pairs the first pass skipped); the hook is not told which
pass it is in, so it reads collision()'s own awake_prev argument from its caller's frame (checked:
a hook called from anywhere else raises).

Pairs taken: ellipsoid x ellipsoid, sphere x ellipsoid, capsule x ellipsoid, ellipsoid x cylinder,
ellipsoid x box, ellipsoid x mesh and height field x ellipsoid (the pair table's rows marked warp: every pair
type of ellipsim.mujoco's narrow phase), from the model's collision rules
and its explicit <pair>s (their margin, gap and material), except pairs with a collision sensor (they
stay with Warp: a sensor reads Warp's own collision record).  A mesh pair is taken when its mesh has MuJoCo's
own hull (mesh_graph; the one MuJoCo C's narrow phase runs) of at most kernels.MAX_POSED_HULL_VERTICES = 3000
vertices (in every world's geom_dataid): up to kernels.MAX_HULL_VERTICES = 64 the mesh row stores the hull in the
ellipsoid's frame in its per-thread scratch, above it runs the core's posed path (the same bits, two bytes of
scratch a vertex); a larger hull, or a mesh without one, stays with Warp's GJK/EPA.  The hulls are built once at
attach (core.pairs.hull.mesh_graph_hull, mujoco/hull.py's mesh_hull's reader, on the Model's mesh_graph and
float32 mesh_vert; the core's adjacency builder) and uploaded.

Graph capture: the hook launches one kernel (two on a model with surface velocities) on arrays made at
attach (pair table, counters) and the model's and data's own; it makes
no array, reads nothing back to the host and takes no branch on device data, which is what capture on
CUDA needs.  On CPU Warp does not capture, and no capture has been run yet (no GPU here):
tests/test_warp.py checks that a call makes no array and reads nothing back.

Geom order: a pair's geoms as Warp's NXN broad phase orders them (lower type first, then index); under
SAP, Warp orders two geoms of one type by its sort, so its contact for such a pair may name them the
other way round, with the opposite normal: the same contact.

Surface velocity: collision() fills contact.surfacevel before the hook, for its own contacts; the hook
runs Warp's _contact_surfacevel again over all of them, ellipsim's included.
"""

import sys

import numpy as np
import warp as wp
from mujoco_warp._src import types as mjw_types

from ..core.pairs.hull import mesh_graph_hull
from ..pair_table import MESH, ROW_MESH, TYPE_NAMES
from ..pair_table import WARP_PAIR_TYPES as PAIR_TYPES  # the rows it takes
from . import kernels

# The pair table both glues read (ellipsim/pair_table.py); its geom codes are MuJoCo Warp's too.
assert all(int(getattr(mjw_types.GeomType, name.upper())) == t for t, name in TYPE_NAMES.items())
COUNTER_NAMES = ("pairs", "contacts", "unproven", "overflow", "deep", "failed", "capped")


def _trid(i, j, n):
    """MuJoCo Warp's index of the unordered type pair (i, j) in geom_pair_type_count (io.py)."""
    i, j = (j, i) if j < i else (i, j)
    return (i * (2 * n - i - 1)) // 2 + j


def _upper_tri(n, i, j):
    """MuJoCo Warp's index of geoms (i < j) in nxn_pairid (io.py, upper_tri_index)."""
    return i * (2 * n - i - 1) // 2 + j - i - 1


def mesh_hulls(m):
    """The hull the mesh row takes for each mesh id of the mujoco_warp Model m, or None (the mesh's pairs stay
    with Warp): MuJoCo's own hull (core.pairs.hull.mesh_graph_hull, the reader of mujoco/hull.py's mesh_hull, on
    the Model's mesh_graph and float32 mesh_vert), at most kernels.MAX_POSED_HULL_VERTICES vertices."""
    graph, graphadr, vert = m.mesh_graph.numpy(), m.mesh_graphadr.numpy(), m.mesh_vert.numpy()
    vertadr, vertnum = m.mesh_vertadr.numpy(), m.mesh_vertnum.numpy()
    hulls = []
    for mesh in range(len(vertadr)):
        try:
            hull = mesh_graph_hull(graph, int(graphadr[mesh]), vert, int(vertadr[mesh]), int(vertnum[mesh]))
        except ValueError:  # no hull in the model (or a degenerate triangle): Warp's
            hull = None
        if hull is not None and len(hull.vertices) > kernels.MAX_POSED_HULL_VERTICES:
            hull = None
        hulls.append(hull)
    return hulls


def _mesh_geoms_taken(m, hulls):
    """Per geom of m: False for a mesh geom whose mesh, in any world's geom_dataid, has no hull in `hulls`."""
    geom_type = m.geom_type.numpy()
    dataid = m.geom_dataid.numpy().reshape(-1, len(geom_type))
    ok = np.ones(len(geom_type), bool)
    for g in np.flatnonzero(geom_type == MESH):
        ok[g] = all(0 <= i < len(hulls) and hulls[i] is not None for i in dataid[:, g])
    return ok


def _selection(geom_type, pairs, pairid, geom_taken):
    """(mask over the model's filtered pair table of the pairs taken, those pairs (k, 2) int32 with their
    geoms ordered as _add_geom_pair orders them: the lower type first, the normal from the first, and each
    pair's row of PAIR_TYPES' `row` column (k,) int32).  geom_taken: per geom, False for a mesh whose pairs
    stay with Warp (_mesh_geoms_taken)."""
    t1, t2 = geom_type[pairs[:, 0]], geom_type[pairs[:, 1]]
    lo, hi = np.minimum(t1, t2), np.maximum(t1, t2)
    row = np.full(len(pairs), -1, np.int32)
    for r in PAIR_TYPES:
        row[(lo == r.type1) & (hi == r.type2)] = r.row
    mesh = np.where(t1 == MESH, pairs[:, 0], pairs[:, 1])
    row[(row == ROW_MESH) & ~geom_taken[mesh]] = -1  # a hull over the scratch's size, or none: Warp's
    take = (row >= 0) & (pairid[:, 0] >= -1) & (pairid[:, 1] == -1)  # default and explicit pairs, no sensor
    ordered = np.where((t1 > t2)[:, None], pairs[:, ::-1], pairs)[take]
    return take, ordered.astype(np.int32).reshape(-1, 2), row[take]


def candidate_pairs(m, *, pair_ids=False):
    """The pairs attach(m) would take from the mujoco_warp Model m, as Attachment.pairs, without attaching;
    pair_ids: also their pair ids (k, 2): entry 0 the explicit <pair>'s index (its margin, gap) or -1."""
    pairid = m.nxn_pairid_filtered.numpy()
    taken = _mesh_geoms_taken(m, mesh_hulls(m))
    take, ordered, _ = _selection(m.geom_type.numpy(), m.nxn_geom_pair_filtered.numpy(), pairid, taken)
    return (ordered, pairid[take].reshape(-1, 2)) if pair_ids else ordered


def _counts_without(m, lo, hi):
    """geom_pair_type_count less the taken pairs (lo, hi: their types), so Warp builds and launches no
    narrow-phase kernel for a type left without pairs; unchanged where that would change what Warp does
    with the pairs it keeps: its convex narrow phase runs EPA for 16 iterations instead of
    opt.ccd_iterations when box x box pairs are all the convex pairs there are (collision_convex.py), so
    then the taken types keep their counts and their kernels run over no pair of theirs."""
    from mujoco_warp._src.collision_driver import MJ_COLLISION_TABLE

    ntypes = len(mjw_types.GeomType)
    table = dict(MJ_COLLISION_TABLE)
    if m.opt.disableflags & mjw_types.DisableBit.NATIVECCD:  # as collision_driver._narrowphase
        table[(mjw_types.GeomType.BOX, mjw_types.GeomType.BOX)] = mjw_types.CollisionType.PRIMITIVE
    before = list(m.geom_pair_type_count)
    after = list(before)
    for a, b in zip(lo, hi):
        after[_trid(int(a), int(b), ntypes)] -= 1
    convex = [_trid(int(a), int(b), ntypes) for (a, b), kind in table.items() if kind == mjw_types.CollisionType.CONVEX]
    boxbox = _trid(int(mjw_types.GeomType.BOX), int(mjw_types.GeomType.BOX), ntypes)
    nccd = lambda c: sum(c[i] for i in convex)  # noqa: E731
    box_only_before = before[boxbox] > 0 and before[boxbox] == nccd(before)
    box_only_after = after[boxbox] > 0 and after[boxbox] == nccd(after)
    return tuple(before if box_only_after != box_only_before else after)


class Attachment:
    """ellipsim's contacts on one mujoco_warp Model (module docstring).  Use attach(m)."""

    def __init__(self, m):
        if not isinstance(m, mjw_types.Model):
            raise TypeError(f"m must be a mujoco_warp Model (mujoco_warp.put_model), got {type(m).__name__}")
        hook = m.callback.contactfilter
        if isinstance(getattr(hook, "__self__", None), Attachment):
            raise ValueError("m is already attached: detach it first (one attachment per model)")
        self.model = m
        self._previous_hook = hook
        self._saved = {
            name: getattr(m, name)
            for name in ("nxn_geom_pair_filtered", "nxn_pairid_filtered", "nxn_pairid", "geom_pair_type_count")
        }
        device = m.geom_type.device
        geom_type = m.geom_type.numpy()
        pairs = m.nxn_geom_pair_filtered.numpy()
        pairid = m.nxn_pairid_filtered.numpy()
        hulls = mesh_hulls(m)
        take, ordered, rows = _selection(geom_type, pairs, pairid, _mesh_geoms_taken(m, hulls))
        # only the hulls of the meshes whose pairs are taken
        used = {
            int(i)
            for g in np.unique(ordered[rows == ROW_MESH][:, 1])
            for i in m.geom_dataid.numpy().reshape(-1, len(geom_type))[:, g]
        }
        self._hulls = kernels.hull_arrays([h if i in used else None for i, h in enumerate(hulls)], device)
        lo, hi = np.sort(geom_type[pairs[take]].reshape(-1, 2), axis=1).T
        self.pairs = ordered
        self.npairs = len(self.pairs)
        self._pair_geom = wp.array(self.pairs.reshape(-1, 2), dtype=wp.vec2i, device=device)
        self._pair_id = wp.array(pairid[take].reshape(-1, 2), dtype=wp.vec2i, device=device)
        self._pair_row = wp.array(rows, dtype=int, device=device)
        self._counters = wp.zeros(kernels.NCOUNTERS, dtype=wp.int64, device=device)  # (int32 wraps at 4096 worlds)
        # this model's tables without the taken pairs
        keep = ~take
        ngeom = len(geom_type)
        full = m.nxn_pairid.numpy().copy()
        taken = pairs[take]
        if len(taken):
            idx = _upper_tri(ngeom, np.minimum(taken[:, 0], taken[:, 1]), np.maximum(taken[:, 0], taken[:, 1]))
            full[idx, 0] = -2
        count = _counts_without(m, lo, hi)
        self._tables = {
            "nxn_geom_pair_filtered": wp.array(pairs[keep].reshape(-1, 2), dtype=wp.vec2i, device=device),
            "nxn_pairid_filtered": wp.array(pairid[keep].reshape(-1, 2), dtype=wp.vec2i, device=device),
            "nxn_pairid": wp.array(full.reshape(-1, 2), dtype=wp.vec2i, device=device),
            "geom_pair_type_count": count,
        }
        for name, value in self._tables.items():
            setattr(m, name, value)
        m.callback.contactfilter = self._hook
        self.attached = True

    # the hook ------------------------------------------------------------------------------------

    def _hook(self, m, d):
        if m is not self.model:
            raise RuntimeError("an ellipsim attachment's hook was called with another model")
        caller = sys._getframe(1)
        if caller.f_code.co_name != "collision" or "awake_prev" not in caller.f_locals:
            raise RuntimeError("ellipsim.warp's contact hook runs only from mujoco_warp's collision()")
        awake_prev = caller.f_locals["awake_prev"]
        self.launch(d, awake_prev)
        if self._previous_hook is not None:
            self._previous_hook(m, d)

    def launch(self, d, awake_prev=None):
        """Append ellipsim's contacts of every world to d (what the hook does after Warp's narrow phase)."""
        m = self.model
        if self.npairs == 0 or d.naconmax == 0:
            return
        enable_sleep = bool(m.opt.enableflags & mjw_types.EnableBit.SLEEP)
        incremental = awake_prev is not None
        per_thread = kernels.PAIRS_PER_THREAD["cuda" if m.geom_type.device.is_cuda else "cpu"]
        kernel = kernels.contact_kernel(enable_sleep, incremental, per_thread)
        c = d.contact
        wp.launch(
            kernel,
            dim=(d.nworld, -(-self.npairs // per_thread)),
            inputs=[
                self._pair_geom,
                self._pair_id,
                self._pair_row,
                *self._hulls,
                m.geom_type,
                m.geom_bodyid,
                m.geom_size,
                m.geom_rbound,
                m.geom_condim,
                m.geom_priority,
                m.geom_solmix,
                m.geom_solref,
                m.geom_solimp,
                m.geom_friction,
                m.geom_margin,
                m.geom_gap,
                m.geom_adhesion,
                m.pair_dim,
                m.pair_solref,
                m.pair_solreffriction,
                m.pair_solimp,
                m.pair_margin,
                m.pair_gap,
                m.pair_adhesion,
                m.pair_friction,
                m.geom_dataid,
                m.hfield_size,
                m.hfield_nrow,
                m.hfield_ncol,
                m.hfield_adr,
                m.hfield_data,
                d.geom_xpos,
                d.geom_xmat,
                d.body_awake,
                awake_prev if incremental else d.body_awake,
                d.naconmax,
            ],
            outputs=[
                c.dist,
                c.pos,
                c.frame,
                c.includemargin,
                c.friction,
                c.solref,
                c.solreffriction,
                c.solimp,
                c.dim,
                c.geom,
                c.efc_address,
                c.worldid,
                c.type,
                c.geomcollisionid,
                c.adhesion,
                d.nacon,
                self._counters,
            ],
            device=m.geom_type.device,
        )
        if m.flg_surfacevel:  # collision() ran this before the hook, over its own contacts: again, over ours too
            from mujoco_warp._src.collision_driver import _contact_surfacevel

            wp.launch(
                _contact_surfacevel,
                dim=d.naconmax,
                inputs=[
                    m.geom_surfacevel,
                    d.geom_xpos,
                    d.geom_xmat,
                    c.pos,
                    c.frame,
                    c.geom,
                    c.worldid,
                    d.naconmax,
                    d.nacon,
                ],
                outputs=[c.surfacevel],
                device=m.geom_type.device,
            )

    # the user's side -----------------------------------------------------------------------------

    @property
    def counters(self):
        """Totals since attach (or reset_counters) over all worlds and calls: pairs (evaluated by the
        narrow phase, past the bounding spheres), contacts (appended, overflow included), unproven
        (maxima not proven global: a branch and bound out of its budget, ellipsoid pairs' or a cylinder
        rim's; the best found is used), overflow (contacts not written
        because d.naconmax was reached), deep (ellipsoid pairs beyond the shallow-contact proof, sent to the branch and bound; capsule,
        box and cylinder pairs whose certificates did not close and whose pieces were all bounded or solved; mesh
        pairs enumerated), failed (height-field pairs left without contacts: a degenerate prism or a non-finite
        distance; mesh pairs with a non-finite distance: where MuJoCo C's narrow phase calls MuJoCo's own function), capped
        (height-field pairs that made mjMAXCONPAIR (50) contacts: their further prisms within the margin made none).
        Reading synchronises with the device."""
        values = self._counters.numpy()
        return dict(zip(COUNTER_NAMES, (int(v) for v in values)))

    def reset_counters(self):
        self._counters.zero_()

    def detach(self):
        """Put back the model's pair tables and its previous hook; calling it twice is harmless."""
        if not self.attached:
            return
        m = self.model
        if m.callback.contactfilter != self._hook:
            raise RuntimeError("m.callback.contactfilter was replaced after attach: restore it before detach")
        for name, value in self._saved.items():
            setattr(m, name, value)
        m.callback.contactfilter = self._previous_hook
        self.attached = False

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.detach()

    def __repr__(self):
        state = "attached" if self.attached else "detached"
        return f"<ellipsim.warp.Attachment {state}: {self.npairs} pairs per world>"


def attach(m):
    """Give ellipsim's contacts to the sphere, capsule, ellipsoid, cylinder, box, convex mesh (a hull of at most
    kernels.MAX_POSED_HULL_VERTICES = 3000 vertices; larger ones stay with Warp) and height field x ellipsoid pairs
    of the mujoco_warp Model m (collision, forward and step on m, every world in one launch); returns the
    Attachment (a context manager; .detach(), .counters)."""
    return Attachment(m)
