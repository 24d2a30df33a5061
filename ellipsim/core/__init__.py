"""The geometry core: ellipsoids, their exact relation, the Perram-Wertheim scale, signed distance.

Pure numpy and numba: nothing here imports MuJoCo, rerun or trimesh (tests/test_layout.py checks).
"""
