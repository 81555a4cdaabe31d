"""The report's 3D view in a real browser: headless Chromium driven through the DevTools protocol
(tests/chromium_cdp.py). Skips, saying why, only where no Chromium can be started.

Two pages. A test page whose frames are closed forms (a planar two-link arm swinging with a
period of 2 s, independent of mrnea's kinematics; joint 1 flagged saturated from 1.0 to 1.5 s;
a matplotlib figure with a green vertical line at T_MARK), and the report ``mrnea demo`` writes.
"""

from __future__ import annotations

import base64
import io
import json
import re
from pathlib import Path

import numpy as np
import pytest
from chromium_cdp import Browser
from click.testing import CliRunner
from conftest import chromium, open_report, time_marker
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from PIL import Image  # matplotlib's dependency

from mrnea.cli import main
from mrnea.report import shapes as shp
from mrnea.report import view3d, view3d_html

DT, PERIOD, T_END, T_MARK = 0.01, 2.0, 6.0, 2.75
L1, L2 = 0.6, 0.4
DEMO_BUDGET = 3_000_000  # bytes: the demo's report stays under 3 MB


def planar_frames(t: np.ndarray) -> np.ndarray:
    """(F, 2, 4, 4): joint 1 about z at 0.3 m above the base, joint 2 about z at (L1, 0, 0)."""
    q1, q2 = 0.9 * np.sin(2 * np.pi * t / PERIOD), 1.2 * np.sin(2 * np.pi * t / PERIOD + 1)
    T = np.zeros((t.size, 2, 4, 4))
    T[..., 3, 3] = 1
    for i, a in enumerate((q1, q1 + q2)):
        T[:, i, 0, 0], T[:, i, 0, 1], T[:, i, 1, 0], T[:, i, 1, 1] = (np.cos(a), -np.sin(a),
                                                                      np.sin(a), np.cos(a))
        T[:, i, 2, 2] = 1
    T[:, 0, 2, 3] = 0.3
    T[:, 1, :3, 3] = T[:, 0, :3, 3] + L1 * np.column_stack([np.cos(q1), np.sin(q1),
                                                             np.zeros_like(q1)])
    return T


def closed_form_page() -> str:
    t = np.arange(0.0, T_END + DT / 2, DT)
    idx = view3d.frame_indices(t, 2)
    sat = np.zeros((t.size, 2), dtype=bool)
    sat[(t >= 1.0) & (t < 1.5), 0] = True
    shapes = [[shp.Shape("cylinder", (0.1, 0.3), shp.frame_z_to((0, 0, 1.0), (0, 0, 0.15)))],
              [shp.capsule_between((0, 0, 0), (L1, 0, 0), 0.04, joint=0)],
              [shp.capsule_between((0, 0, 0), (L2, 0, 0), 0.04, joint=1)]]
    spec = view3d.scene_data(t[idx], planar_frames(t[idx]), planar_frames(t[idx] - 0.1), shapes,
                             view3d.pool_flags(sat, idx), ["j1", "j2"], (0.0, T_END, DT),
                             (L2, 0, 0))
    fig = Figure(figsize=(8, 3), dpi=100)
    FigureCanvasAgg(fig)
    ax = fig.add_axes((0.1, 0.2, 0.85, 0.7))
    ax.plot(t, np.sin(t))
    ax.axvline(T_MARK, color="#00ff00", lw=1)
    ax.set_xlim(-0.3, T_END + 0.3)
    ax.set_xlabel("time t [s]")
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    png = base64.b64encode(buf.getvalue()).decode()
    return (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>t</title></head><body>"
            f"{view3d_html.scene_html(spec)}<figure id='f' data-xaxes='"
            f"{view3d_html.figure_axes(fig)}'><img style='border:1px solid #ddd' "
            f"src='data:image/png;base64,{png}'></figure></body></html>")


@pytest.fixture(scope="module")
def browser():
    with chromium(1100, 1300) as b:
        yield b


def open_view(browser: Browser, url: str):
    page = open_report(browser, url)
    page.evaluate("document.querySelectorAll('.mv3d-legend, .mv3d-sat, .mv3d-hint')"
                  ".forEach(e => e.style.visibility = 'hidden')")  # the 3D scene alone in shots
    page.next_frames(2)
    return page


