"""One self-contained HTML report of a simulation run: verdict first, then the 3D view of the
motion (:mod:`mrnea.report.view3d_html`, optional), the first infeasible instant, the per-joint
table, the run parameters and the figures, embedded as PNG data URIs. No external resource: the
view's scripts and data are inline, and the page works from ``file://``."""

from __future__ import annotations

import html
import math
import os
import re
from collections.abc import Mapping, Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.figure import Figure

from mrnea.describe import describe
from mrnea.errors import OutputError, StateError
from mrnea.io.pathcsv import INTERPOLATIONS
from mrnea.io.source import as_path
from mrnea.io.writer import check_new, write_file
from mrnea.report.drawing import MAX_POINTS, fmt_number, joint_units, png_data_uri
from mrnea.report.figures import plot_result, require_result
from mrnea.report.view3d import result_scene
from mrnea.report.view3d_html import decimals, figure_axes, license_html, scene_html
from mrnea.summary import TIMES
from mrnea.validate import choice

if TYPE_CHECKING:
    from mrnea.simulate import SimulationResult

_CSS = """
body { font-family: -apple-system, "Segoe UI", Helvetica, Arial, sans-serif; margin: 0 auto;
       max-width: 1400px; padding: 1em 2em; color: #222; background: #fff; }
h1 { font-size: 1.4em; margin-bottom: 0.2em; }
h2 { font-size: 1.15em; border-bottom: 1px solid #ccc; padding-bottom: 0.2em; margin-top: 1.6em; }
.verdict { font-size: 1.5em; font-weight: bold; padding: 0.8em 1em; border-radius: 6px;
           color: #fff; margin: 0.6em 0 1em 0; line-height: 1.35; }
.ok { background: #1b7f3b; }
.bad { background: #b3261e; }
.partial { background: #a15c00; }
table { border-collapse: collapse; font-size: 0.9em; margin: 0.4em 0; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: right; }
th { background: #f0f0f0; text-align: center; }
td.l, th.l { text-align: left; }
tr.sat td { background: #fdecea; }
.scroll { overflow-x: auto; }
.note { color: #555; font-size: 0.88em; }
figure { margin: 1em 0 2em 0; }
figure img { max-width: 100%; height: auto; border: 1px solid #ddd; }
figcaption { font-size: 0.9em; color: #444; margin-top: 0.3em; }
pre { background: #f7f7f7; padding: 0.6em; overflow-x: auto; font-size: 0.85em; }
"""

_CAPTIONS = {
    "motion": "Programmed (dashed) vs achieved (solid) position, velocity and acceleration per "
              "joint; shaded: command clamped to a joint limit; dotted red: first infeasible "
              "instant.",
    "efforts": "The program's own requirement (dashed: the commanded motion with the full "
               "actuator model, before any lag), ± the effort limit and the effort the drives "
               "applied; shaded: saturated. Right-hand axis: motor side (τ/G).",
    "reactions": "Reaction force and moment each joint transmits (magnitude, axial part, "
                 "radial force / bending moment), in the joint frame.",
    "tracking": "Tracking error q_cmd - q per joint; shaded: effort saturated.",
}


def _e(x: object) -> str:
    return html.escape(str(x), quote=True)


def _row(cells: Sequence[str], cls: str = "", head: bool = False) -> str:
    tag = "th" if head else "td"
    attr = f' class="{cls}"' if cls else ""
    body = "".join(f'<{tag} class="l">{c}</{tag}>' if k == 0 else f"<{tag}>{c}</{tag}>"
                   for k, c in enumerate(cells))
    return f"<tr{attr}>{body}</tr>"


class _Html(str):
    """Text that is HTML already: :func:`_kv_table` does not escape it again."""


def _kv_table(rows: Sequence[tuple[str, str]]) -> str:
    body = "".join(f'<tr><th class="l">{_e(k)}</th><td class="l">'
                   f'{v if isinstance(v, _Html) else _e(v)}</td></tr>' for k, v in rows)
    return f"<table>{body}</table>"


def _time(t: float, dt: float) -> str:
    """``t`` with as many decimals as the cycle ``dt`` needs (at least 3)."""
    return f"{t:.{decimals(dt)}f}"


def _instant(t: float, dt: float, link: bool) -> _Html:
    """The time ``t`` [s] as text, with ``link`` a link that shows it in the 3D view."""
    text = _time(t, dt)
    return _Html(f'<a href="#t={text}" title="show this instant in the 3D view">{text}</a>'
                 if link else text)


