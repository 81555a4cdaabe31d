"""``mrnea size`` as a real process (issue 27): its files (pandas reads sizing.csv in one call,
summary.json is strict JSON), ``mrnea check`` reproducing the verification from
chosen_drives.toml and from sized_robot.toml, the page in headless Chromium at 800 and 1400 px,
the "nothing fits" verdict (exit 1) and bad input (one error line, exit 2)."""

from __future__ import annotations

import json

import pandas as pd
import pytest
from chromium_cdp import Browser, ChromiumUnavailable
from conftest import figure_scales, mrnea_cli, one_error_line
from test_sizing import CATALOGUE, arm

PROGRAM = """[program]
name = "swing"
robot = "arm.toml"
dt = 0.01

[path]
profile = "trapezoidal"
waypoints = [[-0.3, 0.0], [0.6, 1.0], [-0.3, 0.0]]
velocity_limit = [1.5, 1.5]
acceleration_limit = [5.0, 5.0]
"""


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    d = tmp_path_factory.mktemp("size")
    arm().to_toml(d / "arm.toml")
    (d / "swing.toml").write_text(PROGRAM)
    (d / "cat.toml").write_text(CATALOGUE)
    res = mrnea_cli("size", "arm.toml", "swing.toml", "--catalogue", "cat.toml", "--out", "out",
                    cwd=d)
    return d, res


def _strict(text: str):
    def bad(c):
        raise ValueError(f"not strict JSON: {c}")
    return json.loads(text, parse_constant=bad)


def test_size_writes_its_files_and_check_reproduces_it(work):
    d, res = work
    assert res.returncode == 0, res.stderr
    assert res.stdout.splitlines()[0].startswith("j1: C + G50")
    df = pd.read_csv(d / "out" / "sizing.csv")
    assert len(df) == 2 * 6 and set(df["joint"]) == {"j1", "j2"}
    assert (df["status"] == "chosen").sum() == 2
    assert (df.loc[df["status"] == "rejected", "worst_ratio"] > 1).all()
    assert (df.loc[df["status"] != "rejected", "worst_ratio"] <= 1).all()
    assert df.loc[df["status"] == "rejected", "reason"].str.contains(" x ").all()
    summary = _strict((d / "out" / "summary.json").read_text())
    assert summary["fits"] and summary["verified"]
    chosen = {j["joint"]: j["chosen"]["drive"] for j in summary["joints"]}
    assert chosen == dict(zip(df.loc[df["status"] == "chosen", "joint"],
                              df.loc[df["status"] == "chosen", "drive"], strict=True))
    # the sidecar alone (the drives' masses stay off the links) and the sized robot file
    ok = mrnea_cli("check", "arm.toml", "swing.toml", "--actuators", "out/chosen_drives.toml",
                   cwd=d)
    assert ok.returncode == 0, ok.stdout + ok.stderr
    (d / "any.toml").write_text(PROGRAM.replace('robot = "arm.toml"\n', ""))  # names no robot
    ok = mrnea_cli("check", "out/sized_robot.toml", "any.toml", cwd=d)
    assert ok.returncode == 0, ok.stdout + ok.stderr
    # the outputs are not replaced without --force
    again = mrnea_cli("size", "arm.toml", "swing.toml", "--catalogue", "cat.toml", "--out",
                      "out", cwd=d)
    one_error_line(again, "exists")


@pytest.mark.parametrize("width", [800, 1400])
def test_the_page_in_chromium(work, width):
    d, _ = work
    try:
        with Browser(width=width, height=1000) as b:
            page = b.open((d / "out" / "sizing.html").as_uri())
            shown = page.evaluate(
                "[...document.images].map(i => [i.complete, i.naturalWidth, "
                "i.getBoundingClientRect().width])")
            overflow = page.evaluate("document.documentElement.scrollWidth - innerWidth")
            tables = page.evaluate("document.querySelectorAll('table').length")
            scales = figure_scales(page)
            assert not page.errors and not page.outside_requests
    except ChromiumUnavailable as exc:
        pytest.skip(str(exc))
    assert len(shown) == 2 and all(c and w > 500 and 0 < r <= width for c, w, r in shown)
    assert overflow <= 0 and tables == 2
    # below 960 px a figure keeps its own pixels (and pans in its box), as the reports' do
    assert len(scales) == 2 and min(scales) >= (0.999 if width < 960 else 0.7), scales


def test_nothing_fits_is_a_verdict(work, tmp_path):
    d, _ = work
    small = CATALOGUE.split('[[motor]]\nname = "B"')[0] + CATALOGUE[CATALOGUE.index(
        "[[gearbox]]"):]
    (tmp_path / "small.toml").write_text(small)
    res = mrnea_cli("size", d / "arm.toml", d / "swing.toml", "--catalogue",
                    tmp_path / "small.toml", "--joints", "j1", "--out", tmp_path / "o")
    assert res.returncode == 1, res.stderr
    assert res.stdout.startswith("no motor fits j1: best A + G100 reaches ")
    assert not (tmp_path / "o" / "chosen_drives.toml").exists()
    assert not _strict((tmp_path / "o" / "summary.json").read_text())["fits"]


@pytest.mark.parametrize("text, words", [
    ('[[gearbox]]\nname = "G"\nratio = 10\nefficiency = [0.9, 1.5]\n', ["gearbox 'G'",
                                                                          "efficiency"]),
    ('[[motor]]\nname = "M"\nrated_torque = "big"\n', ["motor 'M'", "rated_torque"]),
    ('[[motor]]\nname = "M"\n', ["motor 'M'", "rated_torque"]),
])
def test_bad_catalogue_one_error_line(work, tmp_path, text, words):
    d, _ = work
    (tmp_path / "bad.toml").write_text(text)
    res = mrnea_cli("size", d / "arm.toml", d / "swing.toml", "--catalogue",
                    tmp_path / "bad.toml", "--out", tmp_path / "o")
    one_error_line(res, "bad.toml", *words)


def test_unknown_joint_one_error_line(work, tmp_path):
    d, _ = work
    res = mrnea_cli("size", d / "arm.toml", d / "swing.toml", "--catalogue", d / "cat.toml",
                    "--joints", "elbow", "--out", tmp_path / "o")
    one_error_line(res, "elbow", "j1")
