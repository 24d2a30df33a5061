"""Exact relations on the float64 inputs: the pair in A's frame, the certified filter, the rational
fallback, the thesis's set-ups and root tests, the Perram-Wertheim scale, classify and contains.

Imports nothing: import the module you need (tests/test_layout.py checks).
"""
