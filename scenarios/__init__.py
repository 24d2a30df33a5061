"""Scenario files shipped with ellipsim (installed as the ellipsim.scenarios package)."""
