"""Drive sizing: each joint's motor and gearbox from catalogues, checked on the coupled robot
(issue 27; docs/sizing.md).

``size_drives(robot, programs, catalogue, joints=None, objective="mass", dwell=0.0,
drive_mass=True) -> SizingResult``.

1. Every program's own requirement (:func:`mrnea.actuators.program_requirement`) on the robot
   as sized so far, the sized joints' own rotor inertia left out: each joint's duty cycle
   (:class:`mrnea.sizing.checks.Duty`; the programs in turn, then ``dwell`` seconds held at the
   last program's final pose).
2. Per joint, every motor x gearbox combination (and drive unit) judged exactly on its duty
   (:func:`mrnea.sizing.checks.judge`): its reflected inertia G^2 (J_motor + J_gearbox) enters
   only the joint's own diagonal term of H_a, so no simulation per combination is needed. The
   best passing one by the objective: ``"mass"`` (lightest; then cheapest, then largest margin),
   ``"price"`` (cheapest; then lightest) or ``"margin"`` (the smallest worst ratio).
3. The choices applied to the robot (:func:`apply_trains`: gear ratio, rotor inertia = motor +
   gearbox, efficiency, the motor's torque-speed curve times G, the speed limits; with
   ``drive_mass``, the default, the motor and gearbox mass as a point mass on the parent link at
   the joint's origin). The masses change what the joints nearer the base need: back to 1 until
   no choice changes (at most n + 1 rounds on a chain: a drive's mass acts only on the joints
   between it and the base).
4. Every program simulated on the sized robot (:func:`mrnea.simulate`, hybrid mode): the
   verification, ``SizingResult.verified``.

When more drive mass never lowers what a parent joint needs (the usual case: the mass hangs on
the parent's link), step 3's fixed point is the optimum over all combinations of all joints;
tests/test_sizing.py compares it with brute force.
"""

from __future__ import annotations

import contextlib
import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mrnea import validate
from mrnea.actuators import program_requirement
from mrnea.cartesian import solve
from mrnea.errors import ModelError, SizingError, listing, quote
from mrnea.io.gridfile import DEMO_PROGRAM
from mrnea.io.program import Program, load_program
from mrnea.model import Link, Robot
from mrnea.resources import require_memory
from mrnea.rigid import combine_inertials
from mrnea.robots.sdt_profile import training_program
from mrnea.simulate import SimulationResult, simulate
from mrnea.sizing.catalogue import Catalogue, Train, load_catalogue
from mrnea.sizing.checks import CHECKS, Duty, Judged, judge, times
from mrnea.sweep.cluster import client as cluster_client

OBJECTIVES = ("mass", "price", "margin")


@dataclass(frozen=True)
class Case:
    """One program to size for: q_cmd (K, n) [rad | m], dt [s], the wrench and its point: the
    last link's (f_ext (K, 6) or (6,), f_ext_point (3,) or (K, 3)) or by link name (mappings of
    those, as :func:`mrnea.simulate` takes them)."""

    name: str
    q_cmd: NDArray
    dt: float
    f_ext: Any = None
    f_ext_point: Any = None


@dataclass(frozen=True)
class JointSizing:
    """One joint's answer: its name, every train judged (``trains``, ``judged``, in catalogue
    order), the index of the chosen one (None: nothing fits) and the duty it was judged on."""

    joint: str
    trains: list[Train]
    judged: Judged
    chosen: int | None
    duty: Duty
    order: list[int]  # the passing trains, best first by the objective

    @property
    def best(self) -> int:
        """The chosen train, or the one that comes closest (smallest worst ratio)."""
        return self.chosen if self.chosen is not None else int(np.argmin(self.judged.worst))

    def message(self) -> str:
        """One line: the chosen drive and its worst ratio, or what the best one lacks."""
        b = self.best
        t, r = self.trains[b], self.judged.ratios[b]
        k = int(np.argmax(r))
        what = list(CHECKS)[k]
        if self.chosen is None:
            return f"no motor fits {self.joint}: best {t.name} reaches {times(r[k], what)}"
        return (f"{self.joint}: {t.name} (worst ratio {r[k]:.3g}, {what}; "
                f"margin {1 - r[k]:.1%})")


