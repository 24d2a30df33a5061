"""Signed distance of two ellipsoids with a proven global maximum: Newton on the sphere, the branch
and bound over the sphere, the spheroid cases, the ellipsoid pair.

Imports nothing: import the module you need (tests/test_layout.py checks).
"""
