"""Baxter (example-robot-data's URDF: a pan head and two 7-joint arms, a tree) from the command
line, with a program that names its joints (``examples/baxter_wave.toml``, issue 25): ``info``
draws the tree; ``check``, ``simulate`` (its report), ``retime`` and ``sweep`` run as real
processes. Oracle for the numbers: Pinocchio's model of the same URDF (``conftest.PinChain``),
its ``rnea`` at the simulated cycles and along the commanded path.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import PinChain, erd_path, mrnea_cli, pin_from_urdf, rel_err

import mrnea

pytest.importorskip("pinocchio")

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
PROGRAM = EXAMPLES / "baxter_wave.toml"
TIPS = ["head", "left_wrist", "right_wrist"]


@pytest.fixture(scope="module")
def baxter():
    path = erd_path("baxter_description/urdf/baxter.urdf")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # meshes left out of the 3D view
        robot = mrnea.load_urdf(path, tip=TIPS)
    return path, robot


@pytest.fixture(scope="module")
def simulated(baxter, tmp_path_factory):
    path, _ = baxter
    out = tmp_path_factory.mktemp("wave")
    res = mrnea_cli("simulate", path, PROGRAM, "--out", out, "--force")
    return res, out


def test_info_draws_the_tree(baxter) -> None:
    path, _ = baxter
    res = mrnea_cli("info", path, *[a for t in TIPS for a in ("--tip", t)])
    assert res.returncode == 0, res.stderr
    lines = res.stdout.splitlines()
    assert lines[1].startswith("a tree of 3 branches: head_pan; right_s0..right_w2; "
                               "left_s0..left_w2")
    table = [ln for ln in lines if ln.split(" ")[-1:] and ln.lstrip().startswith(
        ("head_pan ", "right_", "left_"))][:15]
    # the three branches hang from the base: none set in; a table row per joint, tree order
    assert [ln.split()[0] for ln in table][:3] == ["head_pan", "right_s0", "right_s1"]
    data = json.loads(mrnea_cli("info", path, "--json",
                                *[a for t in TIPS for a in ("--tip", t)]).stdout)
    parents = {j["name"]: j["parent_joint"] for j in data["joints"]}
    assert parents["left_s0"] is None and parents["left_s1"] == "left_s0"


def test_check_names_baxter_achievable(baxter) -> None:
    path, _ = baxter
    res = mrnea_cli("check", path, PROGRAM)
    assert res.returncode == 0, res.stderr
    assert res.stdout.startswith("ACHIEVABLE: baxter follows the program"), res.stdout


def test_simulate_writes_every_cycle_as_pinocchio_has_it(baxter, simulated) -> None:
    path, robot = baxter
    res, out = simulated
    assert res.returncode == 0, res.stderr
    cycles = pd.read_csv(out / "cycles.csv")
    names = robot.joint_names

    def block(kind: str, u: str) -> np.ndarray:
        return cycles[[f"{kind}_{n} [{u}]" for n in names]].to_numpy()

    q, qd = block("q", "rad"), block("qd", "rad/s")
    qdd, tau = block("qdd", "rad/s^2"), block("tau", "N m")
    coulomb = block("coulomb", "N m")
    assert q.shape[1] == 15
    pc = PinChain(robot, pin_from_urdf(path, robot))
    damping = pc.ours(pc.model.damping)  # the URDF's <dynamics damping>, as Pinocchio reads it
    assert np.all(damping == 0.7) and not coulomb.any()
    K = q.shape[0]
    for k in np.linspace(0, K - 2, 12).astype(int):
        # tau = rigid-body effort + viscous friction; cycles.csv holds shortest-repr text
        ref = pc.rnea(q[k], qd[k], qdd[k]) + damping * qd[k]
        assert rel_err(tau[k], ref) < 1e-9, f"cycle {k}"
    # the program's named joints moved, the others held (left arm waves, right arm still)
    qc = block("q_cmd", "rad")
    moved = {n for i, n in enumerate(names) if np.ptp(qc[:, i]) > 0}
    assert moved == {"left_s0", "left_e0", "left_w1", "head_pan"}
    assert np.all(qc[:, names.index("right_s1")] == 0.9)
    html = (out / "report.html").read_text(encoding="utf-8")
    for n in names:
        assert n in html


def test_the_report_reads_at_800_px(simulated) -> None:
    """Fifteen joints: the run parameters' joint list wraps, the page never scrolls sideways;
    every branch is a group of the per-joint tables."""
    from chromium_cdp import Browser, ChromiumUnavailable

    _, out = simulated
    try:
        b = Browser(width=800, height=1000)
    except ChromiumUnavailable as exc:
        pytest.skip(f"no Chromium for the browser tests: {exc}")
    with b:
        page = b.open((out / "report.html").as_uri())
        got = page.evaluate("[window.innerWidth, document.documentElement.scrollWidth, "
                            "document.querySelectorAll('tr.branch').length]")
        assert got == [800, 800, 9], got
        assert page.errors == [] and page.outside_requests == []


@pytest.mark.slow
def test_retime_and_check_the_retimed_program(baxter, tmp_path) -> None:
    path, _ = baxter
    res = mrnea_cli("retime", path, PROGRAM, "--out", tmp_path / "r")
    assert res.returncode == 0, res.stderr
    again = mrnea_cli("check", tmp_path / "r" / "retimed.toml")
    assert again.returncode == 0, again.stderr
    summary = json.loads((tmp_path / "r" / "summary.json").read_text())
    assert summary["duration"] < 7.845  # faster than the program's own 7.845 s


@pytest.mark.slow
def test_sweep_a_named_joints_effort_limit(baxter, tmp_path) -> None:
    """left_s1's effort limit below and above what the program needs of it (Pinocchio's rnea
    along the commanded path, at rest: the dwell at the first waypoint holds it)."""
    path, robot = baxter
    pc = PinChain(robot, pin_from_urdf(path, robot))
    prog = mrnea.load_program(PROGRAM, robot=robot)
    i = robot.joint_names.index("left_s1")
    hold = abs(pc.rnea(prog.q_cmd[0], np.zeros(15), np.zeros(15))[i])
    assert 5.0 < hold < 40.0
    grid = tmp_path / "grid.toml"
    grid.write_text(f'[grid]\n"effort_limit.left_s1" = [{hold * 0.8}, 50.0]\n')
    res = mrnea_cli("sweep", path, PROGRAM, "--grid", grid, "--out", tmp_path / "s",
                    "--workers", "1")
    assert res.returncode == 0, res.stderr
    rows = pd.read_csv(tmp_path / "s" / "sweep.csv")
    col = next(c for c in rows.columns if c.startswith("effort_limit.left_s1"))
    verdict = dict(zip(rows[col].round(6), rows["achievable"], strict=True))
    assert verdict == {round(hold * 0.8, 6): False, 50.0: True}


def test_the_view_traces_every_named_tip(baxter) -> None:
    """The program's three tips (head, left_wrist, right_wrist) are the tree's leaves, and the
    3D view traces each: a path per tip, at that link's point (twice its centre of mass, the
    URDF's lumped inertials as Pinocchio's reduced model has them), through the run."""
    from mrnea.report.view3d import result_scene
    from mrnea.simulate import simulate

    path, robot = baxter
    prog = mrnea.load_program(PROGRAM, robot=robot)
    run = simulate(robot, prog.q_cmd[:40], prog.dt)
    spec = result_scene(run)
    traced = [robot.link_names[k] for k, *_ in spec["tips"]]
    assert sorted(traced) == sorted(TIPS)
    model = pin_from_urdf(path, robot)
    pc = PinChain(robot, model)
    for k, *p in spec["tips"]:
        com = model.inertias[pc.ids[k]].lever  # the link's lumped centre of mass, link frame
        assert rel_err(np.array(p), 2 * np.asarray(com)) < 1e-12, robot.link_names[k]