@dataclass(frozen=True)
class SizingResult:
    """What :func:`size_drives` answers.

    Attributes
    ----------
    robot : the robot as given; ``sized`` the robot with the chosen drives (None where a joint
        has no fit); ``joints`` per sized joint a :class:`JointSizing`; ``objective``,
        ``dwell`` [s], ``drive_mass``; ``rounds``: how many times step 1-3 ran; ``runs``: the
        verifying simulations (one per program; empty when a joint has no fit);
        ``cases``: the programs.
    """

    robot: Robot
    sized: Robot | None
    joints: list[JointSizing]
    objective: str
    dwell: float
    drive_mass: bool
    rounds: int
    cases: list[Case]
    runs: list[SimulationResult] = field(default_factory=list)

    @property
    def fits(self) -> bool:
        """Whether every sized joint has a drive that passes its checks."""
        return all(j.chosen is not None for j in self.joints)

    @property
    def verified(self) -> bool:
        """Whether every program's simulation on the sized robot is ACHIEVABLE."""
        return self.fits and bool(self.runs) and all(r.achievable for r in self.runs)

    @property
    def chosen(self) -> dict[str, Train]:
        """The chosen train per joint that has one."""
        return {j.joint: j.trains[j.chosen] for j in self.joints if j.chosen is not None}

    def lines(self) -> list[str]:
        """One line per joint, then the verification."""
        out = [j.message() for j in self.joints]
        if self.runs:
            out += [f"verified: {c.name}: {r.verdict()}"
                    for c, r in zip(self.cases, self.runs, strict=True)]
        return out


def _is_pair(p: object) -> bool:
    """A ``(q_cmd, dt)`` or ``(q_cmd, dt, f_ext, f_ext_point)`` tuple."""
    return (isinstance(p, tuple) and len(p) in (2, 4) and isinstance(p[1], (int, float))
            and not isinstance(p[1], bool))


def _cases(programs: object, robot: Robot) -> list[Case]:
    if isinstance(programs, (str, Path, Program, Case)) or _is_pair(programs):
        programs = [programs]
    if not isinstance(programs, Sequence) or not programs:
        raise SizingError(f"programs: expected one or more programs (Program, path, or "
                          f"(q_cmd, dt) pairs), got {quote(programs)}")
    out = []
    for k, p in enumerate(programs):
        if isinstance(p, (str, Path)):
            p = training_program() if str(p) == DEMO_PROGRAM else load_program(p)
        if isinstance(p, Program):
            p = solve(p, robot)  # joints by name, Cartesian moves: the robot's joint path
            out.append(Case(p.name, np.asarray(p.q_cmd), p.dt, p.f_ext, p.f_ext_point))
        elif isinstance(p, Case):
            out.append(p)
        elif _is_pair(p):
            out.append(Case(f"program {k + 1}", np.asarray(p[0], dtype=float), float(p[1]),
                            *(p[2:] if len(p) == 4 else ())))
        else:
            raise SizingError(f"programs[{k}]: expected a Program, a program file or a "
                              f"(q_cmd, dt) pair, got {quote(p)}")
    return out


def apply_trains(robot: Robot, trains: dict[str, Train], drive_mass: bool = True) -> Robot:
    """``robot`` with each named joint driven by its train: gear ratio G, rotor inertia J_motor
    + J_gearbox (motor side), the gearbox's efficiency, the motor's curve times G (joint side:
    (G peak, corner / G, no_load / G), or a constant G peak), the velocity limit lowered to
    min(max_speed, max_input_speed) / G; with ``drive_mass`` the motor's and gearbox's mass as a
    point mass on the parent link at the joint's origin (none on the fixed base)."""
    joints, links = list(robot.joints), list(robot.links)
    names = robot.link_names
    for i, j in enumerate(robot.joints):
        t = trains.get(j.name)
        if t is None:
            continue
        G, m = t.gearbox.ratio, t.motor
        curve = (None if m.torque_speed is None else
                 (G * m.torque_speed[0], m.torque_speed[1] / G, m.torque_speed[2] / G))
        vmax = min(j.velocity_limit, m.max_speed / G, t.gearbox.max_input_speed / G)
        joints[i] = dataclasses.replace(
            j, gear_ratio=G, rotor_inertia=m.rotor_inertia + t.gearbox.inertia,
            efficiency=t.gearbox.efficiency, effort_limit=G * m.peak_torque, torque_speed=curve,
            velocity_limit=vmax)
        if drive_mass and t.mass > 0 and j.parent in names:
            p = names.index(j.parent)
            lk = links[p]
            mass, com, inertia = combine_inertials([(lk.mass, lk.com, lk.inertia),
                                                    (t.mass, j.origin[:3, 3], np.zeros((3, 3)))])
            try:
                links[p] = Link(lk.name, mass, com, inertia, lk.visuals)
            except ModelError as exc:  # the drive's mass made the link one mrnea cannot take
                raise SizingError(f"drive {quote(t.name)} of joint {quote(j.name)}: its mass "
                                  f"{t.mass:g} kg on link {quote(lk.name)}: {exc}") from None
    return robot._replace(joints=joints, links=links)


