"""The identification page, ``identify.html`` (issue 28; docs/identification.md).

From the top: what was identified from which log (samples, rate, filter, the regressor's
condition number, the validation), the drives per joint with their standard errors and
residuals, one figure per joint and log (the measured and the predicted efforts, and their
difference, the residual, with the +-3 sigma band of the fit's residual standard deviation;
the rows of a joint at rest, which the fit leaves out, drawn thin and grey; the held-out end of
the log shaded), the table of base parameters (least squares estimate, standard error, the
identified robot's value, the prior's), and the identified links. Drawn on Agg without pyplot
(:mod:`mrnea.report.drawing`), embedded as PNG data URIs: one self-contained file, no script.
"""

from __future__ import annotations

import html
import math
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Patch

from mrnea.identify.estimate import IdentificationResult, Prediction
from mrnea.report.drawing import fmt_number, label, new_figure, plot_line, png_data_uri
from mrnea.report.html import FIGSCROLL_CSS, page, stamp

if TYPE_CHECKING:
    from matplotlib.axes import Axes

__all__ = ["efforts_figure", "identify_html"]

_CSS = """body{font-family:-apple-system,"Segoe UI",Helvetica,Arial,sans-serif;max-width:1400px;
margin:0 auto;padding:1em 2em;color:#222}h1{font-size:1.4em}h2{font-size:1.15em;
border-bottom:1px solid #ccc;margin-top:1.6em}table{border-collapse:collapse;font-size:0.85em}
td,th{border:1px solid #ccc;padding:2px 6px;text-align:right;white-space:nowrap}
th{background:#f0f0f0}td.t{text-align:left}.note{color:#555;font-size:0.88em}
.figs{display:flex;flex-wrap:wrap;gap:0.5em 1em}.figs figure{margin:0.3em 0;flex:1 1 560px;
max-width:700px;min-width:0}figure img{max-width:100%;height:auto;border:1px solid #ddd}
.scroll{overflow-x:auto}tr.folded td{color:#666}
@media (max-width:960px){body{padding:0.6em 0.8em}}""" + FIGSCROLL_CSS
FIT, CHECK, MEASURED, REST = "tab:blue", "tab:orange", "0.55", "0.8"


def _series(ax: Axes, p: Prediction, j: int, values: Any, color: str) -> None:
    """Joint j's ``values`` (K, n) thin and grey where the joint rests, in ``color`` where the
    fit uses its rows."""
    used = p.used[:, j]
    plot_line(ax, p.time, np.where(used, np.nan, values[:, j]), color=REST, lw=0.6)
    plot_line(ax, p.time, np.where(used, values[:, j], np.nan), color=color, lw=0.9)


def efforts_figure(result: IdentificationResult, j: int, which: str) -> Figure:
    """Joint j's measured and predicted efforts and residual, ``which``: ``"log"`` (the fitted
    rows, then the held-out end of the log, if any, shaded) or ``"validation"`` (the validation
    log given apart)."""
    jt = result.robot.joints[j]
    unit = jt.unit("tau")
    validation_log = which == "validation"
    held_out = not validation_log and result.options["validation"] == "holdout"
    parts = ([(result.validation, CHECK)] if validation_log else
             [(result.fit, FIT)] + ([(result.validation, CHECK)] if held_out else []))
    fig = new_figure(7.0, 4.4)
    top = fig.add_axes((0.11, 0.52, 0.86, 0.39))
    bottom = fig.add_axes((0.11, 0.245, 0.86, 0.24), sharex=top)
    for p, color in parts:
        plot_line(top, p.time, p.measured[:, j], color=MEASURED, lw=0.6)
        _series(top, p, j, p.predicted, color)
        _series(bottom, p, j, p.measured - p.predicted, color)
    if held_out:
        for ax in (top, bottom):
            ax.axvspan(result.validation.time[0], result.validation.time[-1], color=CHECK,
                       alpha=0.08, lw=0)
    s = 3 * float(result.sigma[j])
    for y in (-s, s):
        bottom.axhline(y, color="black", lw=0.8, ls="--")
    lim = max(4 * s, *(float(np.nanmax(np.abs(np.where(p.used[:, j],
                                                          p.measured[:, j] - p.predicted[:, j],
                                                          np.nan)), initial=0.0))
                       for p, _ in parts))
    bottom.set_ylim(-1.1 * lim, 1.1 * lim)
    top.tick_params(labelbottom=False)
    top.set_ylabel(f"effort [{unit}]")
    bottom.set_ylabel(f"residual [{unit}]")
    bottom.set_xlabel("time t [s]")
    where = "validation log" if validation_log else "log"
    top.set_title(label(f"{jt.name}: {where}"), fontsize="medium")
    for ax in (top, bottom):
        ax.grid(alpha=0.3)
    handles = [Patch(color=MEASURED, label="measured"),
               Patch(color=CHECK if validation_log else FIT,
                     label="predicted" if validation_log else "predicted, fitted rows")]
    if held_out:
        handles.append(Patch(color=CHECK, label="predicted, held out"))
    handles += [Patch(color=REST, label="at rest (not fitted)"),
                Patch(facecolor="white", edgecolor="black", ls="--",
                      label=f"\u00b13\u03c3 ({fmt_number(s)} {unit})")]
    fig.legend(handles=handles, loc="lower center", bbox_to_anchor=(0.5, 0.0), ncols=3,
               fontsize="small", frameon=False)
    return fig


