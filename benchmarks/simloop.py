"""The simulation system's cycle written in Python with Pinocchio calls: what mrnea.simulate is
compared with.

Usage: ``out = pinocchio_loop(model, data, robot, q_cmd, dt, limit)``; ``check(result, out,
robot)`` gives the largest deviations from an ``mrnea.simulate(..., mode="paper")`` result.

Per cycle k, as kernels/simulate.py and kernels/achievable.py do in paper mode (Eq. 44):
desired acceleration from the commanded velocity, ``qdd_des = (qd_cmd[k+1] - qd) / dt``; required
efforts ``tau_req = pin.rnea(q, qd, qdd_des) + F_v qd + F_s sign(qd)`` (the rotor inertia is
``model.armature = G^2 J_m``, so rnea includes it), with the Coulomb friction of the velocity
the cycle wants, v (F+ moving up, -F- moving down; at rest, static friction takes up to its
capacity of the holding effort); saturation ``tau = clip(tau_req, -limit, limit)``; achievable
accelerations ``qdd = pin.aba(q, qd, tau - friction)``; the joint reactions of that motion from
``pin.rnea(q, qd, qdd)``'s ``data.f``; and the state update mrnea uses, ``qd += qdd dt``,
``q += qd dt``. With limits that never bind this is mrnea's exact cycle solve's answer (the
velocity wanted is the velocity held); mrnea's solve where a limit binds or a joint stops or
reverses against friction, its position and velocity clamps and its
speed-dependent limits are not repeated here (so the loop does a little less than mrnea's), and
the reactions are stored as Pinocchio gives them (``data.f``, joint frame after the motion) and
converted only for the check.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from mrnea import Robot


def pinocchio_loop(model: pin.Model, data: pin.Data, robot: Robot, q_cmd: np.ndarray, dt: float,
                   limit: np.ndarray) -> dict[str, np.ndarray]:
    """Run the cycle over every row of q_cmd (K, n) (module docstring); returns the arrays."""
    K, n = q_cmd.shape
    Fv, Fp, Fn = robot.viscous_friction, robot.coulomb_friction[:, 0], robot.coulomb_friction[:, 1]
    v_cmd = np.zeros_like(q_cmd)
    v_cmd[1:] = np.diff(q_cmd, axis=0) / dt
    out = {k: np.empty((K, n)) for k in ("q", "qd", "qdd_des", "qdd", "tau", "tau_required")}
    out["saturated"] = np.empty((K, n), dtype=bool)
    out["reaction"] = np.empty((K, n, 6))
    zero = np.zeros(n)
    q, qd = q_cmd[0].copy(), np.zeros(n)
    forces = data.f
    for k in range(K):
        v = v_cmd[k + 1] if k + 1 < K else zero  # the program ends at rest
        qdd_des = (v - qd) / dt
        h = pin.rnea(model, data, q, qd, qdd_des) + Fv * qd
        friction = Fv * qd + np.where(v > 0.0, Fp, np.where(v < 0.0, -Fn, np.clip(-h, -Fn, Fp)))
        tau_req = h + friction - Fv * qd
        tau = np.clip(tau_req, -limit, limit)
        qdd = pin.aba(model, data, q, qd, tau - friction)
        pin.rnea(model, data, q, qd, qdd)
        W = out["reaction"][k]
        for i in range(n):
            W[i] = forces[i + 1].vector
        out["q"][k], out["qd"][k], out["qdd_des"][k], out["qdd"][k] = q, qd, qdd_des, qdd
        out["tau"][k], out["tau_required"][k] = tau, tau_req
        out["saturated"][k] = np.abs(tau_req) > limit
        qd = qd + qdd * dt
        q = q + qd * dt
    return out


def _rotations(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rotation matrices (K, 3, 3) about the unit axis by each angle (Rodrigues)."""
    x = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    s, c = np.sin(angle)[:, None, None], np.cos(angle)[:, None, None]
    return np.eye(3) + s * x + (1.0 - c) * (x @ x)


def reactions_in_joint_frames(robot: Robot, q: np.ndarray, wrench: np.ndarray) -> np.ndarray:
    """Pinocchio's data.f (joint frame after the motion) in mrnea's convention: the joint frame
    before the motion, moment about its origin (revolute joints: rotate by Rot(axis, q);
    prismatic: same axes, moment shifted by (q axis) x f)."""
    out = np.empty_like(wrench)
    for i, j in enumerate(robot.joints):
        f, m = wrench[:, i, :3], wrench[:, i, 3:]
        axis = np.asarray(j.axis)
        if j.is_prismatic:
            out[:, i, :3] = f
            out[:, i, 3:] = m + np.cross(q[:, i, None] * axis, f)
        else:
            Rq = _rotations(axis, q[:, i])
            out[:, i, :3] = np.einsum("kab,kb->ka", Rq, f)
            out[:, i, 3:] = np.einsum("kab,kb->ka", Rq, m)
    return out


def check(result, out: dict[str, np.ndarray], robot: Robot) -> dict[str, float]:
    """Largest deviations of the Python loop from mrnea.simulate's result, each relative to the
    largest value (or absolute below 1): q, tau, tau_required, qdd, reactions."""

    def rel(a, b):
        return float(np.max(np.abs(a - b)) / max(1.0, float(np.max(np.abs(b)))))

    W = reactions_in_joint_frames(robot, out["q"], out["reaction"])
    return {"q": rel(out["q"], result.q), "qdd": rel(out["qdd"], result.qdd),
            "tau": rel(out["tau"], result.tau),
            "tau_required": rel(out["tau_required"], result.tau_required),
            "reaction": rel(W, result.reaction),
            "saturated cycles": int(result.saturated.any(axis=1).sum())}