def _duties(robot: Robot, cases: list[Case], sized: list[int], dwell: float) -> list[Duty]:
    """Each sized joint's duty cycle on ``robot`` (its own rotor inertia left out)."""
    J = np.array(robot.rotor_inertia)
    J[sized] = 0.0
    bare = robot.with_actuators(rotor_inertia=J)
    parts = []
    for c in cases:
        h0, _ = program_requirement(bare, c.q_cmd, c.dt, c.f_ext, c.f_ext_point, friction=False)
        V = np.zeros_like(c.q_cmd)
        V[1:] = np.diff(c.q_cmd, axis=0) / c.dt
        v = np.vstack([V[1:], np.zeros((1, robot.n))])  # the program ends at rest
        parts.append((h0, V, (v - V) / c.dt, v, np.full(len(V), c.dt)))
    if dwell > 0:  # held at rest at the last program's final pose
        last = cases[-1]
        hold, _ = program_requirement(bare, np.repeat(last.q_cmd[-1:], 2, axis=0), last.dt,
                                      validate.wrench_rows(last.f_ext, -1),
                                      validate.wrench_rows(last.f_ext_point, -1), friction=False)
        z = np.zeros((1, robot.n))
        parts.append((hold[1:], z, z, z, np.array([dwell])))
    h0, qd, qdd, v, dt = (np.concatenate(a) for a in zip(*parts, strict=True))
    F = robot.coulomb_friction
    return [Duty(h0[:, i], qd[:, i], qdd[:, i], v[:, i], dt, (F[i, 0], F[i, 1])) for i in sized]


def _order(trains: list[Train], jd: Judged, objective: str) -> list[int]:
    """The passing trains, best first by the objective (module docstring)."""
    def price(t: Train) -> float:
        return np.inf if t.price is None else t.price
    keys = {"mass": lambda c: (trains[c].mass, price(trains[c]), jd.worst[c]),
            "price": lambda c: (price(trains[c]), trains[c].mass, jd.worst[c]),
            "margin": lambda c: (jd.worst[c], trains[c].mass, price(trains[c]))}[objective]
    return sorted((c for c in range(len(trains)) if jd.worst[c] <= 1.0), key=keys)


CHUNK = 64
"""Combinations judged per task on a Dask cluster (``scheduler``)."""


def _concat(parts: list[Judged]) -> Judged:
    return Judged(*(np.concatenate([getattr(p, f.name) for p in parts])
                    for f in dataclasses.fields(Judged)))


def _judge_all(trains: list[Train], duties: list[Duty], dask: Any) -> list[Judged]:
    """Every joint's combinations judged: here, or in chunks of :data:`CHUNK` on ``dask`` (a
    ``distributed.Client``)."""
    if dask is None:
        return [judge(trains, d) for d in duties]
    chunks = [trains[k:k + CHUNK] for k in range(0, len(trains), CHUNK)]
    futures = [[dask.submit(judge, ch, d, pure=False) for ch in chunks] for d in duties]
    return [_concat(dask.gather(f)) for f in futures]


def _iterate(robot: Robot, cases: list[Case], trains: list[Train], names: list[str],
             sized: list[int], objective: str, dwell: float, drive_mass: bool, dask: Any
             ) -> tuple[list[JointSizing], dict[str, Train], int]:
    """Steps 1-3 of the module docstring until no choice changes: (the joints' answers, the
    choices, the rounds)."""
    chosen: dict[str, Train] = {}
    seen: list[dict[str, str]] = []
    rounds = 0
    while True:
        rounds += 1
        duties = _duties(apply_trains(robot, chosen, drive_mass), cases, sized, dwell)
        result = []
        for nm, duty, jd in zip(names, duties, _judge_all(trains, duties, dask), strict=True):
            order = _order(trains, jd, objective)
            result.append(JointSizing(nm, trains, jd, order[0] if order else None, duty, order))
        new = {r.joint: trains[r.chosen] for r in result if r.chosen is not None}
        key = {k: t.name for k, t in new.items()}
        if key == {k: t.name for k, t in chosen.items()} or key in seen or rounds > len(names) + 2:
            return result, new, rounds
        seen.append(key)
        chosen = new