@pytest.fixture(scope="module")
def page(browser, tmp_path_factory):
    path = tmp_path_factory.mktemp("view3d") / "page.html"
    path.write_text(closed_form_page(), encoding="utf-8")
    return open_view(browser, path.as_uri() + "#t=0.5")


def shot(page, t: float | None = None, selector: str = ".mv3d-stage") -> np.ndarray:
    if t is not None:
        page.evaluate(f"mrneaView3d.setTime({t})")
        page.next_frames(2)
    png = page.screenshot(selector)
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.int16)


def changed(a: np.ndarray, b: np.ndarray) -> float:
    """Fraction of pixels that differ by more than 30 in some channel."""
    return float((np.abs(a - b).max(axis=2) > 30).mean())


def test_opens_at_the_url_time(page) -> None:
    assert page.evaluate("mrneaView3d.time()") == 0.5
    assert page.evaluate("document.querySelector('.mv3d input[type=range]').value") == "0.5"
    assert page.evaluate("document.querySelector('.mv3d output').textContent") == "0.500 s"


def test_canvas_shows_a_scene(page) -> None:
    img = shot(page, 0.5)
    assert img.reshape(-1, 3).std(axis=0).mean() > 5  # not one flat colour


def test_motion_changes_the_picture_and_only_the_motion(page) -> None:
    a, b = shot(page, 0.5), shot(page, 1.5)
    same = shot(page, 0.5 + PERIOD)  # the arm is where it was one period earlier
    moved = changed(a, b)
    assert 0.002 < moved < 0.3
    # the paths are drawn up to the current time, so the later picture has more path; the arm
    # itself (and so all but a thin line) is where it was
    assert changed(a, same) < 0.2 * moved


def test_saturated_joint_is_red_only_while_it_saturates(page) -> None:
    def red(img: np.ndarray) -> float:
        r, g, b = img[..., 0], img[..., 1], img[..., 2]
        return float(((r > 150) & (g < 90) & (b < 90)).mean())

    assert red(shot(page, 1.2)) > 0.001
    assert red(shot(page, 2.5)) < 1e-5
    assert page.evaluate("document.querySelector('.mv3d-sat').textContent") == ""
    page.evaluate("mrneaView3d.setTime(1.2)")
    assert page.evaluate("document.querySelector('.mv3d-sat').textContent") == "saturated: j1"


def columns(img: np.ndarray, mask) -> np.ndarray:
    return np.flatnonzero(mask(img).any(axis=0))


def purple(img: np.ndarray) -> np.ndarray:
    return (np.abs(img[..., 0] - 123) < 40) & (img[..., 1] < 100) & (img[..., 2] > 140)


def hide_markers(page, hidden: bool) -> None:
    page.evaluate("document.querySelectorAll('.mv3d-tline').forEach(e => e.style.visibility = "
                  f"'{'hidden' if hidden else 'visible'}')")


def test_time_marker_lands_on_matplotlibs_line(page) -> None:
    img = shot(page, T_MARK, "#f img")
    hide_markers(page, True)  # the marker covers matplotlib's line when it is right
    bare = shot(page, None, "#f img")
    hide_markers(page, False)
    green = columns(bare, lambda x: (x[..., 1] > 200) & (x[..., 0] < 80))
    marker = columns(img, purple)
    assert green.size and marker.size
    assert abs(marker.mean() - green.mean()) <= 1.5  # pixels


def test_play_advances_the_clock(page) -> None:
    page.evaluate("mrneaView3d.setTime(0)")
    page.evaluate("mrneaView3d.play()")
    page.evaluate("new Promise(r => setTimeout(r, 400))")
    page.evaluate("mrneaView3d.pause()")
    assert 0.0 < page.evaluate("mrneaView3d.time()") < T_END


