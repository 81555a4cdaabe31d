"""URDF reader.

:func:`load_urdf` turns a URDF file into a validated :class:`mrnea.Robot`, a chain or a tree
(:mod:`mrnea.io.urdf_writer` writes one back; :mod:`mrnea.io.urdf_visual` reads the
``<visual>`` elements). Only the Python standard library's :mod:`xml.etree.ElementTree` is used.

How a URDF tree becomes a Robot
-------------------------------
* The *root* is the one link that is no joint's child. Moving joints are ``revolute``,
  ``continuous`` and ``prismatic``; ``fixed`` joints are merged away; ``floating`` and ``planar``
  joints are not supported.
* Without ``tip`` the whole tree loads: every moving joint is a degree of freedom, in
  depth-first order from the root, children in the order of the file's ``<joint>`` elements.
  ``tip`` (one link) keeps the path from the root to it: a chain; several tips keep the
  subtree that holds their paths.
* Each kept link carries everything rigidly attached to it: fixed-joint children (tool frames,
  sensors, flanges), the links after its last moving joint, and, when ``tip`` is given, every
  subtree that leaves the kept joints (its moving joints frozen at ``q = 0``). Masses add up;
  the centre of mass is the mass-weighted mean; inertias are rotated into the kept link's frame
  and moved to the combined centre of mass with the parallel-axis theorem. This is the same
  lumping Pinocchio does for fixed joints and for :func:`pinocchio.buildReducedModel` with the
  locked joints at 0.
* A link joined to a kept link by fixed joints only keeps its frame there
  (:attr:`mrnea.model.Link.frames`: its pose in the kept link's frame, Pinocchio's fixed-joint
  frames), so a tool can be named by it (``panda_hand_tcp``, :mod:`mrnea.tool`).
* Links before the first moving joint are part of the fixed base: their inertia is dropped, and
  the first moving joint's origin is expressed in the root link's frame.
* ``<mimic>`` joints (a joint driven as a linear function of another: gripper fingers, coupled
  joints) are refused when kept, the error naming the joint: leave it out with ``tip`` (its
  links are then lumped, at ``q = 0``, into the link it hangs from). A coupled joint is not an
  independent degree of freedom, and mrnea's drives and verdicts are per joint.

Actuator data: ``<limit>`` gives position, velocity and effort limits, ``<dynamics damping
friction>`` viscous and Coulomb friction, and a ``<transmission>``'s ``<mechanicalReduction>``
the gear ratio (its absolute value: the sign, a direction convention of the motor, is dropped).
A rotor inertia or a torque-speed curve has no place in plain URDF: neither is read nor
written (a curve's peak is written as the effort limit).
"""

from __future__ import annotations

import math
import re
import sys
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from mrnea.errors import ModelError, RobotFileError, clip, listing, quote, shorten
from mrnea.io.sidecar import apply_actuator_file
from mrnea.io.source import as_path, parse_number, read_bytes, refused_prolog
from mrnea.io.urdf_transmission import transmissions
from mrnea.io.urdf_tree import MOVING_TYPES, kept_joints, tip_candidates
from mrnea.io.urdf_visual import materials, visuals
from mrnea.model import DEFAULT_GRAVITY, Frame, Joint, Link, Robot
from mrnea.rigid import combine_inertials, transform
from mrnea.visual import Visual

__all__ = ["load_urdf"]

UNSUPPORTED_TYPES = ("floating", "planar")

#: Written for an unbounded limit (urdfdom rejects ``inf``) and read back as infinite. It is the
#: largest double, the value Pinocchio itself uses for "no limit".
UNBOUNDED = sys.float_info.max
#: Largest URDF file read [bytes]: real robots' files are well under a megabyte (meshes are
#: separate files), a 1000-joint chain about 1 MB.
MAX_URDF_SIZE = 16 * 2**20
_XML_SPACE = re.compile("[ \t\n\r]+")  # what separates numbers in an attribute


@dataclass
class _UrdfLink:
    """A link's ``<inertial>`` as written (validated only if the link ends up in the chain)."""

    name: str
    mass: float = 0.0
    com: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))  # [m], link frame
    # [kg m^2] about the com, in the axes of the inertial frame, rotated by R from the link frame
    inertia: NDArray[np.float64] = field(default_factory=lambda: np.zeros((3, 3)))
    R: NDArray[np.float64] = field(default_factory=lambda: np.eye(3))
    visuals: list[Visual] = field(default_factory=list)  # link frame (io/urdf_visual.py)