def size_drives(
    robot: Robot,
    programs: object,
    catalogue: Catalogue | str | Path,
    joints: Sequence[str] | None = None,
    objective: str = "mass",
    dwell: float = 0.0,
    drive_mass: bool = True,
    scheduler: Any = None,
) -> SizingResult:
    """Choose each joint's drive train from a catalogue (module docstring).

    Parameters
    ----------
    robot : the robot; its links without the drives' masses (``drive_mass``).
    programs : one or more programs: :class:`mrnea.io.Program`, program files (``"demo"``: the
        SDT demo's training profile), or
        ``(q_cmd, dt)`` / ``(q_cmd, dt, f_ext, f_ext_point)`` tuples; the duty cycle runs them
        in turn.
    catalogue : a :class:`Catalogue` or a catalogue file (docs/sizing.md).
    joints : the joints to size (default: all).
    objective : ``"mass"``, ``"price"`` or ``"margin"``.
    dwell : seconds at rest after the programs, holding the final pose (RMS and cubic mean).
    drive_mass : add each drive's mass to its parent link (at the joint's origin).
    scheduler : None (judge here), a Dask scheduler address ``tcp://HOST:PORT`` or a
        ``distributed.Client``: the combinations are judged there in chunks of :data:`CHUNK`,
        through the sweep's cluster connection (:func:`mrnea.sweep.cluster.client`: the
        address checked first); the choice, the iteration and the verification stay here.
    """
    if not isinstance(robot, Robot):
        raise SizingError(f"robot: expected a mrnea.Robot, got {type(robot).__name__}")
    if objective not in OBJECTIVES:
        raise SizingError(f"objective: expected one of {', '.join(OBJECTIVES)}, got "
                          f"{quote(objective)}")
    if isinstance(dwell, bool) or not isinstance(dwell, (int, float)) or not dwell >= 0 \
            or not np.isfinite(dwell):
        raise SizingError(f"dwell: expected seconds >= 0, got {quote(dwell)}")
    cat = catalogue if isinstance(catalogue, Catalogue) else load_catalogue(catalogue)
    if isinstance(joints, str) or not (joints is None or isinstance(joints, Sequence)):
        raise SizingError(f"joints: expected a sequence of joint names, got {quote(joints)}")
    names = list(robot.joint_names) if joints is None else list(joints)
    for nm in names:
        if nm not in robot.joint_names:
            raise SizingError(f"joints: no joint named {quote(nm)} in robot "
                              f"{quote(robot.name)}; its joints: {listing(robot.joint_names)}")
    twice = sorted({nm for nm in names if names.count(nm) > 1}, key=names.index)
    if twice:
        raise SizingError(f"joints: {listing(map(quote, twice))} given twice; name each joint "
                          "once")
    if not names:
        raise SizingError("joints: no joint to size")
    sized = [robot.joint_names.index(nm) for nm in names]
    cases = _cases(programs, robot)
    for c in cases:
        if c.q_cmd.ndim != 2 or c.q_cmd.shape[1] != robot.n:
            raise SizingError(f"{c.name}: q_cmd has shape {c.q_cmd.shape}, the robot has "
                              f"{robot.n} joints")
    trains = cat.combinations()
    K = sum(len(c.q_cmd) for c in cases) + 1
    # judge() holds about 10 (combinations, cycles) float arrays per joint at once
    require_memory(10 * 8.0 * len(trains) * K, f"sizing {len(trains)} combinations over {K} "
                   f"cycles", "use a smaller catalogue or fewer, shorter programs", SizingError)
    with contextlib.ExitStack() as stack:
        dask = None if scheduler is None else stack.enter_context(cluster_client(scheduler,
                                                                                 None))
        result, new, rounds = _iterate(robot, cases, trains, names, sized, objective,
                                       float(dwell), drive_mass, dask)
    fits = all(r.chosen is not None for r in result)
    sized_robot = apply_trains(robot, new, drive_mass) if fits else None
    runs = [simulate(sized_robot, c.q_cmd, c.dt, f_ext=c.f_ext, f_ext_point=c.f_ext_point,
                     reactions=False) for c in cases] if fits else []
    return SizingResult(robot, sized_robot, result, objective, float(dwell), drive_mass, rounds,
                        cases, runs)