def _cell(x: float | None, sig: int = 4) -> str:
    if x is None or not math.isfinite(x):
        return "<td>&ndash;</td>"
    return f"<td>{fmt_number(x, sig)}</td>"


def _plus_minus(j: dict[str, Any], field: str) -> str:
    """Joint j's ``field`` with its standard error, or the base parameter that holds it."""
    x, se = j[field], j[f"{field}_se"]
    if se is None:
        return (f"<td>{fmt_number(x)} <span class='note'>(in "
                f"{html.escape(str(j['folded'][field]))})</span></td>")
    return f"<td>{fmt_number(x)} ± {fmt_number(se, 2)}</td>"


def _drives_table(summary: dict[str, Any]) -> str:
    heads = ["joint", "G² J<sub>m</sub>", "F<sub>v</sub>", "F<sub>+</sub>", "F<sub>&minus;</sub>",
             "residual &sigma;", "RMS fit", "RMS validation", "unit of effort"]
    rows = ["<div class='scroll'><table><tr>" + "".join(f"<th>{h}</th>" for h in heads)
            + "</tr>"]
    for j in summary["joints"]:
        rows.append(
            f"<tr><td class='t'>{html.escape(j['joint'])}</td>"
            + _plus_minus(j, "reflected_rotor_inertia")
            + _plus_minus(j, "viscous_friction")
            + _plus_minus(j, "coulomb_friction_pos")
            + _plus_minus(j, "coulomb_friction_neg")
            + _cell(j["residual_std"], 3) + _cell(j["fit_rms"], 3)
            + _cell(j["validation_rms"], 3) + f"<td class='t'>{j['effort_unit']}</td></tr>")
    return "\n".join(rows) + "</table></div>"


def _parameters_table(summary: dict[str, Any]) -> str:
    heads = ["#", "base parameter", "unit", "estimate", "standard error", "relative",
             "identified", "prior"]
    rows = ["<div class='scroll'><table><tr>" + "".join(f"<th>{h}</th>" for h in heads)
            + "</tr>"]
    for k, p in enumerate(summary["parameters"]):
        est, se = p["estimate"], p["standard_error"]
        rel = abs(se / est) * 100 if est and se is not None else None
        cls = " class='folded'" if p["folded"] else ""
        rows.append(f"<tr{cls}><td>{k + 1}</td><td class='t'>{html.escape(p['name'])}</td>"
                    f"<td class='t'>{p['unit']}</td>" + _cell(est) + _cell(se, 2)
                    + ("<td>&ndash;</td>" if rel is None else f"<td>{fmt_number(rel, 2)} %</td>")
                    + _cell(p["identified"]) + _cell(p["prior"]) + "</tr>")
    return "\n".join(rows) + "</table></div>"


def _links_table(summary: dict[str, Any]) -> str:
    heads = ["link", "mass [kg]", "c<sub>x</sub> [m]", "c<sub>y</sub> [m]", "c<sub>z</sub> [m]",
             "I<sub>xx</sub>", "I<sub>yy</sub>", "I<sub>zz</sub>", "I<sub>xy</sub>",
             "I<sub>xz</sub>", "I<sub>yz</sub> [kg m²]", "rigid body"]
    rows = ["<div class='scroll'><table><tr>" + "".join(f"<th>{h}</th>" for h in heads)
            + "</tr>"]
    for lk in summary["links"]:
        inertia = lk["inertia"]
        cells = [lk["mass"], *lk["com"], inertia[0][0], inertia[1][1], inertia[2][2],
                 inertia[0][1], inertia[0][2], inertia[1][2]]
        rows.append(f"<tr><td class='t'>{html.escape(lk['link'])}</td>"
                    + "".join(_cell(x) for x in cells)
                    + f"<td class='t'>{'yes' if lk['consistent'] else 'NO'}</td></tr>")
    return "\n".join(rows) + "</table></div>"


