"""Moving ellipsoids: the rigid motion between two poses, time of impact, the swept broad phase.

Imports nothing: import the module you need (tests/test_layout.py checks).
"""
