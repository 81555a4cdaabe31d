"""The :class:`Program` value: a robot program ready to run, and how it is put on a robot.

:func:`mrnea.io.program.load_program` reads a program file into one (format:
``docs/programs.md``); :meth:`Program.load_robot` loads the robot it names and
:meth:`Program.on` puts its path in that robot's joint order (a program naming its joints:
:mod:`mrnea.io.jointnames`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from mrnea.errors import ProgramFileError, StateError, quote, shorten
from mrnea.io.dispatch import RobotOptions, load_robot_spec, resolve_robot, same_robot
from mrnea.io.jointnames import CsvHeader, NamedPath, column_order, named_rows
from mrnea.io.moves import Moves
from mrnea.io.pathcsv import limit_warnings
from mrnea.io.wrench import LinkWrenches, wrench_at, wrenches_on
from mrnea.model import Robot

__all__ = ["Program"]


@dataclass(frozen=True, eq=False)
class Program:
    """A robot program ready for :func:`mrnea.simulate.simulate`, read by :func:`load_program`.

    Run it with ``simulate(prog.load_robot(), prog.q_cmd, prog.dt, f_ext=prog.f_ext,
    f_ext_point=prog.f_ext_point)``, adding ``mode=prog.mode`` when the program sets one.

    Attributes
    ----------
    robot : a built-in robot name (``sdt``, ``puma560``) or the path of a robot file, resolved
        relative to the program file's folder; None if the program names no robot (it then
        runs on a robot given to :meth:`load_robot`).
    options : what the program changes in its robot (``actuators``, ``tip``, ``payload``,
        ``gravity``; paths resolved relative to the program file's folder).
    dt : interpolation cycle [s].
    t : (K,) cycle times [s] (``k dt`` for waypoint paths, the CSV's clock for CSV paths).
    q_cmd : (K, n) commanded joint positions [rad | m].
    f_ext : (K, 6) wrench ``[f; n]`` [N, N m] the end effector exerts on its environment, base
        frame, one row per cycle; None: no external wrench.
    f_ext_point : (3,) point [m] where f_ext acts, in the last link's frame (mrnea's link frame
        n, not the DH frame n of the paper; a program may give it in DH frame n with
        ``point_frame = "flange"``, converted here); None: the last link frame's origin.
    mode : ``"hybrid"``, ``"paper"`` or None (the simulator's default).
    name : the program's name.
    source : the program file it was read from (for messages).
    csv : the CSV file of a CSV path (None for waypoints; for messages).
    interpolation : how a CSV path's rows were resampled to dt (a name of
        :data:`mrnea.io.pathcsv.INTERPOLATIONS`); None for a waypoint path.
    csv_rows : (R, 1 + n) the CSV path's rows, time [s] and positions [rad | m]; None for a
        waypoint path.
    moves : a Cartesian program's tool, q0 and ``[[move]]`` tables (:class:`mrnea.io.moves.Moves`);
        None for a joint path. Such a program's ``t`` and ``q_cmd`` are None until
        :func:`mrnea.cartesian.solve` makes them with the robot (``mrnea.load_program`` does).
    cartesian : the solved Cartesian path (:class:`mrnea.cartesian.CartesianPath`: the programmed
        tool pose of every cycle, the move it belongs to, the inverse kinematics' errors and the
        verdict), kept alongside q_cmd; None for a joint path or before solving.
    named : a path of waypoint tables by joint name (:class:`mrnea.io.jointnames.NamedPath`);
        ``t``, ``q_cmd`` (and ``f_ext``) are None until :meth:`on` makes them on a robot.
    wrench : a Cartesian program's or a named path's ``[wrench]`` breakpoints (times (W,) [s]
        from its first cycle, values (W, 6) [N, N m]), made into ``f_ext`` (a Cartesian
        program's ``f_ext_point`` defaulted to the tool point) when it is solved (:meth:`on`
        for a named path); or wrenches on named links (``[[wrench]]`` tables or a ``link``
        key: a :class:`mrnea.io.wrench.LinkWrenches`), made into ``f_ext`` and
        ``f_ext_point`` by link name (``{link: (K, 6)}``, ``{link: (3,)}``, as
        :func:`mrnea.simulate.simulate` takes them) on the robot, where the names are checked
        (:meth:`on`, :func:`mrnea.cartesian.solve`); None otherwise.
    columns : a CSV path's header (time first), matched to a robot's joint names by :meth:`on`
        where it names them (:func:`mrnea.io.jointnames.column_order`); None for waypoints.
    units : the ``[path]``'s ``units``: ``"deg"`` reads revolute joints in degrees and prismatic
        ones in mm, as ``--units deg`` reads a CSV; q_cmd and csv_rows are SI either way once
        the robot is known (:meth:`apply_units`).

    The arrays are read-only.
    """

    robot: str | None
    dt: float
    t: NDArray[np.float64] | None
    q_cmd: NDArray[np.float64] | None
    f_ext: NDArray[np.float64] | None
    f_ext_point: NDArray[np.float64] | None
    mode: Literal["hybrid", "paper"] | None
    name: str
    source: str = ""
    options: RobotOptions = field(default_factory=RobotOptions)
    csv: str | None = None
    interpolation: str | None = None
    csv_rows: NDArray[np.float64] | None = None
    moves: Moves | None = None
    cartesian: Any = None
    named: NamedPath | None = None
    wrench: tuple[NDArray[np.float64], NDArray[np.float64]] | LinkWrenches | None = None
    columns: CsvHeader | None = None
    units: Literal["rad", "deg"] = "rad"
    _mm_pending: bool = field(default=False, repr=False)

    @property
    def K(self) -> int:
        """Number of cycles."""
        if self.q_cmd is None:
            raise StateError(f"{self.source or self.name}: " + (
                "a program naming its joints has no cycles before it is put on a robot: "
                "program.on(robot)" if self.named else
                "a Cartesian program has no cycles before its inverse kinematics: "
                "mrnea.cartesian.solve(program, robot)") + " (mrnea.load_program does it)")
        return int(self.q_cmd.shape[0])

    @property
    def n(self) -> int:
        """Number of joints (a path of waypoint tables: those it names)."""
        if self.named is not None and self.q_cmd is None:
            return len({name for w in self.named.waypoints for name in w})
        return self.moves.n if self.q_cmd is None else int(self.q_cmd.shape[1])

    @property
    def duration(self) -> float:
        """``(K - 1) dt`` [s]: from the first to the last cycle."""
        return (self.K - 1) * self.dt

    def load_robot(self, robot: str | None = None, options: RobotOptions | None = None
                   ) -> Robot:
        """The robot to run the program on, with the program's options and ``options`` over them.

        Parameters
        ----------
        robot : a robot given besides the program (the command line's ROBOT: a built-in name
            or a path relative to the current folder); None: the one the program names. When
            both are given they must be the same robot (the same built-in, or the same file
            under any path), compared before any option is applied.
        options : options that replace the program's where they are set (the command line's).

        Raises
        ------
        ProgramFileError
            No robot at all, a ``robot`` other than the program's, or a robot whose joint count
            differs from the program's (the message names the file and both counts).
        RobotFileError
            If the robot file cannot be read.
        """
        where = self.source or self.name
        if robot is not None:
            source = resolve_robot(robot)
            if self.robot is not None and not same_robot(source, self.robot):
                raise ProgramFileError(
                    f"robot {quote(robot)} is not the robot {where} names ({self.robot}); "
                    f"give either the program alone or its own robot")
        elif self.robot is None:
            raise ProgramFileError(f"{where}: the program names no robot ([program] robot); "
                                   f"give one (ROBOT PROGRAM on the command line)")
        else:
            source = self.robot
        loaded = load_robot_spec(source, options=(options or RobotOptions()).over(self.options))
        if self.named is not None or (self.moves is not None and isinstance(self.moves.q0,
                                                                            dict)):
            return loaded  # names checked on the robot where the rows are made
        if self._order(loaded) is None and loaded.n != self.n:
            what = (f"its CSV path {self.csv} has {self.n} joint columns" if self.csv else
                    f"[program] q0 has {self.n} joint values" if self.moves else
                    f"{self.n} joint values per waypoint")
            raise ProgramFileError(f"{where}: {what}, robot {shorten(loaded.name)} has "
                                   f"{loaded.n}")
        self.apply_units(loaded)
        self.check_path(loaded)
        return loaded

    def apply_units(self, robot: Robot) -> None:
        """Give a ``units = "deg"`` path's prismatic joints their mm, as ``--units deg`` does
        for a CSV (docs/programs.md). The file does not say which joints are prismatic, so
        every column is parsed as degrees (x pi/180); this rescales q_cmd's and csv_rows'
        columns of ``robot``'s prismatic joints to mm (x 1e-3) once the robot is known (in
        ``robot``'s joint order: :meth:`load_robot`, :meth:`on` and a sweep's programs call
        it). Exact for both kinds of path (a profile and a resampling are linear in the
        waypoints and limits scaled alike), once per program (the arrays stay read-only);
        nothing for a path in rad or a robot without prismatic joints, or a robot of another
        joint count (its caller refuses that) or
        whose CSV header names its joints in another order (:meth:`on` scales them reordered)."""
        if (not self._mm_pending or self.q_cmd is None or not any(robot.is_prismatic)
                or self.n != robot.n):
            return
        order = self._order(robot)
        if order is not None and not np.array_equal(order, np.arange(1, robot.n + 1)):
            return  # columns named out of the robot's order: on() scales them once reordered
        f = np.where(robot.is_prismatic, 1e-3 * 180.0 / np.pi, 1.0)
        for name, a in (("q_cmd", self.q_cmd), ("csv_rows", self.csv_rows)):
            if a is not None:
                a = a * (f if name == "q_cmd" else np.concatenate([[1.0], f]))
                a.setflags(write=False)
                object.__setattr__(self, name, a)  # the frozen dataclass's arrays, replaced
        object.__setattr__(self, "_mm_pending", False)

    def _order(self, robot: Robot) -> NDArray[np.int64] | None:
        """A CSV path's column of each of ``robot``'s joints where its header names them."""
        if self.columns is None:
            return None
        return column_order(self.columns, robot, self.units)

    def on(self, robot: Robot) -> Program:
        """This program with its path in ``robot``'s joint order: a path of waypoint tables
        made into ``t``, ``q_cmd`` (and ``f_ext``), a CSV whose header names joints reordered
        (:mod:`mrnea.io.jointnames`); any other program unchanged.

        Raises
        ------
        ProgramFileError
            A name that is not one of ``robot``'s joints, a joint the CSV has no column for,
            and :func:`mrnea.io.jointnames.named_rows`' errors; naming the file and the joint.
        """
        return self._in_order(robot)._links_on(robot)

    def _links_on(self, robot: Robot) -> Program:
        """Wrenches on named links (:class:`mrnea.io.wrench.LinkWrenches`) made into ``f_ext``
        and ``f_ext_point`` by link name, once the cycles are known (a Cartesian program's:
        :mod:`mrnea.cartesian.solve`); the links checked on ``robot``."""
        if not isinstance(self.wrench, LinkWrenches) or self.t is None:
            return self
        f_ext, points = wrenches_on(self.wrench, robot, self.t, self.source or self.name)
        return dataclasses.replace(self, f_ext=f_ext, f_ext_point=points, wrench=None)

    def _in_order(self, robot: Robot) -> Program:
        if self.named is not None:
            t, q = named_rows(self.named, robot, self.dt)
            links = isinstance(self.wrench, LinkWrenches)
            f_ext = None if self.wrench is None or links else wrench_at(*self.wrench, t)
            for a in (t, q, f_ext):
                if a is not None:
                    a.setflags(write=False)
            made = dataclasses.replace(self, t=t, q_cmd=q, f_ext=f_ext, named=None,
                                       wrench=self.wrench if links else None)
            made.apply_units(robot)
            return made
        order = self._order(robot)
        if order is None or np.array_equal(order, np.arange(1, robot.n + 1)):
            self.apply_units(robot)
            return self
        q, rows = self.q_cmd[:, order - 1], self.csv_rows[:, np.r_[0, order]]
        q.setflags(write=False)
        rows.setflags(write=False)
        names = (self.columns.names[0], *robot.joint_names)
        made = dataclasses.replace(self, q_cmd=q, csv_rows=rows,
                                   columns=self.columns._replace(names=names))
        made.apply_units(robot)
        return made

    def check_path(self, robot: Robot) -> None:
        """A :class:`mrnea.errors.PathWarning` for each joint whose resampled CSV path leaves
        ``robot``'s position limits although the CSV's rows stay within them
        (:func:`mrnea.io.pathcsv.limit_warnings`; :meth:`load_robot` calls it). Nothing for a
        waypoint path."""
        if self.csv_rows is not None:
            p = self.on(robot)
            limit_warnings(robot, p.t, p.q_cmd, p.csv_rows, str(self.interpolation),
                           self.source or self.name)
