"""A convex polytope as the polytope kernel reads it (ellipsim/native/include/ellipsim/pairs/polytope.hpp): its
vertices, edges, outward face normals and triangles, in its own frame.

    hull = convex_hull(points)          # any points; their convex hull (scipy's Qhull)
    hull = as_hull(hull_or_points)      # a Hull checked, or the convex hull of points

A hull from a MuJoCo model's mesh is ellipsim.mujoco.hull.mesh_hull (MuJoCo's own hull, mesh_graph).
"""

from typing import NamedTuple

import numpy as np


class Hull(NamedTuple):
    """vertices (nv, 3) float64, edges (ne, 2) int32 vertex pairs, normals (nf, 3) outward unit face normals,
    faces (nf, 3) int32 the triangles.  A flat face may be several triangles (its diagonals then appear as
    edges): the kernel only gets more candidates from them."""

    vertices: np.ndarray
    edges: np.ndarray
    normals: np.ndarray
    faces: np.ndarray


def from_triangles(vertices, triangles):
    """The Hull of a closed convex triangle mesh: vertices (m, 3), triangles (k, 3) indices into them (any
    orientation: each face's normal is turned away from the vertices' centroid); only the vertices the
    triangles use are kept."""
    vertices = np.asarray(vertices, float)
    triangles = np.asarray(triangles, np.int64).reshape(-1, 3)
    used = np.unique(triangles)
    index = np.full(len(vertices), -1, np.int64)
    index[used] = np.arange(len(used))
    V = np.ascontiguousarray(vertices[used])
    T = index[triangles]
    a, b, c = V[T[:, 0]], V[T[:, 1]], V[T[:, 2]]
    n = np.cross(b - a, c - a)
    length = np.linalg.norm(n, axis=1)
    if not np.all(length > 0):
        raise ValueError(f"triangle {int(np.argmin(length))} of the hull is degenerate (collinear vertices)")
    n /= length[:, None]
    n[np.einsum("ij,ij->i", n, a - V.mean(0)) < 0] *= -1.0
    pairs = np.sort(np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [0, 2]]]), axis=1)
    edges = np.unique(pairs, axis=0).astype(np.int32)
    return Hull(V, np.ascontiguousarray(edges), np.ascontiguousarray(n), np.ascontiguousarray(T.astype(np.int32)))


def mesh_graph_hull(mesh_graph, graphadr, mesh_vert, vertadr, vertnum):
    """The Hull of one mesh as MuJoCo collides it, from a model's arrays (MuJoCo's MjModel or MuJoCo Warp's Model,
    as numpy): its convex graph at graphadr in mesh_graph (numvert, numface, vert_edgeadr (numvert), vert_globalid
    (numvert), edge_localid (numvert + 3 numface), face_globalid (3 numface): the hull's triangles as indices into
    the mesh's vertices) and its vertices mesh_vert[vertadr : vertadr + vertnum] (float32, in the geom's frame)
    widened.  ValueError when the mesh has no graph (graphadr -1) or a degenerate triangle."""
    if graphadr < 0:
        raise ValueError("the mesh has no convex hull in the model (mesh_graphadr -1)")
    g = np.asarray(mesh_graph)[graphadr:]
    nv, nf = int(g[0]), int(g[1])
    faces = g[2 + 3 * nv + 3 * nf : 2 + 3 * nv + 6 * nf].reshape(nf, 3)
    return from_triangles(np.asarray(mesh_vert[vertadr : vertadr + vertnum], float), faces)


def convex_hull(points):
    """The Hull of the convex hull of points (m, 3), m >= 4 not all in a plane; ValueError naming the
    argument otherwise."""
    from scipy.spatial import ConvexHull, QhullError

    p = np.asarray(points, float)
    if p.ndim != 2 or p.shape[1] != 3 or len(p) < 4:
        raise ValueError(f"points must be (m, 3) with m >= 4, got shape {p.shape}")
    if not np.all(np.isfinite(p)):
        raise ValueError("points must be finite")
    try:
        h = ConvexHull(p)
    except QhullError:
        raise ValueError("points must span a volume (they are coplanar, collinear or coincident)") from None
    return from_triangles(p, h.simplices)


def check_hull(hull):
    """The Hull's arrays as the kernel reads them (C-contiguous float64 and int32), checked: shapes, finite
    numbers, unit normals, indices of existing vertices; ValueError naming the field otherwise."""
    if not isinstance(hull, Hull):
        raise ValueError(f"hull must be an ellipsim Hull, got {type(hull).__name__}")
    v = np.ascontiguousarray(hull.vertices, np.float64)
    n = np.ascontiguousarray(hull.normals, np.float64)
    e, f = (np.asarray(x) for x in (hull.edges, hull.faces))
    if v.ndim != 2 or v.shape[1] != 3 or len(v) < 4:
        raise ValueError(f"hull.vertices must be (nv, 3) with nv >= 4, got shape {v.shape}")
    if f.ndim != 2 or f.shape[1] != 3 or len(f) < 4 or n.shape != f.shape:
        raise ValueError(f"hull.faces (nf, 3) and hull.normals (nf, 3) must match, got {f.shape} and {n.shape}")
    if e.ndim != 2 or e.shape[1] != 2 or len(e) < 6:
        raise ValueError(f"hull.edges must be (ne, 2) with ne >= 6, got shape {e.shape}")
    for name, x in (("edges", e), ("faces", f)):
        if not np.issubdtype(x.dtype, np.integer) or x.min() < 0 or x.max() >= len(v):
            raise ValueError(f"hull.{name} must be integer indices of its {len(v)} vertices")
    if not (np.all(np.isfinite(v)) and np.all(np.isfinite(n))):
        raise ValueError("hull.vertices and hull.normals must be finite")
    if np.any(np.abs(np.linalg.norm(n, axis=1) - 1.0) > 1e-9):
        raise ValueError("hull.normals must be unit vectors")
    return Hull(v, np.ascontiguousarray(e, np.int32), n, np.ascontiguousarray(f, np.int32))


def as_hull(hull):
    """A Hull checked (check_hull), or the convex hull of points (m, 3) (convex_hull)."""
    if isinstance(hull, Hull):
        return check_hull(hull)
    return convex_hull(hull)
