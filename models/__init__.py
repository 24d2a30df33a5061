"""MJCF models shipped with ellipsim (installed as the ellipsim.models package)."""