def test_orbit_zoom_and_reset_view(page) -> None:
    page.evaluate("document.querySelector('.mv3d').scrollIntoView()")
    before = shot(page, 0.5)
    box = page.evaluate("(() => { const r = document.querySelector('.mv3d canvas')"
                        ".getBoundingClientRect(); return [r.x, r.y, r.width, r.height]; })()")
    cx, cy = box[0] + box[2] / 2, box[1] + box[3] / 2
    page.mouse("mouseMoved", cx, cy)
    page.mouse("mousePressed", cx, cy, button="left", clickCount=1)
    for k in range(1, 11):
        page.mouse("mouseMoved", cx + 15 * k, cy + 3 * k, button="left", buttons=1)
    page.mouse("mouseReleased", cx + 150, cy + 30, button="left", clickCount=1)
    page.next_frames(2)
    orbited = shot(page)
    assert changed(before, orbited) > 0.01  # the camera turned
    page.mouse("mouseWheel", cx, cy, deltaX=0, deltaY=-600)
    page.next_frames(2)
    assert changed(orbited, shot(page)) > 0.01  # and moved closer
    page.evaluate("document.querySelector('.mv3d-home').click()")
    page.next_frames(2)
    assert changed(before, shot(page)) < 0.001  # "reset view": the first camera again


def test_no_webgl_says_so_and_raises_nothing(tmp_path) -> None:
    """Without WebGL (GPU and software rasteriser off) the view says so in one line and hides
    its controls; the rest of the page is there and nothing is logged as an error."""
    path = tmp_path / "page.html"
    path.write_text(closed_form_page(), encoding="utf-8")
    with chromium(900, 900, ("--disable-gpu", "--disable-software-rasterizer")) as b:
        page = b.open(path.as_uri())
        if page.evaluate("!!document.createElement('canvas').getContext('webgl2')"):
            pytest.skip("this Chromium gives WebGL 2 even with the GPU and rasteriser off")
        assert page.evaluate("mrneaView3d.ready") is None
        assert page.evaluate("getComputedStyle(document.querySelector('.mv3d-nogl-msg'))"
                             ".display") == "block"
        assert page.evaluate("getComputedStyle(document.querySelector('.mv3d-controls'))"
                             ".display") == "none"
        assert page.evaluate("document.querySelector('#f img').complete")
        assert page.errors == [] and page.outside_requests == []


def test_no_error_and_no_request_outside_the_file(page) -> None:
    assert page.errors == []
    assert page.outside_requests == []
    assert Path(page.requests[0]).name.startswith("page.html")


# --- the demo's report ---------------------------------------------------------------------------
@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    out = tmp_path_factory.mktemp("demo") / "out"
    res = CliRunner().invoke(main, ["demo", "--out", str(out), "--quiet"],
                             catch_exceptions=False)
    assert res.exit_code == 1, res.output  # NOT ACHIEVABLE, on purpose
    return out / "report.html", json.loads((out / "summary.json").read_text())


def test_demo_report_size(demo) -> None:
    report, _ = demo
    assert report.stat().st_size < DEMO_BUDGET


def test_demo_report_in_the_browser(browser, demo) -> None:
    report, summary = demo
    t_first = summary["first_infeasible"]["time"]
    page = open_view(browser, report.as_uri())
    page.evaluate("document.querySelector('.mv3d').scrollIntoView()")
    a = shot(page, 5.0)
    assert a.reshape(-1, 3).std(axis=0).mean() > 5  # the canvas is not blank
    b = shot(page, 20.0)
    again = shot(page, 5.0)
    assert changed(a, b) > 0.005  # the trainer turned between 5 s and 20 s ...
    assert changed(a, again) == 0.0  # ... and the picture is the instant's alone
    # the first infeasible instant's link in the table shows that instant
    href = page.evaluate("""(() => { const a = [...document.querySelectorAll('a[href^="#t="]')]
        .find(a => !a.closest('.mv3d')); a.click(); return a.getAttribute('href'); })()""")
    page.next_frames(2)
    assert href == f"#t={t_first:.3f}"
    assert abs(page.evaluate("mrneaView3d.time()") - t_first) < 1e-9
    assert page.evaluate("document.querySelector('.mv3d-sat').textContent") == "saturated: cab_yaw"
    assert page.errors == [] and page.outside_requests == []


