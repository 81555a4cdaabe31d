"""The summary's compiled pass (kernels/peaks.py) and bearing loads (kernels/bearing.py) against
NumPy: the same bits as NumPy's own reductions (np.sum's pairwise order, max, argmax, mean,
np.linalg.norm, np.einsum) give from the run's arrays, and the bearing split against closed forms.

Issue 29 moved these numbers from NumPy expressions into one compiled pass so that a sweep run is
mostly compiled code; sweep rows must stay bit-identical, so equality here is exact.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import random_chain

import mrnea
from mrnea.kernels.bearing import bearing_loads
from mrnea.kernels.peaks import pairwise_sum
from mrnea.robots import puma560, sdt
from mrnea.robots.sdt_profile import training_program


def move(q0, q1, T: float, dt: float) -> np.ndarray:
    """A minimum-jerk move from q0 to q1 in T seconds, then 0.1 s at rest."""
    s = np.clip(np.arange(0.0, T + 0.1, dt) / T, 0.0, 1.0)[:, None]
    return q0 + (np.asarray(q1) - q0) * (10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5)


def spread(rng: np.random.Generator, shape) -> np.ndarray:
    """Values of both signs over 12 orders of magnitude (rounding shows in every sum)."""
    return rng.normal(size=shape) * 10.0 ** rng.uniform(-6, 6, size=shape)


@pytest.mark.parametrize("n", [*range(0, 140), 255, 256, 257, 1023, 1024, 1025, 8401, 100_003])
def test_pairwise_sum_is_numpys_sum(n):
    x = spread(np.random.default_rng(n), n)
    assert pairwise_sum(x) == np.sum(x)  # bit for bit, NumPy's pairwise order
    sq = x ** 2
    assert pairwise_sum(sq) / max(n, 1) == (np.mean(sq) if n else 0.0)


def test_bearing_loads_are_numpys_norm_and_einsum():
    """The six loads as the NumPy expressions (np.linalg.norm over the last axis, np.einsum
    "kij,ij->ki") give them, bit for bit, on random wrenches and unit axes."""
    rng = np.random.default_rng(1)
    for K, n in ((1, 1), (7, 3), (500, 6), (2000, 7)):
        w = spread(rng, (K, n, 6))
        axes = rng.normal(size=(n, 3))
        axes /= np.linalg.norm(axes, axis=1)[:, None]
        axes[0] = (0.0, 0.0, 1.0)
        out = np.empty((6, K, n))
        bearing_loads(w, axes, out)
        for c, vec in ((0, w[:, :, :3]), (3, w[:, :, 3:])):
            along = np.einsum("kij,ij->ki", vec, axes)
            across = np.linalg.norm(vec - along[:, :, None] * axes[None], axis=2)
            assert np.array_equal(out[c], np.linalg.norm(vec, axis=2))
            assert np.array_equal(out[c + 1], np.abs(along))
            assert np.array_equal(out[c + 2], across)


def test_bearing_loads_closed_form():
    """Along and across a joint axis: a force on the axis is all axial, one at right angles all
    radial, one at 30 degrees splits as cos / sin; the parts add up in quadrature."""
    a = np.array([[0.6, 0.0, 0.8]])
    perp = np.array([0.8, 0.0, -0.6])
    w = np.zeros((3, 1, 6))
    w[0, 0, :3] = 5.0 * a[0]  # force along the axis
    w[1, 0, 3:] = 2.0 * perp  # moment across it
    w[2, 0, :3] = 4.0 * (math.cos(math.pi / 6) * a[0] + math.sin(math.pi / 6) * perp)
    out = np.empty((6, 3, 1))
    bearing_loads(w, a, out)
    force, axial, radial, moment, axial_m, bending = out[:, :, 0]
    assert force[0] == pytest.approx(5.0) and axial[0] == pytest.approx(5.0)
    assert radial[0] == pytest.approx(0.0, abs=1e-15)
    assert moment[1] == pytest.approx(2.0) and bending[1] == pytest.approx(2.0)
    assert axial_m[1] == pytest.approx(0.0, abs=1e-15)
    assert axial[2] == pytest.approx(4.0 * math.cos(math.pi / 6))
    assert radial[2] == pytest.approx(2.0)
    assert np.allclose(axial ** 2 + radial ** 2, force ** 2)


def numpy_numbers(r) -> list[dict]:
    """The summary's per-joint numbers from NumPy reductions of the run's arrays (what the
    summary computed before its compiled pass, written out from its docstrings)."""
    out = []
    w = r.reaction
    if w is not None:
        a = np.array([j.axis for j in r.robot.joints])
        loads = []
        for vec in (w[:, :, :3], w[:, :, 3:]):
            along = np.einsum("kij,ij->ki", vec, a)
            loads += [np.linalg.norm(vec, axis=2), np.abs(along),
                      np.linalg.norm(vec - along[:, :, None] * a[None], axis=2)]
    for i, j in enumerate(r.robot.joints):
        pe, lim, t = r.program_effort[:, i], r.program_limit[:, i], r.t
        req = np.abs(pe)
        eta_d, eta_b = j.efficiency_pair
        motor = req * np.where(pe * r.qd_cmd[:, i] < 0.0, eta_b, 1.0 / eta_d)
        limited = 0 < j.effort_limit < math.inf
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(req > 0.0, req / lim, 0.0) if limited else np.zeros_like(req)
        k, kr = int(np.argmax(req)), int(np.argmax(ratio))
        over = np.flatnonzero(req > lim + 8 * np.finfo(float).eps * (lim + req))
        err = np.abs(r.tracking_error[:, i])
        ke = int(np.argmax(err))
        d = {"program_peak_effort": float(req[k]), "program_peak_time": float(t[k]),
             "program_rms_effort": float(np.sqrt(np.mean(pe ** 2))),
             "program_peak_motor_torque": float(motor.max()) / j.gear_ratio,
             "program_rms_motor_torque": float(np.sqrt(np.mean(motor ** 2))) / j.gear_ratio,
             "program_first_over_time": float(t[over[0]]) if over.size else None,
             "time_saturated": float(r.saturated[:, i].sum() * r.dt),
             "time_stuck": float(r.stuck[:, i].sum() * r.dt),
             "peak_motor_torque": float(np.abs(r.tau_motor[:, i]).max()),
             "rms_motor_torque": float(np.sqrt(np.mean(r.tau_motor[:, i] ** 2))),
             "peak_effort": float(np.abs(r.tau[:, i]).max()),
             "peak_speed": float(np.abs(r.qd[:, i]).max()),
             "max_tracking_error": float(err[ke]), "max_tracking_error_time": float(t[ke])}
        if limited:
            d |= {"program_ratio_time": float(t[kr]), "program_effort_at_ratio": float(req[kr]),
                  "program_limit_at_ratio": float(lim[kr]),
                  "program_speed_at_ratio": float(abs(r.qd_cmd[kr, i]))}
            if math.isfinite(ratio[kr]):
                d["program_effort_ratio"] = float(ratio[kr])
        if w is not None:
            for key, c in (("peak_reaction_force", 0), ("peak_axial_force", 1),
                           ("peak_radial_force", 2), ("peak_reaction_moment", 3),
                           ("peak_bending_moment", 5)):
                d[key] = float(loads[c][:, i].max())
        out.append(d)
    return out


def runs():
    """Runs of every kind: the SDT demo (saturating), hybrid and paper mode, without reactions,
    interrupted; the Puma 560 with a gear efficiency and torque-speed curves; a random chain
    with prismatic joints, friction and a position loop."""
    prog = training_program()
    q = prog.q_cmd[:3000]
    yield mrnea.simulate(sdt(), q, prog.dt)
    yield mrnea.simulate(sdt(), q, prog.dt, mode="paper", reactions=False)
    stop = []

    def progress(done, K):
        if done >= 2000 and not stop:
            stop.append(done)
            raise KeyboardInterrupt

    yield mrnea.simulate(sdt(), q, prog.dt, progress=progress)  # interrupted: 2000 cycles
    puma = puma560().with_actuators(efficiency=[[0.9, 0.7]] * 6)
    yield mrnea.simulate(puma, move(np.zeros(6), np.full(6, 1.2), 0.8, 0.002), 0.002)
    rng = np.random.default_rng(5)
    rob = random_chain(rng, 5, prismatic_fraction=0.5).with_actuators(
        effort_limit=[40.0] * 5, gear_ratio=[30.0] * 5, rotor_inertia=[1e-4] * 5,
        coulomb_friction=[[2.0, 1.0]] * 5, efficiency=[[0.8, 0.5]] * 5)
    q1 = np.clip(rng.uniform(-1.0, 1.0, 5), rob.lower, rob.upper)
    yield mrnea.simulate(rob, move(np.zeros(5), q1, 0.6, 0.002), 0.002, catch_up=20.0)


def test_summary_numbers_are_numpys_reductions():
    """Every per-joint number of the summary equals the NumPy reduction of the run's arrays,
    bit for bit (``==``), on runs of every kind; and the per-cycle bearing loads those of
    NumPy's norm and einsum."""
    kinds = set()
    for r in runs():
        s = r.summary()
        kinds.add((r.mode, r.reaction is None, r.completed))
        for jd, ref in zip(s["joints"], numpy_numbers(r), strict=True):
            for key, value in ref.items():
                assert jd[key] == value, (r.robot.name, jd["joint"], key)
            if r.reaction is None:
                assert jd["peak_reaction_force"] is None and jd["peak_bending_moment"] is None
        assert s["max_tracking_error"] == float(np.abs(r.tracking_error).max())
        if r.reaction is not None:
            loads = r.bearing_loads()
            a = np.array([j.axis for j in r.robot.joints])
            along = np.einsum("kij,ij->ki", r.reaction[:, :, 3:], a)
            assert np.array_equal(loads.axial_moment, np.abs(along))
            assert np.array_equal(loads.force, np.linalg.norm(r.reaction[:, :, :3], axis=2))
            assert loads.force.shape == (r.K, r.robot.n)
    assert kinds == {("hybrid", False, True), ("paper", True, True), ("hybrid", False, False)}
