"""The four figures a designer reads after :func:`mrnea.simulate.simulate` (paper Sec. VI).

``"motion"`` (programmed vs achieved position, velocity, acceleration), ``"efforts"`` (the
program's own requirement, the speed-dependent limit and the effort the drives applied,
saturated intervals shaded, motor torque on the right-hand axis), ``"reactions"`` (joint
reaction force and moment magnitudes with their axial/radial and bending parts, for bearing
design) and ``"tracking"``. Long series are
decimated to min/max envelopes (:mod:`mrnea.report.drawing`).
"""

from __future__ import annotations

import os
import sys
from typing import TYPE_CHECKING, Any

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from mrnea.errors import OutputError, StateError
from mrnea.io.source import as_path
from mrnea.io.writer import check_new
from mrnea.report import FIGURES
from mrnea.report.drawing import (
    MAX_JOINTS,
    axes_grid,
    fit_ylim,
    fmt_number,
    header,
    joint_units,
    label,
    peak,
    plot_line,
    save_figure,
    shade,
)
from mrnea.summary import TIMES

if TYPE_CHECKING:
    from mrnea.simulate import SimulationResult

_MIN_ERR = 1e-9  # tracking-error axes span at least ±_MIN_ERR [rad | m]
_C_CMD, _C_ACT, _C_REQ, _C_LIM = "0.35", "C0", "C1", "C3"
_C_SAT, _C_CLAMP = "#d62728", "#ff7f0e"


def _first_time(result: SimulationResult) -> float | None:
    fi = result.summary()["first_infeasible"]
    return None if fi is None else float(fi["time"])


def require_result(result: object) -> None:
    """A StateError unless ``result`` is a :class:`~mrnea.simulate.SimulationResult`.

    The report sits below :mod:`mrnea.simulate` in the import order and does not import it
    (docs/design.md): a SimulationResult exists only once that module is loaded, so the class is
    looked up among the loaded modules.
    """
    simulate = sys.modules.get("mrnea.simulate")
    if simulate is None or not isinstance(result, simulate.SimulationResult):
        raise StateError(f"result: expected a SimulationResult (mrnea.simulate.simulate's), got "
                         f"{type(result).__name__}")


