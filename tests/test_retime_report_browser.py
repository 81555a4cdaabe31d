"""Issue 22's retime report items, on the UR5 pick it names (examples/ur5_pick.toml: the drives'
torque-speed curves and a 3 kg part; shoulder_pan cruises on its curve from 1.0 to 1.4 s of the
retimed program).

* The effort-ratio panel draws the timing, and the timing has no sawtooth: the ratio recomputed
  from the retimed rows with Pinocchio's RNEA, the drive law written out (rotor inertia,
  viscous and Coulomb friction) and the torque-speed curve in closed form equals the plotted
  line, and between 1.0 and 1.45 s it jumps by more than 0.3 only where the effort crosses zero
  from the cruise to the braking (two jumps), never back and forth.
* The page reads at 800 and 1400 px in headless Chromium: no sideways scroll, figures at least at
  0.7 of their pixels (before, at 800 px the figures shrank to 0.4 and their text was unreadable),
  one duration stated with why the simulation lasts a cycle longer, each figure's caption, the
  3D view's time marked on the effort-ratio figure where that time is.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from conftest import chromium, erd_path, open_report, time_marker, to_pinocchio
from drive_oracle import torque_speed

import mrnea
from mrnea.report.retime import retime_figures, write_retime_report

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
WINDOW = (1.0, 1.45)  # s: the reporter's shoulder_pan window


@pytest.fixture(scope="module")
def retimed(tmp_path_factory):
    prog = mrnea.load_program(EXAMPLES / "ur5_pick.toml")
    robot = prog.load_robot(str(erd_path("ur_description/urdf/ur5_robot.urdf")))
    res = mrnea.retime(robot, prog)
    assert res.achievable
    report = write_retime_report(res, tmp_path_factory.mktemp("ur5") / "report.html")
    return res, report


def pinocchio_ratio(robot: mrnea.Robot, Q: np.ndarray, dt: float) -> tuple[np.ndarray, ...]:
    """|tau| / limit per cycle (K, n) of the rows Q at dt: the program's own requirement
    (backward-difference velocity, the next cycle's acceleration, 0 after the last row) by
    pinocchio.rnea plus G^2 J_m qdd + F_v qd + F_c sign(qd), over the torque-speed curve at qd;
    and the speeds (K, n)."""
    import pinocchio as pin

    model = to_pinocchio(robot)
    data = model.createData()
    V = np.zeros_like(Q)
    V[1:] = np.diff(Q, axis=0) / dt
    A = np.diff(np.vstack([V, np.zeros((1, Q.shape[1]))]), axis=0) / dt
    assert np.all(robot.efficiency == 1.0)
    fc = robot.coulomb_friction
    tau = np.array([pin.rnea(model, data, q, v, a) for q, v, a in zip(Q, V, A, strict=True)])
    tau += robot.gear_ratio**2 * robot.rotor_inertia * A + robot.viscous_friction * V
    tau += np.where(V > 0, fc[:, 0], np.where(V < 0, -fc[:, 1], 0.0))
    limit = np.column_stack([torque_speed(*c, V[:, i])
                             for i, c in enumerate(robot.torque_speed)])
    return np.abs(tau) / limit, V


def test_the_effort_ratio_draws_the_timing_which_has_no_sawtooth(retimed) -> None:
    res, _ = retimed
    ratio, V = pinocchio_ratio(res.robot, res.q_cmd, res.dt)
    _, _, t, after = res.effort_ratios()
    # moving this cycle and the next the same way: at rest, a start or a reversal the Coulomb
    # share is set-valued (the drive law's box), not sign(qd)
    moving = V * np.vstack([V[1:], np.zeros((1, V.shape[1]))]) > 0
    np.testing.assert_allclose(after[moving], ratio[moving], rtol=1e-7, atol=1e-9)
    pan = res.robot.joint_names.index("shoulder_pan_joint")
    ax = next(a for a in retime_figures(res)["effort_ratio"].axes
              if a.get_title(loc="left").startswith("shoulder\\_pan") or
              a.get_title(loc="left").startswith("shoulder_pan"))
    drawn = [ln for ln in ax.get_lines() if len(ln.get_xdata()) == t.size]
    assert len(drawn) == 1  # the retimed line, every cycle drawn (651 rows: no envelope)
    np.testing.assert_allclose(np.asarray(drawn[0].get_xdata(), float), t, rtol=0, atol=1e-12)
    y = np.asarray(drawn[0].get_ydata(), float)
    np.testing.assert_allclose(y[moving[:, pan]], ratio[moving[:, pan], pan], rtol=1e-7)
    win = (t >= WINDOW[0]) & (t <= WINDOW[1])
    r = ratio[win, pan]
    assert np.all(np.abs(V[win, pan]) > 1.0)  # shoulder_pan moves fast throughout the window
    assert r.max() <= res.margin + 1e-6  # within the planning margin
    jumps = np.flatnonzero(np.abs(np.diff(r)) > 0.3)
    # the only jumps: the effort crossing zero from the cruise to the braking, one cycle apart
    assert len(jumps) <= 2 and (len(jumps) < 2 or jumps[1] - jumps[0] == 1), (t[win][jumps],
                                                                              r[jumps])
    cruise = (t[win] > 1.05) & (t[win] < 1.39)  # on the torque-speed curve: a smooth ratio
    assert np.abs(np.diff(r[cruise])).max() < 0.01, np.abs(np.diff(r[cruise])).max()


LAYOUT = """(() => ({
  page: document.documentElement.scrollWidth, inner: window.innerWidth,
  tables: [...document.querySelectorAll('table')].map(t => [t.scrollWidth,
                                                           t.parentElement.clientWidth]),
  scale: [...document.querySelectorAll('figure img')].map(
    i => i.getBoundingClientRect().width / i.naturalWidth),
  captions: [...document.querySelectorAll('figure figcaption')].map(c => c.textContent),
  verdict: document.querySelector('#verdict').textContent,
}))()"""


@pytest.mark.parametrize("width", [800, 1400])
def test_the_retime_report_reads_at_800_and_1400_px(retimed, width: int) -> None:
    res, report = retimed
    with chromium(width) as b:
        page = open_report(b, report.as_uri() + "#t=1.2")
        got = page.evaluate(LAYOUT)
        assert got["page"] <= got["inner"] == width
        for scroll, box in got["tables"]:
            assert scroll <= box, got["tables"]
        assert len(got["scale"]) == 2 and min(got["scale"]) >= 0.7, got["scale"]
        assert [c.split(":")[0] for c in got["captions"]] == ["phase plane", "effort ratio"]
        assert all(len(c) > 150 for c in got["captions"])
        rows = res.q_cmd.shape[0]
        first_last = (rows - 1) * res.dt  # the rows' span; the simulation runs one cycle a row
        verdict = " ".join(got["verdict"].split())
        said = re.findall(r"(\d+(?:\.\d+)?) s from its first row to its last", verdict)
        assert [float(s) for s in said] == [pytest.approx(first_last, abs=5e-4)], verdict
        assert (f"({rows} rows; simulated as {rows} cycles of {res.dt:g} s, "
                f"{rows * res.dt:.4g} s)") in verdict
        have, want, t = time_marker(page, "effort_ratio")  # the 3D view's time marked on the figure
        assert t == pytest.approx(1.2, abs=res.dt) and abs(have - want) <= 2.0, (have, want)
        (Path(report).parent / f"retime-{width}.png").write_bytes(page.screenshot(None))
