"""The report on a branching robot (issue 25): the per-joint tables grouped by branch, the 3D
view's simple shapes joining each body to every joint it carries, a trace at every branch's tip,
and the page in headless Chromium at 800 and 1400 px. Robot: ``examples/waist_two_arms.urdf``
(a waist carrying a torso with two 4-joint arms); the expected geometry is read from the URDF
text itself (joint origins, the hands' centres of mass), not from mrnea.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from conftest import chromium, open_report

import mrnea
from mrnea.report import shapes as shp
from mrnea.report import write_report
from mrnea.report.view3d import result_scene
from mrnea.simulate import simulate

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
URDF = EXAMPLES / "waist_two_arms.urdf"
BRANCHES = ["branch waist, on the base", "branch shoulder_pitch_l..wrist_l, on waist",
            "branch shoulder_pitch_r..wrist_r, on waist"]


def _urdf():
    root = ET.parse(URDF).getroot()
    origin = {j.get("name"): np.array(j.find("origin").get("xyz").split(), float)
              for j in root.iter("joint")}
    com = {lk.get("name"): np.array(lk.find("inertial/origin").get("xyz").split(), float)
           for lk in root.iter("link")}
    return origin, com


@pytest.fixture(scope="module")
def run():
    prog = mrnea.load_program(EXAMPLES / "waist_left_swing.toml")
    robot = prog.load_robot()
    return simulate(robot, prog.q_cmd, prog.dt)


def test_simple_shapes_join_each_body_to_every_joint_it_carries(tmp_path) -> None:
    text = re.sub(r"<visual>.*?</visual>", "", URDF.read_text(), flags=re.S)  # no visuals
    (tmp_path / "bare.urdf").write_text(text)
    robot = mrnea.load_urdf(tmp_path / "bare.urdf")
    origin, com = _urdf()
    torso = shp.robot_shapes(robot)[1]  # the waist's link: carries both shoulders
    caps = [s for s in torso if s.kind == "capsule"]
    ends = sorted(np.round(s.origin[:3, 3] * 2, 9).tolist() for s in caps)  # mid-point x 2
    assert ends == sorted([origin["shoulder_pitch_l"].tolist(),
                           origin["shoulder_pitch_r"].tolist()])
    drives = sorted(s.joint for s in torso if s.kind == "cylinder")
    assert drives == [1, 5]  # shoulder_pitch_l and shoulder_pitch_r
    for body, hand in ((5, "hand_l"), (9, "hand_r")):  # a tip: to twice its centre of mass
        caps = [s for s in shp.robot_shapes(robot)[body] if s.kind == "capsule"]
        assert len(caps) == 1 and np.allclose(caps[0].origin[:3, 3], com[hand], atol=1e-12)


def test_the_view_traces_every_branchs_tip(run) -> None:
    _, com = _urdf()
    spec = result_scene(run)
    assert spec["tips"] == [[4, *(2 * com["hand_l"]).tolist()], [8, *(2 * com["hand_r"]).tolist()]]


def test_the_tables_are_grouped_by_branch(run, tmp_path) -> None:
    page = write_report(run, tmp_path / "r.html", view3d=False).read_text(encoding="utf-8")
    rows = re.findall(r'<tr class="branch"><th colspan="\d+">(.*?)</th></tr>', page)
    assert rows == BRANCHES * 3  # in each of the three per-joint tables, in the tree's order
    # each group holds its joints: the left arm's four rows follow its header
    first = page.index(BRANCHES[1])
    after = page[first:page.index(BRANCHES[2], first)]
    for name in ("shoulder_pitch_l", "shoulder_roll_l", "elbow_l", "wrist_l"):
        assert f'<td class="l">{name}</td>' in after


@pytest.mark.parametrize("width", [800, 1400])
def test_the_tree_report_reads_at_800_and_1400_px(run, tmp_path, width) -> None:
    report = write_report(run, tmp_path / "report.html")
    with chromium(width) as b:
        page = open_report(b, report.as_uri() + "#t=3.0")
        got = page.evaluate("""(() => ({
          inner: window.innerWidth, page: document.documentElement.scrollWidth,
          tables: [...document.querySelectorAll('.scroll')].map(
            d => [d.scrollWidth, d.clientWidth]),
          branches: document.querySelectorAll('tr.branch').length}))()""")
        assert got["page"] <= got["inner"] == width
        assert got["branches"] == 9
        for scroll, box in got["tables"]:
            assert scroll <= box, got["tables"]
        (tmp_path / f"tree-{width}.png").write_bytes(page.screenshot(None))
        assert page.errors == [] and page.outside_requests == []
