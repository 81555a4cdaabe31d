"""A program file's ``[wrench]`` table(s): breakpoints read, and interpolated at the cycles.

Format: ``docs/programs.md`` ("[wrench]"). :func:`read_wrenches` reads one ``[wrench]`` table or
several (``[[wrench]]``, each with its ``link``); :func:`read_wrench` checks one table (a
:class:`mrnea.io.tomlcheck.TomlCheck` names the file and the key at fault); :func:`wrench_at`
gives the wrench of every cycle, for a path when the file is read and for a Cartesian program
once its moves are solved (:mod:`mrnea.cartesian.solve`); :func:`wrenches_on` does it for
wrenches on named links, once the robot is known (their names are checked there).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mrnea.errors import ProgramFileError, quote
from mrnea.frozen import MAGNITUDES
from mrnea.io.dispatch import flange_of
from mrnea.io.tomlcheck import TomlCheck
from mrnea.model import Robot
from mrnea.validate import WRENCH_BOUND

__all__ = ["POINT_FRAMES", "WRENCH_KEYS", "LinkWrenches", "read_wrench", "read_wrenches",
           "wrench_at", "wrenches_on"]

WRENCH_KEYS = ("times", "values", "point", "point_frame", "link")
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


class LinkWrenches(dict):
    """Wrenches on named links, as a program file gives them: ``{link: (times (W,) [s], values
    (W, 6) [N, N m], point (3,) [m] in that link's frame or None)}``, the key None for a table
    without ``link`` (the last link; a Cartesian program's TCP)."""


def read_wrenches(check: TomlCheck, given: Any, robot: str | None
                  ) -> tuple[tuple[NDArray, NDArray] | LinkWrenches, NDArray | None]:
    """A program's ``[wrench]`` (one table) or ``[[wrench]]`` (a list of tables): (wrench,
    point). One table without ``link``: ``(times, values)`` and its point (3,) or None, the
    last link's wrench as before. Otherwise a :class:`LinkWrenches` and None (the points are
    in it); two tables on one link are added (:func:`added`)."""
    tables = given if isinstance(given, list) else [check.table(given, "top level", "wrench")]
    if not tables:
        raise check.error("top level", "'wrench' is an empty list: give at least one [[wrench]]")
    read = [read_wrench(check, check.table(t, "top level", f"wrench[{k}]"), robot,
                        "[wrench]" if len(tables) == 1 else f"[[wrench]] {k + 1}")
            for k, t in enumerate(tables)]
    if len(read) == 1 and read[0][0] is None:
        return read[0][1:3], read[0][3]
    out = LinkWrenches()
    for k, (link, *here) in enumerate(read):
        if link in out:
            here = added(out[link], here, f"{check.source}: [[wrench]] {k + 1}", link)
        out[link] = tuple(here)
    return out, None


def added(a: tuple, b: tuple, where: str, link: str | None) -> tuple:
    """Two wrench tables on one link, (times, values, point) each, as one: their sum at every
    instant (each linear between its breakpoints and held outside them, so the sum is so
    between the union of the breakpoints). Both must act at the same point (or both at the
    link frame's origin; no point and ``point = [0, 0, 0]`` are the same): wrenches at two
    points add only through the link's pose, which the table cannot know; a ProgramFileError
    naming ``where`` and the link says so."""
    pa, pb = a[2], b[2]
    if not np.array_equal(_ORIGIN if pa is None else pa, _ORIGIN if pb is None else pb):
        raise ProgramFileError(
            f"{where}: a second wrench on link {quote(link or 'the last link')} at another "
            f"point ({_point(pb)} against {_point(pa)}): wrenches on one link add only at one "
            f"point; give their sum at one point (each force's moment about it added)")
    times = np.union1d(a[0], b[0])
    values = wrench_at(*a[:2], times) + wrench_at(*b[:2], times)
    for x in (times, values):
        x.setflags(write=False)
    return times, values, pb if pa is None else pa


_ORIGIN = np.zeros(3)


def _point(p: NDArray | None) -> str:
    return "the link frame's origin" if p is None else f"point {p.tolist()}"


def wrenches_on(wrenches: LinkWrenches, robot: Robot, t: NDArray, where: str,
                tcp: tuple[int, NDArray] | None = None
                ) -> tuple[dict[str, NDArray], dict[str, NDArray]]:
    """``f_ext`` and ``f_ext_point`` by link name (what :func:`mrnea.simulate.simulate` takes)
    of ``wrenches`` at the cycle times t (K,) [s] on ``robot``: each link's (K, 6) wrench and
    its point (3,) where given. A table without ``link`` acts on the last link, or with ``tcp``
    (a Cartesian program's tool: its link's index and point (3,) [m] in that link's frame) on
    the tool's link, at the tool point unless it gives a ``point``. A link the robot does not
    have is a ProgramFileError naming ``where`` (the file) and the link, with a close match."""
    tables: dict[str, tuple] = {}
    for link, (times, values, point) in wrenches.items():
        name = (robot.link_names[-1 if tcp is None else tcp[0]] if link is None else
                robot.link_names[robot.link_index(link, f"{where}: [wrench] 'link'",
                                                  ProgramFileError)])
        here = (times, values, tcp[1] if point is None and link is None and tcp is not None
                else point)
        if name in tables:  # the last link named and a table without 'link'
            here = added(tables[name], here, f"{where}: [wrench]", name)
        tables[name] = here
    f_ext, points = {}, {}
    for name, (times, values, point) in tables.items():
        f_ext[name] = wrench_at(times, values, t)
        f_ext[name].setflags(write=False)
        if point is not None:
            points[name] = point
    return f_ext, points


def read_wrench(check: TomlCheck, table: Mapping[str, Any], robot: str | None,
                where: str = "[wrench]") -> tuple[str | None, NDArray, NDArray, NDArray | None]:
    """(link or None, times (W,) [s], values (W, 6) [N, N m], point (3,) [m] in that link's
    frame (the last link's for None) or None) of a ``[wrench]`` table (docs/programs.md);
    ``robot`` the program's robot spec (a ``"flange"`` point needs a DH robot). ProgramFileError
    naming ``where`` and the key at fault."""
    check.check_keys(table, WRENCH_KEYS, where)
    link = check.string(table["link"], where, "link") if "link" in table else None
    times = check.vector(check.require(table, "times", where), where, "times")
    if np.any(np.diff(times) <= 0):
        k = int(np.argmax(np.diff(times) <= 0)) + 1
        raise check.error(where, f"'times' must be strictly increasing: times[{k}] = "
                                 f"{times[k]} follows {times[k - 1]}")
    values = check.matrix(check.require(table, "values", where), where, "values", width=6,
                          rows=times.size)
    if np.abs(values).max() > WRENCH_BOUND:
        r = int(np.argmax(np.abs(values).max(axis=1)))
        raise check.error(where, f"'values' row {r + 1}: {np.abs(values[r]).max():.3g} is beyond "
                                 f"{WRENCH_BOUND:g} N (or N m), the largest wrench mrnea "
                                 f"accepts; check its units")
    point = None
    if "point" in table:
        point = check.vector(table["point"], where, "point", 3)
        if np.abs(point).max() > MAGNITUDES["length"]:
            raise check.error(where, f"'point' {np.abs(point).max():.3g} m is beyond "
                                     f"{MAGNITUDES['length']:g} m, the largest length mrnea "
                                     f"accepts; check its units")
    frame = table.get("point_frame", "link")
    if frame not in POINT_FRAMES:
        raise check.error(where, f"'point_frame' must be one of "
                                 f"{', '.join(map(repr, POINT_FRAMES))}, got {frame!r}")
    if frame == "flange" and link is not None:
        raise check.error(where, "point_frame = 'flange' is DH frame n, on the last link: give "
                                 "a named link's point in its own frame ('link')")
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
    return link, times, values, point
