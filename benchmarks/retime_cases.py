"""The table of docs/retime.md, "Results": durations before and after (toppra and scale), the
final margin, TOPP-RA solves, scale's factor and Hollerbach's estimate, and the time-optimality
fractions of tests/test_retime_acceptance.py (grid points where the path moves with some joint
at >= 95 % / >= 99 % of its planning limit).

Run: ``python benchmarks/retime_cases.py`` (about a minute).
"""

from __future__ import annotations

import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from test_retime_acceptance import grid_ratios, programs

import mrnea
from mrnea.simulate import simulate


def main() -> None:
    warnings.simplefilter("ignore")  # the Puma's published inertias draw a ModelWarning
    with tempfile.TemporaryDirectory() as tmp:
        files = programs(Path(tmp))
        plain = {"puma_pick": "puma560", "puma_quintic": "puma560", "sdt": "sdt"}
        print("| case | program [s] | achievable as given | toppra [s] | margin | TOPP-RA solves "
              "| scale [s] (factor; estimate) | moving grid points >= 0.95 / >= 0.99 of the "
              "limit |")
        print("|---|---|---|---|---|---|---|---|")
        for curves in (False, True):
            for name, path in files.items():
                prog = mrnea.load_program(path)
                robot = prog.load_robot() if curves else mrnea.io.load_builtin(plain[name])
                before = simulate(robot, prog.q_cmd, prog.dt, f_ext=prog.f_ext,
                                  f_ext_point=prog.f_ext_point).achievable
                res = mrnea.retime(robot, prog)
                sc = mrnea.retime(robot, prog, method="scale")
                r = grid_ratios(robot, prog, res)
                label = f"{name}{' + curves' if curves else ''}"
                print(f"| {label} | {res.original_duration:.3f} | {before} | "
                      f"{res.duration:.3f} | {res.margin:.3f} | "
                      f"{res.summary()['toppra_solves']} | {sc.duration:.3f} "
                      f"({sc.factor:.4f}; {sc.estimate:.4f}) | {np.mean(r >= 0.95):.3f} / "
                      f"{np.mean(r >= 0.99):.3f} |")


if __name__ == "__main__":
    main()