def _first_infeasible_html(result: SimulationResult, link: bool) -> str:
    fi = result.summary()["first_infeasible"]
    if fi is None and not result.completed:
        return (f"<p>None in the {result.K:,} cycles done before the run was interrupted: "
                "whether the rest of the program is achievable is unknown.</p>")
    if fi is None:
        return "<p>None: every cycle stays within the effort, position and velocity limits.</p>"
    k, i = fi["cycle"], result.robot.joint_names.index(fi["joint"])
    u, j = joint_units(result.robot)[i], result.robot.joints[i]
    if "value" in fi:  # the start state is outside the joint's limits
        lo, hi = (fmt_number(x) if x is not None else "∞" for x in fi["limits"])
        return _kv_table([("time", "0 s (the start)"), ("joint", fi["joint"]),
                          ("reason", fi["reason"]), ("value", fmt_number(fi["value"])),
                          ("limits", f"[{lo}, {hi}]")])
    req, avail = fi["required_effort"], fi["available_effort"]
    avail = math.inf if avail is None else avail  # null: unlimited
    ratio = abs(req) / avail if avail > 0 and math.isfinite(avail) else math.inf
    rows = [
        ("time", _Html(f"{_instant(fi['time'], result.dt, link)} s (cycle {k:,})")),
        ("joint", fi["joint"]),
        ("reason", fi["reason"]),
        ("required effort", f"{fmt_number(req)} {u['tau']}"),
        ("available effort (limit at that speed)", f"{fmt_number(avail)} {u['tau']}"),
        ("required / available", f"{ratio:.3g}" if math.isfinite(ratio) else "∞"),
    ]
    nxt = min(k + 1, result.K - 1)  # cycle k heads for the command of row k + 1
    if result.position_clamped[k, i]:
        rows.append((f"commanded position at t = {_time(float(result.t[nxt]), result.dt)} s",
                     f"{fmt_number(float(result.q_cmd[nxt, i]))} {u['q']}; joint range "
                     f"[{fmt_number(j.lower)}, {fmt_number(j.upper)}] {u['q']}"))
    if result.velocity_clamped[k, i] and nxt > k:
        rows.append((f"programmed velocity up to t = {_time(float(result.t[nxt]), result.dt)} s",
                     f"{fmt_number(float(result.qd_cmd[nxt, i]))} {u['qd']}; limit "
                     f"±{fmt_number(j.velocity_limit)} {u['qd']}"))
    return _kv_table(rows)


def _joints_html(result: SimulationResult, link: bool) -> str:
    if result.K == 0:
        return "<p>No cycle was completed.</p>"
    s = result.summary()
    units = joint_units(result.robot)
    with np.errstate(divide="ignore", invalid="ignore"):
        use = np.where(result.limit > 0, np.abs(result.tau) / result.limit, 0.0)
    use = np.nan_to_num(use, nan=0.0, posinf=0.0)
    head = ["joint", "type", "time saturated [s]", "saturated cycles",
            "clamped cycles (pos / vel)", "program's peak effort", "peak motor torque",
            "RMS motor torque", "peak effort / rated limit", "peak |τ| / limit at speed",
            "peak reaction force [N]",
            "peak axial force [N]", "peak radial force [N]", "peak reaction moment [N m]",
            "peak bending moment [N m]", "max tracking error", "at t [s]"]
    rows = [_row([_e(h) for h in head], head=True)]
    for i, (jd, j, u) in enumerate(zip(s["joints"], result.robot.joints, units, strict=True)):
        nsat = int(result.saturated[:, i].sum())
        npos = int(result.position_clamped[:, i].sum())
        nvel = int(result.velocity_clamped[:, i].sum())
        lim = math.inf if jd["effort_limit"] is None else jd["effort_limit"]  # null: unlimited
        pct = f" ({100 * jd['peak_effort'] / lim:.0f} %)" if 0 < lim < math.inf else ""
        ratio = jd["program_effort_ratio"]
        need = f"{fmt_number(jd['program_peak_effort'])} {u['tau']}" + (
            f" ({ratio:.2f} {TIMES} limit)" if ratio is not None else f" ({jd['drive']})")
        cells = [
            jd["joint"], j.type, fmt_number(jd["time_saturated"]), f"{nsat:,}",
            f"{npos:,} / {nvel:,}", need,
            f"{fmt_number(jd['peak_motor_torque'])} {u['motor']}",
            f"{fmt_number(jd['rms_motor_torque'])} {u['motor']}",
            f"{fmt_number(jd['peak_effort'])} / {fmt_number(lim)} {u['tau']}{pct}",
            f"{100 * float(use[:, i].max()) if use.size else 0.0:.1f} %",
            fmt_number(jd["peak_reaction_force"]), fmt_number(jd["peak_axial_force"]),
            fmt_number(jd["peak_radial_force"]), fmt_number(jd["peak_reaction_moment"]),
            fmt_number(jd["peak_bending_moment"]),
            f"{fmt_number(jd['max_tracking_error'])} {u['q']}",
            _instant(jd["max_tracking_error_time"], result.dt, link),
        ]
        bad = nsat or npos or nvel
        rows.append(_row([c if isinstance(c, _Html) else _e(c) for c in cells],
                         cls="sat" if bad else ""))
    return f'<div class="scroll"><table>{"".join(rows)}</table></div>' + _tool_html(result, link)


