"""The robot description: an immutable, validated serial chain or tree of links and joints.

Conventions (the same as URDF's, so URDF files map one to one):

* Frames. Each moving link ``i`` has a frame. Joint ``i`` connects its parent link (the link
  of joint ``λ(i) = parents[i]``, or the fixed base: ``λ(i) = -1``) to link ``i``; on a serial
  chain ``λ(i) = i - 1``. A tree's joints are in depth-first order from the base (each subtree's
  joints together, right after its root), so ``λ(i) < i``. Its ``origin`` is the fixed
  homogeneous transform from the parent link's frame to the joint frame; link ``i``'s frame
  is the joint frame moved by the joint: ``T_i = T_{λ(i)} @ origin_i @ motion_i(q_i)``, where
  ``motion`` is a rotation of ``q_i`` [rad] about ``axis_i`` (revolute, continuous) or a
  translation of ``q_i`` [m] along it (prismatic). ``axis_i`` is a unit vector in the joint frame.
* Inertials. Link mass [kg]; centre of mass ``com`` [m] in the link frame; inertia [kg m^2] about
  the centre of mass, in axes parallel to the link frame.
* Gravity [m/s^2] in base coordinates, default ``(0, 0, -9.81)``.
* Actuator fields per joint (joint side unless said otherwise; the list, with units and
  meanings, and their checks: :mod:`mrnea.actuator_fields`): ``gear_ratio`` G (motor turns per
  joint turn, in [1e-6, 1e6]), ``rotor_inertia`` J_m [kg m^2, motor side], ``viscous_friction`` F_v
  [N m s/rad or N s/m], ``coulomb_friction`` F_s [N m or N] (one magnitude, or two,
  ``(positive direction, negative direction)``: the friction opposing motion with q̇ > 0 and with
  q̇ < 0), ``effort_limit`` [N m or N]
  (``inf``: unlimited); joint limits ``velocity_limit`` [rad/s or m/s] (``inf``: unlimited),
  ``lower``/``upper`` position limits [rad or m] (``-inf``/``inf``: none; always so for
  continuous joints).
* ``torque_speed`` (optional), joint side: ``(peak, corner_speed, no_load_speed)``. The effort
  limit is ``peak`` up to the corner speed, then the smaller of constant power
  ``peak * corner / |qd|`` and the straight line from ``(corner, peak)`` down to zero at the
  no-load speed; zero beyond it. With a curve, ``effort_limit`` equals ``peak``.
* ``efficiency`` η of the gear (one value in [0.01, 1], or two, ``(driving, back-driven)``).
  ``effort_limit`` and the curve are the ideal gear's, G times the motor's; the drive gives
  η times them while it delivers power (effort and speed of the same sign, or at rest) and
  1/η times them while the load drives it back (docs/achievable.md, kernels/drive.py).

A :class:`Robot` is validated once, at construction; every error names the link or joint at fault.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mrnea.actuator_fields import actuator_values, check_actuator_fields
from mrnea.errors import LIST_LIMIT, ModelError, MrneaError, listing, quote, shorten
from mrnea.frozen import (
    Frozen,
    check_magnitude,
    check_name,
    frozen_array,
    real_number,
    rigid_transform,
    warn,
)
from mrnea.rigid import check_inertia, combine_inertials
from mrnea.visual import Visual, visual_tuple

JOINT_TYPES = ("revolute", "continuous", "prismatic")
#: SI unit of each joint quantity, (revolute, prismatic): position, velocity, acceleration, effort.
JOINT_UNITS = {"q": ("rad", "m"), "qd": ("rad/s", "m/s"), "qdd": ("rad/s^2", "m/s^2"),
               "tau": ("N m", "N")}
DEFAULT_GRAVITY = (0.0, 0.0, -9.81)
# a joint axis whose 2-norm is within this of 1 is kept as given (a normalised vector's computed
# norm is within 1.5 eps of 1, measured over 2e5 random axes)
UNIT_TOL = 4 * np.finfo(float).eps


@dataclass(frozen=True, eq=False)
class Frame(Frozen):
    """A named frame fixed to a link: ``origin`` (4, 4), its pose in the link's frame.

    What a URDF's fixed joints merge into a chain link keeps its frame here (a flange, a tool
    centre point such as the Panda's ``panda_hand_tcp``), so that a tool can be named
    (:mod:`mrnea.tool`). Kinematics only: the dynamics never read frames.
    """

    name: str
    origin: ArrayLike = field(default_factory=lambda: np.eye(4))

    def __post_init__(self) -> None:
        check_name(self.name, "frame")
        object.__setattr__(self, "origin", rigid_transform(self.origin,
                                                           f"frame '{self.name}': origin"))


@dataclass(frozen=True, eq=False)
class Link(Frozen):
    """A rigid link: ``mass`` [kg], ``com`` [m, link frame], ``inertia`` [kg m^2, about the com];
    ``visuals``, what it looks like (:class:`mrnea.visual.Visual`, link frame; not dynamics);
    ``frames``, named frames fixed to it (:class:`Frame`, e.g. the URDF links merged into it)."""

    name: str
    mass: float = 0.0
    com: ArrayLike = (0.0, 0.0, 0.0)
    inertia: ArrayLike = field(default_factory=lambda: np.zeros((3, 3)))
    visuals: tuple[Visual, ...] = ()
    frames: tuple[Frame, ...] = ()

    def __post_init__(self) -> None:
        check_name(self.name, "link")
        what = f"link '{self.name}'"
        mass = real_number(self.mass, f"{what}: mass")
        if mass < 0:
            raise ModelError(f"{what}: mass must be >= 0, got {mass}")
        com = frozen_array(self.com, (3,), f"{what}: centre of mass")
        inertia = frozen_array(self.inertia, (3, 3), f"{what}: inertia")
        check_magnitude(mass, "mass", what, "kg")
        check_magnitude(com, "length", f"{what}: centre of mass", "m")
        check_magnitude(inertia, "inertia", what, "kg m^2")
        check_inertia(inertia, what)
        object.__setattr__(self, "visuals", visual_tuple(self.visuals, what))
        frames = tuple(self.frames) if isinstance(self.frames, (tuple, list)) else None
        if frames is None or not all(isinstance(f, Frame) for f in frames):
            raise ModelError(f"{what}: frames must be a sequence of mrnea.model.Frame, got "
                             f"{quote(self.frames)}")
        object.__setattr__(self, "frames", frames)
        object.__setattr__(self, "mass", mass)
        object.__setattr__(self, "com", com)
        object.__setattr__(self, "inertia", inertia)


@dataclass(frozen=True, eq=False)
class Joint(Frozen):
    """A joint moving ``child`` relative to ``parent``; see the module docstring for conventions."""

    name: str
    type: str
    parent: str
    child: str
    origin: ArrayLike = field(default_factory=lambda: np.eye(4))
    axis: ArrayLike = (0.0, 0.0, 1.0)
    lower: float = -math.inf
    upper: float = math.inf
    velocity_limit: float = math.inf
    effort_limit: float = math.inf
    gear_ratio: float = 1.0
    rotor_inertia: float = 0.0
    viscous_friction: float = 0.0
    coulomb_friction: float | tuple[float, float] = 0.0
    torque_speed: tuple[float, float, float] | None = None
    efficiency: float | tuple[float, float] = 1.0

    def __post_init__(self) -> None:
        check_name(self.name, "joint")
        what = f"joint '{self.name}'"
        if self.type not in JOINT_TYPES:
            raise ModelError(
                f"{what}: unsupported joint type {self.type!r} "
                f"(supported: {', '.join(JOINT_TYPES)})"
            )
        origin = rigid_transform(self.origin, f"{what}: origin")
        check_magnitude(origin[:3, 3], "length", f"{what}: origin", "m")
        axis = frozen_array(self.axis, (3,), f"{what}: axis")
        big = float(np.max(np.abs(axis)))
        if big < 1e-12:
            raise ModelError(f"{what}: axis is zero")
        # normalised unless it is a unit vector already (to rounding, UNIT_TOL): normalising
        # twice can move an ulp, and a robot written to a file must read back bit for bit
        if not abs(float(np.linalg.norm(axis)) - 1.0) <= UNIT_TOL:
            axis = axis / big  # first to a max-norm of 1: the 2-norm cannot overflow
            axis = axis / np.linalg.norm(axis)
            axis.setflags(write=False)
        lower = real_number(self.lower, f"{what}: lower limit", allow_inf=True)
        upper = real_number(self.upper, f"{what}: upper limit", allow_inf=True)
        if self.type == "continuous":
            lower, upper = -math.inf, math.inf
        if lower > upper:
            raise ModelError(f"{what}: lower limit {lower} is above upper limit {upper}")
        values = {"lower": lower, "upper": upper,
                  **check_actuator_fields(self, what)}
        object.__setattr__(self, "origin", origin)
        object.__setattr__(self, "axis", axis)
        for k, v in values.items():
            object.__setattr__(self, k, v)

    @property
    def is_prismatic(self) -> bool:
        return self.type == "prismatic"

    @property
    def coulomb_pair(self) -> tuple[float, float]:
        """``(F+, F-)``: the Coulomb friction magnitudes opposing positive and negative motion."""
        c = self.coulomb_friction
        return c if isinstance(c, tuple) else (c, c)

    @property
    def efficiency_pair(self) -> tuple[float, float]:
        """``(driving, back-driven)``: the gear efficiencies while the drive delivers power and
        while the load drives it back."""
        e = self.efficiency
        return e if isinstance(e, tuple) else (e, e)

    def unit(self, quantity: str) -> str:
        """SI unit of its ``"q"``, ``"qd"``, ``"qdd"`` or ``"tau"`` (:data:`JOINT_UNITS`)."""
        return JOINT_UNITS[quantity][self.is_prismatic]


#: The robot file writers behind :meth:`Robot.to_urdf` and :meth:`Robot.to_toml`, by format:
#: ``writer(robot, path, overwrite) -> path``. :mod:`mrnea.io` (which imports this module, never
#: the reverse) fills it when it is imported, and ``import mrnea`` imports it (docs/design.md).
WRITERS: dict[str, Callable[[Robot, str | Path, bool], Path]] = {}


def _warn_massless(links: tuple[Link, ...], parents: list[int]) -> None:
    """A ModelWarning per massless link (no mass, no inertia), naming what it carries; the first
    :data:`~mrnea.errors.LIST_LIMIT` links one warning each, the others in one more.

    Linear in the number of links (it had walked every massless link's subtree: a 3,000-link
    chain of massless links took half a minute and printed 3,000 warnings)."""
    n = len(links)
    heavy = [lk.mass > 0 or bool(np.any(lk.inertia)) for lk in links]
    massless = [i for i in range(n) if not heavy[i]]
    if not massless:
        return
    end = list(range(1, n + 1))  # link i's subtree is i .. end[i] - 1 (depth-first order)
    count = [int(h) for h in heavy]  # massive links in link i's subtree
    for k in range(n - 1, 0, -1):
        if parents[k] >= 0:
            end[parents[k]] = max(end[parents[k]], end[k])
            count[parents[k]] += count[k]
    following = [n] * (n + 1)  # following[k]: the first massive link at k or after
    for k in range(n - 1, -1, -1):
        following[k] = k if heavy[k] else following[k + 1]
    for i in massless[:LIST_LIMIT]:
        carried, k = [], following[i + 1]
        while k < end[i] and len(carried) < LIST_LIMIT:
            carried.append(links[k].name)
            k = following[k + 1]
        more = f" and {count[i] - len(carried)} more" if count[i] > len(carried) else ""
        tail = (f"well-posed: it carries {', '.join(map(shorten, carried))}{more}" if carried
                else "nothing it carries has mass either, so H is singular and forward "
                     "dynamics will fail")
        warn(f"link '{shorten(links[i].name)}' is massless ({tail})", stacklevel=3)
    if len(massless) > LIST_LIMIT:
        rest = [links[i].name for i in massless[LIST_LIMIT:]]
        warn(f"{len(rest)} more links are massless: {listing(rest)}", stacklevel=3)


class Robot(Frozen):
    """An immutable serial chain or tree: ``joints[i]`` moves ``links[i]`` relative to the link
    its ``parent`` names, the base or the link of an earlier joint (:attr:`parents`).

    Parameters
    ----------
    joints : sequence of Joint, root to tip, depth first (a chain: each joint's parent the
        previous joint's child); ``joints[0].parent`` is the base link.
    links : sequence of Link, the moving links, ``links[i]`` is ``joints[i].child``.
    gravity : (3,) gravity acceleration [m/s^2] in base coordinates.
    name : the robot's name.
    base : name of the fixed base link (defaults to ``joints[0].parent``).
    base_visuals : what the fixed base looks like (:class:`mrnea.visual.Visual`, base frame).
    """

    def __init__(
        self,
        joints: Sequence[Joint],
        links: Sequence[Link],
        gravity: ArrayLike = DEFAULT_GRAVITY,
        name: str = "robot",
        base: str | None = None,
        base_visuals: Sequence[Visual] = (),
    ) -> None:
        check_name(name, "robot")
        joints, links = tuple(joints), tuple(links)
        if not joints:
            raise ModelError(f"robot '{name}': has no moving joint")
        if len(joints) != len(links):
            raise ModelError(
                f"robot '{name}': {len(joints)} joints but {len(links)} moving links"
            )
        for obj, cls in [(j, Joint) for j in joints] + [(lk, Link) for lk in links]:
            if not isinstance(obj, cls):
                raise ModelError(f"robot '{name}': expected a {cls.__name__}, got {obj!r}")
        base = joints[0].parent if base is None else base
        index = {base: -1}  # link name -> the joint moving it (-1: the base)
        parents: list[int] = []
        for i, (j, lk) in enumerate(zip(joints, links, strict=True)):
            if j.child != lk.name:
                raise ModelError(f"joint '{j.name}': child is '{j.child}', expected '{lk.name}'")
            if j.parent not in index:
                raise ModelError(
                    f"joint '{j.name}': parent is '{j.parent}', which is neither the base "
                    f"'{base}' nor the link of an earlier joint (joints go root to tip, "
                    f"depth first)")
            p = index[j.parent]
            # depth-first order: the parent is the base or on the path to the previous link
            k = i - 1
            while k > p:
                k = parents[k]
            if k != p:
                raise ModelError(
                    f"joint '{j.name}': parent is '{j.parent}', whose subtree was closed by "
                    f"joint '{joints[i - 1].name}': the joints must be in depth-first order "
                    f"(each subtree's joints together, after its root)")
            parents.append(p)
            index.setdefault(lk.name, i)
        for kind, names in (("joint", [j.name for j in joints]),
                            ("link", [base] + [lk.name for lk in links])):
            seen: set[str] = set()  # linear: names.count() made a 20,000-joint load take 20 s
            dup = sorted({x for x in names if x in seen or seen.add(x)})
            if dup:
                raise ModelError(f"robot '{name}': duplicate {kind} names: {listing(dup)}")
        owner = {x: f"link {quote(x)}" for x in [base] + [lk.name for lk in links]}
        for lk in links:  # a tool names a link or a frame: one name, one frame
            for f in lk.frames:
                if f.name in owner:
                    raise ModelError(f"link {quote(lk.name)}: frame {quote(f.name)}: the name "
                                     f"is taken by {owner[f.name]} (a tool names one frame)")
                owner[f.name] = f"a frame of link {quote(lk.name)}"
        _warn_massless(links, parents)
        self._joints = joints
        self._links = links
        self._parents = tuple(parents)
        self._gravity = frozen_array(gravity, (3,), f"robot '{name}': gravity")
        check_magnitude(self._gravity, "gravity", f"robot '{name}'", "m/s^2")
        self._name = str(name)
        self._base = base
        self._base_visuals = visual_tuple(base_visuals, f"robot '{name}': base")

    def _state(self) -> dict[str, Any]:
        """The constructor's arguments (Frozen: equality, hash, copies and pickling by value)."""
        return {"joints": self._joints, "links": self._links, "gravity": self._gravity,
                "name": self._name, "base": self._base, "base_visuals": self._base_visuals}

    # --- read-only description ------------------------------------------------------------
    name = property(lambda self: self._name, doc="The robot's name.")
    base = property(lambda self: self._base, doc="Name of the fixed base link.")
    joints = property(lambda self: self._joints, doc="The n joints, root to tip.")
    links = property(lambda self: self._links, doc="The n moving links, root to tip.")
    gravity = property(lambda self: self._gravity, doc="(3,) gravity [m/s^2], base frame.")
    base_visuals = property(lambda self: self._base_visuals,
                            doc="What the fixed base looks like (Visual, base frame).")

    parents = property(
        lambda self: self._parents,
        doc="λ: per joint i, the index of the joint whose link carries its link (-1: the base); "
            "i - 1 for every i on a serial chain. Joints are in depth-first order, so "
            "parents[i] < i (docs/notation.md, Trees).")

    @property
    def is_serial(self) -> bool:
        """True for a serial chain (``parents[i] == i - 1`` for every joint)."""
        return all(p == i - 1 for i, p in enumerate(self._parents))

    @property
    def n(self) -> int:
        """Number of moving joints (degrees of freedom)."""
        return len(self._joints)

    @property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(j.name for j in self._joints)

    @property
    def link_names(self) -> tuple[str, ...]:
        return tuple(lk.name for lk in self._links)

    def _per_joint(self, attr: str) -> NDArray[np.float64]:
        a = np.array([getattr(j, attr) for j in self._joints], dtype=np.float64)
        a.setflags(write=False)
        return a

    lower = property(lambda self: self._per_joint("lower"), doc="(n,) lower position limits.")
    upper = property(lambda self: self._per_joint("upper"), doc="(n,) upper position limits.")
    velocity_limit = property(lambda self: self._per_joint("velocity_limit"),
                              doc="(n,) velocity limits [rad/s or m/s].")
    effort_limit = property(lambda self: self._per_joint("effort_limit"),
                            doc="(n,) joint-side effort limits [N m or N].")
    gear_ratio = property(lambda self: self._per_joint("gear_ratio"), doc="(n,) gear ratios G.")
    rotor_inertia = property(lambda self: self._per_joint("rotor_inertia"),
                             doc="(n,) rotor inertias J_m [kg m^2], motor side.")
    viscous_friction = property(lambda self: self._per_joint("viscous_friction"),
                                doc="(n,) viscous friction F_v, joint side.")
    coulomb_friction = property(
        lambda self: np.array([j.coulomb_pair for j in self._joints], dtype=np.float64),
        doc="(n, 2) Coulomb friction magnitudes [F+, F-] per joint (opposing positive, "
            "negative motion) [N m or N], joint side.")
    efficiency = property(
        lambda self: np.array([j.efficiency_pair for j in self._joints], dtype=np.float64),
        doc="(n, 2) gear efficiencies [driving, back-driven] per joint.")

    @property
    def torque_speed(self) -> tuple[tuple[float, float, float] | None, ...]:
        """Per joint: ``(peak, corner_speed, no_load_speed)`` or None (constant limit)."""
        return tuple(j.torque_speed for j in self._joints)

    @property
    def masses(self) -> NDArray[np.float64]:
        """(n,) link masses [kg]."""
        a = np.array([lk.mass for lk in self._links])
        a.setflags(write=False)
        return a

    @property
    def is_prismatic(self) -> NDArray[np.bool_]:
        """(n,) True where the joint is prismatic."""
        return np.array([j.is_prismatic for j in self._joints])

    # --- modified copies ------------------------------------------------------------------
    def with_actuators(self, **fields: ArrayLike) -> Robot:
        """A copy with actuator fields replaced.

        Keywords are any of :data:`mrnea.actuator_fields.ACTUATOR_FIELDS` (read by
        :func:`mrnea.actuator_fields.actuator_values`). ``effort_limit``, ``gear_ratio``,
        ``rotor_inertia``, ``viscous_friction``, ``coulomb_friction``: each a scalar (all joints)
        or an ``(n,)`` sequence (per joint, root to tip); ``coulomb_friction`` also an ``(n, 2)``
        array, or a sequence of n entries each a number or a pair ``[positive direction,
        negative direction]`` (asymmetric friction); ``efficiency`` likewise (one value in [0.01, 1]
        for all joints, n of them, or n entries each a number or a pair ``[driving,
        back-driven]``). ``effort_limit`` sets a constant limit
        at every speed and removes any torque-speed curve. ``torque_speed`` sets curves: one
        ``(peak, corner_speed, no_load_speed)`` triple for all joints, or a sequence of n
        triples or ``None`` (no curve for that joint).
        """
        per_joint = actuator_values(fields, self.n)
        joints = [
            dataclasses.replace(j, **{k: v[i] for k, v in per_joint.items()})
            for i, j in enumerate(self._joints)
        ]
        return self._replace(joints=joints)

    def with_gravity(self, gravity: ArrayLike) -> Robot:
        """A copy with another gravity vector [m/s^2, base frame], e.g. ``(0, 0, 9.81)`` for a
        robot hanging from the ceiling whose base z axis points up."""
        return self._replace(gravity=gravity)

    def with_payload(self, mass: float, com: ArrayLike = (0.0, 0.0, 0.0),
                     inertia: ArrayLike | None = None, link: str | None = None) -> Robot:
        """A copy carrying a payload rigidly fixed to a link, merged into its inertials.

        Parameters
        ----------
        mass : the payload's mass [kg], >= 0.
        com : (3,) its centre of mass [m] in the link's frame (the last link's: as
            ``f_ext_point``).
        inertia : (3, 3) [kg m^2] about its centre of mass, axes of the link's frame;
            None: a point mass. The link keeps its name; its inertials become those of
            the two bodies joined (:func:`mrnea.rigid.combine_inertials`).
        link : the name of the link carrying it (a branching robot's hand, say); None: the
            last link. A name the robot does not have is a ModelError naming it.
        """
        try:
            p = Link("payload", mass, com, np.zeros((3, 3)) if inertia is None else inertia)
        except ModelError as exc:
            raise ModelError(f"with_payload: {exc}") from None
        i = self.n - 1 if link is None else self.link_index(link, "payload")
        old = self._links[i]
        m, c, inertia_sum = combine_inertials([(old.mass, old.com, old.inertia),
                                               (p.mass, p.com, p.inertia)])
        merged = Link(old.name, m, c, inertia_sum, old.visuals, old.frames)
        return self._replace(links=(*self._links[:i], merged, *self._links[i + 1:]))

    def link_index(self, link: str, what: str, error: type[MrneaError] = ModelError) -> int:
        """Index of the link named ``link`` (link i moves with joint i); an ``error`` naming
        ``what`` and the link, with a close match, when the robot has no such link."""
        names = self.link_names
        if link not in names:
            close = difflib.get_close_matches(str(link), names, n=1)
            raise error(f"{what}: no link named {quote(link)} in robot {quote(self._name)}"
                        f"{f' (did you mean {close[0]!r}?)' if close else ''}; its "
                        f"links: {shorten(', '.join(names), 300)}")
        return names.index(link)

    def _replace(self, **kw: object) -> Robot:
        return Robot(**{**self._state(), **kw})  # type: ignore[arg-type]

    # --- export ---------------------------------------------------------------------------------
    def to_urdf(self, path: str | Path, overwrite: bool = False) -> Path:
        """Write this robot as a URDF file: :func:`mrnea.io.write_urdf` (what URDF cannot hold,
        the rotor inertia, a torque-speed curve and the gear efficiency, is dropped). Returns
        ``path``."""
        return WRITERS["urdf"](self, path, overwrite)

    def to_toml(self, path: str | Path, overwrite: bool = False) -> Path:
        """Write this robot as a native TOML robot file, every field exactly:
        :func:`mrnea.io.write_native`. Returns ``path``."""
        return WRITERS["toml"](self, path, overwrite)

    def __repr__(self) -> str:
        return f"Robot(name={self._name!r}, n={self.n}, joints={list(self.joint_names)})"
