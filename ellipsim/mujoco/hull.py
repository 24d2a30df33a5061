"""A mesh geom's convex hull as MuJoCo collides it, and a height field's grid (mjc_Convex reads mesh_graph, built by user_mesh.cc), in the
form the polytope kernel takes (core/pairs/hull.py).

mesh_graph, per mesh at mesh_graphadr: numvert, numface, vert_edgeadr (numvert), vert_globalid (numvert),
edge_localid (numvert + 3 numface), face_globalid (3 numface): the hull's triangles as indices into the mesh's
vertices (mesh_vert from mesh_vertadr, already in the geom's frame: MuJoCo moves a mesh to its centroid frame and
shifts the geom by mesh_pos).
"""

import numpy as np

from ..core.pairs.height_field import HeightField
from ..core.pairs.hull import mesh_graph_hull


def mesh_hull(model, mesh):
    """The Hull of mesh `mesh` (id or name) of the MjModel `model`: MuJoCo's own hull (its triangles), the
    vertices in the geom's frame.  ValueError naming the mesh when it has no hull (mesh_graphadr -1)."""
    import mujoco

    if isinstance(mesh, str):
        mid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_MESH, mesh)
        if mid < 0:
            raise ValueError(f"mesh {mesh!r} is not in the model")
    else:
        mid = int(mesh)
        if not 0 <= mid < model.nmesh:
            raise ValueError(f"mesh must be an id in [0, {model.nmesh}) or a name, got {mesh!r}")
    adr = int(model.mesh_graphadr[mid])
    if adr < 0:
        raise ValueError(f"mesh {mid} has no convex hull in the model (mesh_graphadr -1)")
    start, count = int(model.mesh_vertadr[mid]), int(model.mesh_vertnum[mid])
    return mesh_graph_hull(model.mesh_graph, adr, model.mesh_vert, start, count)


def model_height_field(model, hfield):
    """The HeightField (core/pairs/height_field.py) of height field `hfield` (id) of the MjModel `model`: its
    elevations (hfield_data, float32 in [0, 1]) and size, as mjc_ConvexHField reads them."""
    h = int(hfield)
    if not 0 <= h < model.nhfield:
        raise ValueError(f"hfield must be an id in [0, {model.nhfield}), got {hfield!r}")
    nrow, ncol, adr = int(model.hfield_nrow[h]), int(model.hfield_ncol[h]), int(model.hfield_adr[h])
    elevation = np.asarray(model.hfield_data[adr : adr + nrow * ncol], np.float32).reshape(nrow, ncol)
    return HeightField(elevation, np.asarray(model.hfield_size[h], np.float64).copy())
