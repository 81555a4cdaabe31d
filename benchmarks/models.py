"""The benchmark robots and their twins in the other libraries.

* :func:`cases` -- UR5 and Panda (example-robot-data), the SDT and the Puma 560 (built in), each
  with the Pinocchio model the way a Pinocchio user builds it: from the URDF (Panda: the finger
  joints locked with ``buildReducedModel``); the built-in robots exported with ``to_urdf``.
* :func:`to_pinocchio` -- the same chain built directly (one Pinocchio joint per mrnea joint,
  ``nq == nv``), used for the random chains and the simulation loop.
* :func:`random_chain` -- a random, physically consistent chain (tests/conftest.py's builder).
* :func:`puma_program` -- the smooth Puma 560 program of the simulation benchmarks.
* :func:`rel_err` -- the error measure of the tests: ``max|a - b| / max(1, max|b|)``.
"""

from __future__ import annotations

import site
import sys
import tempfile
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

import mrnea
from mrnea import Robot

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
from conftest import random_chain


def rel_err(a, b) -> float:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return float(np.max(np.abs(a - b)) / max(1.0, float(np.max(np.abs(b)))))


def erd_dir() -> Path:
    """example-robot-data's ``robots`` folder."""
    for p in site.getsitepackages():
        d = Path(p) / "cmeel.prefix" / "share" / "example-robot-data" / "robots"
        if d.is_dir():
            return d
    sys.exit("example-robot-data not found: pip install -e '.[test]'")


@dataclass
class Case:
    """One robot: the mrnea Robot, Pinocchio's model, and how our q maps to Pinocchio's."""

    label: str
    robot: Robot
    model: pin.Model
    source: str  # where the model comes from, for the report

    def __post_init__(self) -> None:
        self.data = self.model.createData()
        ids = [self.model.getJointId(name) for name in self.robot.joint_names]
        joints = [self.model.joints[i] for i in ids]
        # our joint order is Pinocchio's velocity order for every robot here (checked)
        assert [jm.idx_v for jm in joints] == list(range(self.robot.n)), self.label
        self._unbounded = [(jm.idx_q, k) for k, jm in enumerate(joints) if jm.nq == 2]
        self._bounded = [(jm.idx_q, k) for k, jm in enumerate(joints) if jm.nq == 1]

    def config(self, q: np.ndarray) -> np.ndarray:
        """Pinocchio's configuration of our q (n,) or (B, n): (cos, sin) for unbounded joints."""
        q = np.asarray(q, dtype=float)
        out = np.zeros((*q.shape[:-1], self.model.nq))
        for iq, k in self._bounded:
            out[..., iq] = q[..., k]
        for iq, k in self._unbounded:
            out[..., iq] = np.cos(q[..., k])
            out[..., iq + 1] = np.sin(q[..., k])
        return out


def _pin_from_urdf(path: Path, robot: Robot) -> pin.Model:
    full = pin.buildModelFromUrdf(str(path))
    keep = set(robot.joint_names)
    locked = [i for i in range(1, full.njoints) if full.names[i] not in keep]
    model = pin.buildReducedModel(full, locked, pin.neutral(full)) if locked else full
    model.gravity = pin.Motion(np.concatenate([robot.gravity, np.zeros(3)]))
    return model


def cases() -> list[Case]:
    """The four benchmark robots (module docstring)."""
    erd = erd_dir()
    ur5 = erd / "ur_description" / "urdf" / "ur5_robot.urdf"
    panda = erd / "panda_description" / "urdf" / "panda.urdf"
    robots = [("UR5", mrnea.load_urdf(ur5), ur5, "example-robot-data ur5_robot.urdf"),
              ("Panda", mrnea.load_urdf(panda, tip="panda_link8"), panda,
               "example-robot-data panda.urdf, fingers locked")]
    out = [Case(label, robot, _pin_from_urdf(path, robot), source)
           for label, robot, path, source in robots]
    tmp = Path(tempfile.mkdtemp(prefix="mrnea-bench-"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the Puma's published inertias draw a ModelWarning
        builtins = [("SDT", mrnea.robots.sdt()), ("Puma 560", mrnea.robots.puma560())]
    for label, robot in builtins:
        path = robot.to_urdf(tmp / f"{robot.name}.urdf")
        out.append(Case(label, robot, _pin_from_urdf(path, robot), "mrnea.robots, to_urdf"))
    return out


def to_pinocchio(robot: Robot) -> pin.Model:
    """``robot`` as a Pinocchio model, joint by joint: RX/RY/RZ (PX/PY/PZ) when the axis is a
    coordinate axis, else the unaligned joint; our link frame is the joint frame after motion."""
    model = pin.Model()
    model.name = robot.name
    parent = 0
    unit = {(1.0, 0.0, 0.0): "X", (0.0, 1.0, 0.0): "Y", (0.0, 0.0, 1.0): "Z"}
    for j, lk in zip(robot.joints, robot.links, strict=True):
        axis = np.asarray(j.axis, dtype=float)
        kind = "P" if j.is_prismatic else "R"
        name = unit.get(tuple(axis.tolist()))
        if name:
            jm = getattr(pin, f"JointModel{kind}{name}")()
        elif j.is_prismatic:
            jm = pin.JointModelPrismaticUnaligned(axis)
        else:
            jm = pin.JointModelRevoluteUnaligned(axis)
        origin = np.asarray(j.origin)
        parent = model.addJoint(parent, jm, pin.SE3(origin[:3, :3].copy(), origin[:3, 3].copy()),
                                j.name)
        model.appendBodyToJoint(parent, pin.Inertia(float(lk.mass), np.array(lk.com),
                                                    np.array(lk.inertia)), pin.SE3.Identity())
    model.gravity = pin.Motion(np.concatenate([robot.gravity, np.zeros(3)]))
    return model


# --- random chains (tests/conftest.py's builder) ---------------------------------------------

def random_chains(ns, seed: int = 0) -> dict[int, Robot]:
    """One random chain per size n, the same in every process (seeded by (seed, n))."""
    return {n: random_chain(np.random.default_rng([seed, n]), n) for n in ns}


def puma_program(K: int, dt: float) -> np.ndarray:
    """A smooth Puma 560 program, at rest at both ends: q0 + A (1 - cos(2 pi m t / T)) / 2."""
    t = np.arange(K)[:, None] * dt
    q0 = np.array([0.0, 0.5, -0.5, 0.0, 0.5, 0.0])
    A = np.array([1.0, 0.8, 0.8, 1.5, 1.0, 2.0])
    m = np.array([2, 3, 4, 3, 5, 4])
    return q0 + A * (1.0 - np.cos(2.0 * np.pi * m * t / (K * dt))) / 2.0