def test_demo_report_opens_at_its_url_time(browser, demo) -> None:
    report, summary = demo
    t_first = summary["first_infeasible"]["time"]
    page = open_view(browser, f"{report.as_uri()}#t={t_first}")
    assert page.evaluate("mrneaView3d.time()") == t_first
    assert float(page.evaluate("document.querySelector('.mv3d input[type=range]').value")) \
        == pytest.approx(t_first, abs=1e-9)
    # the plots mark that time: on the motion figure, the marker covers matplotlib's dotted
    # red line of the first infeasible instant (first axes)
    selector = "figure[id$='-motion'] img"
    box = json.loads(page.evaluate(f"document.querySelector(\"{selector}\").closest('figure')"
                                   ".dataset.xaxes"))[0]
    marked = shot(page, None, selector)
    hide_markers(page, True)
    bare = shot(page, None, selector)
    hide_markers(page, False)
    h, w = bare.shape[:2]
    x0, x1, y0, y1 = (round(box[0] * w), round(box[1] * w), round((1 - box[3]) * h),
                      round((1 - box[2]) * h))

    def axes(img: np.ndarray) -> np.ndarray:
        return img[y0 + 2:y1 - 2, x0 + 2:x1 - 2]

    # the dotted line is thin and the page shows the PNG scaled down: faint red, on every
    # other run of pixels; the column where most pixels are reddish
    reddish = axes(bare)[..., 0] - axes(bare)[..., 1:].max(axis=2) > 30
    counts = reddish.sum(axis=0)
    assert counts.max() > 0.3 * reddish.shape[0]
    red = np.flatnonzero(counts >= 0.5 * counts.max())
    marker = columns(axes(marked), purple)
    assert red.size <= 2 and marker.size
    assert abs(marker.mean() - red.mean()) <= 1.5
    n_axes = page.evaluate("[...document.querySelectorAll('figure[data-xaxes]')]"
                           ".reduce((s, f) => s + JSON.parse(f.dataset.xaxes).length, 0)")
    shown = page.evaluate("[...document.querySelectorAll('.mv3d-tline')]"
                          ".filter(e => e.style.display === 'block').length")
    assert n_axes > 0 and shown == n_axes
    assert page.errors == [] and page.outside_requests == []


# --- the demo's report at 800 and 1400 px --------------------------------------------------------
LAYOUT = """(() => {
  const tables = [...document.querySelectorAll('table')];
  const joints = [...document.querySelectorAll('table.joints')];
  const imgs = [...document.querySelectorAll('figure img')];
  const units = [...document.querySelectorAll('table.joints th .u')];
  const numeric = joints.flatMap(t => [...t.querySelectorAll('td')].map(td => td.textContent))
    .filter(s => /^[-\\d]/.test(s));
  return {
    page: document.documentElement.scrollWidth, inner: window.innerWidth,
    tables: tables.map(t => [t.scrollWidth, t.parentElement.clientWidth]),
    ids: joints.map(t => t.id),
    columns: joints.map(t => t.rows[0].cells.length),
    unitLines: units.map(u => u.getClientRects().length),
    unitTexts: units.map(u => u.textContent),
    numeric: numeric,
    scale: imgs.map(i => i.getBoundingClientRect().width / i.naturalWidth),
    fig3: (document.querySelector("figure[id$='-fig3'] figcaption") || {}).textContent || "",
    verdict: document.querySelector('#verdict').textContent,
    verdictNote: document.querySelector('#verdict-note').textContent,
    firstNote: document.querySelector('#first-note').textContent,
  };
})()"""

