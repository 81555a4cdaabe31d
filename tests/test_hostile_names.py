"""Any legal joint, link or robot name renders in the figures and the HTML report.

Names may hold anything but control characters: matplotlib's math-text markers (``$``, ``\\``,
``_``, ``^``, ``{}``), HTML (``<script>``, ``&``, quotes), any script and very long names. The
figures are drawn to PNG (where a ``$...$`` pair would make matplotlib's math-text parser fail),
the report is parsed as HTML (its text must give the names back, and no element may come from a
name), and a whole ``mrnea simulate`` run must write every file.
"""

from __future__ import annotations

import json
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

from mrnea.io.program import Program
from mrnea.model import Joint, Link, Robot
from mrnea.report import plot_result, write_report
from mrnea.report.sweep import write_sweep_html
from mrnea.simulate import simulate
from mrnea.sweep import check_grid
from mrnea.sweep.engine import _frame
from mrnea.sweep.rows import run_case

NAMES = [
    "a$\\frac$1", "$", "$$", "\\", "under_score", "x^2", "{}", "$\\alpha_{1}^{2}$", "%d %s",
    "<script>alert(1)</script>", "a & b", '"quoted"', "it's", "名前", "\U0001f916 robot",
    "x" * 300, "\u202eright-to-left", "¯\\_(ツ)_/¯",
]


def _robot(names: list[str], robot_name: str) -> Robot:
    joints, links = [], []
    parent = "base <b>"
    for k, name in enumerate(names):
        child = f"link {name}"
        axis = (0, 0, 1) if k % 2 == 0 else (0, 1, 0)
        origin = np.eye(4)
        origin[0, 3] = 0.0 if k == 0 else 0.2
        joints.append(Joint(f"joint {name}", "revolute", parent, child, origin=origin, axis=axis,
                            effort_limit=5.0, velocity_limit=2.0))
        links.append(Link(child, 1.0, (0.1, 0.0, 0.0), np.eye(3) * 1e-2))
        parent = child
    return Robot(joints, links, name=robot_name)


@pytest.fixture(scope="module")
def result():
    robot = _robot(NAMES[:8], "$robot$ <i>&amp;</i> \\frac{a}{b}")
    q = np.linspace(0.0, 1.0, 60)[:, None] * np.ones(robot.n)
    return simulate(robot, q, 0.01)


