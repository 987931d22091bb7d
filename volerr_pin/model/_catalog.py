"""The machines shipped with volerr_pin: where they are and their names.

A module of its own, importing nothing of the model, so that listing the machines (the command
line's completion of a machine name, its "did you mean") does not load Pinocchio.
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["SPEC_FILE", "bundled_machines", "machines_dir"]

SPEC_FILE = "errors.toml"


def machines_dir() -> Path:
    """Folder of the bundled machines (``VOLERR_MACHINES`` overrides it).

    Returns
    -------
    Path
        The ``VOLERR_MACHINES`` environment variable when it is set (whether or not the folder
        exists); otherwise the first existing folder of ``machines/`` beside the package and
        ``machines/`` inside it; otherwise ``machines/`` beside the package.
    """
    env = os.environ.get("VOLERR_MACHINES")
    if env:
        return Path(env)
    here = Path(__file__).resolve().parents[1]   # the package (this module is in its model/)
    for candidate in (here.parent / "machines", here / "machines"):
        if candidate.is_dir():
            return candidate
    return here.parent / "machines"


def bundled_machines() -> list[str]:
    """Names of the machines shipped with volerr_pin.

    Returns
    -------
    list of str
        Sorted names of the sub-folders of :func:`machines_dir` that hold an ``errors.toml``;
        empty when that folder does not exist.
    """
    root = machines_dir()
    return sorted(p.name for p in root.iterdir() if (p / SPEC_FILE).is_file()) if root.is_dir() else []
