"""Figures and the HTML report (mrnea.report) on short SDT runs: one saturating, one achievable.

The first simulation compiles the Numba kernels (tens of seconds, once per cache). Rendering is
the slow part afterwards, so only a few tests draw PNGs; the others inspect the figure objects
or stub the plotting out.
"""

from __future__ import annotations

import base64
import dataclasses
import html
import json
import os
import re
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest
from matplotlib.collections import PolyCollection
from matplotlib.figure import Figure
from matplotlib.text import Text

import mrnea
import mrnea.report.html as report_html
from mrnea import OutputError, forward_dynamics, inverse_dynamics, mass_matrix_and_bias
from mrnea.model import Link, Robot
from mrnea.report import MAX_POINTS, fig3, plot_result, write_report
from mrnea.report.drawing import envelope
from mrnea.simulate import SimulationResult, simulate

PNG = b"\x89PNG\r\n\x1a\n"
FIGURES = {"motion", "efforts", "reactions", "tracking"}
K, DT = 400, 0.005


def program(K: int = K, dt: float = DT) -> np.ndarray:
    """Smooth cosine ramps on all four joints; cab_pitch also gets a 0.5 rad/s velocity step at
    mid-run, which the SDT's pitch drive (3000 N m) cannot follow in one cycle."""
    t = np.arange(K) * dt
    T = K * dt
    s = 0.5 * (1 - np.cos(np.pi * t / T))
    q = np.outer(s, [0.1, 0.2, 0.3, 0.2])
    q[:, 3] += np.where(t > T / 2, 0.5 * (t - T / 2), 0.0)
    return q


@pytest.fixture(scope="module")
def sdt() -> Robot:
    return mrnea.robots.sdt()


@pytest.fixture(scope="module")
def saturating(sdt: Robot) -> SimulationResult:
    res = simulate(sdt, program(), DT)
    assert not res.achievable and res.saturated[:, 3].any()
    return res


@pytest.fixture(scope="module")
def achievable(sdt: Robot) -> SimulationResult:
    res = simulate(sdt.with_actuators(effort_limit=1e9), program(), DT)
    assert res.achievable
    return res


class StrictHTML(HTMLParser):
    """Checks that every element is closed in order; collects img/link/script/a attributes."""

    VOID = frozenset({"area", "base", "br", "col", "embed", "hr", "img", "input", "link", "meta",
                      "source", "track", "wbr"})

    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.stack: list[str] = []
        self.errors: list[str] = []
        self.tags: dict[str, list[dict[str, str | None]]] = {}
        self.text: list[str] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        self.tags.setdefault(tag, []).append(dict(attrs))
        if tag not in self.VOID:
            self.stack.append(tag)

    def handle_endtag(self, tag: str) -> None:
        if tag in self.VOID:
            return
        if not self.stack or self.stack[-1] != tag:
            self.errors.append(f"</{tag}> closes {self.stack[-1:] or 'nothing'}")
        else:
            self.stack.pop()

    def handle_data(self, data: str) -> None:
        self.text.append(data)


def parse(path: Path) -> tuple[str, StrictHTML]:
    doc = path.read_text(encoding="utf-8")
    p = StrictHTML()
    p.feed(doc)
    p.close()
    assert not p.errors, p.errors
    assert not p.stack, f"unclosed elements: {p.stack}"
    assert doc.startswith("<!DOCTYPE html>")
    return doc, p


def assert_self_contained(doc: str, p: StrictHTML, view3d: bool = True) -> None:
    """No reference to anything outside the page (the browser test also checks that the page
    makes no request); scripts only with the 3D view, and inline."""
    lowered = doc.lower()
    # the one URL: the XHTML namespace's name in three.js, an identifier that is never fetched
    assert set(re.findall(r"https?://[^\s\"'<>)]+", lowered)) <= {"http://www.w3.org/1999/xhtml"}
    assert "<link" not in lowered and "@import" not in lowered
    scripts = p.tags.get("script", [])
    assert all("src" not in attrs for attrs in scripts)
    assert bool(scripts) == view3d
    imgs = p.tags.get("img", [])
    assert imgs
    for img in imgs:
        src = img["src"] or ""
        assert src.startswith("data:image/png;base64,")
        assert base64.b64decode(src.split(",", 1)[1]).startswith(PNG)


