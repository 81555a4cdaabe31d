"""Retime the built-in Puma 560's pick-and-place example and the SDT's training profile.

Run: ``python examples/retime_examples.py [--figures docs]`` (about ten seconds once the
kernels are compiled). Prints, for each program and method, the duration before and after, the
margin (toppra) or factor (scale), and the verification; with ``--figures``, writes the phase
plane and the effort ratios of the toppra results as PNG files (the ones in docs/retime.md).

The same from the command line, for the Puma 560 (a program file naming its robot):

    mrnea retime puma560 examples/puma_pick.toml --out pick-retimed
    mrnea check puma560 pick-retimed/retimed.toml
"""

from __future__ import annotations

import argparse
from pathlib import Path

import mrnea
from mrnea.report.drawing import save_figure
from mrnea.report.retime import retime_figures
from mrnea.robots.sdt_profile import training_profile

HERE = Path(__file__).resolve().parent


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--figures", type=Path, help="write the toppra results' figures here")
    args = ap.parse_args()
    pick = mrnea.load_program(HERE / "puma_pick.toml")
    programs = {
        "puma": (pick.load_robot(), pick),  # dwells, and a 20 N push while gripping
        "sdt": (mrnea.robots.sdt(), training_profile(0.005)),  # (t, q): not achievable as is
    }
    for name, (robot, program) in programs.items():
        for method in ("toppra", "scale"):
            res = mrnea.retime(robot, program, method=method)
            print(f"{name}: {res.verdict()}")
            if method == "toppra" and args.figures:
                for fig_name, fig in retime_figures(res).items():
                    path = args.figures / f"retime-{name}-{fig_name.replace('_', '-')}.png"
                    print(f"  {save_figure(fig, path, overwrite=True, dpi=80)}")


if __name__ == "__main__":
    main()
