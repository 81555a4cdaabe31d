"""Forward dynamics on trees (issue 25): Baxter (17 joints: head, two 7-joint arms, one finger
per gripper) and the Allegro hand (16: four fingers of 4 on the palm) of example-robot-data,
loaded with a fixed base, against ``pinocchio.aba`` from Python.

* Per call (ns of thread CPU time, best of 9 rounds of timeit's autorange, one state):
  ``mrnea.forward_dynamics`` by the mRNEA (one pass and the tree's sparse L^T L solve,
  kernels/solve.py ``ltl_solve``) and by mrnea's ABA, and ``pinocchio.aba``.
* Per state in a batch of B = 1000 (ns of wall-clock time: mrnea's batch runs on Numba's
  threads, whose CPU time counts their spin-waits too): mrnea's batch call against a Python
  loop of ``pinocchio.aba``. On a loaded machine these two are only indicative.
* The factorisation alone (ns of thread CPU time, a compiled loop of 1000 solves of the same H,
  best of 9): the dense Cholesky against the sparse LTL.

CPU time keeps the other figures meaningful on a loaded machine (preemption is not counted). Each
mrnea result is checked against Pinocchio's (max relative error printed). Printed as JSON::

    PYTHONPATH=$PWD/src python benchmarks/tree_fd.py

(docs/performance.md, section 14).
"""

from __future__ import annotations

import json
import site
import time
import timeit
import warnings
from pathlib import Path

import numba as nb
import numpy as np
import pinocchio as pin

import mrnea
from mrnea.compiled import of
from mrnea.kernels.solve import cholesky_solve, ltl_solve

TREES = {  # name: (file, tips), as tests/test_tree_urdf.py loads them
    "baxter": ("baxter_description/urdf/baxter.urdf",
               ("head", "right_wrist", "left_wrist", "r_gripper_l_finger", "l_gripper_l_finger")),
    "allegro": ("allegro_hand_description/urdf/allegro_right_hand.urdf", None),
}
B = 1000


def robots_dir() -> Path:
    return next(Path(sp) / "cmeel.prefix/share/example-robot-data/robots"
                for sp in site.getsitepackages()
                if (Path(sp) / "cmeel.prefix/share/example-robot-data/robots").is_dir())


def pin_model(path: Path, robot: mrnea.Robot):
    """Pinocchio's model of the URDF, the joints mrnea leaves out locked at 0 (as mrnea lumps
    them), mrnea's gravity."""
    full = pin.buildModelFromUrdf(str(path))
    keep = set(robot.joint_names)
    locked = [i for i in range(1, full.njoints) if full.names[i] not in keep]
    model = pin.buildReducedModel(full, locked, pin.neutral(full)) if locked else full
    model.gravity = pin.Motion(np.concatenate([np.asarray(robot.gravity, float), np.zeros(3)]))
    return model


def to_pin(model, robot: mrnea.Robot, q, v, tau):
    """Pinocchio's (q, v, tau) of mrnea's, joint by name ((cos, sin) for a continuous joint)."""
    qp, vp, tp = pin.neutral(model), np.zeros(model.nv), np.zeros(model.nv)
    for k, name in enumerate(robot.joint_names):
        jm = model.joints[model.getJointId(name)]
        if jm.nq == 2:
            qp[jm.idx_q:jm.idx_q + 2] = np.cos(q[k]), np.sin(q[k])
        else:
            qp[jm.idx_q] = q[k]
        vp[jm.idx_v], tp[jm.idx_v] = v[k], tau[k]
    return qp, vp, tp


def per_call(f, timer=time.thread_time) -> float:
    """ns per call of f: best of 9 rounds of timeit's autorange, in CPU time (a loaded
    machine's preemption is not counted)."""
    f()
    t = timeit.Timer(f, timer=timer)
    num, _ = t.autorange()
    return min(t.repeat(9, num)) / num * 1e9


@nb.njit
def _chol_loop(H, rhs, L, x, N):
    s = 0
    for _ in range(N):
        s += cholesky_solve(H, rhs, L, x)
    return s


@nb.njit
def _ltl_loop(m, H, rhs, L, x, N):
    s = 0
    for _ in range(N):
        s += ltl_solve(m, H, rhs, L, x)
    return s


def loop_ns(f) -> float:
    f()
    best = np.inf
    for _ in range(9):
        t = time.thread_time_ns()
        f()
        best = min(best, time.thread_time_ns() - t)
    return best / 1000


def measure(rel: str, tips: tuple[str, ...] | None, rng: np.random.Generator) -> dict:
    """The figures of one robot (module docstring)."""
    path = robots_dir() / rel
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # visuals left out of the 3D view
        robot = mrnea.load_urdf(path, tip=tips)
    model = pin_model(path, robot)
    data = model.createData()
    n = robot.n
    lo = np.where(np.isfinite(robot.lower), robot.lower, -np.pi)
    hi = np.where(np.isfinite(robot.upper), robot.upper, np.pi)
    Q, V, T = rng.uniform(lo, hi, (B, n)), rng.normal(0, 1, (B, n)), rng.normal(0, 5, (B, n))
    q, v, tau = Q[0], V[0], T[0]
    P = [to_pin(model, robot, *s) for s in zip(Q, V, T, strict=True)]
    qp, vp, tp = P[0]
    ref = np.array([pin.aba(model, data, *s).copy() for s in P])
    iv = [model.joints[model.getJointId(j)].idx_v for j in robot.joint_names]
    err = max(float(np.max(np.abs(mrnea.forward_dynamics(robot, Q, V, T, method=meth)
                                  - ref[:, iv]) / np.max(np.abs(ref))))
              for meth in ("mrnea", "aba"))

    def pin_batch():
        for s in P:
            pin.aba(model, data, *s)
    m = of(robot)[0]
    H, _ = mrnea.mass_matrix_and_bias(robot, q, v)
    rhs, L, x = tau.copy(), np.empty((n, n)), np.empty(n)
    r = {"n": n,
         "call_mrnea": per_call(lambda: mrnea.forward_dynamics(robot, q, v, tau)),
         "call_mrnea_aba": per_call(lambda: mrnea.forward_dynamics(robot, q, v, tau,
                                                                   method="aba")),
         "call_pinocchio_aba": per_call(lambda: pin.aba(model, data, qp, vp, tp)),
         "batch_mrnea": per_call(lambda: mrnea.forward_dynamics(robot, Q, V, T),
                                 time.perf_counter) / B,
         "batch_pinocchio_loop": per_call(pin_batch, time.perf_counter) / B,
         "factor_solve_dense_cholesky": loop_ns(lambda: _chol_loop(H, rhs, L, x, 1000)),
         "factor_solve_sparse_ltl": loop_ns(lambda: _ltl_loop(m, H, rhs, L, x, 1000))}
    return {**{k: round(val, 1) for k, val in r.items()}, "max_rel_err_vs_pinocchio": err}


def main() -> None:
    rng = np.random.default_rng(0)
    print(json.dumps({name: measure(rel, tips, rng) for name, (rel, tips) in TREES.items()},
                     indent=1))


if __name__ == "__main__":
    main()
