"""The geometry core: ellipsoids, their exact relation, the Perram-Wertheim scale, signed distance.

numpy and the compiled core (ellipsim/native, C++): nothing here imports MuJoCo, rerun or trimesh
(tests/test_layout.py checks).
"""
