"""A sweep on a branching robot (issue 25): per-joint grid keys name joints of different
branches (``effort_limit.waist``, the torso's joint; ``effort_limit.shoulder_pitch_l``, on the
left arm), run on a cluster in processes of its own reached through its scheduler address
(``conftest.scheduler_address``), on ``examples/waist_two_arms.urdf`` with
``examples/waist_left_swing.toml`` (waypoints by joint name).

Oracle: Pinocchio's model of the same URDF. The program's own requirement of each joint is
``pinocchio.rnea`` at the program's states (q_cmd[k], qd_cmd[k] = (q_cmd[k] - q_cmd[k-1]) / dt,
qdd = (qd_cmd[k+1] - qd_cmd[k]) / dt, the velocity after the last row 0: docs/simulation.md);
the URDF has no friction nor rotor inertia, so that is the whole actuator model. A row is
achievable exactly when both swept limits are above those peaks (the other joints' limits are
far above theirs), and a row's per-joint columns carry the joints' names.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import mrnea

pin = pytest.importorskip("pinocchio")

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
URDF = EXAMPLES / "waist_two_arms.urdf"
PROGRAM = EXAMPLES / "waist_left_swing.toml"


def program_peaks(robot: mrnea.Robot, prog) -> np.ndarray:
    """Per joint, the peak |effort| the commanded motion needs, by pinocchio.rnea."""
    model = pin.buildModelFromUrdf(str(URDF))
    assert [model.names[i] for i in range(1, model.njoints)] == list(robot.joint_names)
    data = model.createData()
    q, dt = prog.q_cmd, prog.dt
    v = np.vstack([np.zeros((1, robot.n)), np.diff(q, axis=0) / dt])  # qd_cmd
    a = (np.vstack([v[1:], np.zeros((1, robot.n))]) - v) / dt
    tau = np.array([pin.rnea(model, data, q[k], v[k], a[k]) for k in range(len(q))])
    return np.abs(tau).max(axis=0)


def test_sweep_per_joint_keys_by_name_on_a_tree(scheduler_address) -> None:
    prog = mrnea.load_program(PROGRAM)
    robot = prog.load_robot()
    assert not robot.is_serial
    names = robot.joint_names
    peak = program_peaks(robot, prog)
    w, s = names.index("waist"), names.index("shoulder_pitch_l")
    assert robot.parents[s] == w  # the left arm hangs from the torso, the waist's link
    # the other joints' limits hold what the program needs of them; the two swept ones
    # are tried just below and just above it
    others = [i for i in range(robot.n) if i not in (w, s)]
    assert np.all(peak[others] < 0.9 * robot.effort_limit[others])
    grid = {"effort_limit.waist": [0.97 * peak[w], 1.03 * peak[w]],
            "effort_limit.shoulder_pitch_l": [0.97 * peak[s], 1.03 * peak[s]]}
    df = mrnea.sweep(robot, prog, grid, client=scheduler_address, progress=False)
    assert len(df) == 4 and df["error"].isna().all()
    for _, row in df.iterrows():
        above_w = row["effort_limit.waist"] > peak[w]
        above_s = row["effort_limit.shoulder_pitch_l"] > peak[s]
        assert bool(row["achievable"]) is bool(above_w and above_s), row.to_dict()
        if not row["achievable"]:
            assert row["first_infeasible_joint"] in {"waist", "shoulder_pitch_l"}
            if not above_w and above_s:
                assert row["first_infeasible_joint"] == "waist"
            if above_w and not above_s:
                assert row["first_infeasible_joint"] == "shoulder_pitch_l"
        # the program's requirement, per joint by name, is Pinocchio's whatever the limits
        for i, n in enumerate(names):
            assert row[f"program_peak_effort.{n}"] == pytest.approx(peak[i], rel=1e-9, abs=1e-9)
    # a variant changes only the named joint, whichever branch it is on
    v = mrnea.sweep.variant(robot, **{"effort_limit.shoulder_pitch_l": 5.0})
    changed = np.flatnonzero(v.effort_limit != robot.effort_limit)
    assert changed.tolist() == [s] and v.effort_limit[s] == 5.0
