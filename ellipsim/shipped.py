"""The folders shipped with ellipsim: models/ (MJCF) and scenarios/ (TOML).

Installed, they are the packages ``ellipsim.models`` and ``ellipsim.scenarios`` (see pyproject's
package-dir). Imported from a source checkout (``python -m pytest`` in the repository puts the
checkout's ``ellipsim/`` first on sys.path), those packages do not exist; the folders are then the
top-level ones next to ``ellipsim/``.
"""

import importlib.resources
import pathlib


def folder(name):
    """A Traversable for the shipped folder ``name`` ("models" or "scenarios")."""
    try:
        return importlib.resources.files(f"ellipsim.{name}")
    except ModuleNotFoundError:
        path = pathlib.Path(__file__).resolve().parent.parent / name
        if not path.is_dir():
            raise FileNotFoundError(f"ellipsim's {name}/ folder is missing (looked for {path})") from None
        return path


def source_checkout():
    """The root of the source checkout this ellipsim runs from (a folder with ellipsim's
    pyproject.toml next to the package: an editable install, or `python -m` in the checkout), or
    None for an installed copy."""
    root = pathlib.Path(__file__).resolve().parent.parent
    try:
        text = (root / "pyproject.toml").read_text(encoding="utf-8")
    except OSError:
        return None
    return root if 'name = "ellipsim"' in text else None
