"""Figures and a self-contained HTML report of a simulation (paper Secs. II, IV and VI).

* :func:`plot_result` -- the figures a designer reads after :func:`mrnea.simulate.simulate`:
  ``"motion"`` (programmed vs achieved position, velocity, acceleration), ``"efforts"`` (joint
  effort and required effort against the speed-dependent limit, saturated intervals shaded, motor
  torque on the right-hand axis), ``"reactions"`` (joint reaction force and moment magnitudes
  with their axial/radial and bending parts, for bearing design) and ``"tracking"``.
* :func:`fig3` -- the paper's Fig. 3: joint torques by the RNEA and by the mRNEA (``H qdd + u'``)
  along a trajectory, and the input accelerations against those forward dynamics recovers.
* :func:`write_report` -- one HTML file, verdict first, figures embedded as PNG data URIs: no
  external resource, no JavaScript.

Rendering uses matplotlib's object-oriented API with the Agg canvas
(:class:`matplotlib.figure.Figure` + :class:`~matplotlib.backends.backend_agg.FigureCanvasAgg`);
``matplotlib.pyplot`` and the global backend are never touched, so this module works headless
and does not disturb an interactive session. The returned figures are not registered with
pyplot: save them with ``fig.savefig(...)``.

Decimation. A run can hold 10^6 cycles; plotting every sample would be slow and no more
informative at screen resolution. Every time series with more than :data:`MAX_POINTS` samples is
reduced to a min/max envelope: the samples are split into ``MAX_POINTS // 2`` consecutive buckets
and each bucket contributes its minimum and its maximum, in time order (plus the first and last
samples). Peaks, spikes and the extent of oscillations are therefore kept exactly; only the detail
inside a bucket (at most ``2 K / MAX_POINTS`` cycles) is lost. Shaded intervals (saturation,
clamps) are computed at full resolution, merged where the gap between two intervals is below
1/1500 of the run's duration, and drawn at least 1/600 of the duration wide so that a one-cycle
saturation stays visible. Tables in the report always use the full-resolution data.
"""

from __future__ import annotations

import base64
import html
import io
import math
import os
import re
import secrets
from collections.abc import Iterable, Mapping, Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from numpy.typing import ArrayLike, NDArray

from mrnea.dynamics import forward_dynamics, inverse_dynamics, mass_matrix_and_bias
from mrnea.simulate import atomic_write

if TYPE_CHECKING:
    from matplotlib.axes import Axes

    from mrnea.model import Robot
    from mrnea.simulate import SimulationResult

__all__ = ["MAX_POINTS", "fig3", "plot_result", "write_report"]

MAX_POINTS = 5000
"""At most about this many points are drawn per line (see the module docstring)."""

_DPI = 100
_MERGE = 1500  # shaded intervals closer than duration / _MERGE are merged
_MIN_SHADE = 600  # shaded intervals are drawn at least duration / _MIN_SHADE wide
_MIN_ERR = 1e-9  # tracking-error axes span at least ±_MIN_ERR [rad | m]
_OFF_SCALE = 3.0  # a series more than this times the axis' core range is drawn off scale
_C_CMD, _C_ACT, _C_REQ, _C_LIM = "0.35", "C0", "C1", "C3"
_C_SAT, _C_CLAMP = "#d62728", "#ff7f0e"


# --- helpers -------------------------------------------------------------------------------------
def _new_figure(width: float, height: float) -> Figure:
    """A Figure on its own Agg canvas (no pyplot, no global state)."""
    fig = Figure(figsize=(width, height), dpi=_DPI)
    FigureCanvasAgg(fig)
    return fig


def _grid(nrows: int, ncols: int, width: float, row_height: float, *, left: float = 0.95,
          right: float = 0.3, top: float = 0.95, bottom: float = 0.55, hgap: float = 0.5,
          wgap: float = 0.85) -> tuple[Figure, NDArray]:
    """A figure with an ``nrows x ncols`` grid of axes sharing x, margins given in inches.

    The layout is fixed rather than "constrained": constrained layout measures every text
    twice and roughly doubles the rendering time of these many-axes figures. ``top`` leaves
    room for the suptitle and the figure legend, ``hgap`` for each axes' title.
    """
    height = top + bottom + nrows * row_height + (nrows - 1) * hgap
    fig = _new_figure(width, height)
    axw = (width - left - right - (ncols - 1) * wgap) / ncols
    axs = fig.subplots(nrows, ncols, sharex=True, squeeze=False, gridspec_kw={
        "left": left / width, "right": 1 - right / width, "top": 1 - top / height,
        "bottom": bottom / height, "hspace": hgap / row_height, "wspace": wgap / axw})
    for ax in axs.flat:
        ax.yaxis.set_offset_position("right")  # a "1e-5" multiplier must not hit the title
    return fig, axs