def shown_joints(r: SimulationResult) -> list[int]:
    """The joints a figure draws, in chain order: every joint, or for a robot of more than
    :data:`MAX_JOINTS` joints those that matter most: the first infeasible joint, then those
    that exceeded a limit in the most cycles, then those whose effort came closest to its
    limit."""
    n = r.robot.n
    if n <= MAX_JOINTS:
        return list(range(n))
    bad = (r.saturated | r.position_clamped | r.velocity_clamped).sum(axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        use = np.where(r.limit > 0, np.abs(r.tau_required) / r.limit, 0.0)
    use = np.nan_to_num(use, nan=0.0, posinf=np.finfo(float).max).max(axis=0, initial=0.0)
    order = sorted(range(n), key=lambda i: (-int(bad[i]), -float(use[i]), i))
    fi = r.summary()["first_infeasible"]
    if fi is not None:
        first = r.robot.joint_names.index(fi["joint"])
        order.remove(first)
        order.insert(0, first)
    return sorted(order[:MAX_JOINTS])


def _title(r: SimulationResult, what: str, shown: list[int]) -> str:
    """A figure's title: the robot, what is drawn, and how many of its joints."""
    cut = (f"\n{len(shown)} of {r.robot.n} joints: those that exceeded a limit or came closest; "
           "every joint is in the report's table and in cycles.csv"
           if len(shown) < r.robot.n else "")
    return f"{label(r.robot.name)}: {what}{cut}"


def _top(r: SimulationResult, shown: list[int]) -> float:
    """The top margin [in] for the title :func:`_title` writes (a second line if joints are cut)."""
    return 0.95 if len(shown) == r.robot.n else 1.2


def _motion_figure(r: SimulationResult) -> Figure:
    t, units, shown = r.t, joint_units(r.robot), shown_joints(r)
    fig, axs = axes_grid(len(shown), 3, 14.0, 1.7, top=_top(r, shown))
    t_first = _first_time(r)
    clamp_seen = {"position": False, "velocity": False}
    for row, i in enumerate(shown):
        j, u = r.robot.joints[i], units[i]
        cols = (("position", "q", r.q_cmd, r.q, r.position_clamped),
                ("velocity", "qd", r.qd_cmd, r.qd, r.velocity_clamped),
                ("acceleration", "qdd", r.program_qdd(), r.qdd, None))
        for c, (what, key, prog, real, clamp) in enumerate(cols):
            ax = axs[row, c]
            if clamp is not None and shade(ax, t, clamp[:, i], r.dt, _C_CLAMP):
                clamp_seen[what] = True
            plot_line(ax, t, prog[:, i], color=_C_CMD, lw=1.0, ls="--")
            plot_line(ax, t, real[:, i], color=_C_ACT, lw=1.2)
            if t_first is not None:
                ax.axvline(t_first, color=_C_SAT, lw=0.8, ls=":")
            if key == "qdd":
                fit_ylim(ax, [real[:, i]], [("programmed", prog[:, i])], u[key])
            ax.set_title(f"{label(j.name)}: {what}", fontsize="medium", loc="left")
            sym = {"q": "q", "qd": "q̇", "qdd": "q̈"}[key]
            ax.set_ylabel(f"{sym} [{u[key]}]")
            ax.grid(True, alpha=0.3)
    for ax in axs[-1]:
        ax.set_xlabel("time t [s]")
    handles: list[Any] = [
        Line2D([], [], color=_C_CMD, ls="--", label="programmed (q_cmd, qd_cmd, program_qdd)"),
        Line2D([], [], color=_C_ACT, label="achieved (q, qd, qdd)"),
    ]
    if t_first is not None:
        handles.append(Line2D([], [], color=_C_SAT, ls=":", label="first infeasible instant"))
    if any(clamp_seen.values()):
        handles.append(Patch(color=_C_CLAMP, alpha=0.3, label="command clamped to a joint limit"))
    header(fig, _title(r, "programmed vs achieved motion", shown), handles)
    return fig


def _efforts_figure(r: SimulationResult) -> Figure:
    t, units, shown = r.t, joint_units(r.robot), shown_joints(r)
    fig, axs = axes_grid(len(shown), 1, 13.0, 1.8, right=1.0, top=_top(r, shown))
    axs = axs[:, 0]
    t_first = _first_time(r)
    any_sat = False
    for row, i in enumerate(shown):
        j, u, ax = r.robot.joints[i], units[i], axs[row]
        any_sat |= shade(ax, t, r.saturated[:, i], r.dt, _C_SAT)
        lim = r.limit[:, i]
        finite = np.isfinite(lim)
        if finite.any():
            lt, lv = t[finite], lim[finite]
            plot_line(ax, lt, lv, color=_C_LIM, lw=1.0)
            plot_line(ax, lt, -lv, color=_C_LIM, lw=1.0)
        plot_line(ax, t, r.tau[:, i], color=_C_ACT, lw=1.3)
        need = r.program_effort[:, i]  # the commanded motion's, never the lag's recovery
        plot_line(ax, t, need, color=_C_REQ, lw=1.0, ls="--")  # dashes on top
        if t_first is not None:
            ax.axvline(t_first, color=_C_SAT, lw=0.8, ls=":")
        fit_ylim(ax, [r.tau[:, i]], [("program requirement", need), ("limit", lim)], u["tau"])
        G = float(r.robot.gear_ratio[i])
        sec = ax.secondary_yaxis("right", functions=(lambda x, G=G: x / G,
                                                     lambda x, G=G: x * G))
        sec.set_ylabel(f"motor τ/G [{u['motor']}]\n(G = {G:g})", fontsize="small")
        ax.set_ylabel(f"τ [{u['tau']}]")
        sat_time = float(r.saturated[:, i].sum() * r.dt)
        title = f"{label(j.name)}: joint effort (saturated {fmt_number(sat_time)} s"
        if r.K:
            jd = r.summary()["joints"][i]
            ratio = jd["program_effort_ratio"]
            title += (f"; the program needs up to {fmt_number(jd['program_peak_effort'])} "
                      f"{u['tau']}, " + (f"at most {ratio:.2f} {TIMES} the limit at its speed"
                                         if ratio is not None else jd["drive"]))
        ax.set_title(title + ")", fontsize="medium", loc="left")
        ax.grid(True, alpha=0.3)
    axs[-1].set_xlabel("time t [s]")
    handles: list[Any] = [
        Line2D([], [], color=_C_ACT, label="applied effort τ (simulated robot)"),
        Line2D([], [], color=_C_REQ, ls="--",
               label="program's requirement (commanded motion, before any lag)"),
        Line2D([], [], color=_C_LIM, label="± effort limit at the robot's speed"),
    ]
    if any_sat:
        handles.append(Patch(color=_C_SAT, alpha=0.3, label="saturated"))
    if t_first is not None:
        handles.append(Line2D([], [], color=_C_SAT, ls=":", label="first infeasible instant"))
    header(fig, _title(r, "joint efforts against actuator limits (joint side left, motor side "
                       "right)", shown), handles)
    return fig


def _reactions_figure(r: SimulationResult) -> Figure:
    t, shown = r.t, shown_joints(r)
    fig, axs = axes_grid(len(shown), 2, 14.0, 1.7, top=_top(r, shown))
    loads = r.bearing_loads()
    for row, i in enumerate(shown):
        j = r.robot.joints[i]
        a, b = axs[row]
        plot_line(a, t, loads.force[:, i], color="k", lw=1.3)
        plot_line(a, t, loads.axial_force[:, i], color="C2", lw=1.0)
        plot_line(a, t, loads.radial_force[:, i], color="C4", lw=1.0)
        plot_line(b, t, loads.moment[:, i], color="k", lw=1.3)
        plot_line(b, t, loads.axial_moment[:, i], color="C2", lw=1.0)
        plot_line(b, t, loads.bending_moment[:, i], color="C4", lw=1.0)
        f_peak, m_peak = fmt_number(peak(loads.force[:, i])), fmt_number(peak(loads.moment[:, i]))
        a.set_title(f"{label(j.name)}: reaction force (peak {f_peak} N)", fontsize="medium",
                    loc="left")
        b.set_title(f"{label(j.name)}: reaction moment (peak {m_peak} N m)", fontsize="medium",
                    loc="left")
        a.set_ylabel("force [N]")
        b.set_ylabel("moment [N m]")
        for ax in (a, b):
            ax.set_ylim(bottom=0)
            ax.grid(True, alpha=0.3)
    for ax in axs[-1]:
        ax.set_xlabel("time t [s]")
    header(fig, _title(r, "joint reaction loads (joint frames, for bearing design)", shown), [
        Line2D([], [], color="k", label="magnitude"),
        Line2D([], [], color="C2", label="axial (along the joint axis)"),
        Line2D([], [], color="C4", label="radial force / bending moment (across the axis)"),
    ])
    return fig


def _tracking_figure(r: SimulationResult) -> Figure:
    t, units, shown = r.t, joint_units(r.robot), shown_joints(r)
    fig, axs = axes_grid(len(shown), 1, 13.0, 1.4, top=_top(r, shown))
    axs = axs[:, 0]
    t_first = _first_time(r)
    any_sat = False
    for row, i in enumerate(shown):
        j, u, ax = r.robot.joints[i], units[i], axs[row]
        e = r.tracking_error[:, i]
        any_sat |= shade(ax, t, r.saturated[:, i], r.dt, _C_SAT)
        plot_line(ax, t, e, color=_C_ACT, lw=1.2)
        ax.axhline(0.0, color="0.5", lw=0.6)
        if t_first is not None:
            ax.axvline(t_first, color=_C_SAT, lw=0.8, ls=":")
        title = f"{label(j.name)}: tracking error q_cmd - q"
        if not e.any():  # none (0 below the resolution): say so, no axis of rounding noise
            title += ": none"
            ax.set_ylim(-1.0, 1.0)
            ax.set_yticks([0.0])
            # above the zero line (axes-relative: the line is at 0.5), never across it
            ax.text(0.5, 0.78, "no tracking error", transform=ax.transAxes, ha="center",
                    va="center", color="0.35", fontsize="medium")
        else:
            k = int(np.argmax(np.abs(e)))
            ax.plot([t[k]], [e[k]], "o", color=_C_SAT, ms=5)
            title += (f" (max |e| = {fmt_number(abs(float(e[k])))} {u['q']} "
                      f"at t = {fmt_number(float(t[k]))} s)")
            if abs(float(e[k])) < _MIN_ERR:  # a tiny error: not drawn as a huge one
                ax.set_ylim(-_MIN_ERR, _MIN_ERR)
        ax.set_title(title, fontsize="medium", loc="left")
        ax.set_ylabel(f"e [{u['q']}]")
        ax.grid(True, alpha=0.3)
    axs[-1].set_xlabel("time t [s]")
    handles: list[Any] = [Line2D([], [], color=_C_ACT, label="tracking error"),
                          Line2D([], [], color=_C_SAT, marker="o", ls="", label="largest |error|")]
    if any_sat:
        handles.append(Patch(color=_C_SAT, alpha=0.3, label="effort saturated"))
    header(fig, _title(r, "tracking error (programmed - achieved position)", shown), handles)
    return fig



def plot_result(result: SimulationResult, path: str | os.PathLike[str] | None = None,
                overwrite: bool = False) -> dict[str, Figure]:
    """The figures of a simulation run, optionally saved as PNG files.

    Parameters
    ----------
    result : SimulationResult
        A run of :func:`mrnea.simulate.simulate` (possibly interrupted).
    path : str or path-like, optional
        A directory (created if missing). Each figure is written there as ``<name>.png``
        through :func:`mrnea.io.writer.create` (whole or not at all, never through a link).
    overwrite : bool, default False
        Replace existing files (or links) of these names; otherwise OutputError, raised
        before any figure is drawn.

    Returns
    -------
    dict of str to matplotlib.figure.Figure
        ``"motion"``: per joint, programmed (dashed) vs achieved position, velocity and
        acceleration; clamped commands shaded. ``"efforts"``: per joint, applied effort
        ``tau``, the program's own requirement ``program_effort`` (dashed; not
        ``tau_required``, which after a saturation holds the drive's attempt to recover the lag
        within one cycle) and ``±limit`` (the limit at the current speed, so it follows a
        torque-speed curve), saturated intervals shaded, motor torque ``tau / G`` on the
        right-hand axis. ``"reactions"``: per joint, magnitude, axial
        and radial parts of the reaction force [N] and of the reaction moment [N m] (the
        across-axis moment is the bending moment a bearing carries). ``"tracking"``: per joint,
        ``q_cmd - q`` with its largest value marked, or "no tracking error" where it is 0 (below
        the resolution of :attr:`~mrnea.simulate.SimulationResult.tracking_error`).

    Notes
    -----
    Series longer than :data:`MAX_POINTS` samples are drawn as min/max envelopes (see the module
    docstring), so plotting stays fast for runs of 10^6 cycles. A one-cycle spike of required
    effort or programmed acceleration (a velocity step in the program) is clipped so that it
    does not flatten the rest; its peak is then written in the corner of the axes.
    """
    require_result(result)
    folder = None if path is None else as_path(path, "path", OutputError)
    check_new([] if folder is None else [folder / f"{name}.png" for name in FIGURES],
              overwrite)  # overwrite's type too, with or without a folder
    figs = {
        "motion": _motion_figure(result),
        "efforts": _efforts_figure(result),
        "reactions": _reactions_figure(result),
        "tracking": _tracking_figure(result),
    }
    if folder is not None:
        try:
            folder.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise OutputError(f"{folder}: cannot create the folder: {exc.strerror}") from None
        for name, fig in figs.items():
            save_figure(fig, folder / f"{name}.png", overwrite)
    return figs
