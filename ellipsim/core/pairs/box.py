"""Signed distance of an ellipsoid and a box with a proven global maximum (MuJoCo's ellipsoid x box
narrow phase).

Method: max over unit n of sigma(n) = n.e - h_E(n) - h_K(n) (ellipsoid_pair.py), split into the smooth
strata of the box's support function, each solved globally by Eberly's secular equation
(pairs/point_ellipsoid.hpp; Eberly, "Distance from a point to an ellipse, an ellipsoid, or a
hyperellipsoid", sec. 2-3; GTCG 10.5.2), certified by two convex-duality bounds or by enumerating
every critical point.  Same contract and conventions as capsule.py.

The box K = sum_j r_j [-1, 1] v_j centred at e (v_j its axes in E's principal frame; orthonormal to
rounding from MuJoCo C's float64 rotations, only to ~1e-7 from MuJoCo Warp's float32 ones: K is then the
parallelepiped they span, and face_normal, edge_plane, sd_point_box and upper_bound2 compute for it), so
h_K(n) = sum_j r_j |n.v_j| and sigma is smooth except on the three great circles n.v_j = 0.  Its
strata: the 8 open octants (vertex contacts: sigma = f_q(n) = n.q - h_E(n), q = e minus the box
vertex facing E), the 12 open quarter circles (edge contacts: the 2-D point-ellipse problem in the
plane of the other two axes, q = e minus the edge's midpoint) and the 6 face normals (face contacts).

Local solve (an active set): per box axis, either n.v_j = 0 is imposed (the contact feature extends
along v_j) or the sign of n.v_j is fixed; each state's piece is solved globally (foot3, the projected
ellipse's foot2, or a face normal).  KKT at the result: a free axis whose sign flipped becomes active;
an active axis whose witness coordinate y_j = (e - s_E(n) - sigma n).v_j leaves [-r_j, r_j] is freed
with the sign of y_j.  It starts at the best face normal, so a flush face (the usual resting contact)
costs one support evaluation per face.

Certificates (global upper bounds on max sigma, any unit n; concavity of h on R^3):
* ub1 = sd(e - s_E(n) + rho n, K) - rho, rho the rolling radius of E (E = E' + ball(rho)): the exact
  point-box signed distance.  Tight when separated or shallow.
* ub2 = sd(e - c, E) - t for a ball(c, t) inside K, c the witness clamped into K (t > 0 only for a
  face contact: the largest ball in K tangent to that face at c), sd bounded above by weak duality.
When neither closes (deep crossings), a branch and bound over the 26 pieces (enumerate_max): a piece
whose extended smooth function's certified maximum does not beat the incumbent is skipped, one whose
maximiser lies inside it is taken whole, the others have every critical point evaluated: a complete
case analysis, status ENUMERATED.  Before that, a negative incumbent lets whole closed octants (a vertex
piece with its three edges and corners) and edge arcs be skipped by tangent planes of h_E
(tangent_cones.py): three dot products a node.

Ported from the validated pair-type prototype (10 000 poses: never below a 20 000-direction reference
by more than 1e-12 of the smaller shortest half-size; every maximum certified or enumerated).
"""

#: How box_ellipsoid proved its maximum (as capsule.py): CERTIFIED or ENUMERATED, both proofs.
CERTIFIED, ENUMERATED = 0, 1
#: state value of an axis in the local solve: n.v_j = 0 imposed (else the sign +1 / -1 of n.v_j)
ACTIVE = 0
#: active-set switches of the local solve before it hands over to the certificates / enumeration
MAX_SWITCHES = 8
#: the tangent-plane tests' disc axis: none (r = 0, a box has no disc part)
NO_AXIS = (0.0, 0.0, 1.0)
