"""Load a robot file of any supported format, chosen by the file's suffix."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from mrnea.errors import RobotFileError
from mrnea.model import Robot

__all__ = ["SUFFIXES", "load_robot"]

#: Supported suffixes (case-insensitive) and the format each one selects.
SUFFIXES = {".urdf": "URDF", ".xml": "URDF", ".toml": "native TOML"}


def load_robot(path: str | Path, **kw: Any) -> Robot:
    """Load a robot file, choosing the reader from the file's suffix.

    Parameters
    ----------
    path : str or Path
        ``.urdf`` or ``.xml``: read by :func:`mrnea.io.urdf.load_urdf`; ``.toml``: read by
        :func:`mrnea.io.native.load_native`. The suffix is matched case-insensitively.
    **kw
        Passed on to the reader (e.g. ``tip=`` for URDF).

    Returns
    -------
    Robot
        The validated robot (frames and units as documented in :mod:`mrnea.model`).

    Raises
    ------
    RobotFileError
        Unsupported suffix (the message lists the supported ones), or any error of the reader.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix in (".urdf", ".xml"):
        from mrnea.io.urdf import load_urdf

        return load_urdf(path, **kw)
    if suffix == ".toml":
        from mrnea.io.native import load_native

        return load_native(path, **kw)
    supported = ", ".join(f"{s} ({fmt})" for s, fmt in SUFFIXES.items())
    raise RobotFileError(
        f"{path}: unsupported robot file suffix {path.suffix or '(none)'!r}; supported: {supported}"
    )
