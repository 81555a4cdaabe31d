"""A sweep (issue 25) of a program with wrenches on two named links of a tree robot (the torso
with two arms of examples/), over payloads on the last link, run on a Dask scheduler by its
address. Oracle: Pinocchio's ``rnea`` at rest of the same URDF, the payload a point mass added
to the last link's body and the two wrenches in its ``fext`` (built as tests/test_link_wrench.py
does): holding a pose, every cycle's joint effort is that, so each row's ``peak_effort.<joint>``
is its magnitude, per joint by name.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import PinChain, pin_from_urdf
from test_link_wrench import HOLD, P_L, TWO_WRENCHES, URDF, W_L, W_R, _hold_program, _pin_fext

import mrnea

pin = pytest.importorskip("pinocchio")


def test_a_sweep_of_payloads_with_wrenches_on_named_links_equals_pinocchio(
        tmp_path, scheduler_address) -> None:
    prog = _hold_program(tmp_path, TWO_WRENCHES)
    robot = mrnea.load_urdf(URDF)
    grid = {"payload": [0.0, 1.5], "payload_point": [[0.03, 0.0, 0.04]]}
    df = mrnea.sweep(robot, prog, grid, client=scheduler_address, progress=False)
    assert len(df) == 2 and df["error"].isna().all(), df["error"].tolist()
    q = np.array([HOLD.get(j, 0.0) for j in robot.joint_names])
    zero = np.zeros(robot.n)
    for _, row in df.iterrows():
        model = pin_from_urdf(URDF, robot)
        pc = PinChain(robot, model)
        last = pc.ids[robot.n - 1]  # the last link's body
        model.inertias[last] = model.inertias[last] + pin.Inertia(
            float(row["payload"]), np.array([0.03, 0.0, 0.04]), np.zeros((3, 3)))
        fext = _pin_fext(pc, robot, q, {"hand_l": np.array(W_L), "upper_arm_r": np.array(W_R)},
                         {"hand_l": np.array(P_L)})
        ref = pc.ours(pin.rnea(model, pc.data, pc.config(q), zero, zero, fext))
        got = np.array([row[f"peak_effort.{j}"] for j in robot.joint_names])
        assert np.allclose(got, np.abs(ref), rtol=1e-9, atol=1e-9), (got, ref)
    # the payload changes the efforts (the oracle tells the rows apart)
    a, b = (np.array([df.iloc[i][f"peak_effort.{j}"] for j in robot.joint_names]) for i in (0, 1))
    assert np.max(np.abs(a - b)) > 1e-3
