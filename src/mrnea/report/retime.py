"""The report of a retiming (:func:`mrnea.retime`): the phase plane, the effort ratio of every
joint before and after, and the verdict, in one self-contained HTML page.

* :func:`retime_figures` -- ``"phase_plane"`` (path speed against path position, with the limit
  curve: the classic picture of time-optimal path parameterisation) and ``"effort_ratio"``
  (per joint, the program's own requirement over its limit, before and after).
* :func:`write_retime_report` -- the page: verdict first, the 3D view of the retimed motion
  (optional), the durations, the per-joint table, the figures, the verification and the run's
  parameters; figures as PNG data URIs, no external resource (the 3D view's script is in the
  page; without it, no JavaScript).
"""

from __future__ import annotations

import os
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from mrnea import validate
from mrnea.describe import describe
from mrnea.errors import OutputError, StateError
from mrnea.io.source import as_path
from mrnea.io.writer import check_new, write_file
from mrnea.report.drawing import (
    DPI,
    MAX_JOINTS,
    axes_grid,
    fit_ylim,
    fmt_number,
    header,
    label,
    new_figure,
    plot_line,
    png_data_uri,
)
from mrnea.report.html import _e, _kv_table, _row, page, stamp
from mrnea.report.pngs import draw_pngs
from mrnea.report.view3d import result_scene
from mrnea.report.view3d_html import figure_axes, license_html, scene_html

if TYPE_CHECKING:
    from mrnea.retime import RetimeResult

RETIME_FIGURES = ("phase_plane", "effort_ratio")
"""The names of :func:`retime_figures`' figures."""

_C_LIM, _C_NEW, _C_OLD, _C_DWELL = "C3", "C0", "0.45", "0.85"
REST_FRACTION = 0.01  # the phase plane leaves out grid points where no joint moves faster than
#                       this fraction of the piece's fastest |dq/ds| (the path at rest)
_CAPTIONS = {
    "phase_plane": "Path speed ds/dt against the path position s (the program's own clock, so "
                   "ds/dt = 1 is the program's timing). Red: the limit curve, the largest path "
                   "speed at which some path acceleration keeps every joint within its effort "
                   "limit at that speed and its velocity limit (the true model: rotor inertia, "
                   "viscous and Coulomb friction, torque-speed curves, the wrench); blue: the "
                   "retimed program; grey bands: dwells, kept as holds of the same duration. "
                   "Where the path is at rest (the ends of a move, via points) no joint moves, "
                   "the limit curve is unbounded and the path speed means nothing: neither is "
                   "drawn there. "
                   "The retimed speed stays below the curve where a joint needs its whole "
                   "effort to keep accelerating or to brake in time for what follows, and "
                   "touches it where the speed itself is the limit.",
    "effort_ratio": "Per joint, the effort the program's own commanded motion requires over "
                    "the effort limit at the commanded speed: the program as given (grey, "
                    "dashed) and retimed (blue), each on its own clock; above 1 the program is "
                    "not achievable.",
}


def _phase_figure(res: RetimeResult) -> Figure:
    fig = new_figure(13.0, 4.6)
    ax = fig.add_axes((0.07, 0.13, 0.91, 0.68))
    sd_all = np.concatenate([p.sd for p in res.phase])
    top = max(1.5, 3.0 * float(np.percentile(sd_all, 90)))
    end = 0.0
    for p in res.phase:
        x = p.t0 + p.s
        if p.t0 > end:  # a dwell before this piece
            ax.axvspan(end, p.t0, color=_C_DWELL, alpha=0.5, lw=0)
        end = float(x[-1])
        # where the path is at rest (a piece's ends, via points) no joint moves: the limit curve
        # is unbounded there and the path speed means nothing, so neither is drawn (drawn, both
        # were vertical spikes to the top of the axis at every dwell boundary: issue 22)
        speed = np.max(np.abs(p.coefficients.qs), axis=1)
        still = speed < REST_FRACTION * speed.max()
        for y, color in ((p.limit_curve(), _C_LIM), (p.sd, _C_NEW)):
            ax.plot(x, np.where(still, np.nan, np.minimum(y, top * 1.05)), color=color, lw=1.2)
    if res.original_duration > end:
        ax.axvspan(end, res.original_duration, color=_C_DWELL, alpha=0.5, lw=0)
    ax.axhline(1.0, color="k", lw=0.8, ls=":")
    ax.set_xlim(0.0, res.original_duration)
    ax.set_ylim(0.0, top)
    ax.set_xlabel("path position s [s on the program's clock]")
    ax.set_ylabel("path speed ds/dt")
    ax.grid(True, alpha=0.3)
    how = (f"TOPP-RA, planning margin {res.margin:.3g}" if res.method == "toppra"
           else f"uniform scaling, factor {res.factor:.4g}")
    header(fig, f"{label(res.robot.name)}: phase plane ({how}): {fmt_number(res.duration)} s "
                f"instead of {fmt_number(res.original_duration)} s", [
        Line2D([], [], color=_C_LIM, label="limit curve (true limits)"),
        Line2D([], [], color=_C_NEW, label=f"retimed ({res.method})"),
        Line2D([], [], color="k", ls=":", label="the program's timing (ds/dt = 1)"),
        Patch(color=_C_DWELL, alpha=0.5, label="dwell"),
    ])
    return fig


