"""Which robot a name means: a built-in robot, or a robot file read by the reader its suffix picks.

The built-in robots' files are package data in ``mrnea/robots/data`` (:mod:`mrnea.robots` gives
them named constructors); this module reads them, so :mod:`mrnea.robots` imports ``io`` and
never the other way round.
"""

from __future__ import annotations

import dataclasses
import os
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

from numpy.typing import NDArray

from mrnea.errors import ModelError, ModelWarning, RobotFileError, quote
from mrnea.io import native, urdf
from mrnea.io.mesh import find_package_file
from mrnea.io.payload import Payload
from mrnea.io.sidecar import apply_actuator_file
from mrnea.io.source import as_path, expand_home
from mrnea.model import Robot
from mrnea.visual import Visual

__all__ = ["BUILTIN_ROBOTS", "SUFFIXES", "RobotOptions", "flange_of", "load_builtin",
           "load_robot", "load_robot_spec", "resolve_robot", "same_robot"]

#: Names of the built-in robots (files ``mrnea/robots/data/<name>.toml``).
BUILTIN_ROBOTS = ("sdt", "puma560")

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
        Passed on to the reader (e.g. ``tip=`` for URDF, ``actuators=`` for both).

    Returns
    -------
    Robot
        The validated robot (frames and units as documented in :mod:`mrnea.model`).

    Raises
    ------
    RobotFileError
        Unsupported suffix (the message lists the supported ones), or any error of the reader.
    """
    path = as_path(path, "path", RobotFileError)
    if os.path.isdir(path):
        raise RobotFileError(f"{path}: cannot read robot file: it is a directory, not a regular "
                             "file")
    suffix = path.suffix.lower()
    if suffix == ".xacro":
        raise RobotFileError(
            f"{path}: a xacro file (ROS's XML macros), not a URDF: expand it first, e.g. "
            f"'xacro {path.name} > {path.name.removesuffix(path.suffix)}"
            f"{'' if path.stem.lower().endswith('.urdf') else '.urdf'}'")
    allowed = {".urdf": ("tip", "actuators"), ".xml": ("tip", "actuators"),
               ".toml": ("actuators",)}.get(suffix, ())
    for key in kw:
        if key not in allowed:
            raise RobotFileError(f"{key}: not an option of the {SUFFIXES.get(suffix, '')} reader "
                                 f"(options: {', '.join(allowed) or 'none'})")
    if suffix in (".urdf", ".xml"):
        return urdf.load_urdf(path, **kw)
    if suffix == ".toml":
        return native.load_native(path, **kw)
    supported = ", ".join(f"{s} ({fmt})" for s, fmt in SUFFIXES.items())
    raise RobotFileError(
        f"{path}: unsupported robot file suffix {quote(path.suffix or '(none)')}; supported: "
        f"{supported}"
    )


def load_builtin(name: str) -> Robot:
    """Load a built-in robot by name (one of :data:`BUILTIN_ROBOTS`).

    Raises
    ------
    RobotFileError
        If ``name`` is not a built-in robot.
    """
    if not isinstance(name, str):
        raise RobotFileError(f"name: expected a built-in robot's name (str), got "
                             f"{type(name).__name__}")
    if name not in BUILTIN_ROBOTS:
        raise RobotFileError(
            f"unknown built-in robot {quote(name)}; available: {', '.join(BUILTIN_ROBOTS)}")
    resource = resources.files("mrnea").joinpath("robots", "data", f"{name}.toml")
    # Built-ins are curated, not the user's input: no ModelWarning. (The published Puma 560's
    # link 1 is a lumped inertia about its axis only, Izz = 0.35 with no mass, and its link 3's
    # principal moments 0.0125 + 0.066 < 0.086: both break the triangle inequality as published.)
    with resources.as_file(resource) as path, warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelWarning)
        return native.load_native(path)


def resolve_robot(spec: str, base_dir: str | Path | None = None) -> str:
    """The robot ``spec`` names: a built-in robot's name, or the path of a robot file.

    Parameters
    ----------
    spec : a name in :data:`BUILTIN_ROBOTS` (these win over a file of the same name), else a
        path (``~`` expanded).
    base_dir : the folder a relative path is taken in (a program's folder); None: the path is
        returned as given, relative to the current folder.

    Returns
    -------
    str
        The built-in name, or the file's path (whether the file exists is not checked here: the
        reader says so, naming the file).
    """
    if not isinstance(spec, str):
        raise RobotFileError(f"spec: expected a built-in robot's name or a robot file's path "
                             f"(str), got {type(spec).__name__} {quote(spec)}")
    base = None if base_dir is None else as_path(base_dir, "base_dir", RobotFileError)
    if spec in BUILTIN_ROBOTS:
        return spec
    p = expand_home(as_path(spec, "spec", RobotFileError), RobotFileError)
    if base is not None and not p.is_absolute():
        p = base / p
    return str(p)


def same_robot(a: str, b: str) -> bool:
    """Whether two resolved sources (:func:`resolve_robot`) are the same robot: the same
    built-in name, or paths of the same file (however they are written)."""
    if a in BUILTIN_ROBOTS or b in BUILTIN_ROBOTS:
        return a == b
    try:
        return os.path.samefile(a, b)
    except OSError:  # one does not exist: compare the paths
        return Path(a).resolve() == Path(b).resolve()


@dataclass(frozen=True)
class RobotOptions:
    """What changes a loaded robot: the command line's ``--actuators``, ``--tip``,
    ``--payload``, ``--gravity`` and a program's keys of the same names.

    Attributes
    ----------
    actuators : the path of a sidecar actuator file (:func:`apply_actuator_file`), or None.
    tip : the URDF chain's last link, or several (the subtree holding them), or None (the
        whole tree): :func:`mrnea.io.urdf.load_urdf`.
    payload : the :class:`~mrnea.io.payload.Payload` s fixed to their links (each the last
        link by default), a tuple of them (one Payload is taken as a tuple of one), or None.
    gravity : (3,) gravity [m/s^2] in base coordinates replacing the robot's, or None.
    package_path : folders where the robot file's ``package://`` mesh names not found at load
        are looked for (:func:`with_package_path`; the command line's ``--package-path``), or
        None.
    """

    actuators: str | None = None
    tip: str | tuple[str, ...] | None = None
    payload: tuple[Payload, ...] | None = None
    gravity: tuple[float, float, float] | None = None
    package_path: tuple[str, ...] | None = None

    def __post_init__(self) -> None:
        # a library caller's wrong type is an error naming the field, never a TypeError from
        # tuple(); a str is refused (payload: its characters, one payload each) or taken as
        # one folder (package_path: "abc" searched "a", "b" and "c")
        if isinstance(self.payload, Payload):  # one payload: a tuple of one
            object.__setattr__(self, "payload", (self.payload,))
        elif self.payload is not None:
            if isinstance(self.payload, (str, bytes)) or not _iterable(self.payload):
                raise RobotFileError(f"payload: expected a Payload (mrnea.io.parse_payload), "
                                     f"several or None, got {type(self.payload).__name__} "
                                     f"{quote(self.payload)}")
            object.__setattr__(self, "payload", tuple(self.payload))
        if isinstance(self.package_path, (str, os.PathLike)):
            object.__setattr__(self, "package_path", (self.package_path,))
        elif self.package_path is not None:
            if isinstance(self.package_path, bytes) or not _iterable(self.package_path):
                raise RobotFileError(f"package_path: expected folders (a sequence of paths) or "
                                     f"None, got {type(self.package_path).__name__} "
                                     f"{quote(self.package_path)}")
            object.__setattr__(self, "package_path", tuple(self.package_path))

    def over(self, other: RobotOptions) -> RobotOptions:
        """These options where they are set, ``other``'s elsewhere (the command line's over a
        program's)."""
        return dataclasses.replace(other, **{f.name: getattr(self, f.name)
                                             for f in dataclasses.fields(self)
                                             if getattr(self, f.name) is not None})


def _iterable(value: Any) -> bool:
    try:
        iter(value)
    except TypeError:
        return False
    return True


def load_robot_spec(spec: str, base_dir: str | Path | None = None,
                    options: RobotOptions | None = None) -> Robot:
    """Load the robot ``spec`` names: a built-in robot or a robot file (:func:`resolve_robot`).

    ``options`` are applied in this order: the chain's ``tip`` (URDF files only), the sidecar
    ``actuators`` file (over the robot file's own values), each ``payload`` on its link (the
    last by default; :meth:`~mrnea.model.Robot.with_payload`, one after the other), ``gravity``
    (over the robot file's).

    Raises
    ------
    RobotFileError
        ``spec`` is neither a built-in robot nor a file (a name without a robot file's
        suffix), the file cannot be read (the message names it) or is malformed, ``tip`` is
        given for a robot that is not a URDF file.
    """
    opt = RobotOptions() if options is None else options
    if not isinstance(opt, RobotOptions):
        raise RobotFileError(f"options: expected a RobotOptions or None, got "
                             f"{type(opt).__name__} {quote(opt)}")
    source = resolve_robot(spec, base_dir)
    suffix = Path(source).suffix.lower()
    if source not in BUILTIN_ROBOTS and suffix not in SUFFIXES and not os.path.lexists(source):
        raise RobotFileError(f"{quote(spec)} is neither a built-in robot "
                             f"({', '.join(BUILTIN_ROBOTS)}) nor a file (looked for {source})")
    if opt.tip is not None and suffix not in (".urdf", ".xml"):
        raise RobotFileError(f"{source}: tip {quote(opt.tip)} chooses a URDF tree's chain; "
                             f"this robot is a chain already")
    robot = (load_builtin(source) if source in BUILTIN_ROBOTS else
             load_robot(source, **({} if opt.tip is None else {"tip": opt.tip})))
    if opt.package_path is not None:
        robot = with_package_path(robot, opt.package_path)
    if opt.actuators is not None:
        robot = apply_actuator_file(robot, opt.actuators)
    try:
        for p in opt.payload or ():
            robot = robot.with_payload(*p)
        if opt.gravity is not None:
            robot = robot.with_gravity(opt.gravity)
    except ModelError as exc:
        raise RobotFileError(f"{source}: {exc}") from None
    return robot


def with_package_path(robot: Robot, folders: Sequence[str | os.PathLike[str]]) -> Robot:
    """``robot`` with each mesh named ``package://PKG/...`` that was not found when it was
    loaded looked for in ``folders`` (each ``PKG`` itself or a folder holding it, in order,
    before ``$ROS_PACKAGE_PATH`` had its turn at load); a name no folder holds stays as it was
    (the report draws that link as a capsule, and says so)."""
    dirs = [Path(f) for f in folders]

    def moved(v: Visual) -> Visual:  # the same object when its mesh stays where it was
        mesh = find_package_file(v.mesh, dirs) if v.kind == "mesh" and v.mesh else v.mesh
        return v if mesh == v.mesh else dataclasses.replace(v, mesh=mesh)

    def found(visuals: tuple[Visual, ...]) -> tuple[Visual, ...]:
        return tuple(moved(v) for v in visuals)

    # only a link whose visuals change is rebuilt: rebuilding one validates it again, which
    # warned (ModelWarning) about a built-in robot's curated inertias on every --package-path
    links = [lk if (v := found(lk.visuals)) == lk.visuals else dataclasses.replace(lk, visuals=v)
             for lk in robot.links]
    return Robot(robot.joints, links, gravity=robot.gravity, name=robot.name, base=robot.base,
                 base_visuals=found(robot.base_visuals))


def flange_of(source: str) -> NDArray | None:
    """The pose (4x4) of the DH flange frame in the last link's frame of the robot ``source``
    names (:func:`resolve_robot`): a built-in robot or a native file given by a DH table
    (:func:`mrnea.io.native.native_flange`); None for a robot given otherwise (URDF, origin/axis
    form), which has no DH frames."""
    if source in BUILTIN_ROBOTS:
        resource = resources.files("mrnea").joinpath("robots", "data", f"{source}.toml")
        with resources.as_file(resource) as path, warnings.catch_warnings():
            warnings.simplefilter("ignore", ModelWarning)
            return native.native_flange(path)
    return native.native_flange(source) if Path(source).suffix.lower() == ".toml" else None
