"""A program file's ``[wrench]`` table: its breakpoints read, and interpolated at the cycles.

Format: ``docs/programs.md`` ("[wrench]"). :func:`read_wrench` checks the table (a
:class:`mrnea.io.tomlcheck.TomlCheck` names the file and the key at fault); :func:`wrench_at`
gives the wrench of every cycle, for a path when the file is read and for a Cartesian program
once its moves are solved (:mod:`mrnea.cartesian.solve`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mrnea.io.dispatch import flange_of
from mrnea.io.tomlcheck import TomlCheck

__all__ = ["POINT_FRAMES", "WRENCH_KEYS", "read_wrench", "wrench_at"]

WRENCH_KEYS = ("times", "values", "point", "point_frame")
#: The frames ``[wrench] point`` may be given in: the last link's frame (the default, what
#: :func:`mrnea.simulate.simulate` takes) or, for a robot given by a DH table, DH frame n.
POINT_FRAMES = ("link", "flange")


def wrench_at(times: NDArray, values: NDArray, t: NDArray) -> NDArray[np.float64]:
    """(K, 6) the wrench of a ``[wrench]`` table's breakpoints (times (W,) [s], values (W, 6)
    [N, N m]) at the cycle times t (K,) [s]: linear between them, held before and after."""
    f_ext = np.empty((t.size, 6))
    for c in range(6):
        f_ext[:, c] = np.interp(t, times, values[:, c])
    return f_ext


def read_wrench(check: TomlCheck, table: Mapping[str, Any], robot: str | None
                ) -> tuple[NDArray, NDArray, NDArray | None]:
    """(times (W,) [s], values (W, 6) [N, N m], point (3,) [m] in the last link's frame or
    None) of a ``[wrench]`` table (docs/programs.md); ``robot`` the program's robot spec (a
    ``"flange"`` point needs a DH robot). ProgramFileError naming the key at fault."""
    where = "[wrench]"
    check.check_keys(table, WRENCH_KEYS, where)
    times = check.vector(check.require(table, "times", where), where, "times")
    if np.any(np.diff(times) <= 0):
        k = int(np.argmax(np.diff(times) <= 0)) + 1
        raise check.error(where, f"'times' must be strictly increasing: times[{k}] = "
                                 f"{times[k]} follows {times[k - 1]}")
    values = check.matrix(check.require(table, "values", where), where, "values", width=6,
                          rows=times.size)
    point = None
    if "point" in table:
        point = check.vector(table["point"], where, "point", 3)
    frame = table.get("point_frame", "link")
    if frame not in POINT_FRAMES:
        raise check.error(where, f"'point_frame' must be one of "
                                 f"{', '.join(map(repr, POINT_FRAMES))}, got {frame!r}")
    if frame == "flange":  # DH frame n -> the last link's frame: p_link = B_n p_flange
        B = flange_of(robot)
        if B is None:
            raise check.error(where, f"point_frame = 'flange' needs a robot given by a DH table "
                                     f"(dh = \"standard\" or \"modified\"); {robot} is not")
        p = np.zeros(3) if point is None else point
        point = B[:3, :3] @ p + B[:3, 3]
    for a in (times, values, point):
        if a is not None:
            a.setflags(write=False)
    return times, values, point
