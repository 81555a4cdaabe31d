"""The 3D view's markers of a Cartesian program's move targets: in the scene spec, and drawn in
headless Chromium (tests/chromium_cdp.py; skips only where no Chromium can be started).

Oracles: the targets written in the program file (positions) and Pinocchio's tool0 rotation of the
solved q at the target (orientation, as a quaternion by ``pin.Quaternion``); in the browser, the
count of magenta blobs (scipy.ndimage.label) on a page with three well-separated targets against
the same page without them.
"""

from __future__ import annotations

import io

import numpy as np
import pinocchio as pin
import pytest
from chromium_cdp import Browser, ChromiumUnavailable
from conftest import erd_path, pin_from_urdf
from PIL import Image
from scipy import ndimage
from test_cartesian_blend import CORNERS, MOVES, UR5, _program
from test_ik import PinTool
from test_report_browser import closed_form_page, open_view

import mrnea
from mrnea.cartesian import solve
from mrnea.io.program import loads_program
from mrnea.report import view3d, view3d_html


def test_a_cartesian_run_marks_its_targets_in_the_scene():
    path = erd_path(UR5)
    robot = mrnea.load_urdf(path)
    ref = PinTool(robot, pin_from_urdf(path, robot), "tool0")
    prog = solve(loads_program(_program(path, MOVES)), robot)
    res = mrnea.simulate(robot, prog.q_cmd, prog.dt, cartesian=prog.cartesian)
    marks = np.array(view3d.result_scene(res)["targets"])
    assert marks.shape == (3, 7)
    np.testing.assert_array_equal(marks[:, :3], CORNERS)
    # the last target is reached: its orientation is Pinocchio's at the last commanded q
    qx, qy, qz, qw = marks[2, 3:]
    R = pin.Quaternion(qw, qx, qy, qz).toRotationMatrix()
    assert np.linalg.norm(pin.log3(R.T @ ref.pose(prog.q_cmd[-1])[:3, :3])) <= 1e-9
    assert "move targets" in view3d_html.scene_html(view3d.result_scene(res))
    joint = mrnea.simulate(robot, prog.q_cmd, prog.dt)  # no Cartesian path: no markers
    assert view3d.result_scene(joint)["targets"] == []
    assert "move targets" not in view3d_html.scene_html(view3d.result_scene(joint))


def _magenta(img: np.ndarray) -> np.ndarray:  # the markers' #c51b8a
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    return (np.abs(r - 197) < 40) & (g < 80) & (np.abs(b - 138) < 40)


def test_the_markers_are_drawn(tmp_path, monkeypatch):
    try:
        browser = Browser(width=1100, height=1300)
    except ChromiumUnavailable as exc:
        pytest.skip(f"no Chromium for the browser tests: {exc}")
    real = view3d.scene_data
    T = np.tile(np.eye(4), (3, 1, 1))
    T[:, :3, 3] = [[0.9, -0.5, 0.3], [0.9, 0.5, 0.3], [-0.3, 0.9, 0.3]]
    blobs = []
    with browser:
        for targets in (T, None):
            monkeypatch.setattr(view3d, "scene_data",
                                lambda *a, _t=targets, **k: real(*a, **k, targets=_t))
            f = tmp_path / f"page{len(blobs)}.html"
            f.write_text(closed_form_page(), encoding="utf-8")
            page = open_view(browser, f.as_uri() + "#t=0.5")
            png = page.screenshot(".mv3d-stage")
            img = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.int16)
            mask = ndimage.binary_opening(_magenta(img), iterations=2)  # dots, not thin sticks
            blobs.append(ndimage.label(mask)[1])
            assert not page.errors
    assert blobs == [3, 0]
