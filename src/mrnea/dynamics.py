"""Rigid-body dynamics and kinematics, the public NumPy API (paper Eq. 1: no rotor inertia, no
friction).

Every function takes one state, arrays of shape ``(n,)``, or a batch, shape ``(B, n)``; arguments
of both kinds broadcast against each other, and a batch runs as one compiled, parallel loop.
Units: q [rad | m], qd [rad/s | m/s], qdd [rad/s^2 | m/s^2], tau [N m | N].

External wrench. ``f_ext = [f_e; n_e]`` (6,) or (B, 6), in base coordinates [N, N m], is the wrench
the last moving link exerts **on its environment** (the paper's k_e): the joints must supply
``J(q)^T f_ext`` on top of the free motion. It acts at the origin of the last link's frame, or at
``f_ext_point`` (3,) or (B, 3) [m], a point given in that link's frame (the paper's p_e). Example:
the tool pushes down on a table with 10 N: ``f_ext = [0, 0, -10, 0, 0, 0]``. (A force the
environment applies *to* the robot, Pinocchio's and MuJoCo's convention, is the negative.)

Wrenches on any links, by name (a tree's two hands, a link halfway along an arm): ``f_ext`` a
mapping ``{link: [f; n]}``, each value (6,) or (B, 6), with the same meaning (base coordinates,
what that link exerts on its environment), and ``f_ext_point`` None or ``{link: p}``, each p (3,)
or (B, 3) [m] in that link's own frame (default its origin). Link i is the one joint i moves
(``robot.link_names``). This is Pinocchio's ``fext``, a wrench per body, with two differences
of convention: Pinocchio's is the force applied *to* the body, in its joint's local frame about
the joint origin; ours is its negative, in base coordinates, at the point given. Example: the
left hand pushes down with 10 N at 0.1 m along its z axis, the right hand holds a 2 N m moment
about the base z axis: ``f_ext={"hand_l": [0, 0, -10, 0, 0, 0], "hand_r": [0, 0, 0, 0, 0, 2]},
f_ext_point={"hand_l": [0, 0, 0.1]}``. An unknown link is a StateError naming it.

The caller's arrays are never modified. Errors are :class:`mrnea.errors.StateError` (shapes, NaN,
unknown method) and :class:`mrnea.errors.SingularMassMatrixError`.

The fast path. A single state of one-dimensional float64 ndarrays without a wrench (a Jacobian: with
or without its point) goes straight to a kernel's compiled ``free`` entry (:class:`_Entry`), on the
robot's compiled arrays and the scratch :mod:`mrnea.compiled` keeps: at n = 6 the kernel takes about
2 us, so every check in Python counts. The wrapper checks only what the entry cannot (dtype and
ndim: the entry would read another dtype or ndim wrongly); the kernel checks the lengths (status
SIZE), the layout (a strided view: status LAYOUT) and finiteness. Anything else (lists, a
batch, a wrong length, a strided view, NaN, a Robot not compiled yet or a non-Robot, which fail
with KeyError, AttributeError or the entry's TypeError) takes the validated path,
:func:`_evaluate`, which converts the inputs (:mod:`mrnea.validate`) or names the
offending one.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from typing import Literal

import numba as nb
import numpy as np
from numpy.typing import ArrayLike, NDArray

from mrnea import compiled, validate
from mrnea.compiled import BY_ID
from mrnea.errors import StateError, quote
from mrnea.kernels.aba import aba, aba_batch
from mrnea.kernels.engines import (
    ENGINE_CRBA,
    ENGINE_MRNEA,
    ENGINE_WALKER_ORIN,
    fd_batch,
    fd_crba,
    fd_walker_orin,
    mass_matrix_bias_batch,
)
from mrnea.kernels.kinematics import frames, frames_batch, jacobian_batch, link_jacobian_ws
from mrnea.kernels.kinematics import jacobian as jacobian_kernel
from mrnea.kernels.layout import (
    IN_T,
    MODEL_T,
    MODEL_TREE_T,
    OUT1_T,
    OUT2_T,
    OUT3_T,
    SCRATCH_T,
    TREE,
    batch_scratch,
)
from mrnea.kernels.mrnea import fd_mrnea, mrnea
from mrnea.kernels.rnea import reactions, reactions_batch, rnea, rnea_batch
from mrnea.kernels.status import OK
from mrnea.kernels.walker_orin import walker_orin
from mrnea.model import Robot
from mrnea.tool import Tool, tool_frame

Method = Literal["mrnea", "walker_orin", "crba", "aba"]


class _Entry:
    """A single-state kernel called through its machine-code entries for fixed signatures.

    Numba's dispatcher types every argument on every call to pick the compiled version; at this
    size that costs about a third of a call. The public functions check what the entry cannot
    (the fast path in the module docstring, or :func:`mrnea.validate.inputs`), so they call an
    entry directly: ``free`` takes ``fext=None, pe=None`` (no external wrench: two fewer arrays
    cross from Python; the kernel passes the zero wrench to its pass itself, so that the pass is
    the batches' and the loop's compiled copy: kernels/entry.py), ``call`` takes both arrays,
    ``links`` the per-link wrench arrays (n, 6) and (n, 3) (a wrench by link name). The state
    arrays are typed any layout (``IN_T``); the kernel reads them as C arrays where they are
    contiguous, else returns LAYOUT and the wrapper takes the validated path.
    ``Dispatcher.compile`` compiles an entry (or loads it from Numba's disk cache) on its first
    call and returns it.
    The kernel's arguments are ``(model, *states, *optional, *outputs, scratch)``: ``optional``
    counts the inputs ``free`` passes as None (the wrench and its point; a Jacobian's point).
    These entries take a serial chain's model; ``tree``, the same entries for a tree's model (the
    two differ in type: kernels/layout.py), is used where ``BY_ID``'s tree flag is set (a
    chain's entry given a tree's model would read it in the wrong order).
    """

    __slots__ = ("_kernel", "call", "free", "links", "tree")

    def __init__(self, kernel: nb.core.registry.CPUDispatcher, *outputs: nb.types.Type,
                 optional: int = 2, model: nb.types.Type = MODEL_T) -> None:
        py_func = getattr(kernel, "py_func", kernel)  # a plain function under NUMBA_DISABLE_JIT
        states = [IN_T] * (py_func.__code__.co_argcount - 2 - optional - len(outputs))
        self._kernel = kernel
        self.tree = (self if model is MODEL_TREE_T else
                     _Entry(kernel, *outputs, optional=optional, model=MODEL_TREE_T))
        if hasattr(kernel, "compile"):
            given, none = [IN_T] * optional, [nb.types.none] * optional
            self.call = self._first(
                "call", nb.types.int64(model, *states, *given, *outputs, SCRATCH_T))
            self.free = self._first(
                "free", nb.types.int64(model, *states, *none, *outputs, SCRATCH_T))
            self.links = self._first(
                "links", nb.types.int64(model, *states, *[OUT2_T] * optional, *outputs,
                                        SCRATCH_T))
        else:
            self.call = self.free = self.links = kernel

    def _first(self, slot: str, sig: nb.core.typing.Signature) -> Callable[..., int]:
        """A stand-in for the entry ``slot`` that compiles it on its first call."""

        def first(*args: object) -> int:
            entry = self._kernel.compile(sig)
            setattr(self, slot, entry)
            return entry(*args)

        return first


_FD = {  # method: the single-state entry, the batch kernel
    "mrnea": (_Entry(fd_mrnea, OUT1_T), partial(fd_batch, engine=ENGINE_MRNEA)),
    "walker_orin": (_Entry(fd_walker_orin, OUT1_T), partial(fd_batch, engine=ENGINE_WALKER_ORIN)),
    "crba": (_Entry(fd_crba, OUT1_T), partial(fd_batch, engine=ENGINE_CRBA)),
    "aba": (_Entry(aba, OUT1_T), aba_batch),
}
_HB = {"mrnea": (_Entry(mrnea, OUT2_T, OUT1_T),
                 partial(mass_matrix_bias_batch, engine=ENGINE_MRNEA)),
       "walker_orin": (_Entry(walker_orin, OUT2_T, OUT1_T),
                       partial(mass_matrix_bias_batch, engine=ENGINE_WALKER_ORIN))}
_RNEA = _Entry(rnea, OUT1_T)
_REACTIONS = _Entry(reactions, OUT2_T)
_FRAMES = _Entry(frames, OUT3_T, optional=0)
_JACOBIAN = _Entry(jacobian_kernel, OUT2_T, optional=1)
_F64 = np.dtype(np.float64)
_FAST_MISS = (KeyError, AttributeError, TypeError)  # what sends a fast-path call to _evaluate


def _evaluate(
    robot: Robot,
    kernel: _Entry,
    kernel_batch: Callable[..., None],
    states: dict[str, ArrayLike],
    f_ext: ArrayLike | None,
    f_ext_point: ArrayLike | None,
    shapes: Callable[[int], tuple[tuple[int, ...], ...]],
) -> list[NDArray[np.float64]]:
    """The validated path every public function shares: check and broadcast the inputs, run
    the single-state kernel or the batch kernel, raise what its status reports. ``shapes(n)``:
    the outputs' shapes for one state (a batch prepends B). Returns the outputs."""
    batched, arrays, fe, pe = validate.inputs(robot, states, f_ext, f_ext_point)
    m, _, ws, _ = compiled.of(robot)
    if m[0, TREE]:
        kernel = kernel.tree
    if batched:
        B = arrays[0].shape[0]
        outputs = [np.empty((B, *shape)) for shape in shapes(robot.n)]
        status = np.empty(B, dtype=np.int64)
        kernel_batch(m, *arrays, fe, pe, *outputs, status, batch_scratch(robot.n))
    else:
        outputs = [np.empty(shape) for shape in shapes(robot.n)]
        if f_ext is None:  # a point without a force changes nothing
            status = kernel.free(m, *arrays, None, None, *outputs, ws)
        elif fe.ndim == 2:  # a wrench per link
            status = kernel.links(m, *arrays, fe, pe, *outputs, ws)
        else:
            status = kernel.call(m, *arrays, fe, pe, *outputs, ws)
    if batched or status != OK:
        validate.check_status(robot, status, {**states, "f_ext": f_ext, "f_ext_point": f_ext_point})
    return outputs


def inverse_dynamics(
    robot: Robot,
    q: ArrayLike,
    qd: ArrayLike,
    qdd: ArrayLike,
    f_ext: ArrayLike | None = None,
    f_ext_point: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """Joint efforts ``tau = H(q) qdd + C(q, qd) qd + g(q) + J^T f_ext`` (Eq. 1) by the RNEA.

    Returns tau, (n,) or (B, n) [N m | N]. See the module docstring for shapes and ``f_ext``.
    """
    if f_ext is None and f_ext_point is None:
        try:  # the fast path (module docstring)
            m, shape, ws, _, tree = BY_ID[id(robot)]
            if q.dtype is qd.dtype is qdd.dtype is _F64 and q.ndim == qd.ndim == qdd.ndim == 1:
                tau = np.empty(shape)
                if (_RNEA.tree if tree else _RNEA).free(m, q, qd, qdd, None, None, tau, ws) == OK:
                    return tau
        except _FAST_MISS:
            pass
    args = {"q": q, "qd": qd, "qdd": qdd}
    (tau,) = _evaluate(robot, _RNEA, rnea_batch, args, f_ext, f_ext_point, lambda n: ((n,),))
    return tau


def mass_matrix_and_bias(
    robot: Robot,
    q: ArrayLike,
    qd: ArrayLike,
    f_ext: ArrayLike | None = None,
    f_ext_point: ArrayLike | None = None,
    method: Literal["mrnea", "walker_orin"] = "mrnea",
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The mass matrix H and bias u' with ``tau = H qdd + u'`` (Eqs. 2-3, 34-36).

    ``method="mrnea"`` (default) computes both in the paper's single modified RNEA pass;
    ``"walker_orin"`` by Walker-Orin method 1 (n + 1 Newton-Euler passes), for comparison.
    Returns H, (n, n) or (B, n, n), and u', (n,) or (B, n). u' includes gravity and f_ext.
    """
    if f_ext is None and f_ext_point is None:
        try:  # the fast path (module docstring); an unknown method fails here, and below
            m, shape, ws, _, tree = BY_ID[id(robot)]
            if q.dtype is qd.dtype is _F64 and q.ndim == qd.ndim == 1:
                H, u = np.empty(shape * 2), np.empty(shape)  # (n, n), (n,)
                e = _HB[method][0]
                if (e.tree if tree else e).free(m, q, qd, None, None, H, u, ws) == OK:
                    return H, u
        except _FAST_MISS:
            pass
    kernel, kernel_batch = validate.choice("method", method, _HB)
    H, u = _evaluate(robot, kernel, kernel_batch, {"q": q, "qd": qd}, f_ext, f_ext_point,
                     lambda n: ((n, n), (n,)))
    return H, u


def forward_dynamics(
    robot: Robot,
    q: ArrayLike,
    qd: ArrayLike,
    tau: ArrayLike,
    f_ext: ArrayLike | None = None,
    f_ext_point: ArrayLike | None = None,
    method: Method = "mrnea",
) -> NDArray[np.float64]:
    """Joint accelerations qdd from efforts tau: solves ``H qdd = tau - u'`` (Eq. 2).

    ``method``: ``"mrnea"`` (default; the paper: one mRNEA pass and a Cholesky solve),
    ``"walker_orin"`` (method 1, n + 1 RNEA passes), ``"crba"`` (composite-rigid-body H, RNEA
    bias), ``"aba"`` (articulated-body algorithm, O(n)). Returns qdd, (n,) or (B, n).
    Raises SingularMassMatrixError where H is not positive definite.
    """
    if f_ext is None and f_ext_point is None:
        try:  # the fast path (module docstring); an unknown method fails here, and below
            m, shape, ws, _, tree = BY_ID[id(robot)]
            if q.dtype is qd.dtype is tau.dtype is _F64 and q.ndim == qd.ndim == tau.ndim == 1:
                qdd = np.empty(shape)
                e = _FD[method][0]
                if (e.tree if tree else e).free(m, q, qd, tau, None, None, qdd, ws) == OK:
                    return qdd
        except _FAST_MISS:
            pass
    kernel, kernel_batch = validate.choice("method", method, _FD)
    args = {"q": q, "qd": qd, "tau": tau}
    (qdd,) = _evaluate(robot, kernel, kernel_batch, args, f_ext, f_ext_point, lambda n: ((n,),))
    return qdd


def joint_reactions(
    robot: Robot,
    q: ArrayLike,
    qd: ArrayLike,
    qdd: ArrayLike,
    f_ext: ArrayLike | None = None,
    f_ext_point: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """Each joint's 6-axis reaction wrench, for bearing and link design (Eqs. 18-19, 32).

    Returns (n, 6) or (B, n, 6): row i is ``[f; n]``, the force [N] and moment [N m] that link
    i-1 (the base for i = 0) exerts on link i through joint i, expressed in joint i's frame
    (the parent link's frame moved by the joint origin: fixed to the parent, z-free for a
    URDF joint with axis z) with the moment taken about that frame's origin, a point of the
    joint axis. The component along the joint axis of the moment (revolute) or force
    (prismatic) is the joint effort tau_i; the rest is what the bearing carries.
    """
    if f_ext is None and f_ext_point is None:
        try:  # the fast path (module docstring)
            m, shape, ws, _, tree = BY_ID[id(robot)]
            if q.dtype is qd.dtype is qdd.dtype is _F64 and q.ndim == qd.ndim == qdd.ndim == 1:
                out = np.empty((*shape, 6))
                e = _REACTIONS.tree if tree else _REACTIONS
                if e.free(m, q, qd, qdd, None, None, out, ws) == OK:
                    return out
        except _FAST_MISS:
            pass
    args = {"q": q, "qd": qd, "qdd": qdd}
    (out,) = _evaluate(robot, _REACTIONS, reactions_batch, args, f_ext, f_ext_point,
                       lambda n: ((n, 6),))
    return out


def forward_kinematics(robot: Robot, q: ArrayLike, tool: Tool = None) -> NDArray[np.float64]:
    """Homogeneous poses of the base and of every link frame, in base coordinates; with
    ``tool``, the tool frame's pose after them.

    Parameters
    ----------
    robot : Robot
    q : (n,) or (B, n) joint positions [rad | m].
    tool : None, or a tool frame (:mod:`mrnea.tool`): on a serial chain fixed to the last link,
        the name of the last link or of a frame fixed to it (``"panda_hand_tcp"``),
        ``{"xyz": [m], "rpy": [rad]}`` in the last link's frame, or a (4, 4) transform; on a
        tree fixed to the link it names (a link's or a frame's name, or ``{"xyz", "rpy",
        "link"}``).

    Returns
    -------
    T : (n + 1, 4, 4) or (B, n + 1, 4, 4); with a tool (n + 2, 4, 4) or (B, n + 2, 4, 4).
        ``T[0]`` is the base frame (the identity);
        ``T[i + 1]`` is link i's frame ``T_i = T_{i-1} @ origin_i @ motion_i(q_i)`` (URDF
        conventions, :mod:`mrnea.model`): its rotation ``T[i + 1, :3, :3]`` (the link's axes in
        base coordinates) and origin ``T[i + 1, :3, 3]`` [m]. The order of Pinocchio's
        ``data.oMi`` (index 0 the universe). With a tool fixed to link i,
        ``T[n + 1] = T[i + 1] @ T_tool`` is the tool frame (Pinocchio's ``data.oMf`` of that
        frame). Either way ``T[-1]`` is the tool frame's pose (without a tool, the last link's).
    """
    if tool is not None:
        validate.require_robot(robot)
        link, Tt = tool_frame(robot, tool)
        T = forward_kinematics(robot, q)
        return np.concatenate([T, (T[..., link + 1, :, :] @ Tt)[..., None, :, :]], axis=-3)
    try:  # the fast path (module docstring)
        m, shape, ws, _, tree = BY_ID[id(robot)]
        if q.dtype is _F64 and q.ndim == 1:
            T = np.empty((shape[0] + 1, 4, 4))
            if (_FRAMES.tree if tree else _FRAMES).free(m, q, T, ws) == OK:
                return T
    except _FAST_MISS:
        pass
    batched, q, _ = validate.kinematics_inputs(robot, q, None)
    m, _, ws, _ = compiled.of(robot)
    T = np.empty((*q.shape[:-1], robot.n + 1, 4, 4))
    if batched:
        status = np.empty(q.shape[0], dtype=np.int64)
        frames_batch(m, q, T, status, batch_scratch(robot.n))
    else:
        status = (_FRAMES.tree if m[0, TREE] else _FRAMES).free(m, q, T, ws)
    validate.check_status(robot, status, {"q": q})
    return T


def jacobian(robot: Robot, q: ArrayLike, point: ArrayLike | None = None,
             link: str | None = None) -> NDArray[np.float64]:
    """The geometric Jacobian of a point of the last link (or of ``link``), in base coordinates.

    ``J @ qd = [v; w]``: the linear velocity [m/s] of the point and the angular velocity
    [rad/s] of the last link, both in base coordinates (rows linear then angular, Pinocchio's
    order; its ``LOCAL_WORLD_ALIGNED`` Jacobian of a frame at the point). Column k is
    ``[z_k x (p - o_k); z_k]`` for a revolute joint k and ``[z_k; 0]`` for a prismatic one
    (z_k, o_k: joint k's axis and a point on it; p: the point). ``J.T @ f_ext`` is the effort
    the joints supply against a wrench ``f_ext = [f; n]`` the last link exerts at the point
    (:func:`inverse_dynamics` with ``f_ext_point=point``).

    Parameters
    ----------
    robot : Robot
    q : (n,) or (B, n) joint positions [rad | m].
    point : (3,) or (B, 3) [m], in the last link's frame (``link``'s); None: its origin.
    link : None (the last link), or the name of any link of the robot (``robot.link_names``;
        on a tree, any branch's) or of a frame fixed to one (``Link.frames``: a URDF link
        merged by a fixed joint, a TCP): the point is fixed to that link, given in that link's
        (or frame's) axes and origin, and column k is zero unless joint k carries it.
        Pinocchio's ``getFrameJacobian`` of a frame at the point on that link,
        ``LOCAL_WORLD_ALIGNED``.

    Returns
    -------
    J : (6, n) or (B, 6, n) [m/rad or -, rad/rad or rad/m: per unit joint rate].
    """
    if link is not None:
        return _link_jacobian(robot, q, point, link)
    try:  # the fast path (module docstring); a point must be a (3,) float64 array
        m, shape, ws, _, tree = BY_ID[id(robot)]
        if q.dtype is _F64 and q.ndim == 1 and (point is None or (
                point.dtype is _F64 and point.ndim == 1)):
            J = np.empty((6, shape[0]))
            if point is None:
                status = (_JACOBIAN.tree if tree else _JACOBIAN).free(m, q, None, J, ws)
            else:
                status = (_JACOBIAN.tree if tree else _JACOBIAN).call(m, q, point, J, ws)
            if status == OK:
                return J
    except _FAST_MISS:
        pass
    batched, q, p = validate.kinematics_inputs(robot, q, point)
    m, _, ws, _ = compiled.of(robot)
    J = np.empty((*q.shape[:-1], 6, robot.n))
    if batched:
        status = np.empty(q.shape[0], dtype=np.int64)
        jacobian_batch(m, q, p, J, status, batch_scratch(robot.n))
    else:
        status = (_JACOBIAN.tree if m[0, TREE] else _JACOBIAN).call(m, q, p, J, ws)
    validate.check_status(robot, status, {"q": q, "point": p})
    return J


def _link_jacobian(robot: Robot, q: ArrayLike, point: ArrayLike | None,
                   link: str) -> NDArray[np.float64]:
    """:func:`jacobian` of a point of the named link or frame, state by state
    (``link_jacobian_ws``); a frame's point is moved into its link's frame first."""
    validate.require_robot(robot)
    frames = {f.name: (t, f.origin) for t, lk in enumerate(robot.links) for f in lk.frames}
    if not isinstance(link, str):
        raise StateError(f"link: expected a link's or frame's name (str), got "
                         f"{type(link).__name__} {quote(link)}")
    if link not in robot.link_names and link not in frames:
        raise StateError(f"link: {link!r} is neither a link of robot '{robot.name}' (its links: "
                         f"{', '.join(robot.link_names)}) nor a frame fixed to one"
                         + (f" (its frames: {', '.join(frames)})" if frames else ""))
    batched, q, p = validate.kinematics_inputs(robot, q, point)
    m, _, ws, _ = compiled.of(robot)
    if link in robot.link_names:
        t = robot.link_names.index(link)
    else:  # the point in the frame's axes -> the link's
        t, origin = frames[link]
        p = np.ascontiguousarray(p @ origin[:3, :3].T + origin[:3, 3])
    Q, P = np.atleast_2d(q), np.atleast_2d(p)
    J = np.empty((Q.shape[0], 6, robot.n))
    status = np.array([link_jacobian_ws(m, Q[b], t, P[b], J[b], ws) for b in range(len(Q))])
    validate.check_status(robot, status if batched else int(status[0]), {"q": q, "point": p})
    return J if batched else J[0]
