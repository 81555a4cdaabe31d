"""Issue 24 part 2: jerk-limited retiming of the Puma 560 pick and the SDT's training profile
(``demo``, as examples/sdt_training.toml), against the unlimited time-optimal retime, and a
figure of the joint torques.

For each robot: the unlimited retime (toppra, margin 0.98), the largest jerk its rows ask
(third differences over dt^3, :func:`mrnea.retime.jerk.jerks`), then the jerk-limited retime
at each limit given (one for every joint): its duration against the unlimited one, the margin,
the verification, the largest jerk of its rows over the limit, the wall time. The figure
(``--figures DIR``): the simulated joint torques against time, unlimited and at the figure's
jerk limit, one panel per joint, with the effort limits.

Run: ``python benchmarks/retime_jerk.py [--figures docs] [--only SDT]``.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

import mrnea
from mrnea.retime.jerk import jerks

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
CASES = {  # name: (robot, program, jerk limits [rad/s^3], the limit of the figure)
    "Puma 560 pick": (lambda: mrnea.robots.puma560(), lambda: mrnea.load_program(
        EXAMPLES / "puma_pick.toml"), (5000.0, 2000.0, 1000.0), 2000.0),
    "SDT training profile": (lambda: mrnea.robots.sdt(), lambda: mrnea.load_program(
                                 EXAMPLES / "sdt_training.toml"),
                             (10.0, 3.0), 3.0),
}


def figure(name: str, unlimited: mrnea.retime.RetimeResult, limited: mrnea.retime.RetimeResult,
           jerk: float, path: Path) -> None:
    """The joint torques of both verifying simulations against time, one panel per joint."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    robot = unlimited.robot
    fig, axes = plt.subplots(robot.n, 1, figsize=(8, 1.9 * robot.n + 0.6), sharex=True)
    for i, ax in enumerate(np.atleast_1d(axes)):
        for res, label, style in ((unlimited, f"time-optimal, {unlimited.duration:.3f} s",
                                   dict(color="tab:red", lw=0.8)),
                                  (limited, f"jerk ≤ {jerk:g} rad/s³, {limited.duration:.3f} s",
                                   dict(color="tab:blue", lw=1.2))):
            ax.plot(res.simulation.t, res.simulation.tau[:, i], label=label, **style)
        lim = robot.effort_limit[i]
        if np.isfinite(lim):
            for sgn in (1, -1):
                ax.axhline(sgn * lim, color="grey", lw=0.6, ls="--")
        ax.set_ylabel(f"{robot.joint_names[i]}\n[N m]", fontsize=8)
        ax.tick_params(labelsize=8)
    axes[0].set_title(f"{name}: joint torques, time-optimal and jerk-limited "
                      "(dashed: effort limits)", fontsize=9)
    axes[0].legend(fontsize=8, loc="upper right")
    axes[-1].set_xlabel("t [s]")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--figures", type=Path, default=None, help="write the torque figures here")
    ap.add_argument("--only", default="", help="only the cases whose name contains this")
    args = ap.parse_args()
    print("| case | jerk limit [rad/s³] | duration [s] | vs unlimited | margin | verified | "
          "largest jerk / limit | retime [s] |")
    print("|" + "---|" * 8)
    for name, (make_robot, make_program, limits, shown) in CASES.items():
        if args.only not in name:
            continue
        robot, prog = make_robot(), make_program()
        t0 = time.perf_counter()
        base = mrnea.retime(robot, prog)
        wall = time.perf_counter() - t0
        peak = np.abs(jerks(base.q_cmd, base.dt)).max()
        print(f"| {name} | none (rows ask up to {peak:.0f}) | {base.duration:.3f} | - | "
              f"{base.margin:.4f} | {base.achievable} | - | {wall:.1f} |", flush=True)
        for jerk in limits:
            t0 = time.perf_counter()
            res = mrnea.retime(robot, prog, jerk_limit=jerk)
            wall = time.perf_counter() - t0
            ratio = np.abs(jerks(res.q_cmd, res.dt)).max() / jerk
            print(f"| {name} | {jerk:g} | {res.duration:.3f} | "
                  f"{100 * (res.duration / base.duration - 1):+.1f} % | {res.margin:.4f} | "
                  f"{res.achievable} | {ratio:.4f} | {wall:.1f} |", flush=True)
            if args.figures is not None and jerk == shown:
                slug = name.split()[0].lower()
                figure(name, base, res, jerk, args.figures / f"retime-{slug}-jerk-torque.png")


if __name__ == "__main__":
    main()
