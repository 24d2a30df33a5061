"""Signed distance of an ellipsoid and another shape, one module per pair type (as coal's src/distance/):
point-ellipsoid primitives, capsule, box, cylinder.

Imports nothing: import the module you need (tests/test_layout.py checks).
"""