@dataclass
class _UrdfJoint:
    name: str
    type: str
    parent: str
    child: str
    origin: NDArray[np.float64]  # 4x4, parent link frame -> joint frame
    fields: dict[str, object] = field(default_factory=dict)  # Joint keyword arguments
    mimic: bool = False


class _Reader:
    """Parses one URDF document; every error names the file and the element at fault."""

    def __init__(self, path: Path) -> None:
        self.path = path

    def error(self, message: str) -> RobotFileError:
        return RobotFileError(clip(f"{self.path}: {message}"))

    # --- attribute helpers ----------------------------------------------------------------
    def required(self, elem: ET.Element, attr: str, what: str) -> str:
        value = elem.get(attr)
        if value is None:
            raise self.error(f"{what}: <{shorten(elem.tag)}> has no '{attr}' attribute")
        return value

    def floats(self, elem: ET.Element | None, attr: str, n: int, what: str,
               default: tuple[float, ...] | None = None, allow_inf: bool = False
               ) -> NDArray[np.float64]:
        """``n`` numbers from a whitespace-separated attribute (``default`` if absent), in
        the strict grammar of :func:`mrnea.io.source.parse_number` (``inf``: only where
        ``allow_inf``)."""
        text = None if elem is None else elem.get(attr)
        if text is None:
            if default is None:
                tag = "element" if elem is None else f"<{shorten(elem.tag)}>"
                raise self.error(f"{what}: {tag} has no '{attr}' attribute")
            return np.array(default, dtype=float)
        assert elem is not None
        attribute = f"<{shorten(elem.tag)} {attr}=\"{shorten(text)}\">"
        parts = _XML_SPACE.split(text.strip(" \t\n\r")) if text.strip(" \t\n\r") else []
        if len(parts) != n:
            raise self.error(f"{what}: {attribute}: expected {n} number(s), got {len(parts)}")
        out = np.empty(n)
        for k, part in enumerate(parts):
            try:
                out[k] = parse_number(part, allow_inf)
            except ValueError as exc:
                raise self.error(f"{what}: {attribute}: {exc}") from None
        return out

    def number(self, elem: ET.Element | None, attr: str, what: str,
               default: float | None = None, allow_inf: bool = False) -> float:
        return float(self.floats(elem, attr, 1, what, None if default is None else (default,),
                                 allow_inf)[0])

    def text_number(self, elem: ET.Element, what: str) -> float:
        """The number that is ``elem``'s text content."""
        text = (elem.text or "").strip(" \t\n\r")
        try:
            return parse_number(text)
        except ValueError as exc:
            raise self.error(f"{what}: <{elem.tag}>{shorten(text)}</{elem.tag}>: {exc}"
                             ) from None

    def origin(self, elem: ET.Element, what: str) -> NDArray[np.float64]:
        """The 4x4 transform of ``elem``'s ``<origin xyz rpy>`` child (identity if absent)."""
        o = elem.find("origin")
        xyz = self.floats(o, "xyz", 3, what, (0.0, 0.0, 0.0))
        rpy = self.floats(o, "rpy", 3, what, (0.0, 0.0, 0.0))
        return transform(xyz, rpy)

    # --- document ---------------------------------------------------------------------------
    def parse_root(self) -> ET.Element:
        data = read_bytes(self.path, "robot file", RobotFileError, MAX_URDF_SIZE)
        if not data.strip():
            raise self.error("file is empty")
        refused = refused_prolog(data)
        if refused is not None:
            raise self.error(f"refused: {refused}; URDF needs no DTD, and XML entities can "
                             "expand a small file into a huge one or read other files")
        try:
            root = ET.fromstring(data)
        except ET.ParseError as exc:
            line, col = exc.position
            raise self.error(f"invalid XML at line {line}, column {col}: {exc}") from None
        except (LookupError, ValueError) as exc:  # e.g. an unknown encoding in the declaration
            raise self.error(f"invalid XML: {exc}") from None
        if root.tag != "robot":
            raise self.error(f"root element is <{shorten(root.tag)}>, expected <robot>")
        return root

    def link(self, elem: ET.Element, index: int) -> _UrdfLink:
        name = self.required(elem, "name", f"link #{index + 1}")
        if not name:
            raise self.error(f"link #{index + 1}: empty name")
        inertial = elem.find("inertial")
        if inertial is None:
            return _UrdfLink(name)
        what = f"link {quote(name)} <inertial>"
        T = self.origin(inertial, what)
        mass_el = inertial.find("mass")
        if mass_el is None:
            raise self.error(f"{what}: no <mass> element")
        mass = self.number(mass_el, "value", what)
        inertia_el = inertial.find("inertia")
        if inertia_el is None:
            raise self.error(f"{what}: no <inertia> element")
        ixx, ixy, ixz, iyy, iyz, izz = (
            self.number(inertia_el, a, what) for a in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
        )
        inertia = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
        return _UrdfLink(name, mass, T[:3, 3].copy(), inertia, T[:3, :3].copy())

    def inertial(self, lk: _UrdfLink) -> tuple[float, NDArray, NDArray]:
        """Validated mass [kg], com [m] and inertia about the com [kg m^2] in the link frame."""
        try:  # mass >= 0, finite values, PSD inertia (a rotation keeps it PSD)
            Link(lk.name, lk.mass, lk.com, lk.inertia)
        except ModelError as exc:
            raise self.error(str(exc)) from None
        inertia = lk.R @ lk.inertia @ lk.R.T
        return lk.mass, lk.com, 0.5 * inertia + 0.5 * inertia.T  # (I + I^T) / 2 could overflow

    def joint(self, elem: ET.Element, index: int) -> _UrdfJoint:
        name = self.required(elem, "name", f"joint #{index + 1}")
        if not name:
            raise self.error(f"joint #{index + 1}: empty name")
        what = f"joint {quote(name)}"
        jtype = self.required(elem, "type", what)
        if jtype in UNSUPPORTED_TYPES:
            raise self.error(
                f"{what}: joint type {quote(jtype)} is not supported (a serial chain has only "
                f"{', '.join(MOVING_TYPES)} and fixed joints)"
            )
        if jtype not in (*MOVING_TYPES, "fixed"):
            raise self.error(
                f"{what}: unknown joint type {quote(jtype)} (known: {', '.join(MOVING_TYPES)}, "
                f"fixed, "
                f"{', '.join(UNSUPPORTED_TYPES)})"
            )
        ends = []
        for tag in ("parent", "child"):
            e = elem.find(tag)
            if e is None:
                raise self.error(f"{what}: no <{tag}> element")
            ends.append(self.required(e, "link", what))
        j = _UrdfJoint(name, jtype, ends[0], ends[1], self.origin(elem, what))
        if jtype == "fixed":
            return j
        j.mimic = elem.find("mimic") is not None
        f = j.fields
        f["axis"] = self.floats(elem.find("axis"), "xyz", 3, what, (1.0, 0.0, 0.0))
        limit = elem.find("limit")
        if limit is not None:
            for attr, key, default in (("lower", "lower", -math.inf),
                                       ("upper", "upper", math.inf),
                                       ("effort", "effort_limit", math.inf),
                                       ("velocity", "velocity_limit", math.inf)):
                v = self.number(limit, attr, f"{what} <limit>", default, allow_inf=True)
                f[key] = math.copysign(math.inf, v) if abs(v) >= UNBOUNDED else v
        dyn = elem.find("dynamics")
        if dyn is not None:
            f["viscous_friction"] = self.number(dyn, "damping", f"{what} <dynamics>", 0.0)
            f["coulomb_friction"] = self.number(dyn, "friction", f"{what} <dynamics>", 0.0)
        return j


