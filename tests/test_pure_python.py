"""mrnea runs with Numba's compiler switched off (``NUMBA_DISABLE_JIT=1``, a debugging aid the
benchmarks' flop counter uses): the package imports, and its kernels, run as Python, give
Pinocchio's inverse dynamics and forward dynamics."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
from conftest import to_pinocchio

_SCRIPT = """
import json, numpy as np, mrnea
robot = mrnea.robots.puma560()
q, qd, qdd = np.linspace(-1, 1, 6), np.linspace(0.5, -0.5, 6), np.linspace(-2, 3, 6)
tau = mrnea.inverse_dynamics(robot, q, qd, qdd)
fd = mrnea.forward_dynamics(robot, q, qd, tau + 1.0)
print(json.dumps({"tau": tau.tolist(), "fd": fd.tolist()}))
"""


def test_the_package_runs_as_python_and_agrees_with_pinocchio() -> None:
    import pinocchio as pin

    import mrnea

    env = dict(os.environ, NUMBA_DISABLE_JIT="1")
    out = subprocess.run([sys.executable, "-c", _SCRIPT], env=env, capture_output=True,
                         text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    got = json.loads(out.stdout.strip().splitlines()[-1])
    model = to_pinocchio(mrnea.robots.puma560())
    data = model.createData()
    q, qd, qdd = np.linspace(-1, 1, 6), np.linspace(0.5, -0.5, 6), np.linspace(-2, 3, 6)
    tau = pin.rnea(model, data, q, qd, qdd)
    np.testing.assert_allclose(got["tau"], tau, rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(got["fd"], pin.aba(model, data, q, qd, tau + 1.0),
                               rtol=1e-10, atol=1e-10)