def _header(fig: Figure, title: str, handles: list[Any]) -> None:
    """Suptitle and one legend for the whole figure, above the axes (fixed offsets in inches)."""
    h = fig.get_figheight()
    lines = title.count("\n") + 1
    fig.suptitle(title, y=1 - 0.1 / h, va="top", fontweight="bold")
    fig.legend(handles=handles, loc="upper center",
               bbox_to_anchor=(0.5, 1 - (0.12 + 0.24 * lines) / h),
               ncols=min(len(handles), 5), fontsize="small", frameon=False)


def _envelope(t: NDArray, y: NDArray, max_points: int = MAX_POINTS) -> tuple[NDArray, NDArray]:
    """Min/max-envelope decimation of one series to about ``max_points`` points.

    The series is split into ``max_points // 2`` buckets of consecutive samples; each keeps its
    minimum and maximum sample, in time order, so extremes survive exactly.
    """
    K = y.shape[0]
    if K <= max_points:
        return t, y
    b = -(-K // max(1, max_points // 2))  # samples per bucket
    m = K // b * b
    Y = y[:m].reshape(-1, b)
    start = np.arange(0, m, b)
    parts = [start + Y.argmin(axis=1), start + Y.argmax(axis=1), np.array([0, K - 1])]
    if m < K:
        parts.append(np.array([m + int(np.argmin(y[m:])), m + int(np.argmax(y[m:]))]))
    idx = np.unique(np.concatenate(parts))
    return t[idx], y[idx]


def _plot(ax: Axes, t: NDArray, y: NDArray, **kw: Any) -> Line2D:
    """``ax.plot`` of the series, decimated by :func:`_envelope`."""
    tt, yy = _envelope(t, y)
    return ax.plot(tt, yy, **kw)[0]


def _intervals(t: NDArray, mask: NDArray, dt: float) -> list[tuple[float, float]]:
    """``(start, width)`` of the runs of True in ``mask``; cycle k covers ``[t_k, t_k + dt)``."""
    if mask.shape[0] == 0 or not mask.any():
        return []
    m = np.concatenate(([False], mask.astype(bool), [False]))
    edges = np.flatnonzero(m[1:] != m[:-1])
    starts, ends = t[edges[0::2]], t[edges[1::2] - 1] + dt
    gap = (t[-1] - t[0] + dt) / _MERGE
    out: list[list[float]] = []
    for s, e in zip(starts.tolist(), ends.tolist(), strict=True):
        if out and s - out[-1][1] <= gap:
            out[-1][1] = e
        else:
            out.append([s, e])
    least = (t[-1] - t[0] + dt) / _MIN_SHADE  # keep a one-cycle interval visible
    return [(s, max(e - s, least)) for s, e in out]


def _shade(ax: Axes, t: NDArray, mask: NDArray, dt: float, color: str) -> bool:
    """Shade the intervals where ``mask`` holds over the full height of ``ax``."""
    spans = _intervals(t, mask, dt)
    if spans:
        ax.broken_barh(spans, (0, 1), transform=ax.get_xaxis_transform(), facecolor=color,
                       alpha=0.18, linewidth=0, zorder=0)
    return bool(spans)


def _peak(a: NDArray) -> float:
    a = np.abs(a[np.isfinite(a)])
    return float(a.max()) if a.size else 0.0


def _fit_ylim(ax: Axes, core: Sequence[NDArray],
              optional: Sequence[tuple[str, NDArray]]) -> None:
    """Scale the y axis to ``core`` and to each ``optional`` series unless it would dwarf them.

    An optional series whose peak exceeds :data:`_OFF_SCALE` times the range so far (e.g. the
    one-cycle spike of required effort a velocity step in the program causes, or an effort limit
    of 1e9) is drawn clipped, scaled by its 99.5th percentile if that fits, and its peak is noted
    in the corner of the axes.
    """
    top = max((_peak(a) for a in core), default=0.0)
    notes = []
    clipped = False
    for label, a in optional:
        finite = np.abs(a[np.isfinite(a)])
        if finite.size == 0:
            continue
        peak = float(finite.max())
        if top == 0.0 or peak <= _OFF_SCALE * top:
            top = max(top, peak)
            continue
        clipped = True
        robust = float(np.quantile(finite, 0.995))
        if robust <= _OFF_SCALE * top:
            top = max(top, robust)
        notes.append(f"{label} peak {_num(peak)} off scale")
    if clipped and top > 0:
        ax.set_ylim(-1.1 * top, 1.1 * top)
        ax.text(0.995, 0.97, "; ".join(notes), transform=ax.transAxes, ha="right", va="top",
                fontsize="x-small", color="0.3",
                bbox={"boxstyle": "round,pad=0.2", "fc": "white", "ec": "0.7", "alpha": 0.85})


def _units(robot: Robot) -> list[dict[str, str]]:
    """Per joint: SI units of position, velocity, acceleration and effort."""
    out = []
    for j in robot.joints:
        if j.is_prismatic:
            out.append({"q": "m", "qd": "m/s", "qdd": "m/s²", "tau": "N", "motor": "N m or N"})
        else:
            out.append({"q": "rad", "qd": "rad/s", "qdd": "rad/s²", "tau": "N m", "motor": "N m"})
    return out


def _num(x: float, sig: int = 4) -> str:
    """A readable number: fixed notation with thousands separators in [1e-3, 1e7), else e."""
    if not math.isfinite(x):
        return "∞" if x > 0 else "-∞" if x < 0 else "NaN"
    if x == 0:
        return "0"
    mag = math.floor(math.log10(abs(x)))
    if -3 <= mag < 7:
        text = f"{x:,.{max(0, sig - 1 - mag)}f}"
        return text.rstrip("0").rstrip(".") if "." in text else text
    return f"{x:.{sig - 1}e}"


def _first_time(result: SimulationResult) -> float | None:
    fi = result.summary()["first_infeasible"]
    return None if fi is None else float(fi["time"])


def _axial_split(vec: NDArray, axes: NDArray) -> tuple[NDArray, NDArray]:
    """Components of (K, n, 3) ``vec`` along each joint's unit axis (n, 3), and across it."""
    along = np.einsum("kij,ij->ki", vec, axes)
    across = np.linalg.norm(vec - along[:, :, None] * axes[None], axis=2)
    return along, across


def _save_png(fig: Figure, path: Path) -> None:
    """Write ``fig`` as a PNG at ``path`` atomically (temporary file, then os.replace).

    The temporary file is opened with ``"xb"`` (not :func:`tempfile.mkstemp`, whose files are
    mode 0600) so that the PNG gets the usual permissions of the process' umask.
    """
    tmp = path.with_name(f".{path.name}.{secrets.token_hex(6)}.tmp")
    try:
        with open(tmp, "xb") as fh:
            fig.savefig(fh, format="png", dpi=_DPI, metadata={"Software": None})
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def _file_mode() -> int:
    """``0o666`` less the process' umask, read without changing it (0o644 if unknown)."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("Umask:"):
                return 0o666 & ~int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    return 0o644


def _png_data_uri(fig: Figure) -> str:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=_DPI, metadata={"Software": None})
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


# --- plot_result ---------------------------------------------------------------------------------
def _motion_figure(r: SimulationResult) -> Figure:
    n, t, units = r.robot.n, r.t, _units(r.robot)
    fig, axs = _grid(n, 3, 14.0, 1.7)
    t_first = _first_time(r)
    clamp_seen = {"position": False, "velocity": False}
    for i, (j, u) in enumerate(zip(r.robot.joints, units, strict=True)):
        cols = (("position", "q", r.q_cmd, r.q, r.position_clamped),
                ("velocity", "qd", r.qd_cmd, r.qd, r.velocity_clamped),
                ("acceleration", "qdd", r.qdd_des, r.qdd, None))
        for c, (what, key, prog, real, clamp) in enumerate(cols):
            ax = axs[i, c]
            if clamp is not None and _shade(ax, t, clamp[:, i], r.dt, _C_CLAMP):
                clamp_seen[what] = True
            _plot(ax, t, prog[:, i], color=_C_CMD, lw=1.0, ls="--")
            _plot(ax, t, real[:, i], color=_C_ACT, lw=1.2)
            if t_first is not None:
                ax.axvline(t_first, color=_C_SAT, lw=0.8, ls=":")
            if key == "qdd":
                _fit_ylim(ax, [real[:, i]], [("programmed", prog[:, i])])
            ax.set_title(f"{j.name}: {what}", fontsize="medium", loc="left")
            sym = {"q": "q", "qd": "q̇", "qdd": "q̈"}[key]
            ax.set_ylabel(f"{sym} [{u[key]}]")
            ax.grid(True, alpha=0.3)
    for ax in axs[-1]:
        ax.set_xlabel("time t [s]")
    handles: list[Any] = [
        Line2D([], [], color=_C_CMD, ls="--", label="programmed (q_cmd, qd_cmd, qdd_des)"),
        Line2D([], [], color=_C_ACT, label="achieved (q, qd, qdd)"),
    ]
    if t_first is not None:
        handles.append(Line2D([], [], color=_C_SAT, ls=":", label="first infeasible instant"))
    if any(clamp_seen.values()):
        handles.append(Patch(color=_C_CLAMP, alpha=0.3, label="command clamped to a joint limit"))
    _header(fig, f"{r.robot.name}: programmed vs achieved motion", handles)
    return fig


def _efforts_figure(r: SimulationResult) -> Figure:
    n, t, units = r.robot.n, r.t, _units(r.robot)
    fig, axs = _grid(n, 1, 13.0, 1.8, right=1.0)
    axs = axs[:, 0]
    t_first = _first_time(r)
    any_sat = False
    for i, (j, u) in enumerate(zip(r.robot.joints, units, strict=True)):
        ax = axs[i]
        any_sat |= _shade(ax, t, r.saturated[:, i], r.dt, _C_SAT)
        lim = r.limit[:, i]
        finite = np.isfinite(lim)
        if finite.any():
            lt, lv = t[finite], lim[finite]
            _plot(ax, lt, lv, color=_C_LIM, lw=1.0)
            _plot(ax, lt, -lv, color=_C_LIM, lw=1.0)
        _plot(ax, t, r.tau[:, i], color=_C_ACT, lw=1.3)
        _plot(ax, t, r.tau_required[:, i], color=_C_REQ, lw=1.0, ls="--")  # dashes on top
        if t_first is not None:
            ax.axvline(t_first, color=_C_SAT, lw=0.8, ls=":")
        _fit_ylim(ax, [r.tau[:, i]], [("required", r.tau_required[:, i]), ("limit", lim)])
        G = float(r.robot.gear_ratio[i])
        sec = ax.secondary_yaxis("right", functions=(lambda x, G=G: x / G,
                                                     lambda x, G=G: x * G))
        sec.set_ylabel(f"motor τ/G [{u['motor']}]\n(G = {G:g})", fontsize="small")
        ax.set_ylabel(f"τ [{u['tau']}]")
        sat_time = float(r.saturated[:, i].sum() * r.dt)
        ax.set_title(f"{j.name}: joint effort (saturated {_num(sat_time)} s)",
                     fontsize="medium", loc="left")
        ax.grid(True, alpha=0.3)
    axs[-1].set_xlabel("time t [s]")
    handles: list[Any] = [
        Line2D([], [], color=_C_ACT, label="applied effort τ"),
        Line2D([], [], color=_C_REQ, ls="--", label="required for the program τ_required"),
        Line2D([], [], color=_C_LIM, label="± effort limit at current speed"),
    ]
    if any_sat:
        handles.append(Patch(color=_C_SAT, alpha=0.3, label="saturated"))
    if t_first is not None:
        handles.append(Line2D([], [], color=_C_SAT, ls=":", label="first infeasible instant"))
    _header(fig, f"{r.robot.name}: joint efforts against actuator limits (joint side left, "
            "motor side right)", handles)
    return fig


def _reactions_figure(r: SimulationResult) -> Figure:
    n, t = r.robot.n, r.t
    fig, axs = _grid(n, 2, 14.0, 1.7)
    axes = np.array([j.axis for j in r.robot.joints])
    f, m = r.reaction[:, :, :3], r.reaction[:, :, 3:]
    f_ax, f_rad = _axial_split(f, axes)
    m_ax, m_bend = _axial_split(m, axes)
    f_mag, m_mag = np.linalg.norm(f, axis=2), np.linalg.norm(m, axis=2)
    for i, j in enumerate(r.robot.joints):
        a, b = axs[i]
        _plot(a, t, f_mag[:, i], color="k", lw=1.3)
        _plot(a, t, np.abs(f_ax[:, i]), color="C2", lw=1.0)
        _plot(a, t, f_rad[:, i], color="C4", lw=1.0)
        _plot(b, t, m_mag[:, i], color="k", lw=1.3)
        _plot(b, t, np.abs(m_ax[:, i]), color="C2", lw=1.0)
        _plot(b, t, m_bend[:, i], color="C4", lw=1.0)
        a.set_title(f"{j.name}: reaction force (peak {_num(_peak(f_mag[:, i]))} N)",
                    fontsize="medium", loc="left")
        b.set_title(f"{j.name}: reaction moment (peak {_num(_peak(m_mag[:, i]))} N m)",
                    fontsize="medium", loc="left")
        a.set_ylabel("force [N]")
        b.set_ylabel("moment [N m]")
        for ax in (a, b):
            ax.set_ylim(bottom=0)
            ax.grid(True, alpha=0.3)
    for ax in axs[-1]:
        ax.set_xlabel("time t [s]")
    _header(fig, f"{r.robot.name}: joint reaction loads (joint frames, for bearing design)", [
        Line2D([], [], color="k", label="magnitude"),
        Line2D([], [], color="C2", label="axial (along the joint axis)"),
        Line2D([], [], color="C4", label="radial force / bending moment (across the axis)"),
    ])
    return fig


def _tracking_figure(r: SimulationResult) -> Figure:
    n, t, units = r.robot.n, r.t, _units(r.robot)
    fig, axs = _grid(n, 1, 13.0, 1.4)
    axs = axs[:, 0]
    t_first = _first_time(r)
    any_sat = False
    for i, (j, u) in enumerate(zip(r.robot.joints, units, strict=True)):
        ax = axs[i]
        e = r.tracking_error[:, i]
        any_sat |= _shade(ax, t, r.saturated[:, i], r.dt, _C_SAT)
        _plot(ax, t, e, color=_C_ACT, lw=1.2)
        ax.axhline(0.0, color="0.5", lw=0.6)
        if t_first is not None:
            ax.axvline(t_first, color=_C_SAT, lw=0.8, ls=":")
        title = f"{j.name}: tracking error q_cmd - q"
        if e.size:
            k = int(np.argmax(np.abs(e)))
            ax.plot([t[k]], [e[k]], "o", color=_C_SAT, ms=5)
            title += f" (max |e| = {_num(abs(float(e[k])))} {u['q']} at t = {_num(float(t[k]))} s)"
            if abs(float(e[k])) < _MIN_ERR:  # rounding noise: draw it as the flat line it is
                ax.set_ylim(-_MIN_ERR, _MIN_ERR)
        ax.set_title(title, fontsize="medium", loc="left")
        ax.set_ylabel(f"e [{u['q']}]")
        ax.grid(True, alpha=0.3)
    axs[-1].set_xlabel("time t [s]")
    handles: list[Any] = [Line2D([], [], color=_C_ACT, label="tracking error"),
                          Line2D([], [], color=_C_SAT, marker="o", ls="", label="largest |error|")]
    if any_sat:
        handles.append(Patch(color=_C_SAT, alpha=0.3, label="effort saturated"))
    _header(fig, f"{r.robot.name}: tracking error (programmed - achieved position)", handles)
    return fig


FIGURES = ("motion", "efforts", "reactions", "tracking")


def plot_result(result: SimulationResult, path: str | os.PathLike[str] | None = None,
                overwrite: bool = False) -> dict[str, Figure]:
    """The figures of a simulation run, optionally saved as PNG files.

    Parameters
    ----------
    result : SimulationResult
        A run of :func:`mrnea.simulate.simulate` (possibly interrupted).
    path : str or path-like, optional
        A directory (created if missing). Each figure is written there as ``<name>.png``,
        atomically (temporary file, then :func:`os.replace`).
    overwrite : bool, default False
        Replace existing files of these names; otherwise FileExistsError, raised before any
        file is written.

    Returns
    -------
    dict of str to matplotlib.figure.Figure
        ``"motion"``: per joint, programmed (dashed) vs achieved position, velocity and
        acceleration; clamped commands shaded. ``"efforts"``: per joint, applied effort
        ``tau``, required effort ``tau_required`` (dashed) and ``±limit`` (the limit at the
        current speed, so it follows a torque-speed curve), saturated intervals shaded, motor
        torque ``tau / G`` on the right-hand axis. ``"reactions"``: per joint, magnitude, axial
        and radial parts of the reaction force [N] and of the reaction moment [N m] (the
        across-axis moment is the bending moment a bearing carries). ``"tracking"``: per joint,
        ``q_cmd - q`` with its largest value marked.

    Notes
    -----
    Series longer than :data:`MAX_POINTS` samples are drawn as min/max envelopes (see the module
    docstring), so plotting stays fast for runs of 10^6 cycles. A one-cycle spike of required
    effort or programmed acceleration (a velocity step in the program) is clipped so that it
    does not flatten the rest; its peak is then written in the corner of the axes.
    """
    if path is not None:
        refuse_existing([Path(path) / f"{name}.png" for name in FIGURES], overwrite)
    figs = {
        "motion": _motion_figure(result),
        "efforts": _efforts_figure(result),
        "reactions": _reactions_figure(result),
        "tracking": _tracking_figure(result),
    }
    if path is not None:
        folder = Path(path)
        folder.mkdir(parents=True, exist_ok=True)
        for name, fig in figs.items():
            _save_png(fig, folder / f"{name}.png")
    return figs


def refuse_existing(paths: Iterable[str | os.PathLike[str]], overwrite: bool) -> None:
    """FileExistsError naming the first of ``paths`` that exists, unless ``overwrite``."""
    if overwrite:
        return
    for p in map(Path, paths):
        if p.exists():
            raise FileExistsError(f"{p} exists; pass overwrite=True (CLI: --force)")


# --- Fig. 3 --------------------------------------------------------------------------------------
def fig3(robot: Robot, t: ArrayLike, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike) -> Figure:
    """The paper's Fig. 3 for ``robot`` along a trajectory.

    (a) Joint torques ``u_i`` by the RNEA (:func:`mrnea.inverse_dynamics`, lines) and by the
    mRNEA, ``H qdd + u'`` from :func:`mrnea.mass_matrix_and_bias` (markers). (b) The input
    accelerations (lines) and those :func:`mrnea.forward_dynamics` recovers from the RNEA
    torques (markers). The largest differences are printed in the titles.

    Parameters
    ----------
    robot : Robot
    t : (K,) array_like
        Time [s].
    q, qd, qdd : (K, n) array_like
        Joint positions, velocities and accelerations along the trajectory (SI units).

    Returns
    -------
    matplotlib.figure.Figure
        One row per joint; column (a) torques, column (b) accelerations.
    """
    t = np.asarray(t, dtype=float)
    qdd = np.asarray(qdd, dtype=float)
    if t.ndim != 1 or qdd.ndim != 2 or qdd.shape[0] != t.shape[0]:
        raise ValueError(f"fig3: expected t (K,) and q, qd, qdd (K, n); got t {t.shape}, "
                         f"qdd {qdd.shape}")
    u_rnea = inverse_dynamics(robot, q, qd, qdd)
    H, u_bias = mass_matrix_and_bias(robot, q, qd)
    u_mrnea = np.einsum("kij,kj->ki", H, qdd) + u_bias
    qdd_fd = forward_dynamics(robot, q, qd, u_rnea)
    du = np.abs(u_rnea - u_mrnea)
    da = np.abs(qdd_fd - qdd)
    rel_u = float(du.max() / max(_peak(u_rnea), 1e-300))
    rel_a = float(da.max() / max(_peak(qdd), 1e-300))

    n, units = robot.n, _units(robot)
    fig, axs = _grid(n, 2, 14.0, 1.7, top=1.15)
    every = max(1, t.shape[0] // 40)
    for i, (j, un) in enumerate(zip(robot.joints, units, strict=True)):
        a, b = axs[i]
        color = f"C{i % 10}"
        _plot(a, t, u_rnea[:, i], color=color, lw=1.4)
        a.plot(t[::every], u_mrnea[::every, i], "o", ms=4, mfc="none", color="k", mew=0.9)
        _plot(b, t, qdd[:, i], color=color, lw=1.4)
        b.plot(t[::every], qdd_fd[::every, i], "s", ms=4, mfc="none", color="k", mew=0.9)
        a.set_title(f"(a) {j.name}: u  (max |Δu| = {float(du[:, i].max()):.2e} {un['tau']})",
                    fontsize="medium", loc="left")
        b.set_title(f"(b) {j.name}: q̈  (max |Δq̈| = {float(da[:, i].max()):.2e} {un['qdd']})",
                    fontsize="medium", loc="left")
        a.set_ylabel(f"u [{un['tau']}]")
        b.set_ylabel(f"q̈ [{un['qdd']}]")
        for ax in (a, b):
            ax.grid(True, alpha=0.3)
    for ax in axs[-1]:
        ax.set_xlabel("time t [s]")
    _header(fig, (
        f"Fig. 3, {robot.name}: (a) joint torques, RNEA vs mRNEA: max difference "
        f"{du.max():.3e} (relative {rel_u:.3e})\n(b) input accelerations vs forward dynamics: "
        f"max difference {da.max():.3e} (relative {rel_a:.3e})"), [
        Line2D([], [], color="0.3", lw=1.4, label="(a) RNEA: inverse_dynamics"),
        Line2D([], [], color="k", marker="o", mfc="none", ls="", label="(a) mRNEA: H q̈ + u'"),
        Line2D([], [], color="0.3", lw=1.4, label="(b) input q̈"),
        Line2D([], [], color="k", marker="s", mfc="none", ls="",
               label="(b) forward_dynamics(q, q̇, u_RNEA)"),
    ])
    return fig


# --- HTML report ---------------------------------------------------------------------------------
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
    "efforts": "Applied joint effort, effort the program required (dashed) and ± the effort "
               "limit at the current speed; shaded: saturated. Right-hand axis: motor side "
               "(τ/G).",
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


def _kv_table(rows: Sequence[tuple[str, str]]) -> str:
    body = "".join(f'<tr><th class="l">{_e(k)}</th><td class="l">{_e(v)}</td></tr>'
                   for k, v in rows)
    return f"<table>{body}</table>"


def _time(t: float, dt: float) -> str:
    """``t`` with as many decimals as the cycle ``dt`` needs (at least 3)."""
    decimals = max(3, math.ceil(-math.log10(dt) - 1e-9)) if dt > 0 else 6
    return f"{t:.{decimals}f}"


def _first_infeasible_html(result: SimulationResult) -> str:
    fi = result.summary()["first_infeasible"]
    if fi is None:
        return "<p>None: every cycle stays within the effort, position and velocity limits.</p>"
    k, i = fi["cycle"], result.robot.joint_names.index(fi["joint"])
    u, j = _units(result.robot)[i], result.robot.joints[i]
    req, avail = fi["required_effort"], fi["available_effort"]
    ratio = abs(req) / avail if avail > 0 and math.isfinite(avail) else math.inf
    rows = [
        ("time", f"{_time(fi['time'], result.dt)} s (cycle {k:,})"),
        ("joint", fi["joint"]),
        ("reason", fi["reason"]),
        ("required effort", f"{_num(req)} {u['tau']}"),
        ("available effort (limit at that speed)", f"{_num(avail)} {u['tau']}"),
        ("required / available", f"{ratio:.3g}" if math.isfinite(ratio) else "∞"),
    ]
    nxt = min(k + 1, result.K - 1)  # cycle k heads for the command of row k + 1
    if result.position_clamped[k, i]:
        rows.append((f"commanded position at t = {_time(float(result.t[nxt]), result.dt)} s",
                     f"{_num(float(result.q_cmd[nxt, i]))} {u['q']}; joint range "
                     f"[{_num(j.lower)}, {_num(j.upper)}] {u['q']}"))
    if result.velocity_clamped[k, i] and nxt > k:
        rows.append((f"programmed velocity up to t = {_time(float(result.t[nxt]), result.dt)} s",
                     f"{_num(float(result.qd_cmd[nxt, i]))} {u['qd']}; limit "
                     f"±{_num(j.velocity_limit)} {u['qd']}"))
    return _kv_table(rows)


def _joints_html(result: SimulationResult) -> str:
    s = result.summary()
    units = _units(result.robot)
    with np.errstate(divide="ignore", invalid="ignore"):
        use = np.where(result.limit > 0, np.abs(result.tau) / result.limit, 0.0)
    use = np.nan_to_num(use, nan=0.0, posinf=0.0)
    head = ["joint", "type", "time saturated [s]", "saturated cycles",
            "clamped cycles (pos / vel)", "peak motor torque", "RMS motor torque",
            "peak effort / rated limit", "peak |τ| / limit at speed", "peak reaction force [N]",
            "peak axial force [N]", "peak radial force [N]", "peak reaction moment [N m]",
            "peak bending moment [N m]", "max tracking error", "at t [s]"]
    rows = [_row([_e(h) for h in head], head=True)]
    for i, (jd, j, u) in enumerate(zip(s["joints"], result.robot.joints, units, strict=True)):
        nsat = int(result.saturated[:, i].sum())
        npos = int(result.position_clamped[:, i].sum())
        nvel = int(result.velocity_clamped[:, i].sum())
        lim = jd["effort_limit"]
        pct = f" ({100 * jd['peak_effort'] / lim:.0f} %)" if 0 < lim < math.inf else ""
        cells = [
            jd["joint"], j.type, _num(jd["time_saturated"]), f"{nsat:,}", f"{npos:,} / {nvel:,}",
            f"{_num(jd['peak_motor_torque'])} {u['motor']}",
            f"{_num(jd['rms_motor_torque'])} {u['motor']}",
            f"{_num(jd['peak_effort'])} / {_num(lim)} {u['tau']}{pct}",
            f"{100 * float(use[:, i].max()) if use.size else 0.0:.1f} %",
            _num(jd["peak_reaction_force"]), _num(jd["peak_axial_force"]),
            _num(jd["peak_radial_force"]), _num(jd["peak_reaction_moment"]),
            _num(jd["peak_bending_moment"]),
            f"{_num(jd['max_tracking_error'])} {u['q']}",
            _time(jd["max_tracking_error_time"], result.dt),
        ]
        bad = nsat or npos or nvel
        rows.append(_row([_e(c) for c in cells], cls="sat" if bad else ""))
    return f'<div class="scroll"><table>{"".join(rows)}</table></div>'


def _params_html(result: SimulationResult) -> str:
    s = result.summary()
    from mrnea import __version__

    return _kv_table([
        ("robot", result.robot.name),
        ("degrees of freedom n", str(result.robot.n)),
        ("joints", ", ".join(result.robot.joint_names)),
        ("interpolation cycle dt", f"{result.dt:.6g} s"),
        ("cycles", f"{result.K:,}"),
        ("duration", f"{s['duration']:.6g} s"),
        ("saturation mode", result.mode),
        ("forward-dynamics engine", result.fd),
        ("run", "completed" if result.completed else "INTERRUPTED: partial result"),
        ("mrnea version", __version__),
    ])


def write_report(
    result: SimulationResult,
    path: str | os.PathLike[str],
    overwrite: bool = False,
    extra_figures: Mapping[str, Figure] | None = None,
) -> Path:
    """Write one self-contained HTML report of a simulation run.

    Contents, top to bottom: the verdict (:meth:`SimulationResult.verdict`), large, green when
    achievable, red when not (amber for an interrupted but so far achievable run); the first
    infeasible instant (time, joint, reason, required vs available effort); the per-joint table
    of :meth:`SimulationResult.summary` (time saturated, peak and RMS motor torque, peak effort
    vs limit, peak reaction force with its axial and radial parts, peak moment and bending
    moment, worst tracking error and when); the run parameters; the figures of
    :func:`plot_result` and then ``extra_figures``. Figures are embedded as base64 PNG data URIs
    and the style sheet is inline: the file needs no network, no other file and no JavaScript.

    Parameters
    ----------
    result : SimulationResult
    path : str or path-like
        The HTML file to write. Its folder is created if missing.
    overwrite : bool, default False
        Replace an existing file. Without it an existing file raises FileExistsError and is
        left untouched.
    extra_figures : mapping of str to matplotlib.figure.Figure, optional
        More figures to append, e.g. ``{"Fig. 3": fig3(robot, t, q, qd, qdd)}``.

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    FileExistsError
        If ``path`` exists and ``overwrite`` is False (checked before any work is done).
    """
    path = Path(path)
    writer = atomic_write(path, overwrite)  # refuses an existing file before any rendering
    path.parent.mkdir(parents=True, exist_ok=True)
    s = result.summary()
    verdict = result.verdict()
    cls = "bad" if not s["achievable"] else "ok" if result.completed else "partial"

    figures = list(plot_result(result).items())
    if extra_figures:
        figures += list(extra_figures.items())
    fig_html = []
    for k, (name, fig) in enumerate(figures):
        caption = f": {_e(_CAPTIONS[name])}" if name in _CAPTIONS else ""
        slug = re.sub(r"[^A-Za-z0-9_-]+", "-", str(name)).strip("-")
        fig_html.append(
            f'<figure id="fig{k + 1}-{slug}"><img alt="{_e(name)}" src="{_png_data_uri(fig)}">'
            f"<figcaption><b>{_e(name)}</b>{caption}</figcaption></figure>")

    stamp = datetime.now(UTC).strftime("%Y-%m-%d %H:%M:%S UTC")
    doc = f"""<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{_e(f"mrnea simulation report: {result.robot.name}")}</title>
<style>{_CSS}</style>
</head>
<body>
<h1>Simulation report: {_e(result.robot.name)}</h1>
<p class="note">Will the robot make the programmed motion? Generated {_e(stamp)} by mrnea.</p>
<div class="verdict {cls}" id="verdict">{_e(verdict)}</div>
<h2>First infeasible instant</h2>
{_first_infeasible_html(result)}
<h2>Per joint</h2>
{_joints_html(result)}
<p class="note">Efforts are joint side (N m for revolute, N for prismatic joints); motor torque
is τ/G. Reaction loads are in each joint's frame: axial along the joint axis, radial / bending
across it. Rows in red: the joint saturated or its command was clamped.</p>
<h2>Run parameters</h2>
{_params_html(result)}
<details><summary>Robot model</summary><pre>{_e(result.robot.describe())}</pre></details>
<h2>Figures</h2>
<p class="note">Series longer than {MAX_POINTS:,} samples are drawn as min/max envelopes;
peaks are exact.</p>
{"".join(fig_html)}
</body>
</html>
"""
    with writer as fh:
        fh.write(doc)
    try:  # atomic_write's temporary file is mode 0600; give the report the usual permissions
        os.chmod(path, _file_mode())
    except OSError:
        pass
    return path
