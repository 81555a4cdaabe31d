"""Issue 22: a limit from a torque-speed curve says where it comes from in the report's table as
in the verdict, read in headless Chromium at 800 and 1400 px. The Puma 560 with one curve on
every joint (test_summary_schema's CURVE) moves fast enough that its worst joint's ratio is taken
on the curve's falling part; the table's "that limit" is the curve's closed form at the
program's speed (a backward difference of the rows), "the limit from" names the curve and that
speed, and the verdict names the curve's peak.
"""

from __future__ import annotations

import numpy as np
import pytest
from chromium_cdp import Browser, ChromiumUnavailable
from test_summary_schema import CURVE, curve_limit

import mrnea
from mrnea.report import write_report
from mrnea.simulate import simulate
from mrnea.trajectory import quintic

DT = 0.005
ROW = """(name => {
  const t = document.querySelector('table#joints-program');
  const head = [...t.rows[0].cells].map(c => c.textContent);
  const row = [...t.rows].find(r => r.cells[0].textContent === name);
  return {head: head, row: [...row.cells].map(c => c.textContent),
          verdict: document.querySelector('#verdict').textContent,
          page: document.documentElement.scrollWidth, inner: window.innerWidth,
          scroll: [t.scrollWidth, t.parentElement.clientWidth]};
})"""


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    robot = mrnea.robots.puma560().with_actuators(torque_speed=CURVE)
    _, q = quintic([np.zeros(6), np.full(6, 1.0)], dt=DT, velocity_limit=1.5,
                   acceleration_limit=20.0)
    res = simulate(robot, q, DT)
    return res, q, write_report(res, tmp_path_factory.mktemp("curve") / "report.html",
                                view3d=False)


@pytest.mark.parametrize("width", [800, 1400])
def test_the_table_says_the_limit_is_the_curves_at_the_programs_speed(run, width) -> None:
    res, q, report = run
    s = res.summary()
    i = res.robot.joint_names.index(s["worst_joint"])
    k = round(s["joints"][i]["program_ratio_time"] / DT)
    w = abs(q[k, i] - q[k - 1, i]) / DT  # the program's speed: a backward difference [rad/s]
    assert CURVE[1] < w < CURVE[2]  # on the curve's falling part, below its peak
    try:
        b = Browser(width=width, height=1000)
    except ChromiumUnavailable as exc:
        pytest.skip(f"no Chromium for the browser tests: {exc}")
    with b:
        page = b.open(report.as_uri())
        got = page.evaluate(f"{ROW}({res.robot.joint_names[i]!r})")
    assert got["page"] <= got["inner"] == width
    assert got["scroll"][0] <= got["scroll"][1], got["scroll"]
    col = {h.split("[")[0].strip(): c for h, c in zip(got["head"], got["row"], strict=True)}
    assert "[N m]" in got["head"][got["head"].index(next(h for h in got["head"]
                                                         if h.startswith("that limit")))]
    assert float(col["that limit"].replace(",", "")) == pytest.approx(curve_limit(w), rel=5e-4)
    assert curve_limit(w) < CURVE[0]
    assert col["the limit from"] == f"torque\u2013speed curve at {w:.4g} rad/s", col
    verdict = " ".join(got["verdict"].replace("\u00a0", " ").split())
    assert f"at {w:.4g} rad/s on its torque\u2013speed curve (peak 150 N m)" in verdict, verdict