# --- plot_result ---------------------------------------------------------------------------------
def test_plot_result_writes_four_pngs(saturating: SimulationResult, tmp_path: Path) -> None:
    out = tmp_path / "plots" / "run1"
    figs = plot_result(saturating, out)
    assert set(figs) == FIGURES
    assert all(isinstance(f, Figure) for f in figs.values())
    assert sorted(p.name for p in out.iterdir()) == sorted(f"{n}.png" for n in FIGURES)
    umask = os.umask(0o022)
    os.umask(umask)
    for name in FIGURES:
        data = (out / f"{name}.png").read_bytes()
        assert data.startswith(PNG) and len(data) > 10_000
        assert (out / f"{name}.png").stat().st_mode & 0o777 == 0o666 & ~umask
    # joint names in the titles, SI units in the labels
    for name, fig in figs.items():
        titles = " ".join(ax.get_title(loc="left") for ax in fig.axes)
        for j in saturating.robot.joint_names:
            assert j in titles, (name, j)
    labels = " ".join(ax.get_ylabel() for ax in figs["efforts"].axes)
    assert "N m" in labels
    assert "[rad]" in " ".join(ax.get_ylabel() for ax in figs["motion"].axes)
    assert "[N]" in " ".join(ax.get_ylabel() for ax in figs["reactions"].axes)


def test_efforts_plot_limit_array_and_saturation(sdt: Robot, saturating: SimulationResult) -> None:
    """The limit drawn is the per-cycle limit array (a torque-speed curve makes it vary), the
    requirement drawn is the program's, and saturated intervals are shaded only where the joint
    saturated."""
    curves = [(25000.0, 0.05, 3.2), (4000.0, 0.05, 3.0), (5000.0, 0.05, 2.0), (3000.0, 0.3, 1.5)]
    res = simulate(sdt.with_actuators(torque_speed=curves), program(), DT)
    assert np.ptp(res.limit[:, 1]) > 1.0  # cab_yaw's limit falls with speed
    for r in (res, saturating):
        axes = [ax for ax in plot_result(r)["efforts"].axes if ax.get_title(loc="left")]
        assert len(axes) == r.robot.n
        for i, ax in enumerate(axes):
            ys = [line.get_ydata() for line in ax.get_lines()]
            assert any(np.array_equal(y, r.limit[:, i]) for y in ys)
            assert any(np.array_equal(y, -r.limit[:, i]) for y in ys)
            # the program's own requirement, never the cycle's lag recovery (issue 11)
            assert any(np.array_equal(y, r.program_effort[:, i]) for y in ys)
            lagging = not np.array_equal(r.tau_required[:, i], r.program_effort[:, i])
            assert not (lagging and any(np.array_equal(y, r.tau_required[:, i]) for y in ys))
            shaded = any(isinstance(c, PolyCollection) for c in ax.collections)
            assert shaded == bool(r.saturated[:, i].any())


def test_long_runs_are_decimated(sdt: Robot) -> None:
    n_cycles = 12_000
    res = simulate(sdt.with_actuators(effort_limit=1e9), program(n_cycles, 0.001), 0.001)
    for fig in plot_result(res).values():
        for ax in fig.axes:
            for line in ax.get_lines():
                assert len(line.get_xdata()) <= MAX_POINTS + 4


def test_envelope_keeps_extremes() -> None:
    rng = np.random.default_rng(1)
    t = np.arange(1_000_003) * 1e-3
    y = rng.normal(size=t.size)
    y[123_457] = 50.0
    y[777_777] = -60.0
    tt, yy = envelope(t, y)
    assert yy.size <= MAX_POINTS + 4
    assert np.all(np.diff(tt) > 0)
    assert yy.max() == 50.0 and yy.min() == -60.0
    assert tt[0] == t[0] and tt[-1] == t[-1]
    short = np.arange(10.0)
    assert envelope(short, short)[1] is short


# --- fig3 ----------------------------------------------------------------------------------------
def sdt_trajectory(n_samples: int = 201) -> tuple[np.ndarray, ...]:
    t = np.linspace(0.0, 4.0, n_samples)
    w = 2 * np.pi / 4.0
    amp = np.array([0.8, 1.0, 0.6, 0.4])
    phase = np.array([0.0, 0.5, 1.0, 1.5])
    arg = w * t[:, None] + phase
    return t, amp * np.sin(arg), amp * w * np.cos(arg), -amp * w**2 * np.sin(arg)