@pytest.mark.parametrize("width", [800, 1400])
def test_demo_report_reads_at_800_and_1400_px(demo, width: int) -> None:
    """No sideways scroll of the page or of a table; the per-joint tables split (what the
    program needs, what the robot did, motor torques and bearing loads), at most 10 columns,
    units in the headers only and never split across lines; figures drawn at least at 0.7 of
    their pixels (at 800 px a figure pans inside its own box); Fig. 3's caption; the labels of
    the verdict and of the first infeasible instant; the time marker where the time is."""
    report, _ = demo
    with chromium(width) as b:
        page = open_view(b, f"{report.as_uri()}#t=14.21")
        got = page.evaluate(LAYOUT)
        assert got["inner"] == width
        assert got["page"] <= got["inner"], got["page"]
        for scroll, box in got["tables"]:
            assert scroll <= box, got["tables"]
        assert got["ids"] == ["joints-program", "joints-response", "joints-loads"]
        assert max(got["columns"]) <= 10
        assert got["unitLines"] and set(got["unitLines"]) == {1}
        assert {"[N m]", "[s]", "[N]", "[rad]", "[%]"} <= set(got["unitTexts"])
        for text in got["numeric"]:  # numbers alone: the unit is in the header
            assert re.fullmatch(r"[-\d.,e+]+( / [\d,]+)?", text), text
        assert min(got["scale"]) >= 0.7, got["scale"]
        assert "RNEA" in got["fig3"] and len(got["fig3"]) > 150
        assert "6485\u00a0N\u00a0m, 1.62 \u00d7 its 4000\u00a0N\u00a0m limit" in got["verdict"]
        assert "program's own requirement" in " ".join(got["verdictNote"].split())
        assert "first cycle over a limit" in " ".join(got["firstNote"].split())
        have, want, _ = time_marker(page, "motion")
        assert abs(have - want) <= 2.0, (have, want)
        shot_path = Path(report).with_name(f"report-{width}.png")
        shot_path.write_bytes(page.screenshot(None))
        assert page.errors == [] and page.outside_requests == []


TRACKING = """(() => {
  const fig = document.querySelector("figure[id$='-tracking']"), img = fig.querySelector('img');
  const W = img.clientWidth, H = img.clientHeight, c = document.createElement('canvas');
  c.width = W; c.height = H;
  const g = c.getContext('2d');
  g.drawImage(img, 0, 0, W, H);  // the figure as drawn on the page, at its scale
  const px = g.getImageData(0, 0, W, H).data;
  return JSON.parse(fig.dataset.xaxes).map(([x0, x1, y0, y1]) => {
    const L = Math.round(x0 * W) + 3, R = Math.round(x1 * W) - 3;
    const T = Math.round((1 - y1) * H) + 3, B = Math.round((1 - y0) * H) - 3;
    const line = [], text = [];
    for (let y = T; y < B; y++) {
      let ink = 0, grey = 0;
      for (let x = L; x < R; x++) {
        const k = 4 * (y * W + x), r = px[k], gr = px[k + 1], b = px[k + 2];
        const hi = Math.max(r, gr, b), lo = Math.min(r, gr, b);
        if (lo < 200) ink++;
        // dark grey (the note's 0.35 grey, not the blue error line nor the red marks) in the
        // middle third, where the centred note is
        if (hi - lo < 12 && hi < 150 && x > L + (R - L) / 3 && x < R - (R - L) / 3) grey++;
      }
      if (ink > 0.6 * (R - L)) line.push(y);  // a horizontal line across the axes
      else if (grey >= 2) text.push(y);
    }
    return {line: line, text: text};
  });
})()"""


@pytest.mark.parametrize("width", [800, 1400])
def test_no_tracking_error_note_clears_the_zero_line(demo, width: int) -> None:
    """The tracking-error figure as the page draws it (the PNG painted on a canvas at its drawn
    size, its axes boxes from ``data-xaxes``): in each panel of a joint without tracking error
    (summary.json: max_tracking_error 0) the note "no tracking error" lies wholly above the
    zero line, not across it; the joint with an error has no note."""
    report, summary = demo
    zero = [j["max_tracking_error"] == 0 for j in summary["joints"]]
    assert any(zero) and not all(zero)
    with chromium(width) as b:
        page = open_report(b, report.as_uri())
        panels = page.evaluate(TRACKING)
    assert len(panels) == len(zero)
    for none, p in zip(zero, panels, strict=True):
        assert p["line"], p  # the zero line (and, flat, the error on it)
        if none:
            assert p["text"] and max(p["text"]) < min(p["line"]) - 1, p
        else:
            assert not p["text"], p
