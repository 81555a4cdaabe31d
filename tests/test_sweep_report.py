"""sweep.html and its figures, from the rows of a serial loop (no cluster): what the map and the
curves draw is read back from the figures and checked against the rows, worked out by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import chromium, figure_scales
from matplotlib.patches import Rectangle
from test_cli import EXAMPLES, html_text

from mrnea.errors import StateError
from mrnea.io import load_program
from mrnea.report.sweep import feasibility_map, load_curves, write_sweep_html
from mrnea.robots import puma560
from mrnea.sweep import check_grid, time_scaled, units
from mrnea.sweep.engine import _frame
from mrnea.sweep.rows import run_case

GRID = {"payload": [0.0, 7.5, 15.0], "time_scale": [0.5, 1.0]}


@pytest.fixture(scope="module")
def rows():
    robot, prog = puma560(), load_program(EXAMPLES / "puma_pick.toml")
    keys, cases = check_grid(robot, GRID)
    out = {k: run_case(robot, time_scaled(prog, c["time_scale"]), c)
           for k, c in enumerate(cases)}
    df = _frame(keys, [prog.name], [(k, (0, c["time_scale"]), c)
                                    for k, c in enumerate(cases)], out, False)
    df.attrs["units"] = units(robot, keys)  # as mrnea.sweep sets it
    return df


def test_the_map_draws_each_variant(rows):
    """One cell per variant: its ratio as colour, its limiting joint and ratio as text, hatched
    when not achievable."""
    fig = feasibility_map(rows, "payload", "time_scale")
    ax = fig.axes[0]
    texts = {t.get_position(): t.get_text() for t in ax.texts}
    hatched = {(p.get_x() + 0.5, p.get_y() + 0.5) for p in ax.patches
               if isinstance(p, Rectangle) and p.get_hatch()}
    for _, r in rows.iterrows():
        cell = (GRID["payload"].index(r["payload"]), GRID["time_scale"].index(r["time_scale"]))
        limit = (r["first_infeasible_joint"] if isinstance(r["first_infeasible_joint"], str)
                 else r["worst_joint"])
        assert texts[cell] == f"{limit}\n{r['worst_effort_ratio']:.2f}"
        assert (cell in hatched) is (not r["achievable"])
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("payload [kg]", "time_scale")
    image = ax.images[0].get_array()
    assert image[1, 2] == rows.loc[5, "worst_effort_ratio"]  # y = time_scale 1.0, x = 15 kg


def test_the_curves_are_the_rows_maxima(rows):
    """At the time scale with the most achievable rows, each joint's line is its column."""
    fig = load_curves(rows, "payload")
    best = max(GRID["time_scale"], key=lambda s: int(rows[rows["time_scale"] == s][
        "achievable"].sum()))
    sel = rows[rows["time_scale"] == best]
    for ax, entry in zip(fig.axes, ("program_peak_motor_torque", "peak_reaction_force",
                                    "peak_reaction_moment"), strict=True):
        lines = {ln.get_label(): ln for ln in ax.get_lines()}
        assert len(lines) == 6
        for joint, ln in lines.items():
            assert ln.get_xdata().tolist() == GRID["payload"]
            assert ln.get_ydata().tolist() == sel[f"{entry}.{joint}"].tolist()
    assert f"time_scale = {best}" in fig._suptitle.get_text()


def test_the_page(rows, tmp_path):
    page = write_sweep_html(rows, tmp_path / "s.html", "puma560")
    assert page.read_text().count("data:image/png;base64,") == 2
    text = html_text(page)
    assert "6 rows (1 program(s))" in text and "Design sweep: puma560" in text
    # rows that do not vary time_scale (an interrupted sweep): no map, said so; the curves
    part = rows.iloc[[0, 2]].copy()
    part.attrs.update(completed=False, cases=6)
    page = write_sweep_html(part, tmp_path / "p.html", "puma560", list(GRID),
                            map_axes=("payload", "time_scale"))
    assert page.read_text().count("data:image/png;base64,") == 1
    text = html_text(page)
    assert "INTERRUPTED: 2 of 6 done" in text
    assert "Feasibility map over payload, time_scale: not drawn" in text


@pytest.mark.parametrize("kw, match", [
    ({"map_axes": ("payload", "speed")}, "map_axes"),
    ({"curves": "speed"}, "curves"),
    ({"keys": ["payload", "speed"]}, "keys: 'speed' is not a column"),
])
def test_bad_page_arguments(rows, tmp_path, kw, match):
    with pytest.raises(StateError, match=match):
        write_sweep_html(rows, tmp_path / "s.html", "puma560", **kw)
    assert not (tmp_path / "s.html").exists()


def test_a_parameter_that_does_not_vary_cannot_be_an_axis(rows):
    one = rows[rows["time_scale"] == 1.0]
    with pytest.raises(StateError, match="y: 'time_scale' is not a swept numeric parameter"):
        feasibility_map(one, "payload", "time_scale")
    assert math.isfinite(float(np.nanmax(rows["worst_effort_ratio"])))


@pytest.mark.parametrize("width", [800, 1400])
def test_the_page_reads_at_800_and_1400_px(rows, tmp_path, width):
    """Headless Chromium: no sideways scroll of the page or of the rows' table box; both
    figures drawn at least at 0.7 of their pixels, and below 960 px at their own size (panning
    in their own box, as the reports' figures do: scaled to 800 px their text was
    unreadable)."""
    path = write_sweep_html(rows, tmp_path / "s.html", "puma560")
    with chromium(width) as b:
        page = b.open(path.as_uri())
        scales = figure_scales(page)
        got = page.evaluate("""(() => ({inner: innerWidth,
          page: document.documentElement.scrollWidth,
          boxes: [...document.querySelectorAll('.figscroll')].map(
            d => d.getBoundingClientRect().right)}))()""")
        assert not page.errors and not page.outside_requests
    assert got["page"] <= got["inner"] == width
    assert len(got["boxes"]) == 2 and max(got["boxes"]) <= width
    assert len(scales) == 2 and min(scales) >= (0.999 if width < 960 else 0.7), scales