def _ratio_figure(res: RetimeResult) -> Figure:
    t0, before, t1, after = res.effort_ratios()
    n = res.robot.n
    worst = np.nan_to_num(np.maximum(before.max(axis=0), after.max(axis=0)),
                          posinf=np.finfo(float).max)
    shown = sorted(sorted(range(n), key=lambda i: (-worst[i], i))[:MAX_JOINTS])
    fig, axs = axes_grid(len(shown), 1, 13.0, 1.5, top=0.95 if len(shown) == n else 1.2)
    axs = axs[:, 0]
    for ax, i in zip(axs, shown, strict=True):
        j = res.robot.joints[i]
        b, a = np.where(np.isfinite(before[:, i]), before[:, i], np.nan), after[:, i]
        plot_line(ax, t0, b, color=_C_OLD, lw=1.0, ls="--")
        plot_line(ax, t1, np.where(np.isfinite(a), a, np.nan), color=_C_NEW, lw=1.2)
        ax.axhline(1.0, color=_C_LIM, lw=0.9)
        fit_ylim(ax, [a[np.isfinite(a)], np.ones(1)], [("before", b[np.isfinite(b)])])
        ax.set_ylim(bottom=0.0)
        ax.set_title(f"{label(j.name)}: peak {fmt_number(float(np.nanmax(b)))} before, "
                     f"{fmt_number(float(np.nanmax(a)))} after", fontsize="medium", loc="left")
        ax.set_ylabel("|τ| / limit")
        ax.grid(True, alpha=0.3)
    axs[-1].set_xlabel("time t [s] (each program on its own clock)")
    cut = (f"\n{len(shown)} of {n} joints: those closest to or over their limits; every joint "
           "is in the report's table" if len(shown) < n else "")
    header(fig, f"{label(res.robot.name)}: effort the program requires over the limit at its "
                f"speed{cut}", [
        Line2D([], [], color=_C_OLD, ls="--",
               label=f"program as given ({fmt_number(res.original_duration)} s)"),
        Line2D([], [], color=_C_NEW, label=f"retimed ({fmt_number(res.duration)} s)"),
        Line2D([], [], color=_C_LIM, label="limit"),
    ])
    return fig


def retime_figures(result: RetimeResult) -> dict[str, Figure]:
    """The figures of a retiming (:data:`RETIME_FIGURES`, module docstring)."""
    return {"phase_plane": _phase_figure(result), "effort_ratio": _ratio_figure(result)}


def _numbers(res: RetimeResult) -> list[tuple[str, str]]:
    s = res.summary()
    # a program of M rows lasts (M - 1) dt from its first row to its last (issue 22)
    rows = [("program", f"{fmt_number(res.original_duration)} s from its first row to its last "
                        f"({res.original_q_cmd.shape[0]:,} rows at {res.original_dt:g} s)"),
            ("retimed", f"{fmt_number(res.duration)} s from its first row to its last "
                        f"({res.t.size:,} rows at {res.dt:g} s; the simulation runs one cycle "
                        f"per row, {fmt_number(res.t.size * res.dt)} s)"),
            ("speed-up", f"{s['speedup']:.3g} x" if s["speedup"] else "-"),
            ("method", "toppra: TOPP-RA along the path, held at every cycle"
             if res.method == "toppra"
             else "scale: uniform time scaling (Hollerbach), bisected on the simulation")]
    if res.method == "toppra":
        rows += [("planning margin", f"{res.margin:.4g} (asked {s['margin_asked']:.4g}; margins "
                                     "tried: "
                                     f"{', '.join(f'{m:.4g}' for m in s['margins_tried'])})"),
                 ("TOPP-RA solves", str(s["toppra_solves"]))]
    else:
        rows += [("time factor", f"{res.factor:.6g} (Hollerbach's closed-form estimate "
                                 f"{res.estimate:.6g})"),
                 ("largest fraction of a limit used", f"{res.margin:.4g}")]
    rows += [("moving pieces / dwells", f"{s['moving_pieces']} / {s['dwells']}"),
             ("simulation mode", res.mode),
             ("verification", res.simulation.verdict())]
    return rows