class _Parsed(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.tags: list[str] = []
        self.scripts: list[dict] = []
        self.text: list[str] = []

    def handle_starttag(self, tag: str, attrs: list) -> None:
        self.tags.append(tag)
        if tag == "script":
            self.scripts.append(dict(attrs))

    def handle_data(self, data: str) -> None:
        self.text.append(data)


def test_figure_titles_escape_math_text(result) -> None:
    figs = plot_result(result)  # drawn (and so parsed as text) in the tests below
    titles = [ax.get_title(loc="left") for ax in figs["motion"].axes]
    assert any("a\\$\\frac\\$1" in t for t in titles)  # escaped: drawn as written
    assert "\\$robot\\$" in figs["motion"]._suptitle.get_text()


def test_the_report_draws_escapes_and_keeps_every_name(tmp_path: Path) -> None:
    """Every name in one robot: the report renders its figures (12 joints each) to PNG and
    lists every joint in its tables."""
    robot = _robot(NAMES, "<script>robot</script> $\\frac$")
    res = simulate(robot, np.linspace(0.0, 0.5, 30)[:, None] * np.ones(robot.n), 0.01)
    path = write_report(res, tmp_path / "report.html")
    page = path.read_text(encoding="utf-8")
    parsed = _Parsed()
    parsed.feed(page)
    # the 3D view's three scripts (its data, three.js, the viewer) and no other: any other would
    # come from a name
    assert parsed.scripts == [{"type": "application/json", "class": "mv3d-data"}, {}, {}]
    assert page.count("data:image/png;base64,") == 4
    text = "".join(parsed.text)
    for name in NAMES:
        assert f"joint {name}" in text, name
    assert "<script>robot</script> $\\frac$" in text


def test_the_sweep_page_draws_escapes_and_keeps_every_name(tmp_path: Path) -> None:
    """A sweep of the robot of every name (rows of a serial loop): sweep.html draws its map,
    labelled with limiting joints, and its curves (12 of the 18 joints) to PNG, and its table
    gives the names back, no element coming from one."""
    robot = _robot(NAMES, "<script>robot</script> $\\frac$")
    q = np.linspace(0.0, 0.5, 30)[:, None] * np.ones(robot.n)
    prog = Program(robot="x", dt=0.01, t=np.arange(30) * 0.01, q_cmd=q, f_ext=None,
                   f_ext_point=None, mode=None, name="<b>prog</b> $x$")
    keys, cases = check_grid(robot, {"payload": [0.0, 1.0], "rotor_inertia": [0.0, 1e-4]})
    rows = {k: run_case(robot, prog, case) for k, case in enumerate(cases)}
    df = _frame(keys, [prog.name], [(k, (0, 1.0), c) for k, c in enumerate(cases)], rows, False)
    assert df["error"].isna().all() and df["worst_joint"].notna().all()
    page = write_sweep_html(df, tmp_path / "sweep.html", robot.name).read_text(encoding="utf-8")
    parsed = _Parsed()
    parsed.feed(page)
    assert "script" not in parsed.tags and "b" not in parsed.tags
    assert page.count("data:image/png;base64,") == 2
    text = "".join(parsed.text)
    assert "<script>robot</script> $\\frac$" in text and "<b>prog</b> $x$" in text
    assert all(name in text for name in df["worst_joint"])


def test_a_cli_run_with_hostile_names_writes_every_file(tmp_path: Path) -> None:
    names = ["a$\\frac$1", "$\\alpha_{1}^{2}$", "<script>alert(1)</script>", "名前",
             "\U0001f916 robot", "x" * 300]
    lines = ['[robot]', 'name = "$\\\\frac$ <script>x</script>"']
    for k, name in enumerate(names):
        esc = name.replace("\\", "\\\\").replace('"', '\\"')
        lines += ["[[joint]]", f'name = "j {esc}"', 'type = "revolute"',
                  f'origin = {{ xyz = [{0.0 if k == 0 else 0.1}, 0.0, 0.0] }}',
                  f"axis = [0.0, {k % 2}.0, {1 - k % 2}.0]", "effort_limit = 50.0",
                  "[joint.link]", f'name = "l {esc}"', "mass = 1.0", "com = [0.05, 0.0, 0.0]",
                  "inertia = { ixx = 1e-3, iyy = 1e-3, izz = 1e-3 }"]
    (tmp_path / "robot.toml").write_text("\n".join(lines) + "\n", encoding="utf-8")
    n = len(names)
    header = "t," + ",".join(f"q{k}" for k in range(n))
    rows = [f"{t}," + ",".join(f"{0.01 * t:.4f}" for _ in range(n)) for t in range(4)]
    (tmp_path / "path.csv").write_text("\n".join([header, *rows]) + "\n")
    out = tmp_path / "out"
    res = subprocess.run([sys.executable, "-m", "mrnea", "simulate", tmp_path / "robot.toml",
                          tmp_path / "path.csv", "--dt", "0.5", "--out", out, "--json"],
                         capture_output=True, text=True, timeout=600)
    assert res.returncode in (0, 1), res.stderr
    assert "Traceback" not in res.stderr and "warning" not in res.stderr, res.stderr
    summary = json.loads(res.stdout)
    assert [j["joint"] for j in summary["joints"]] == [f"j {name}" for name in names]
    assert sorted(p.name for p in out.iterdir()) == sorted(
        ["cycles.csv", "summary.json", "report.html", "motion.png", "efforts.png",
         "reactions.png", "tracking.png"])
    header_row = (out / "cycles.csv").read_text(encoding="utf-8").splitlines()[0]
    assert "q_j a$\\frac$1" in header_row