def _tool_html(result: SimulationResult, link: bool) -> str:
    """A Cartesian program's tool errors (the real motion against the programmed pose): the
    peaks, in mm and mrad, and when; nothing for a joint program."""
    s = result.summary()
    if "max_tool_position_error" not in s:
        return ""
    cells = [_e("tool (Cartesian program)"),
             _e(f"max position error {fmt_number(s['max_tool_position_error'] * 1e3)} mm"),
             _instant(s["max_tool_position_error_time"], result.dt, link),
             _e(f"max orientation error {fmt_number(s['max_tool_orientation_error'] * 1e3)} "
                f"mrad"),
             _instant(s["max_tool_orientation_error_time"], result.dt, link)]
    head = ["tool path", "position", "at t [s]", "orientation", "at t [s]"]
    return (f'<table class="tool">{_row([_e(h) for h in head], head=True)}'
            f"{_row(cells)}</table>")


def _params_html(result: SimulationResult, interpolation: str | None) -> str:
    s = result.summary()
    from mrnea import __version__

    path = ([("CSV path resampled by", f"{interpolation}: {INTERPOLATIONS[interpolation]}")]
            if interpolation else [])
    return _kv_table([
        ("robot", result.robot.name),
        ("degrees of freedom n", str(result.robot.n)),
        ("joints", ", ".join(result.robot.joint_names)),
        ("interpolation cycle dt", f"{result.dt:.6g} s"),
        *path,
        ("cycles", f"{result.K:,}"),
        ("duration", f"{s['duration']:.6g} s"),
        ("saturation mode", result.mode),
        ("forward-dynamics engine", result.fd),
        ("run", "completed" if result.completed
         else f"INTERRUPTED after {result.K:,} cycles: partial result"),
        ("mrnea version", __version__),
    ])


def stamp() -> str:
    """The time a page is generated, UTC, to the second."""
    return datetime.now(UTC).strftime("%Y-%m-%d %H:%M:%S UTC")


def page(title: str, heading: str, body: str, css: str = _CSS) -> str:
    """One self-contained HTML page of the reports (simulation, retiming, sweep): the document
    head with the style sheet ``css`` (the simulation report's by default), ``title`` and the
    ``<h1>`` ``heading`` (both text, escaped here), then ``body`` (HTML)."""
    return f"""<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{_e(title)}</title>
<style>{css}</style>
</head>
<body>
<h1>{_e(heading)}</h1>
{body}
</body>
</html>
"""