def _joints_table(res: RetimeResult) -> str:
    head = ["joint", "peak |τ| / limit before", "at t [s]", "peak |τ| / limit after",
            "at t [s]"]
    rows = [_row([_e(h) for h in head], head=True)]
    for jd in res.summary()["joints"]:
        rb, ra = jd["peak_effort_ratio_before"], jd["peak_effort_ratio_after"]
        cells = [jd["joint"], "∞" if rb is None else f"{rb:.3g}",
                 fmt_number(jd["peak_effort_ratio_before_time"]),
                 "∞" if ra is None else f"{ra:.3g}",
                 fmt_number(jd["peak_effort_ratio_after_time"])]
        rows.append(_row([_e(c) for c in cells],
                         cls="sat" if rb is None or rb > 1 else ""))
    return f'<div class="scroll"><table>{"".join(rows)}</table></div>'


def write_retime_report(result: RetimeResult, path: str | os.PathLike[str],
                        overwrite: bool = False, files: Mapping[str, Any] | None = None,
                        view3d: bool = True) -> Path:
    """Write one self-contained HTML page of a retiming.

    Contents, top to bottom: the verdict (:meth:`RetimeResult.verdict`, green when the
    verification accepts the retimed program); with ``view3d``, the interactive 3D view of the
    retimed motion as the verification simulated it (:mod:`mrnea.report.view3d_html`; its slider
    marks the retimed clock on the effort-ratio figure); the durations, method, margin or factor
    and the verification; per joint, the peak of the program's requirement over its limit before
    and after; the figures of :func:`retime_figures`; ``files`` (name -> path, e.g. the retimed
    program's) and the robot model.

    Raises
    ------
    OutputError
        If ``path`` exists and ``overwrite`` is False (checked before any work), is a directory,
        or cannot be written (:func:`mrnea.io.writer.write_file`: whole or not at all).
    """
    # the report imports nothing above it (docs/design.md): a RetimeResult exists only once
    # its module is loaded, so the class is looked up among the loaded modules
    module = sys.modules.get("mrnea.retime.result")
    if module is None or not isinstance(result, module.RetimeResult):
        raise StateError(f"result: expected a RetimeResult (mrnea.retime's), got "
                         f"{type(result).__name__}")
    path = as_path(path, "path", OutputError)
    if files is not None and not isinstance(files, Mapping):
        raise StateError(f"files: expected a mapping of names to paths, got "
                         f"{type(files).__name__}")
    view3d = validate.flag(view3d, "view3d")
    check_new([path], overwrite)
    cls = "ok" if result.achievable else "bad"
    figs = []
    drawn = retime_figures(result)  # fixed layouts: figure_axes needs no drawing here
    for k, ((name, fig), png) in enumerate(zip(drawn.items(), draw_pngs(
            [(fig, DPI) for fig in drawn.values()]), strict=True)):
        uri = png_data_uri(png)
        axes = (f" data-xaxes='{figure_axes(fig)}'" if view3d and name == "effort_ratio"
                else "")
        # below 960 px a figure keeps a readable size and pans inside its own box (.figscroll,
        # as the simulation report's; scaled to the page, its text was unreadable at 800 px)
        figs.append(f'<figure id="fig{k + 1}-{name}"{axes}><div class="figscroll">'
                    f'<img alt="{name}" src="{uri}"></div>'
                    f"<figcaption><b>{name.replace('_', ' ')}</b>: {_e(_CAPTIONS[name])}"
                    "</figcaption></figure>")
    view_html = (f"<h2>3D view (retimed)</h2>\n{scene_html(result_scene(result.simulation))}"
                 if view3d else "")
    listing = _kv_table([(k, str(v)) for k, v in (files or {}).items()]) if files else ""
    body = f"""\
<p class="note">The same path, the fastest timing the robot can make. Generated {_e(stamp())} by
mrnea.</p>
<div class="verdict {cls}" id="verdict">{_e(result.verdict())}</div>
{view_html}
<h2>Durations</h2>
{_kv_table(_numbers(result))}
<h2>Per joint</h2>
{_joints_table(result)}
<p class="note">|τ| / limit: the effort the commanded motion requires (the actuator model:
rotor inertia, friction, the wrench) over the effort limit at the commanded speed, its peak over
the program; rows in red: over the limit before retiming.</p>
<h2>Figures</h2>
{"".join(figs)}
{"<h2>Files</h2>" + listing if listing else ""}
<details><summary>Robot model</summary><pre>{_e(describe(result.robot, width=120))}</pre></details>
{license_html() if view3d else ""}"""
    name = result.robot.name
    return write_file(path, page(f"mrnea retiming report: {name}", f"Retiming report: {name}",
                                 body), overwrite)
