"""A one-shot proof that a deep local maximum of sigma is global: the internal ellipsoid of A + (-B)
tangent in the contact direction (Kurzhanski & Valyi, Ellipsoidal Calculus for Estimation and Control,
1997, sec. 2.3: internal approximations of a sum of ellipsoids).

In A's principal frame (as branch_and_bound.py) sigma(n) = n.e - |F_A n| - |F_B n| with F_A = diag(a),
F_B = diag(b) U^T, and max over unit n of sigma is the signed distance of the point e to the centred
Minkowski sum M = A + B (support h_A + h_B).  For any orthogonal S, X = S F_A + F_B has |X n| <=
|F_A n| + |F_B n| (triangle inequality), so the ellipsoid Q = X^T (unit ball) lies inside M and

    max sigma <= sd(e, Q) = -dist(e, boundary of Q)    (e inside Q).

Choosing S to turn F_A n* / h_A(n*) onto F_B n* / h_B(n*) at the local maximum n* makes Q touch M there
with the same support point: sd(e, Q) = sigma(n*) exactly when the ball of radius -sigma(n*) about e
fits in Q, which the remaining freedom of S (a turn or a reflection about that direction) serves: it
is chosen to maximise the smallest curvature radius of Q at the contact, (the smallest singular value
of S' M_A + M_B)^2 / (h_A + h_B) with M_A, M_B the two bodies' tangent maps, over 8 turns and 8
reflections.  dist(e, boundary Q)^2 >= g(t) = t (e^T (W + t I)^-1 e - 1) for every t > -lambda_min(W),
W = X^T X (Lagrangian weak duality, as pairs/point_ellipsoid.hpp's bound in Q's principal frame), with equality
at t* = sigma(n*) (h_A(n*) + h_B(n*)) when the bound is tight: no eigen-decomposition and no root
finding.  On leaves.xml's deep contacts and random deep crossings (generic, 8:1 elongated, 25:1:1/10
leaves) it proves 89-99 % of the first runs' maxima for ~0.3 us; the rest go to the branch and bound.

Rounding (u = 2^-53; every bound below is taken outwards): the float S has |S n| <= (1 + eta) |n| with
eta from its computed orthonormality defect, the float X differs from S F_A + F_B by <= 6.1 u (max a +
max b) in norm (both add to max sigma <= sd(e, Q) + eps1); W + t I is formed and Cholesky-factored in
float, L L^T = K + E with |E| <= gamma_4 |L||L^T| (Higham, Accuracy and Stability of Numerical
Algorithms, 2nd ed., Thm 10.3) plus the rounding of forming K; lambda_min(L L^T) >= 1 / |L^-1|_F^2 from
the explicit 3x3 triangular inverse; the forward substitution's backward error |dL| <= gamma_3 |L|
(Thm 8.5).  Then e^T K^-1 e <= |y|^2 (1 + gamma_3 N |L|_F)^2 / (1 - |E| lambda_lo^-1), N >= |L^-1|_F.
"""