def load_urdf(
    path: str | Path, tip: str | Sequence[str] | None = None,
    actuators: str | Path | None = None
) -> Robot:
    """Load a URDF file as a :class:`mrnea.Robot`: the whole tree, or the joints ``tip`` keeps.

    Parameters
    ----------
    path : str or Path
        The URDF file.
    tip : str or sequence of str, optional
        None: every moving joint (the whole tree, depth first). A link name: the chain from the
        root to that link. Several: the subtree holding the paths to all of them. Subtrees
        off the kept joints are lumped, at ``q = 0``, into the kept link they hang from.
    actuators : str or Path, optional
        A sidecar actuator file (TOML) for what URDF cannot say: rotor inertias, torque-speed
        curves, or overrides (:func:`mrnea.io.sidecar.apply_actuator_file`).

    Returns
    -------
    Robot
        ``n`` moving joints, depth first from the root (children in file order); each joint's
        parent is the kept link it hangs from (``Robot.parents``). Link frames are the URDF link
        frames of the kept links (the children of the kept joints); joint origins [m, rad] are
        expressed in the parent kept link's frame (the root link's frame for a joint on the
        base), composed with any fixed joints in between. Masses [kg], centres of mass [m, link
        frame] and inertias [kg m^2, about the com, link-frame axes] include everything rigidly
        attached. Gravity is ``(0, 0, -9.81)`` m/s^2 (URDF has no gravity). The base is the root
        link.

    Notes
    -----
    Defaults follow the URDF specification where this does not contradict the model: missing
    ``<origin>`` -> identity; missing ``<axis>`` -> ``(1, 0, 0)``; missing ``<inertial>`` ->
    massless link; missing ``lower``/``upper`` -> unbounded (the URDF specification says 0,
    which would lock the joint); missing ``effort``/``velocity`` -> unlimited; a limit of
    magnitude >= ``sys.float_info.max`` (what :func:`mrnea.io.write_urdf` writes for "none")
    is read as infinite. Continuous joints have no position limits. The gear ratio is
    ``abs(mechanicalReduction)`` of a single-joint, single-actuator ``<transmission>`` (1
    without one). A chain joint in a coupled transmission (differential, several actuators)
    gets 1 and a :class:`UserWarning`; transmissions naming joints the file does not have are
    ignored. Masses and inertias are checked (``mass >= 0``, inertia symmetric positive
    semi-definite) only for links that are kept: the fixed base's links are dropped
    unchecked. The robot's name is ``<robot name>`` (the file's stem if absent).

    Raises
    ------
    RobotFileError
        The file cannot be read, is not XML, not a URDF, not a tree, has an unsupported element
        (``floating``/``planar`` joints, a kept ``<mimic>`` joint) or non-physical
        values; the message names the file and the element.
    """
    path = as_path(path, "path", RobotFileError)
    tips = () if tip is None else (tip,) if isinstance(tip, str) else tip
    if not isinstance(tips, (tuple, list)) or not all(isinstance(t, str) for t in tips):
        raise RobotFileError(f"tip: expected a link name (str), several, or None, got "
                             f"{type(tip).__name__} {quote(tip)}")
    if actuators is not None:
        actuators = as_path(actuators, "actuators", RobotFileError)
    rd = _Reader(path)
    root = rd.parse_root()
    robot_name = root.get("name") or path.stem

    links: dict[str, _UrdfLink] = {}
    named_colors, left_out = materials(rd, root), []
    for k, elem in enumerate(root.findall("link")):
        lk = rd.link(elem, k)
        if lk.name in links:
            raise rd.error(f"duplicate link name {quote(lk.name)}")
        lk.visuals = visuals(rd, elem, lk.name, named_colors, left_out)
        links[lk.name] = lk
    joints: dict[str, _UrdfJoint] = {}
    parent_joint: dict[str, _UrdfJoint] = {}  # child link -> the joint above it
    children: dict[str, list[_UrdfJoint]] = {name: [] for name in links}
    for k, elem in enumerate(root.findall("joint")):
        j = rd.joint(elem, k)
        if j.name in joints:
            raise rd.error(f"duplicate joint name {quote(j.name)}")
        for end in (j.parent, j.child):
            if end not in links:
                raise rd.error(f"joint {quote(j.name)}: refers to link {quote(end)}, which does "
                               "not exist")
        if j.child in parent_joint:
            raise rd.error(
                f"joint {quote(j.name)}: link {quote(j.child)} is already the child of joint "
                f"{quote(parent_joint[j.child].name)} (a link can have only one parent)"
            )
        if j.parent == j.child:
            raise rd.error(f"joint {quote(j.name)}: link {quote(j.child)} is its own parent "
                           "(cycle)")
        joints[j.name] = j
        parent_joint[j.child] = j
        children[j.parent].append(j)
    if not links:
        raise rd.error(f"robot {quote(robot_name)} has no <link>")

    # --- tree structure -------------------------------------------------------------------
    roots = [name for name in links if name not in parent_joint]
    if not roots:
        raise rd.error("the links form a cycle: every link is some joint's child (no root link)")
    if len(roots) > 1:
        raise rd.error(
            f"not a tree: {len(roots)} root links (links that are no joint's child): "
            f"{listing(sorted(roots))}"
        )
    base = roots[0]
    order: list[str] = []  # depth-first, parents before children
    stack = [base]
    while stack:
        name = stack.pop()
        order.append(name)
        stack.extend(j.child for j in reversed(children[name]))
    if len(order) != len(links):
        unreached = sorted(set(links) - set(order))
        raise rd.error(
            f"not a tree: links {listing(unreached)} are not connected to root link "
            f"{quote(base)} (their joints form a cycle)"
        )

    # --- choose the joints: all, or those on the paths to the tips ------------------------
    n_moving = sum(j.type in MOVING_TYPES for j in joints.values())
    if n_moving == 0:
        raise rd.error(f"robot {quote(robot_name)} has no moving joint")
    kept = kept_joints(rd, order, parent_joint, tips)
    # depth first, children in file order (``order``): Robot's order (Pinocchio's URDF parser
    # orders a link's children by joint name instead: tests compare by name)
    chain_path = [parent_joint[name] for name in order[1:] if parent_joint[name].name in kept]
    chain = {j.name: i + 1 for i, j in enumerate(chain_path)}  # joint -> body index (1..n)
    for j in chain_path:
        if j.mimic:
            # a candidate's path avoids every <mimic> joint, not only this one: a tip it
            # suggests must load
            candidates = tip_candidates(links, order, parent_joint, children)
            raise rd.error(
                f"joint {quote(j.name)}: <mimic> joints (coupled to another joint) are not "
                f"supported: keep the links whose paths avoid it with tip=<link name> "
                f"(command line: --tip LINK, once per branch), and it is lumped at q = 0 into "
                f"the link it hangs from" + (f"; candidate tip links, heaviest chain first: "
                                             f"{listing(candidates)}" if candidates else ""))

    # --- lump every link into its chain body ---------------------------------------------------
    # body 0 is the fixed base; pose[name] is the link's frame in its body's frame (q = 0 for
    # moving joints off the chain).
    body = {base: 0}
    pose = {base: np.eye(4)}
    chain_origin: dict[str, NDArray] = {}
    parts: list[list[tuple[float, NDArray, NDArray]]] = [[] for _ in range(len(chain) + 1)]
    looks: list[list[Visual]] = [[] for _ in range(len(chain) + 1)]  # visuals, body frames
    # the links joined to a chain link by fixed joints only keep their frames (a tool frame)
    rigid = {base}
    fixed_frames: list[list[Frame]] = [[] for _ in range(len(chain) + 1)]
    for name in order:
        if name != base:
            j = parent_joint[name]
            if j.name in chain:
                chain_origin[j.name] = pose[j.parent] @ j.origin
                body[name], pose[name] = chain[j.name], np.eye(4)
                rigid.add(name)
            else:
                body[name], pose[name] = body[j.parent], pose[j.parent] @ j.origin
                if j.type == "fixed" and j.parent in rigid:
                    rigid.add(name)
                    fixed_frames[body[name]].append(Frame(name, pose[name]))
        looks[body[name]] += [v.moved(pose[name]) for v in links[name].visuals]
        if body[name] == 0:  # part of the fixed base: dropped, hence not validated either
            continue
        mass, com, inertia = rd.inertial(links[name])
        R, p = pose[name][:3, :3], pose[name][:3, 3]
        parts[body[name]].append((mass, R @ com + p, R @ inertia @ R.T))

    # --- gear ratios -----------------------------------------------------------------------------
    trans = transmissions(rd, root)
    robot_joints, robot_links = [], []
    coupled: dict[str, list[str]] = {}  # coupled transmission -> its chain joints
    kept_link = [base] + [j.child for j in chain_path]  # body index -> its link
    try:
        for i, j in enumerate(chain_path, start=1):
            kw = dict(j.fields)
            if j.name in trans:
                tname, red = trans[j.name]
                if red is None:
                    coupled.setdefault(tname, []).append(j.name)
                else:
                    kw["gear_ratio"] = red
            robot_joints.append(Joint(j.name, j.type, kept_link[body[j.parent]], j.child,
                                      chain_origin[j.name], **kw))
            mass, com, inertia = combine_inertials(parts[i])
            robot_links.append(Link(j.child, mass, com, inertia, tuple(looks[i]),
                                    tuple(fixed_frames[i])))
        robot = Robot(robot_joints, robot_links, DEFAULT_GRAVITY, name=robot_name, base=base,
                      base_visuals=looks[0])
    except ModelError as exc:  # Joint/Link/Robot errors name the joint or link: add the file
        raise rd.error(str(exc)) from None
    if left_out:
        warnings.warn(f"{path}: {len(left_out)} visual(s) left out of the 3D view (the "
                      f"dynamics are unchanged): " + "; ".join(left_out[:5])
                      + ("; ..." if len(left_out) > 5 else ""), UserWarning, stacklevel=2)
    for tname, jnames in coupled.items():
        warnings.warn(
            f"{path}: transmission {quote(tname)} couples joint(s) {listing(jnames)} with other "
            f"joints or actuators; mrnea models one motor per joint, so they get gear ratio 1",
            UserWarning,
            stacklevel=2,
        )
    if actuators is not None:
        robot = apply_actuator_file(robot, actuators)
    return robot
