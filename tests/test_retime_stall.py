"""Regression: TOPP-RA's forward pass must not stall one grid point before a rest.

The Puma 560 with a 15 kg payload 5 cm out along the tool axis, on the pick-and-place example:
its elbow holds the home pose at 0.95 of its limit with Coulomb friction taken both ways, so
braking to rest there leaves little effort to spare. TOPP-RA's greedy forward pass reached the
grid point before the end with x = sd^2 = 1e-8 and crept through the last 0.3 mrad of the path
for 5.9 s: 10.515 s where uniform scaling takes 8.860 s, and the same path on a clock 0.1 %
slower (``time_scaled(prog, 0.999)``, whose rows differ by rounding) 4.8 s
(:func:`mrnea.retime.toppra._solve`).

Independent of the planner's arrays: the verifying simulation is run again here; uniform
scaling (Hollerbach's bisection on the simulation) bounds the duration from above; the
program's own requirement per cycle, as the simulation computes it, must have some joint at
its planning limit in almost every cycle of motion (the stall had a joint at its limit in 37 %
of them); no cycle of motion but the pieces' last may creep (every joint under 1 urad); and the
acceptance test's time-optimality criterion on the grid holds.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from test_retime_acceptance import _pieces, grid_ratios

import mrnea
from mrnea.simulate import simulate
from mrnea.sweep.timescale import time_scaled
from mrnea.sweep.variants import variant

PICK = Path(__file__).resolve().parents[1] / "examples" / "puma_pick.toml"
CREEP = 1e-6  # rad per cycle: every joint slower than this is creeping
AT_LIMIT, ALMOST_EVERY_CYCLE = 0.95, 0.9  # fraction of the planning limit; of the moving cycles


@pytest.fixture(scope="module")
def heavy():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the Puma's published inertias draw a ModelWarning
        robot = variant(mrnea.robots.puma560(), payload=15.0, payload_point=[0, 0, 0.05])
        prog = mrnea.load_program(PICK)
        res = {"toppra": mrnea.retime(robot, prog, method="toppra"),
               "scale": mrnea.retime(robot, prog, method="scale"),
               "slower clock": mrnea.retime(robot, time_scaled(prog, 0.999), method="toppra")}
    return robot, prog, res


def test_not_longer_than_scale_and_same_as_on_a_slower_clock(heavy):
    _, _, res = heavy
    assert res["toppra"].duration <= res["scale"].duration
    # the same path (to dt^2 |q''| / 8 between rows) has the same time-optimal timing
    assert res["toppra"].duration == pytest.approx(res["slower clock"].duration, rel=0.01)


def test_verified_and_never_creeping(heavy):
    robot, _, res = heavy
    r = res["toppra"]
    again = simulate(robot, r.q_cmd, r.dt, mode=r.mode, f_ext=r.f_ext, f_ext_point=r.f_ext_point)
    assert again.achievable, again.verdict()
    moving = np.zeros(r.q_cmd.shape[0] - 1, dtype=bool)  # cycle k: row k -> k + 1
    pieces = [(k0, k1) for kind, k0, k1 in _pieces(r.q_cmd) if kind == "move"]
    for k0, k1 in pieces:
        moving[k0:k1] = True
    step = np.abs(np.diff(r.q_cmd, axis=0)).max(axis=1)
    assert np.sum(moving & (step < CREEP)) <= len(pieces)
    ratio = np.max(np.abs(again.program_effort) / again.program_limit, axis=1)[:-1]
    assert np.mean(ratio[moving] >= AT_LIMIT * r.margin) >= ALMOST_EVERY_CYCLE


def test_time_optimal_on_the_grid(heavy):
    robot, prog, res = heavy
    g = grid_ratios(robot, prog, res["toppra"])
    assert g.max() <= 1.001
    assert np.mean(g >= AT_LIMIT) >= 0.95