def _figures(result: IdentificationResult) -> str:
    logs = ["log", "validation"] if result.options["validation"] == "log" else ["log"]
    out = ["<div class='figs'>"]
    for j, jt in enumerate(result.robot.joints):
        for which in logs:
            uri = png_data_uri(efforts_figure(result, j, which))
            what = "validation log" if which == "validation" else "log"
            out.append(f"<figure><div class='figscroll'><img alt='measured and predicted "
                       f"efforts of {html.escape(jt.name, quote=True)}, {what}' src='{uri}'>"
                       "</div></figure>")
    return "\n".join(out) + "</div>"


def identify_html(result: IdentificationResult, summary: dict[str, Any],
                  path: str | os.PathLike[str], overwrite: bool = False) -> Path:
    """Write ``identify.html`` (module docstring) for ``result`` and its ``summary``
    (:func:`mrnea.identify.output.identify_summary`) through :func:`mrnea.io.writer.write_file`."""
    from mrnea.io.writer import write_file

    s = summary
    e = html.escape
    rates = ("read from the log" if s["rates"] == "from the log" else
             f"from the positions, zero-phase Butterworth filter at {fmt_number(s['cutoff'])} Hz")
    if s["validation"] == "log":
        check = (f"predicted on the validation log {e(s['validation_log'])} "
                 f"({s['validation_samples']:,} samples)")
    elif s["validation"] == "holdout":
        check = (f"predicted on the last {fmt_number(100 * s['holdout'])} % of the log "
                 f"({s['validation_samples']:,} samples, held out of the fit, shaded)")
    else:
        check = "none (no held-out part, no validation log)"
    consistent = ("Every link is a rigid body (mass &gt; 0, inertia positive definite with the "
                  "triangle inequality)" if s["physically_consistent"] else
                  "<b>A link is not a rigid body</b>")
    kt = ("" if s["torque_constant"] is None else
          "; efforts from motor currents, τ = G k<sub>t</sub> i, k<sub>t</sub> = "
          + ", ".join(fmt_number(x) for x in s["torque_constant"]) + " N m/A")
    parts = [
        f"<p class='note'>{e(stamp())}. docs/identification.md.</p>",
        f"<p>Log <b>{e(s['log'])}</b>: {s['samples']:,} samples at "
        f"{fmt_number(s['sample_rate'])} Hz ({fmt_number(s['duration'])} s); velocities and "
        f"accelerations {rates}{kt}. Fitted on {s['fit_samples']:,} samples (a joint's rows "
        f"slower than {fmt_number(s['min_speed'])} rad/s or m/s left out), weighted least "
        f"squares then the physically consistent parameters nearest them (prior: the robot "
        f"given, weight {fmt_number(s['prior_weight'])}). {s['base_parameters']} base "
        f"parameters; condition number of the base regressor (columns scaled) "
        f"<b>{fmt_number(s['condition'])}</b>. Validation: {check}. {consistent}.</p>",
        "<h2>Drives (joint side; ± one standard error)</h2>", _drives_table(s),
        "<p class='note'>G² J<sub>m</sub>: reflected rotor inertia [kg m² | kg]; F<sub>v</sub>: "
        "viscous friction [N m s/rad | N s/m]; F<sub>+</sub>, F<sub>&minus;</sub>: Coulomb "
        "friction moving up and down [N m | N], an effort offset folded in. “(in X)”: not a "
        "base parameter of its own; the log identifies it only within base parameter X, and "
        "the identified robot's share follows the prior.</p>",
        "<h2>Measured and predicted efforts</h2>",
        "<p class='note'>Predicted by the least squares estimate on the fitted rows and by the "
        "identified (physically consistent) robot on the held-out rows or the validation log; "
        "residual = measured &minus; predicted.</p>",
        _figures(result),
        "<h2>Base parameters</h2>",
        "<p class='note'>The identifiable combinations of the link and drive parameters "
        "(name: the column it is; “(+k)”: k others fold into it, in grey). Estimate and standard "
        "error: weighted least squares; identified: the physically consistent robot's; prior: "
        "the robot given.</p>", _parameters_table(s),
        "<h2>Links (identified)</h2>",
        "<p class='note'>Centre of mass in the link frame; inertia about the centre of mass, "
        "link axes. Directions the log does not see keep the prior's values.</p>",
        _links_table(s)]
    title = f"Identification: {s['robot']}"
    return write_file(path, page(title, title, "\n".join(parts), _CSS), overwrite)
