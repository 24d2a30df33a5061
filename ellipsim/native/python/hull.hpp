// A convex hull as the bindings hand it to pairs/polytope.hpp: the arrays checked (every index a vertex of the
// hull, one normal per triangle) and its adjacency built once per call by polytope.hpp's build_adjacency, the
// builder every caller shares (the kernel's descent and fans rest on it being exactly the edges' and triangles').
#pragma once

#include <ellipsim/pairs/polytope.hpp>

#include "common.hpp"

namespace ellipsim::binding {

using EdgeArray = In<std::int32_t, nb::shape<-1, 2>>;
using FaceArray = In<std::int32_t, nb::shape<-1, 3>>;

struct BoundHull {
  std::vector<int> adj_start, adj, vface_start, vface;
  pairs::polytope::Hull H;

  BoundHull(const Centers<>& vertices, const EdgeArray& edges, const Centers<>& normals, const FaceArray& faces)
      : H{int(vertices.shape(0)), int(edges.shape(0)), int(normals.shape(0)), vertices.data(),
          edges.data(),           normals.data(),     faces.data()} {
    for (int k = 0; k < 2 * H.ne; ++k)
      if (H.edge[k] < 0 || H.edge[k] >= H.nv) throw std::out_of_range("an edge names a vertex the hull lacks");
    if (static_cast<int>(faces.shape(0)) != H.nf) throw std::invalid_argument("one normal per face");
    for (int k = 0; k < 3 * H.nf; ++k)
      if (H.face[k] < 0 || H.face[k] >= H.nv) throw std::out_of_range("a face names a vertex the hull lacks");
    adj_start.resize(H.nv + 1), adj.resize(2 * std::size_t(H.ne)), vface_start.resize(H.nv + 1),
        vface.resize(3 * std::size_t(H.nf));
    pairs::polytope::build_adjacency(H.nv, H.ne, H.nf, H.edge, H.face, adj_start.data(), adj.data(),
                                     vface_start.data(), vface.data());
    H.adj_start = adj_start.data(), H.adj = adj.data(), H.vface_start = vface_start.data(), H.vface = vface.data();
  }

  // The scratch polytope_ellipsoid takes for this hull, once per call.
  std::vector<double> scratch() const { return std::vector<double>(pairs::polytope::scratch_size(H.nv, H.nf)); }
};

}  // namespace ellipsim::binding
