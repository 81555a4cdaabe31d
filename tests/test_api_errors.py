"""Errors and output shapes of the public dynamics API (mrnea.dynamics).

Every bad argument raises :class:`mrnea.errors.StateError` (a ValueError) whose message starts
with the argument's name; a mass matrix that is not positive definite (a massless moving tip
link) raises :class:`mrnea.errors.SingularMassMatrixError` naming the joint.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
from conftest import random_chain

import mrnea
from mrnea.errors import MrneaError, SingularMassMatrixError, StateError
from mrnea.kernels.layout import compile_model

N = 4
FD_METHODS = ("mrnea", "walker_orin", "crba", "aba")


@pytest.fixture(scope="module")
def robot() -> mrnea.Robot:
    return random_chain(np.random.default_rng(5), N, 0.5)


def _state_args(fn: str) -> tuple[str, ...]:
    return {"inverse_dynamics": ("q", "qd", "qdd"), "joint_reactions": ("q", "qd", "qdd"),
            "mass_matrix_and_bias": ("q", "qd"), "forward_dynamics": ("q", "qd", "tau")}[fn]


FUNCTIONS = ("inverse_dynamics", "mass_matrix_and_bias", "forward_dynamics", "joint_reactions")
# (function, argument) pairs: every argument of every function
ARGS = [(fn, a) for fn in FUNCTIONS for a in (*_state_args(fn), "f_ext", "f_ext_point")]


def call(robot, fn: str, **override):
    """Call ``mrnea.<fn>`` with a valid single state, some arguments replaced by ``override``."""
    kw = {a: np.full(N, 0.1) for a in _state_args(fn)}
    kw["f_ext"] = np.arange(6.0)
    kw["f_ext_point"] = np.array([0.1, 0.0, 0.2])
    kw.update(override)
    return getattr(mrnea, fn)(robot, **kw)


def width(arg: str) -> int:
    return {"f_ext": 6, "f_ext_point": 3}.get(arg, N)


def names_argument(arg: str):
    """A ``pytest.raises`` for a StateError whose message starts with ``arg:``."""
    return pytest.raises(StateError, match=rf"^{re.escape(arg)}:")


def test_error_hierarchy() -> None:
    assert issubclass(StateError, MrneaError)
    assert issubclass(StateError, ValueError)
    assert issubclass(SingularMassMatrixError, ValueError)


# --- shapes ---------------------------------------------------------------------------------------
@pytest.mark.parametrize(("fn", "arg"), ARGS)
@pytest.mark.parametrize("kind", ["short", "long", "3-D", "scalar", "empty-batch", "wide-batch"])
def test_wrong_shape(robot, fn: str, arg: str, kind: str) -> None:
    w = width(arg)
    bad = {"short": np.zeros(w - 1), "long": np.zeros(w + 1), "3-D": np.zeros((2, 3, w)),
           "scalar": np.float64(0.1), "empty-batch": np.zeros((0, w)),
           "wide-batch": np.zeros((3, w + 1))}[kind]
    with names_argument(arg) as info:
        call(robot, fn, **{arg: bad})
    assert str(bad.shape) in str(info.value)


@pytest.mark.parametrize("fn", FUNCTIONS)
def test_mismatched_batch_sizes(robot, fn: str) -> None:
    args = _state_args(fn)
    with pytest.raises(StateError, match="batch sizes differ") as info:
        call(robot, fn, **{args[0]: np.zeros((3, N)), args[1]: np.zeros((2, N))})
    msg = str(info.value)
    assert f"{args[0]} (3, {N})" in msg and f"{args[1]} (2, {N})" in msg
    with pytest.raises(StateError, match="batch sizes differ") as info:
        call(robot, fn, **{args[0]: np.zeros((3, N)), "f_ext": np.zeros((2, 6))})
    assert "f_ext (2, 6)" in str(info.value)


# --- values ---------------------------------------------------------------------------------------
@pytest.mark.parametrize(("fn", "arg"), ARGS)
@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf], ids=["nan", "inf", "-inf"])
@pytest.mark.parametrize("batched", [False, True], ids=["single", "batch"])
def test_non_finite(robot, fn: str, arg: str, value: float, batched: bool) -> None:
    w = width(arg)
    a = np.full((3, w) if batched else w, 0.1)
    a[(1, w - 1) if batched else w - 1] = value
    with names_argument(arg) as info:
        call(robot, fn, **{arg: a})
    assert "NaN or inf" in str(info.value)


NON_NUMERIC = {
    "letters": lambda w: ["a"] * w,
    "objects": lambda w: [object()] * w,
    "none": lambda w: None,
    "dict": lambda w: {"q": 1.0},
    "ragged": lambda w: [[0.0] * w, [0.0] * (w - 1)],
}


@pytest.mark.parametrize(("fn", "arg"), ARGS)
@pytest.mark.parametrize("kind", list(NON_NUMERIC))
def test_non_numeric(robot, fn: str, arg: str, kind: str) -> None:
    if kind == "none" and arg in ("f_ext", "f_ext_point"):
        pytest.skip("None is the documented default of f_ext and f_ext_point")
    with names_argument(arg):
        call(robot, fn, **{arg: NON_NUMERIC[kind](width(arg))})


@pytest.mark.parametrize("fn", FUNCTIONS)
@pytest.mark.parametrize("kind", ["numeric-strings", "complex"])
def test_strings_and_complex_numbers_are_rejected(robot, fn: str, kind: str) -> None:
    """``np.asarray(x, dtype=float)`` turns ``["0.1", ...]`` into floats and drops imaginary
    parts with a mere ComplexWarning; neither is a valid joint state."""
    arg = _state_args(fn)[0]
    bad = ["0.1"] * N if kind == "numeric-strings" else np.full(N, 0.1 + 1j)
    with names_argument(arg):
        call(robot, fn, **{arg: bad})


@pytest.mark.parametrize("method", ["MRNEA", "rnea", "", None, ["mrnea"], 3])
def test_unknown_forward_dynamics_method(robot, method) -> None:
    with names_argument("method") as info:
        call(robot, "forward_dynamics", method=method)
    assert all(repr(m) in str(info.value) for m in FD_METHODS)


@pytest.mark.parametrize("method", ["crba", "aba", "Mrnea", None, ("mrnea",)])
def test_unknown_mass_matrix_method(robot, method) -> None:
    with names_argument("method"):
        call(robot, "mass_matrix_and_bias", method=method)


@pytest.mark.parametrize("fn", FUNCTIONS)
@pytest.mark.parametrize("bad", ["ur5", None, 3.0, "compiled"])
def test_robot_is_not_a_robot(robot, fn: str, bad) -> None:
    not_robot = compile_model(robot) if bad == "compiled" else bad
    kw = {a: np.zeros(N) for a in _state_args(fn)}
    with names_argument("robot"):
        getattr(mrnea, fn)(not_robot, **kw)


# --- singular mass matrix -------------------------------------------------------------------------
def _with_tip(robot: mrnea.Robot, tip: mrnea.Link) -> mrnea.Robot:
    return mrnea.Robot(robot.joints, [*robot.links[:-1], tip], gravity=robot.gravity)


@pytest.mark.parametrize("method", FD_METHODS)
@pytest.mark.parametrize("tip_kind", ["massless", "point-mass-on-axis"])
@pytest.mark.parametrize("batched", [False, True], ids=["single", "batch"])
def test_singular_mass_matrix(robot, method: str, tip_kind: str, batched: bool) -> None:
    """A massless moving tip link (or a point mass on its revolute axis) leaves the last joint
    nothing to accelerate: H is singular, FD raises and names that joint."""
    last = robot.joints[-1]
    if tip_kind == "massless":
        tip = mrnea.Link(robot.links[-1].name)
    else:
        if last.is_prismatic:
            pytest.skip("a point mass on a prismatic axis still has mass to move")
        tip = mrnea.Link(robot.links[-1].name, mass=1.0)  # at the frame origin, on the axis
    bad = _with_tip(robot, tip)
    q = np.full((3, N) if batched else N, 0.3)
    with pytest.raises(SingularMassMatrixError) as info:
        mrnea.forward_dynamics(bad, q, np.zeros(N), np.ones(N), method=method)
    msg = str(info.value)
    assert f"'{last.name}'" in msg
    if batched:
        assert msg.startswith("state 0:")
    # the same robot is fine for everything that does not solve with H
    mrnea.inverse_dynamics(bad, q, np.zeros(N), np.ones(N))
    mrnea.mass_matrix_and_bias(bad, q, np.zeros(N))


def test_singular_state_is_named_in_a_batch(robot) -> None:
    """Only state 2 of the batch is singular (joint 1 of a 2-joint arm is massless when the
    tip's point mass sits on its axis only at q = 0); the error names that state."""
    arm = mrnea.Robot(
        [mrnea.Joint("a", "revolute", "base", "l1", axis=(0, 0, 1)),
         mrnea.Joint("b", "revolute", "l1", "l2", axis=(1, 0, 0),
                     origin=mrnea.transform((0.0, 0.0, 0.0)))],
        [mrnea.Link("l1"), mrnea.Link("l2", mass=1.0, com=(0.0, 0.0, 0.5))],
    )
    # joint a turns the point mass about z; at q_b = 0 the mass is on the z axis
    q = np.array([[0.0, 0.5], [0.0, -0.5], [0.0, 0.0]])
    for method in FD_METHODS:
        with pytest.raises(SingularMassMatrixError, match=r"^state 2: .*'a'"):
            mrnea.forward_dynamics(arm, q, np.zeros((3, 2)), np.zeros((3, 2)), method=method)


# --- output shapes --------------------------------------------------------------------------------
@pytest.mark.parametrize("B", [None, 1, 5])
def test_output_shapes(robot, B) -> None:
    lead = () if B is None else (B,)
    z = np.full((*lead, N), 0.2)
    assert mrnea.inverse_dynamics(robot, z, z, z).shape == (*lead, N)
    for method in ("mrnea", "walker_orin"):
        H, u = mrnea.mass_matrix_and_bias(robot, z, z, method=method)
        assert H.shape == (*lead, N, N)
        assert u.shape == (*lead, N)
    for method in FD_METHODS:
        qdd = mrnea.forward_dynamics(robot, z, z, z, method=method)
        assert qdd.shape == (*lead, N)
        assert qdd.dtype == np.float64
    assert mrnea.joint_reactions(robot, z, z, z).shape == (*lead, N, 6)


def test_broadcasting_and_plain_sequences(robot) -> None:
    """One batched argument makes a batch; the others broadcast. Lists and ints are accepted."""
    Q = np.random.default_rng(0).uniform(-1, 1, size=(3, N))
    single = [0, 1, 0, 1]  # a list of ints
    tau = mrnea.inverse_dynamics(robot, Q, single, single, f_ext=[1, 2, 3, 4, 5, 6])
    assert tau.shape == (3, N)
    for b in range(3):
        np.testing.assert_array_equal(
            tau[b], mrnea.inverse_dynamics(robot, Q[b], np.array(single, dtype=float),
                                           np.array(single, dtype=float),
                                           f_ext=np.arange(1.0, 7.0)))
    # a batch of f_ext alone makes a batch too
    out = mrnea.inverse_dynamics(robot, Q[0], Q[0], Q[0], f_ext=np.zeros((2, 6)))
    assert out.shape == (2, N)
    H, u = mrnea.mass_matrix_and_bias(robot, Q[0], Q[0], f_ext_point=np.zeros((2, 3)))
    assert H.shape == (2, N, N) and u.shape == (2, N)


def test_strided_and_fortran_inputs(robot) -> None:
    """Non-contiguous views and Fortran-ordered batches give the same results as C arrays."""
    rng = np.random.default_rng(3)
    Q, QD, TAU = rng.uniform(-1, 1, size=(3, 5, N))
    wide = np.zeros((5, 2 * N))
    wide[:, ::2] = QD
    QD_view = wide[:, ::2]
    Q_f = np.asfortranarray(Q)
    np.testing.assert_array_equal(mrnea.inverse_dynamics(robot, Q_f, QD_view, TAU),
                                  mrnea.inverse_dynamics(robot, Q, QD, TAU))
    np.testing.assert_array_equal(mrnea.forward_dynamics(robot, Q_f[1], QD_view[1], TAU[1]),
                                  mrnea.forward_dynamics(robot, Q[1], QD[1], TAU[1]))
    # every single-state call (the path that skips Numba's dispatch) on strided and read-only views
    ro = Q[2].copy()
    ro.setflags(write=False)
    for fn, args in ((mrnea.inverse_dynamics, (TAU[2],)), (mrnea.joint_reactions, (TAU[2],)),
                     (mrnea.mass_matrix_and_bias, ()), (mrnea.forward_dynamics, (TAU[2],))):
        a = fn(robot, ro, QD_view[2], *args)
        b = fn(robot, Q[2], QD[2], *args)
        for x, y in zip(a if isinstance(a, tuple) else (a,), b if isinstance(b, tuple) else (b,),
                        strict=True):
            np.testing.assert_array_equal(x, y)
