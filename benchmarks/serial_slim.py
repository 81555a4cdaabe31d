"""Per-call time [ns] of mrnea forward dynamics, inverse dynamics and H + bias on the Puma 560
and the UR5 (best of 9 rounds of timeit's autorange), printed as JSON: run it alternately in two
checkouts (``PYTHONPATH=$PWD/src python benchmarks/serial_slim.py``) to compare their serial
paths (docs/performance.md, section 11).
"""

from __future__ import annotations

import json
import site
import timeit
from pathlib import Path

import numpy as np

import mrnea
from mrnea.robots import puma560


def main() -> None:
    robots_dir = next(Path(sp) / "cmeel.prefix/share/example-robot-data/robots"
                      for sp in site.getsitepackages()
                      if (Path(sp) / "cmeel.prefix/share/example-robot-data/robots").is_dir())
    robots = {"puma": puma560(),
              "ur5": mrnea.load_urdf(robots_dir / "ur_description/urdf/ur5_robot.urdf")}
    out = {}
    rng = np.random.default_rng(0)
    for name, r in robots.items():
        s = tuple(rng.standard_normal(r.n) for _ in range(4))  # q, qd, qdd, tau
        calls = {"fd_mrnea": lambda r=r, s=s: mrnea.forward_dynamics(r, s[0], s[1], s[3]),
                 "id": lambda r=r, s=s: mrnea.inverse_dynamics(r, s[0], s[1], s[2]),
                 "hb": lambda r=r, s=s: mrnea.mass_matrix_and_bias(r, s[0], s[1])}
        for k, f in calls.items():
            f()
            t = timeit.Timer(f)
            num, _ = t.autorange()
            out[f"{name}/{k}"] = round(min(t.repeat(9, num)) / num * 1e9, 1)
    print(json.dumps(out))


if __name__ == "__main__":
    main()
