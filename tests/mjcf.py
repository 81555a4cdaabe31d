"""An mrnea Robot as MuJoCo MJCF with its actuator model (test helper; the body tree follows the
project's benchmarks/to_mjcf.py).

Per joint: ``armature = G^2 J_m``, ``damping = F_v``, and optionally ``frictionloss = F_s``
(with the given ``solreffriction`` / ``solimpfriction``), and one actuator:

* ``"motor"``: ``<motor gear="G" forcerange="-L/G L/G">``: ctrl is the motor torque, the joint
  gets G * clamp(ctrl, +-L/G) (the PAPER mode's clamp, done by MuJoCo);
* ``"velocity"``: ``<velocity gear="G" kv="kv" forcerange="-L/G L/G">``: the motor-side force
  kv (ctrl - G qd), clamped; with ctrl = G v_des the joint gets clamp(K (v_des - qd), +-L),
  K = kv G^2 (a speed-controlled drive of finite gain K);
* ``None``: no actuator.

Contacts are disabled; the integrator and ``eulerdamp`` are options.
"""

from __future__ import annotations

from xml.sax.saxutils import quoteattr

import numpy as np
from scipy.spatial.transform import Rotation

from mrnea import Robot


def quaternion(R: np.ndarray) -> np.ndarray:
    """Unit quaternion (w, x, y, z), MuJoCo's order, of a rotation matrix (SciPy's is x, y, z,
    w)."""
    return np.roll(Rotation.from_matrix(R).as_quat(), 1)


def _num(x: float) -> str:
    return repr(float(x))


def _nums(a) -> str:
    return " ".join(_num(x) for x in np.ravel(a))


def to_mjcf(robot: Robot, actuator: str | None = "motor", L=None, kv: float = 0.0,
            frictionloss=None, solreffriction=None, solimpfriction=None, timestep: float = 1e-3,
            integrator: str = "Euler", eulerdamp: bool = False) -> str:
    """MJCF text of ``robot`` with its actuators (module docstring). ``L`` (n,): joint-side
    limits (finite), default the joints' effort limits."""
    n = robot.n
    G = np.array([j.gear_ratio for j in robot.joints])
    arm = G**2 * np.array([j.rotor_inertia for j in robot.joints])
    damp = np.array([j.viscous_friction for j in robot.joints])
    L = np.array([j.effort_limit for j in robot.joints]) if L is None else np.asarray(L, float)
    fl = np.zeros(n) if frictionloss is None else np.asarray(frictionloss, float)
    lines = [
        f"<mujoco model={quoteattr(robot.name)}>",
        '  <compiler angle="radian" autolimits="false"/>',
        f'  <option gravity="{_nums(robot.gravity)}" timestep="{_num(timestep)}" '
        f'integrator="{integrator}">',
        f'    <flag contact="disable" eulerdamp="{"enable" if eulerdamp else "disable"}"/>',
        "  </option>",
        "  <worldbody>",
    ]
    indent = "    "
    for i, (j, lk) in enumerate(zip(robot.joints, robot.links, strict=True)):
        origin = np.asarray(j.origin)
        I_ = np.asarray(lk.inertia)
        full = (I_[0, 0], I_[1, 1], I_[2, 2], I_[0, 1], I_[0, 2], I_[1, 2])
        kind = "slide" if j.type == "prismatic" else "hinge"
        extra = ""
        if fl[i] > 0:
            extra += f' frictionloss="{_num(fl[i])}"'
            if solreffriction is not None:
                extra += f' solreffriction="{_nums(solreffriction)}"'
            if solimpfriction is not None:
                extra += f' solimpfriction="{_nums(solimpfriction)}"'
        lines += [
            f"{indent}<body name={quoteattr(lk.name)} pos=\"{_nums(origin[:3, 3])}\" "
            f"quat=\"{_nums(quaternion(origin[:3, :3]))}\">",
            f"{indent}  <joint name={quoteattr(j.name)} type=\"{kind}\" axis=\"{_nums(j.axis)}\" "
            f"limited=\"false\" armature=\"{_num(arm[i])}\" damping=\"{_num(damp[i])}\"{extra}/>",
            f"{indent}  <inertial mass=\"{_num(lk.mass)}\" pos=\"{_nums(lk.com)}\" "
            f"fullinertia=\"{_nums(full)}\"/>",
        ]
        indent += "  "
    for _ in robot.joints:
        indent = indent[:-2]
        lines.append(f"{indent}</body>")
    lines.append("  </worldbody>")
    if actuator is not None:
        lines.append("  <actuator>")
        for i, j in enumerate(robot.joints):
            rng = f'forcelimited="true" forcerange="{_num(-L[i] / G[i])} {_num(L[i] / G[i])}"'
            if actuator == "motor":
                lines.append(f'    <motor joint={quoteattr(j.name)} gear="{_num(G[i])}" {rng}/>')
            else:
                lines.append(f'    <velocity joint={quoteattr(j.name)} gear="{_num(G[i])}" '
                             f'kv="{_num(kv)}" {rng}/>')
        lines.append("  </actuator>")
    lines += ["</mujoco>", ""]
    return "\n".join(lines)