def test_fig3_rnea_equals_mrnea(sdt: Robot) -> None:
    t, q, qd, qdd = sdt_trajectory()
    u_rnea = inverse_dynamics(sdt, q, qd, qdd)
    H, u_bias = mass_matrix_and_bias(sdt, q, qd)
    u_mrnea = np.einsum("kij,kj->ki", H, qdd) + u_bias
    scale = np.abs(u_rnea).max()
    assert scale > 1e3
    assert np.abs(u_rnea - u_mrnea).max() / scale < 1e-9
    qdd_back = forward_dynamics(sdt, q, qd, u_rnea)
    assert np.abs(qdd_back - qdd).max() / np.abs(qdd).max() < 1e-9

    fig = fig3(sdt, t, q, qd, qdd)
    assert len(fig.axes) == 2 * sdt.n
    texts = " ".join(x.get_text() for x in fig.findobj(Text))
    rel = [float(x) for x in re.findall(r"relative ([0-9.eE+-]+)", texts)]
    assert len(rel) == 2 and all(r < 1e-9 for r in rel), texts
    for j in sdt.joint_names:
        assert j in texts
    with pytest.raises(ValueError, match="fig3"):
        fig3(sdt, t[:-1], q, qd, qdd)


def test_fig3_eq2_solve_against_scipy() -> None:
    """Fig. 3 (b) solves Eq. 2 with NumPy over K states: each against SciPy's Cholesky solve,
    and a mass matrix that is not positive definite is refused naming its state."""
    from scipy.linalg import cho_factor, cho_solve

    from mrnea import SingularMassMatrixError
    from mrnea.report.paper import _solve_eq2

    rng = np.random.default_rng(3)
    A = rng.normal(size=(7, 4, 4))
    H = A @ A.transpose(0, 2, 1) + 0.1 * np.eye(4)
    rhs = rng.normal(size=(7, 4))
    got = _solve_eq2(H, rhs)
    for k in range(7):
        want = cho_solve(cho_factor(H[k]), rhs[k])
        assert np.allclose(got[k], want, rtol=1e-12, atol=1e-12)
    H[5, 2, 2] = -1.0
    with pytest.raises(SingularMassMatrixError, match="state 5"):
        _solve_eq2(H, rhs)


# --- write_report --------------------------------------------------------------------------------
def test_report_not_achievable(saturating: SimulationResult, sdt: Robot, tmp_path: Path) -> None:
    t, q, qd, qdd = sdt_trajectory(101)
    path = tmp_path / "new" / "report.html"
    out = write_report(saturating, path, extra_figures={"Fig. 3": fig3(sdt, t, q, qd, qdd)})
    assert out == path
    assert [p.name for p in path.parent.iterdir()] == ["report.html"]  # no temporary left
    doc, p = parse(path)
    assert_self_contained(doc, p)
    text = " ".join(p.text).replace("\u00a0", " ")  # numbers bound to their units
    assert saturating.verdict() in text
    assert "NOT ACHIEVABLE" in text
    # verdict first, in the red box
    verdict_div = re.search(r'<div class="verdict (\w+)" id="verdict">([^<]*)</div>', doc)
    assert verdict_div and verdict_div.group(1) == "bad"
    assert html.unescape(verdict_div.group(2)).replace("\u00a0", " ") == saturating.verdict()
    assert doc.index('id="verdict"') < doc.index("<table")
    fi = saturating.summary()["first_infeasible"]
    assert fi["joint"] in text and fi["reason"] in text
    assert len(p.tags["img"]) == len(FIGURES) + 1
    assert "Fig. 3" in text
    # one table row per joint (plus header) in the per-joint table
    for j in saturating.robot.joint_names:
        assert f'<td class="l">{j}</td>' in doc
    for word in ("hybrid", "mrnea", "completed", "0.005 s"):
        assert word in text


def test_report_achievable_overwrites_when_asked(achievable: SimulationResult,
                                                 tmp_path: Path) -> None:
    path = tmp_path / "report.html"
    path.write_text("old")
    write_report(achievable, path, overwrite=True, view3d=False)
    doc, p = parse(path)
    assert_self_contained(doc, p, view3d=False)
    text = " ".join(p.text).replace("\u00a0", " ")  # numbers bound to their units
    assert achievable.verdict() in text
    assert "ACHIEVABLE" in text and "NOT ACHIEVABLE" not in text
    assert 'class="verdict ok"' in doc
    assert len(p.tags["img"]) == len(FIGURES)