def write_report(
    result: SimulationResult,
    path: str | os.PathLike[str],
    overwrite: bool = False,
    extra_figures: Mapping[str, Figure] | None = None,
    interpolation: str | None = None,
    view3d: bool = True,
) -> Path:
    """Write one self-contained HTML report of a simulation run.

    Contents, top to bottom: the verdict (:meth:`SimulationResult.verdict`), large, green when
    achievable, red when not, amber for an interrupted run that exceeded no limit so far; the 3D
    view of the motion (``view3d``); the first infeasible instant (time, joint, reason, required
    vs available effort); the per-joint table
    of :meth:`SimulationResult.summary` (time saturated, peak and RMS motor torque, peak effort
    vs limit, peak reaction force with its axial and radial parts, peak moment and bending
    moment, worst tracking error and when); the run parameters; the figures of
    :func:`plot_result` and then ``extra_figures``. Figures are embedded as base64 PNG data URIs
    and the style sheet is inline: the file needs no network and no other file.

    Parameters
    ----------
    result : SimulationResult
    path : str or path-like
        The HTML file to write. Its folder is created if missing.
    overwrite : bool, default False
        Replace an existing file (or a symbolic link: the link itself, never its target).
        Without it anything at ``path`` is left untouched and OutputError is raised.
    extra_figures : mapping of str to matplotlib.figure.Figure, optional
        More figures to append, e.g. ``{"Fig. 3": fig3(robot, t, q, qd, qdd)}``.
    interpolation : str, optional
        How the program's CSV path was resampled to dt (:attr:`mrnea.io.Program.interpolation`,
        a name of :data:`mrnea.io.pathcsv.INTERPOLATIONS`): the run parameters say it.
    view3d : bool, default True
        Put the interactive 3D view of the motion under the verdict
        (:mod:`mrnea.report.view3d_html`: the robot as it moves and, translucent, as the program
        commands it, on a time slider that is the cycle clock; ``report.html#t=SECONDS`` opens
        it at that instant). It needs a browser with WebGL 2 and adds about 0.6-1 MB (three.js
        and the frames, inline). The times in the tables then link to their instant and the
        figures mark the slider's time. False: no script in the page. A run without any cycle
        gets no view.

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    OutputError
        If ``path`` exists and ``overwrite`` is False, or is a directory (checked before any
        work is done), or cannot be written. The file is written through
        :func:`mrnea.io.writer.write_file`: whole or not at all.
    """
    require_result(result)
    path = as_path(path, "path", OutputError)
    if extra_figures is not None and not (
            isinstance(extra_figures, Mapping)
            and all(isinstance(f, Figure) for f in extra_figures.values())):
        raise StateError("extra_figures: expected a mapping of names to matplotlib Figures, got "
                         f"{type(extra_figures).__name__}")
    check_new([path], overwrite)  # before any rendering
    if interpolation is not None:
        choice("interpolation", interpolation, INTERPOLATIONS)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"{path.parent}: cannot create the folder: {exc.strerror}") from None
    s = result.summary()
    verdict = result.verdict()
    cls = {True: "ok", False: "bad", None: "partial"}[s["achievable"]]

    view3d = view3d and result.K > 0
    figures = list(plot_result(result).items())
    if extra_figures:
        figures += list(extra_figures.items())
    fig_html = []
    for k, (name, fig) in enumerate(figures):
        caption = f": {_e(_CAPTIONS[name])}" if name in _CAPTIONS else ""
        slug = re.sub(r"[^A-Za-z0-9_-]+", "-", str(name)).strip("-")
        uri = png_data_uri(fig)  # the figure drawn as saved: figure_axes reads that layout
        axes = f" data-xaxes='{figure_axes(fig)}'" if view3d else ""
        fig_html.append(
            f'<figure id="fig{k + 1}-{slug}"{axes}><img alt="{_e(name)}" src="{uri}">'
            f"<figcaption><b>{_e(name)}</b>{caption}</figcaption></figure>")
    view_html = (f"<h2>3D view</h2>\n{scene_html(result_scene(result))}" if view3d else "")

    body = f"""\
<p class="note">Will the robot make the programmed motion? Generated {_e(stamp())} by mrnea.</p>
<div class="verdict {cls}" id="verdict">{_e(verdict)}</div>
{view_html}
<h2>First infeasible instant</h2>
{_first_infeasible_html(result, view3d)}
<h2>Per joint</h2>
{_joints_html(result, view3d)}
<p class="note">Efforts are joint side (N m for revolute, N for prismatic joints); motor torque
is τ/G. Reaction loads are in each joint's frame: axial along the joint axis, radial / bending
across it. Rows in red: the joint saturated or its command was clamped.</p>
<h2>Run parameters</h2>
{_params_html(result, interpolation)}
<details><summary>Robot model</summary><pre>{_e(describe(result.robot, width=120))}</pre></details>
<h2>Figures</h2>
<p class="note">Series longer than {MAX_POINTS:,} samples are drawn as min/max envelopes;
peaks are exact.</p>
{"".join(fig_html)}
{license_html() if view3d else ""}"""
    name = result.robot.name
    return write_file(path, page(f"mrnea simulation report: {name}", f"Simulation report: {name}",
                                 body), overwrite)
