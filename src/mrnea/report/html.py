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

from mrnea.describe import branches, describe
from mrnea.errors import OutputError, StateError
from mrnea.io.pathcsv import INTERPOLATIONS
from mrnea.io.source import as_path
from mrnea.io.writer import check_new, write_file
from mrnea.report import FIGURES
from mrnea.report.drawing import DPI, MAX_POINTS, fmt_number, joint_units, png_data_uri
from mrnea.report.figures import plot_result, require_result
from mrnea.report.pngs import draw_pngs
from mrnea.report.view3d import result_scene
from mrnea.report.view3d_html import decimals, figure_axes, license_html, scene_html
from mrnea.validate import choice, flag

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
td { white-space: nowrap; }
th .u { white-space: nowrap; }
h3 { font-size: 1em; margin: 1.2em 0 0.3em 0; }
th { background: #f0f0f0; text-align: center; }
td.l, th.l { text-align: left; }
tr.sat td { background: #fdecea; }
tr.branch th { background: #e4ebf3; text-align: left; font-weight: normal; }
table.kv td { white-space: normal; }
.scroll { overflow-x: auto; }
.note { color: #555; font-size: 0.88em; }
figure { margin: 1em 0 2em 0; }
figure img { max-width: 100%; height: auto; border: 1px solid #ddd; }
figcaption { font-size: 0.9em; color: #444; margin-top: 0.3em; }
@media (max-width: 960px) {
  body { padding: 0.6em 0.8em; }
  th, td { padding: 0.2em 0.35em; }
  .figscroll { overflow-x: auto; }
  .figscroll img { max-width: none; width: 1040px; }
  .figscroll .mv3d-figwrap { max-width: none; }
}
pre { background: #f7f7f7; padding: 0.6em; overflow-x: auto; font-size: 0.85em; }
"""

# Below 960 px a figure of the sweep, sizing and identification pages keeps its own pixels and
# pans inside its own box (``<figure><div class="figscroll"><img ...>``), as the reports' do
# (their _CSS above, at a fixed 1040 px for their 13-inch figures); scaled to an 800 px page the
# figures' text was unreadable.
FIGSCROLL_CSS = ("@media (max-width:960px){.figscroll{overflow-x:auto}"
                 ".figscroll img{max-width:none;width:auto}}")

_CAPTIONS = {
    "motion": "Programmed (dashed) vs achieved (solid) position, velocity and acceleration per "
              "joint; shaded: command clamped to a joint limit; dotted red: first infeasible "
              "instant.",
    "efforts": "The program's own requirement (dashed: the commanded motion with the full "
               "actuator model, before any lag), ± the effort limit and the effort the drives "
               "applied; shaded: saturated. Right-hand axis: motor side (τ/G).",
    "reactions": "Reaction force and moment each joint transmits (magnitude, axial part, "
                 "radial force / bending moment), in the joint frame.",
    "tracking": "Tracking error q_cmd - q per joint; shaded: effort saturated. A joint whose "
                "error stays 0 (below the resolution the cycle resolves) says \u201cno tracking "
                "error\u201d.",
    "fig3": "The paper's Fig. 3 along the simulated motion: (a) each joint's torque by the RNEA "
            "(lines) and by the mRNEA, H q\u0308 + u\u2032 from one pass (markers); (b) the "
            "accelerations of the motion (lines) and those forward dynamics (Eq. 2 solved with the "
            "mRNEA's H and u\u2032) recovers from the RNEA torques (markers). The titles give the "
            "largest differences: rounding, so the two algorithms agree.",
}


def _e(x: object) -> str:
    return html.escape(str(x), quote=True)


NBSP = "\u00a0"
_QUANTITY = re.compile(r"(\d) (N m|N|rad/s|rad|m/s|m|s|%)(?![\w/])")


def nobreak(text: str) -> str:
    """``text`` with each number bound to its unit by no-break spaces (``4000\u00a0N\u00a0m``),
    so that a line never breaks between them or inside ``N m``."""
    return _QUANTITY.sub(lambda m: m[1] + NBSP + m[2].replace(" ", NBSP), text)


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
    return f'<table class="kv">{body}</table>'


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
    if fi is None and result.runaway_time is not None:
        return (f"<p>None in the {result.K:,} cycles before the robot ran away at t = "
                f"{result.runaway_time:.6g} s.</p>")
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
        ("required effort (this cycle, from the robot's own state)",
         f"{fmt_number(req)} {u['tau']}"),
        ("available effort (limit at the robot's speed)", f"{fmt_number(avail)} {u['tau']}"),
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


def _unit(units: Sequence[dict[str, str]], key: str) -> str:
    """The unit of quantity ``key`` over every joint, for a column's header: ``N m``, or
    ``N m | N`` where revolute and prismatic joints mix (the type column says which)."""
    return " | ".join(dict.fromkeys(u[key] for u in units))


def _head(name: str, unit: str = "") -> str:
    """A column header: the name (may wrap) and its unit, which never splits across lines."""
    return _e(name) + (f' <span class="u">[{_e(unit)}]</span>' if unit else "")


def _table(head: Sequence[str], rows: Sequence[str], ident: str,
           groups: Sequence[tuple[str, list[int]]] = ()) -> str:
    """A per-joint table: one row per joint; ``groups`` (a tree's branches, label and joint
    indices) put a row naming each branch above its joints."""
    body = "".join(rows) if not groups else "".join(
        f'<tr class="branch"><th colspan="{len(head)}">{_e(label)}</th></tr>'
        + "".join(rows[i] for i in idx) for label, idx in groups)
    return (f'<div class="scroll"><table class="joints" id="{ident}">'
            f'{_row(head, head=True)}{body}</table></div>')


def _branch_groups(result: SimulationResult) -> list[tuple[str, list[int]]]:
    """A tree's branches as table groups (``branch shoulder_pitch_l..wrist_l, on waist``);
    none for a serial chain."""
    robot = result.robot
    if robot.is_serial:
        return []
    names, parents = robot.joint_names, robot.parents
    return [(f"branch {names[b[0]]}" + (f"..{names[b[-1]]}" if len(b) > 1 else "")
             + (f", on {names[parents[b[0]]]}" if parents[b[0]] >= 0 else ", on the base"), b)
            for b in branches(parents)]


def _joints_html(result: SimulationResult, link: bool) -> str:
    """The per-joint tables: what the program needs, what the simulated robot did, and the
    motor torques with the bearing loads; units in the headers only."""
    if result.K == 0:
        return "<p>No cycle was completed.</p>"
    s = result.summary()
    units = joint_units(result.robot)
    with np.errstate(divide="ignore", invalid="ignore"):
        use = np.where(result.limit > 0, np.abs(result.tau) / result.limit, 0.0)
    use = np.nan_to_num(use, nan=0.0, posinf=0.0)
    tau, q, motor = _unit(units, "tau"), _unit(units, "q"), _unit(units, "motor")
    program, response, loads = [], [], []
    groups = _branch_groups(result)
    for i, (jd, j) in enumerate(zip(s["joints"], result.robot.joints, strict=True)):
        nsat = int(result.saturated[:, i].sum())
        npos = int(result.position_clamped[:, i].sum())
        nvel = int(result.velocity_clamped[:, i].sum())
        lim = math.inf if jd["effort_limit"] is None else jd["effort_limit"]  # null: unlimited
        ratio = jd["program_effort_ratio"]
        if ratio is not None:
            there, source = fmt_number(jd["program_limit_at_ratio"]), jd["program_limit_source"]
            if source == "torque-speed curve":
                source = (f"torque\u2013speed curve at {fmt_number(jd['program_speed_at_ratio'])}"
                          f" {jd['velocity_unit']}")
            ratio_text = f"{ratio:.2f}"
        else:
            there, source = "\u2013", {"unlimited": "unlimited", "unpowered": "no drive (0)"}.get(
                jd["drive"], "beyond the no-load speed")
            ratio_text = "\u2013"
        program.append(_row([_e(c) for c in (
            jd["joint"], j.type, fmt_number(jd["program_peak_effort"]),
            _time(jd["program_peak_time"], result.dt), ratio_text, there, source)],
            cls="sat" if ratio is not None and ratio > 1 else ""))
        cells = [
            jd["joint"], fmt_number(jd["time_saturated"]), f"{nsat:,}", f"{npos:,} / {nvel:,}",
            fmt_number(jd["peak_effort"]), fmt_number(lim),
            f"{100 * jd['peak_effort'] / lim:.0f}" if 0 < lim < math.inf else "\u2013",
            f"{100 * float(use[:, i].max()) if use.size else 0.0:.1f}",
            fmt_number(jd["max_tracking_error"]),
            _instant(jd["max_tracking_error_time"], result.dt, link),
        ]
        response.append(_row([c if isinstance(c, _Html) else _e(c) for c in cells],
                             cls="sat" if nsat or npos or nvel else ""))
        loads.append(_row([_e(c) for c in (
            jd["joint"], fmt_number(jd["peak_motor_torque"]), fmt_number(jd["rms_motor_torque"]),
            fmt_number(jd["peak_reaction_force"]), fmt_number(jd["peak_axial_force"]),
            fmt_number(jd["peak_radial_force"]), fmt_number(jd["peak_reaction_moment"]),
            fmt_number(jd["peak_bending_moment"]))]))
    return (f"""<h3>What the program needs (its own requirement, before any lag)</h3>
{_table([_head("joint"), _head("type"), _head("peak effort", tau), _head("at t", "s"),
         _head("peak / limit at the program's speed"), _head("that limit", tau),
         _head("the limit from")], program, "joints-program", groups)}
<h3>What the simulated robot did</h3>
{_table([_head("joint"), _head("time saturated", "s"), _head("cycles saturated"),
         _head("cycles clamped (pos / vel)"), _head("peak effort", tau),
         _head("rated limit", tau), _head("peak / rated limit", "%"),
         _head("peak |τ| / limit at speed", "%"), _head("max tracking error", q),
         _head("at t", "s")], response, "joints-response", groups)}
<h3>Motor torques and bearing loads</h3>
{_table([_head("joint"), _head("peak motor torque", motor), _head("RMS motor torque", motor),
         _head("peak reaction force", "N"), _head("peak axial force", "N"),
         _head("peak radial force", "N"), _head("peak reaction moment", "N m"),
         _head("peak bending moment", "N m")], loads, "joints-loads", groups)}"""
            + _tool_html(result, link))


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
        ("run", f"stopped at t = {result.runaway_time:.6g} s: the robot ran away"
         if result.runaway_time is not None else "completed" if result.completed
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
    png_folder: str | os.PathLike[str] | None = None,
    extra_png_dpi: float | None = None,
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
    png_folder : str or path-like, optional
        Also write the figures of :func:`plot_result` there as ``<name>.png``: the bytes the
        page embeds, so each figure is drawn once (the files :func:`plot_result` with a
        ``path`` writes; ``overwrite`` as for ``path``, every file checked before any work).
    extra_png_dpi : float, optional
        With ``png_folder``: also write each of ``extra_figures`` there as ``<name>.png``,
        drawn at this resolution [dots per inch] (the CLI's ``fig3.png``: 110, as
        ``mrnea fig3`` writes it; the page embeds it at the report's 100).

    All the PNGs are drawn by :func:`mrnea.report.pngs.draw_pngs`: a share in a second
    process where the machine has a CPU to spare.

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
    pngs = (None if png_folder is None
            else as_path(png_folder, "png_folder", OutputError))
    files = [] if pngs is None else [*FIGURES, *(() if extra_png_dpi is None
                                                 else (extra_figures or {}))]
    check_new([path, *(pngs / f"{n}.png" for n in files)], overwrite)  # before any rendering
    if interpolation is not None:
        choice("interpolation", interpolation, INTERPOLATIONS)
    view3d = flag(view3d, "view3d")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"{path.parent}: cannot create the folder: {exc.strerror}") from None
    s = result.summary()
    verdict = result.verdict()
    cls = {True: "ok", False: "bad", None: "partial"}[s["achievable"]]

    view3d = view3d and result.K > 0
    own = plot_result(result)
    figures = list(own.items()) + list((extra_figures or {}).items())
    extra_files = list((extra_figures or {}).items()) if extra_png_dpi is not None else []
    drawn = draw_pngs([(fig, DPI) for _, fig in figures]
                      + [(fig, extra_png_dpi) for _, fig in extra_files])
    if pngs is not None:  # the own figures as the page embeds them, then the extra files
        pngs.mkdir(parents=True, exist_ok=True)
        for name, png in zip([*own, *(n for n, _ in extra_files)],
                             [*drawn[:len(own)], *drawn[len(figures):]], strict=True):
            write_file(pngs / f"{name}.png", png, overwrite)
    fig_html = []
    for k, (name, fig) in enumerate(figures):
        caption = f": {_e(_CAPTIONS[name])}" if name in _CAPTIONS else ""
        slug = re.sub(r"[^A-Za-z0-9_-]+", "-", str(name)).strip("-")
        uri = png_data_uri(drawn[k])
        axes = f" data-xaxes='{figure_axes(fig)}'" if view3d else ""
        fig_html.append(
            f'<figure id="fig{k + 1}-{slug}"{axes}><div class="figscroll">'
            f'<img alt="{_e(name)}" src="{uri}"></div>'
            f"<figcaption><b>{_e(name)}</b>{caption}</figcaption></figure>")
    view_html = (f"<h2>3D view</h2>\n{scene_html(result_scene(result))}" if view3d else "")

    body = f"""\
<p class="note">Will the robot make the programmed motion? Generated {_e(stamp())} by mrnea.</p>
<div class="verdict {cls}" id="verdict">{_e(nobreak(verdict))}</div>
<p class="note" id="verdict-note">The verdict's numbers are the <b>program's own
requirement</b>: the effort the commanded motion needs (full actuator model, before any lag)
against each joint's limit at the program's speed.</p>
{view_html}
<h2>First infeasible instant</h2>
<p class="note" id="first-note">The <b>first cycle over a limit</b> of the simulated robot: the
effort that cycle needs from where the robot really is, against the limit at its real speed. It
can come before the verdict's peak and be smaller: once a drive saturates the robot lags, and the
later cycles no longer follow the program.</p>
{_first_infeasible_html(result, view3d)}
<h2>Per joint</h2>
{_joints_html(result, view3d)}
<p class="note">Efforts are joint side (N m for revolute, N for prismatic joints); motor torque
is τ/G. Reaction loads are in each joint's frame: axial along the joint axis, radial / bending
across it. Rows in red: the program needs more than the limit, or the joint saturated or its
command was clamped.</p>
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