def test_report_refuses_to_overwrite(saturating: SimulationResult, tmp_path: Path,
                                     monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "report.html"
    path.write_text("keep me")
    with pytest.raises(OutputError, match="exists"):
        write_report(saturating, path)
    assert path.read_text() == "keep me"
    assert [q.name for q in tmp_path.iterdir()] == ["report.html"]

    # a failure while writing leaves the old file intact and no temporary behind
    def boom(*_a: object, **_k: object) -> str:
        raise RuntimeError("render failed")

    monkeypatch.setattr(report_html, "plot_result", lambda r: {"x": Figure()})
    monkeypatch.setattr(report_html, "png_data_uri", boom)
    with pytest.raises(RuntimeError, match="render failed"):
        write_report(saturating, path, overwrite=True)
    assert path.read_text() == "keep me"
    assert [q.name for q in tmp_path.iterdir()] == ["report.html"]


def test_report_escapes_names(saturating: SimulationResult, tmp_path: Path,
                              monkeypatch: pytest.MonkeyPatch) -> None:
    """Robot and joint names are escaped (figures stubbed out: this is about the text)."""
    bad = '<img src="https://x.test/a.png">&'
    rob = saturating.robot
    joints = [dataclasses.replace(j, name=f"{j.name}{bad}" if i == 0 else j.name)
              for i, j in enumerate(rob.joints)]
    evil = Robot(joints=joints, links=[Link(lk.name, lk.mass, lk.com, lk.inertia)
                                       for lk in rob.links],
                 gravity=rob.gravity, name=f"sdt{bad}", base=rob.base)
    res = dataclasses.replace(saturating, robot=evil, _summary={})
    monkeypatch.setattr(report_html, "plot_result", lambda r: {})
    path = write_report(res, tmp_path / "r.html")
    doc, p = parse(path)
    assert bad not in doc
    assert html.escape(f"sdt{bad}") in doc
    # the 3D view's data holds the name as JSON, with every "<" escaped (test_view3d.py)
    data = re.search(r'<script type="application/json" class="mv3d-data">(.*?)</script>', doc,
                     re.S)
    assert data and json.loads(data.group(1))["joints"][0] == evil.joint_names[0]
    assert "https://" not in doc.replace(data.group(0), "").replace(html.escape(bad), "")
    assert "img" not in p.tags
    assert f"sdt{bad}" in " ".join(p.text)


def test_report_interrupted_and_clamped(sdt: Robot, achievable: SimulationResult, tmp_path: Path,
                                        monkeypatch: pytest.MonkeyPatch) -> None:
    """An interrupted, so far achievable run is amber; a position clamp names the joint range."""
    monkeypatch.setattr(report_html, "plot_result", lambda r: {})
    partial = dataclasses.replace(achievable, completed=False, _summary={})
    doc, _ = parse(write_report(partial, tmp_path / "partial.html"))
    assert 'class="verdict partial"' in doc and "INTERRUPTED" in doc
    assert "NOT ACHIEVABLE" not in doc

    q = program()
    q[:, 3] = np.linspace(0.0, 2.0, K)  # cab_pitch runs into its +90 deg stop
    res = simulate(sdt.with_actuators(effort_limit=1e9), q, DT)
    assert res.position_clamped[:, 3].any()
    doc, p = parse(write_report(res, tmp_path / "clamped.html"))
    text = " ".join(p.text).replace("\u00a0", " ")  # numbers bound to their units
    assert "NOT ACHIEVABLE" in text and "position limit" in text and "joint range" in text


def test_result_report_and_plot_methods(achievable: SimulationResult, tmp_path: Path,
                                        monkeypatch: pytest.MonkeyPatch) -> None:
    """SimulationResult.report and .plot are write_report and plot_result (figures stubbed)."""
    monkeypatch.setattr(report_html, "plot_result", lambda r: {})
    doc, p = parse(achievable.report(tmp_path / "a.html"))
    assert 'class="mv3d"' in doc and len(p.tags["script"]) == 3  # data, three.js, viewer
    assert "three.js r187" in doc and "MIT License" in doc  # the licence notice it asks for
    doc, p = parse(achievable.report(tmp_path / "a.html", overwrite=True, view3d=False))
    assert "script" not in p.tags and 'class="mv3d"' not in doc
    with pytest.raises(OutputError, match="exists"):
        achievable.report(tmp_path / "a.html")
    assert set(achievable.plot()) == FIGURES


def test_a_joint_without_tracking_error_says_so(saturating: SimulationResult) -> None:
    """Joints whose error stays 0 (the saturating run lags on cab_pitch alone, and its other
    joints follow exactly: the drives are within their limits) get "no tracking error", without
    a largest-error dot or an axis of rounding noise; the lagging joint keeps its dot."""
    fig = plot_result(saturating)["tracking"]
    axes = {ax.get_title(loc="left").split(":")[0]: ax for ax in fig.axes
            if ax.get_title(loc="left")}
    errors = np.abs(saturating.tracking_error).max(axis=0)
    assert errors[3] > 0 and (errors == 0).any()
    for name, err in zip(saturating.robot.joint_names, errors, strict=True):
        ax = axes[name]
        said = [t.get_text() for t in ax.texts]
        dots = [ln for ln in ax.get_lines() if ln.get_marker() == "o"]
        if err == 0:
            assert said == ["no tracking error"] and not dots
            assert ax.get_title(loc="left").endswith(": none")
            assert ax.get_ylim() == (-1.0, 1.0)
        else:
            assert "no tracking error" not in said and len(dots) == 1


def test_the_programmed_acceleration_is_the_programs_own_with_its_unit(
        saturating: SimulationResult) -> None:
    """Issue 22: the motion figure's dashed acceleration is the program's own (the second
    difference of q_cmd, from rest, 0 after the last row), not the drive's catch-up once it
    lags; cab_pitch's velocity step makes it a one-cycle spike of 0.5 rad/s / 5 ms, drawn off
    scale with a note naming it "programmed" and giving its unit."""
    q = saturating.q_cmd
    V = np.vstack([np.zeros((1, q.shape[1])), np.diff(q, axis=0) / DT])
    A = np.diff(np.vstack([V, np.zeros((1, q.shape[1]))]), axis=0) / DT  # numpy, by hand
    fig = plot_result(saturating)["motion"]
    axes = {ax.get_title(loc="left"): ax for ax in fig.axes if ax.get_title(loc="left")}
    for i, name in enumerate(saturating.robot.joint_names):
        ax = axes[f"{name}: acceleration"]
        dashed = [ln for ln in ax.get_lines() if ln.get_linestyle() == "--"]
        assert len(dashed) == 1
        np.testing.assert_allclose(np.asarray(dashed[0].get_ydata(), float), A[:, i],
                                   rtol=1e-9, atol=1e-9)
    notes = [t.get_text() for t in axes["cab_pitch: acceleration"].texts]
    assert len(notes) == 1, notes
    m = re.fullmatch(r"programmed peak ([\d.]+) rad/s² off scale", notes[0])
    assert m, notes[0]
    assert float(m.group(1)) == pytest.approx(np.abs(A[:, 3]).max(), rel=1e-3)
    assert np.abs(A[:, 3]).max() == pytest.approx(0.5 / DT, rel=0.02)
    assert np.abs(saturating.qdd_des[:, 3] - A[:, 3]).max() > 1.0  # the catch-up: another line


def test_the_report_writes_the_figures_it_embeds(tmp_path) -> None:
    """write_report(png_folder=) writes each figure once: the files are plot_result's, byte for
    byte, and the page embeds the same bytes."""
    import base64

    import mrnea
    from mrnea.report import FIGURES, plot_result, write_report
    from mrnea.trajectory import quintic

    robot = mrnea.robots.puma560()
    _, q_cmd = quintic([np.zeros(6), np.full(6, 0.3)], dt=0.01, velocity_limit=1.0,
                       acceleration_limit=2.0)
    res = mrnea.simulate(robot, q_cmd, dt=0.01)
    plot_result(res, tmp_path / "alone")
    page = write_report(res, tmp_path / "r" / "report.html", view3d=False,
                        png_folder=tmp_path / "r").read_text()
    for name in FIGURES:
        png = (tmp_path / "r" / f"{name}.png").read_bytes()
        assert png == (tmp_path / "alone" / f"{name}.png").read_bytes()
        assert base64.b64encode(png).decode("ascii") in page
    with pytest.raises(mrnea.MrneaError, match=r"motion\.png"):
        write_report(res, tmp_path / "r" / "other.html", png_folder=tmp_path / "r")
