"""The sizing page, ``sizing.html`` (issue 27): per joint the classic sizing plot and the table
of its combinations.

The plot is the motor's torque-speed plane in four quadrants, motor side (speed G qd [rad/s],
torque [N m]) for the chosen drive (or, where nothing fits, the one that comes closest): the
program's operating points (one per cycle; driving ones in quadrants I and III, back-driven
ones in II and IV), the RMS point (RMS torque at the RMS speed, drawn in quadrant I), the
continuous (rated) and peak torque lines, the torque-speed curve mirrored into every quadrant,
and the maximum speed. Drawn on Agg without pyplot (:mod:`mrnea.report.drawing`), embedded as
PNG data URIs: the page is one self-contained file.
"""

from __future__ import annotations

import html
import os
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from mrnea.report.drawing import fmt_number, label, new_figure, png_data_uri
from mrnea.report.html import FIGSCROLL_CSS, page, stamp
from mrnea.sizing.checks import CHECKS, motor_limit
from mrnea.sizing.core import JointSizing, SizingResult
from mrnea.sizing.output import sizing_table

__all__ = ["sizing_figure", "sizing_html"]

MAX_POINTS = 4000  # operating points drawn per joint (every k-th cycle beyond that)
_CSS = """body{font-family:-apple-system,"Segoe UI",Helvetica,Arial,sans-serif;max-width:1400px;
margin:0 auto;padding:1em 2em;color:#222}h1{font-size:1.4em}h2{font-size:1.15em;
border-bottom:1px solid #ccc}table{border-collapse:collapse;font-size:0.85em}
td,th{border:1px solid #ccc;padding:2px 6px;text-align:right}th{background:#f0f0f0}
td.t{text-align:left}td.t:first-child{white-space:nowrap}
tr.chosen td{background:#e6f4ea;font-weight:bold}tr.rejected td{color:#777}
.note{color:#555;font-size:0.88em}.bad{color:#b00020;font-weight:bold}
figure{margin:0.5em 0}figure img{max-width:100%;height:auto;border:1px solid #ddd}
.scroll{overflow-x:auto}""" + FIGSCROLL_CSS


def sizing_figure(js: JointSizing) -> Figure:
    """The four-quadrant torque-speed plot of one joint's chosen (or best) drive."""
    c = js.best
    t = js.trains[c]
    m, G = t.motor, t.gearbox.ratio
    w = G * js.duty.qd
    tau = js.judged.motor[c]
    step = max(1, len(w) // MAX_POINTS)
    fig = new_figure(7.5, 5.4)
    ax = fig.add_axes((0.1, 0.3, 0.86, 0.63))
    back = js.judged.effort[c] * js.duty.qd < 0
    ax.scatter(w[::step][~back[::step]], tau[::step][~back[::step]], s=4, color="tab:blue",
               label="operating points, driving", zorder=3)
    ax.scatter(w[::step][back[::step]], tau[::step][back[::step]], s=4, color="tab:orange",
               label="operating points, back-driven", zorder=3)
    wmax = m.max_speed
    ws = np.linspace(0.0, wmax, 400)
    curve = motor_limit([t], ws[None])[0]
    for sx in (1, -1):
        for sy in (1, -1):
            ax.plot(sx * ws, sy * curve, color="black", lw=1.4,
                    label="peak torque (torque-speed curve)" if sx == sy == 1 else None)
            ax.plot(sx * ws, np.full_like(ws, sy * m.rated_torque), color="tab:green", lw=1.2,
                    ls="--", label="continuous (rated) torque" if sx == sy == 1 else None)
    for sx in (1, -1):
        ax.axvline(sx * wmax, color="gray", lw=1, ls=":",
                   label="maximum speed" if sx == 1 else None)
    ax.plot([js.judged.rms_speed[c]], [js.judged.rms[c]], marker="*", ms=14, color="tab:red",
            ls="none", label=f"RMS point ({fmt_number(js.judged.rms[c])} N m)", zorder=4)
    ax.axhline(0, color="#999", lw=0.6)
    ax.axvline(0, color="#999", lw=0.6)
    ax.set_xlabel("motor speed G q̇ [rad/s]")
    ax.set_ylabel("motor torque [N m]")
    status = "chosen" if js.chosen is not None else "best, does not fit"
    ax.set_title(label(f"{js.joint}: {t.name} ({status})"), fontsize="medium")
    ax.grid(alpha=0.3)
    fig.legend(loc="lower center", bbox_to_anchor=(0.5, 0.0), ncols=2, fontsize="small",
               frameon=False)
    return fig


def _table(df: pd.DataFrame, joint: str) -> str:
    """The rows of one joint: the chosen, the passing ones by rank, the rejected by ratio."""
    cols = ["drive", "ratio", "mass", "price", *[f"{k}_ratio" for k in CHECKS], "worst_ratio",
            "status", "rank", "reason"]
    heads = ["drive", "G", "mass [kg]", "price", "peak", "RMS", "speed", "input speed",
             "gear peak", "gear rated", "worst", "status", "rank", "reason"]
    sub = df[df["joint"] == joint].copy()
    sub["order"] = sub["status"].map({"chosen": 0, "passes": 1, "rejected": 2})
    sub = sub.sort_values(["order", "rank", "worst_ratio"], na_position="last")
    out = ["<div class='scroll'><table><tr>" + "".join(f"<th>{h}</th>" for h in heads)
           + "</tr>"]
    for _, r in sub.iterrows():
        cells = []
        for k in cols:
            v = r[k]
            if k in ("drive", "status", "reason"):
                cells.append(f"<td class='t'>{html.escape(str(v))}</td>")
            elif pd.isna(v):
                cells.append("<td></td>")
            else:
                cls = " class='bad'" if k.endswith("_ratio") and float(v) > 1 else ""
                cells.append(f"<td{cls}>{fmt_number(float(v), 3)}</td>")
        out.append(f"<tr class='{r['status']}'>" + "".join(cells) + "</tr>")
    return "\n".join(out) + "</table></div>"


def sizing_html(result: SizingResult, path: str | os.PathLike[str],
                overwrite: bool = False) -> Path:
    """Write ``sizing.html`` (module docstring) through :func:`mrnea.io.writer.write_file`."""
    from mrnea.io.writer import write_file

    df = sizing_table(result)
    parts = [f"<p class='note'>{html.escape(stamp())}. Objective: {result.objective}; dwell "
             f"{fmt_number(result.dwell)} s; drive masses on the parent links: "
             f"{'yes' if result.drive_mass else 'no'}; {result.rounds} round(s). Ratios are "
             f"need / rating (&le; 1 passes): docs/sizing.md.</p><ul>"]
    parts += [f"<li>{html.escape(line)}</li>" for line in result.lines()]
    parts.append("</ul>")
    for js in result.joints:
        parts.append(f"<h2>{html.escape(js.joint)}</h2>")
        parts.append(f"<p>{html.escape(js.message())}</p>")
        parts.append(f"<figure><div class='figscroll'><img alt='torque-speed plane of "
                     f"{html.escape(js.joint)}' src='{png_data_uri(sizing_figure(js))}'></div>"
                     "</figure>")
        parts.append(_table(df, js.joint))
    title = f"Drive sizing: {result.robot.name}"
    return write_file(path, page(title, title, "\n".join(parts), _CSS), overwrite)
