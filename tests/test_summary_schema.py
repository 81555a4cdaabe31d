"""summary.json explains its numbers: every field documented with its unit in the JSON Schema the
package ships (src/mrnea/summary.schema.json), every summary written validated against it with
the ``jsonschema`` package; a limit from a torque-speed curve said to be one (closed form of the
curve); the per-cycle table gives the program's own acceleration its own column (closed form: a
second difference; the demo's quintic yaw turn peaks at 10/sqrt(3) pi / 3^2 rad/s^2).
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import jsonschema
import numpy as np
import pandas
import pytest
from conftest import mrnea_cli

import mrnea
from mrnea.robots.sdt_profile import training_profile
from mrnea.simulate import simulate
from mrnea.summary import TIMES, schema_path
from mrnea.trajectory import quintic

ROOT = Path(__file__).resolve().parents[1]
SCHEMA = json.loads(schema_path().read_text(encoding="utf-8"))
VALIDATOR = jsonschema.Draft202012Validator(SCHEMA)
# the torque-speed curve (peak [N m], corner [rad/s], no-load speed [rad/s]) of the tests below
CURVE = (150.0, 0.5, 3.0)


def valid(summary: dict) -> dict:
    errors = sorted(VALIDATOR.iter_errors(summary), key=str)
    assert not errors, [f"{list(e.absolute_path)}: {e.message}" for e in errors]
    return summary


def curve_limit(w: float) -> float:
    """The curve's limit at speed w [rad/s], by hand: constant to the corner, then constant
    power P = peak corner, capped by the line to zero at the no-load speed."""
    peak, corner, no_load = CURVE
    return max(0.0, min(peak, peak * corner / w, peak / (no_load - corner) * (no_load - w)))


def _properties(node: dict, where: str = ""):
    """Every (path, property schema) of the schema, nested objects and oneOf branches too."""
    for name, sub in node.get("properties", {}).items():
        yield f"{where}.{name}", sub
        yield from _properties(sub, f"{where}.{name}")
        if "items" in sub:
            yield from _properties(sub["items"], f"{where}.{name}[]")
        for k, branch in enumerate(sub.get("oneOf", [])):
            yield from _properties(branch, f"{where}.{name}|{k}")


def test_the_schema_documents_every_field_and_every_unit():
    jsonschema.Draft202012Validator.check_schema(SCHEMA)
    props = list(_properties(SCHEMA))
    assert len(props) > 60
    for path, sub in props:
        assert sub.get("description"), path
        types = sub.get("type", [])
        if "number" in ([types] if isinstance(types, str) else types):
            assert sub.get("unit"), f"{path}: a number without its unit"
    docs = (ROOT / "docs" / "simulation.md").read_text(encoding="utf-8")
    for path, _ in props:
        name = re.split(r"[.|\[\]]+", path)[-1] or path.split(".")[-2]
        assert f"`{name}`" in docs, f"{name} is not in docs/simulation.md"


def test_summaries_of_every_kind_are_valid():
    _, q = training_profile(0.005)
    demo = valid(simulate(mrnea.robots.sdt(), q, 0.005).summary())
    assert demo["joints"][1]["program_limit_source"] == "effort limit"
    prog = mrnea.load_program(ROOT / "examples" / "puma_pick.toml")
    valid(simulate(prog.load_robot(), prog.q_cmd, prog.dt, f_ext=prog.f_ext,
                   f_ext_point=prog.f_ext_point).summary())
    puma = mrnea.robots.puma560()
    start = np.zeros((50, 6))
    start[:, 1] = 5.0  # outside joint2's limits
    s = valid(simulate(puma, start, 0.005).summary())
    assert s["first_infeasible"]["reason"] == "start outside the position limits"
    free = puma.with_actuators(effort_limit=[math.inf, 0, 97.6, 186.4, 89.4, 24.2])
    s = valid(simulate(free, np.zeros((20, 6)), 0.005, reactions=False).summary())
    assert [j["drive"] for j in s["joints"][:2]] == ["unlimited", "unpowered"]
    valid(simulate(puma, np.zeros((20, 6)), 0.005)._first(0).summary())  # interrupted at once


def test_a_limit_from_the_torque_speed_curve_says_so():
    robot = mrnea.robots.puma560().with_actuators(torque_speed=CURVE)
    _, q = quintic([np.zeros(6), np.full(6, 1.0)], dt=0.005, velocity_limit=1.5,
                   acceleration_limit=20.0)
    res = simulate(robot, q, 0.005)
    s = valid(res.summary())
    jd = next(j for j in s["joints"] if j["joint"] == s["worst_joint"])
    k = round(jd["program_ratio_time"] / 0.005)
    w = abs(q[k, 1] - q[k - 1, 1]) / 0.005  # the program's speed there: a backward difference
    assert jd["program_speed_at_ratio"] == pytest.approx(w, rel=1e-12)
    assert jd["program_limit_at_ratio"] == pytest.approx(curve_limit(w), rel=1e-12)
    assert jd["program_limit_at_ratio"] < CURVE[0]
    assert jd["program_limit_source"] == "torque-speed curve"
    lim = f"{jd['program_limit_at_ratio']:.4g}"
    assert (f"{jd['program_effort_ratio']:.2f} {TIMES} its {lim} N m limit at {w:.4g} rad/s on "
            "its torque\u2013speed curve (peak 150 N m), at t = ") in res.verdict()


def test_written_summaries_are_valid_and_the_table_splits_program_from_catch_up(demo_run):
    res, out = demo_run  # mrnea demo --out DIR --no-3d (conftest; shared with test_exit_codes)
    assert res.returncode == 1, res.stderr
    valid(json.loads((out / "summary.json").read_text()))
    table = pandas.read_csv(out / "cycles.csv")
    dt = 0.005
    q = table["q_cmd_cab_yaw [rad]"].to_numpy()
    own = table["program_qdd_cab_yaw [rad/s^2]"].to_numpy()
    second = np.diff(q, 2) / dt**2  # (q[k+1] - 2 q[k] + q[k-1]) / dt^2, cycle k
    np.testing.assert_allclose(own[1:-1], second, rtol=0, atol=1e-6)
    assert np.abs(own).max() == pytest.approx(10 / math.sqrt(3) * math.pi / 9, rel=1e-3)
    catch_up = table["catch_up_qdd_cab_yaw [rad/s^2]"].to_numpy()
    assert np.abs(catch_up).max() > 10 * np.abs(own).max()  # the drive catching up, not the program
    for name in ("program_effort_cab_yaw [N m]", "program_limit_cab_yaw [N m]",
                 "catch_up_effort_cab_yaw [N m]"):
        assert name in table.columns
    assert not any(c.startswith(("qdd_des", "tau_required")) for c in table.columns)
    res = mrnea_cli("check", ROOT / "examples" / "puma_pick.toml", "--json")
    assert res.returncode == 0
    valid({k: v for k, v in json.loads(res.stdout).items()})
