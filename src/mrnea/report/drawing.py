"""Drawing helpers shared by the report's figures: canvases, axes grids, decimation, shading,
axis scaling, number formatting, and saving a figure through :mod:`mrnea.io.writer`.

Rendering uses matplotlib's object-oriented API with the Agg canvas
(:class:`matplotlib.figure.Figure` + :class:`~matplotlib.backends.backend_agg.FigureCanvasAgg`);
``matplotlib.pyplot`` and the global backend are never touched, so the report works headless
and does not disturb an interactive session. The figures are not registered with pyplot: save
them with :func:`save_figure` or ``fig.savefig(...)``.

Decimation. A run can hold 10^6 cycles; plotting every sample would be slow and no more
informative at screen resolution. Every time series with more than :data:`MAX_POINTS` samples is
reduced to a min/max envelope: the samples are split into ``MAX_POINTS // 2`` consecutive buckets
and each bucket contributes its minimum and its maximum, in time order (plus the first and last
samples). Peaks, spikes and the extent of oscillations are therefore kept exactly; only the detail
inside a bucket (at most ``2 K / MAX_POINTS`` cycles) is lost. Shaded intervals (saturation,
clamps) are computed at full resolution, merged where the gap between two intervals is below
1/1500 of the run's duration, and drawn at least 1/600 of the duration wide so that a one-cycle
saturation stays visible. Tables in the report always use the full-resolution data.

Names. Any legal joint, link or robot name is drawn as it is written: :func:`label` escapes
``$`` (matplotlib would otherwise read ``a$\\frac$1`` as math text and fail when the figure is
drawn) and shortens long names; a character the font lacks is drawn as a box, without a warning.
Figures of a robot with many joints draw at most :data:`MAX_JOINTS` of them (the report's tables
and the CSV have every joint).
"""

from __future__ import annotations

import base64
import contextlib
import io
import math
import os
import warnings
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from numpy.typing import NDArray

from mrnea.errors import OutputError, quote, shorten
from mrnea.io.writer import create
from mrnea.model import JOINT_UNITS

if TYPE_CHECKING:
    from matplotlib.axes import Axes

    from mrnea.model import Robot

MAX_POINTS = 5000
"""At most about this many points are drawn per line (see the module docstring)."""

DPI = 100
MAX_JOINTS = 12
"""At most this many joints are drawn in a figure (one row of axes each)."""
LABEL_LIMIT = 60
"""Names longer than this are shortened in figures (:func:`label`)."""
FORMATS = ("png", "pdf", "svg", "svgz", "eps", "ps", "jpg", "jpeg", "tif", "tiff", "webp")
"""The file suffixes :func:`save_figure` writes (matplotlib's formats that need no LaTeX)."""

_MERGE = 1500  # shaded intervals closer than duration / _MERGE are merged
_MIN_SHADE = 600  # shaded intervals are drawn at least duration / _MIN_SHADE wide
_OFF_SCALE = 3.0  # a series more than this times the axis' core range is drawn off scale


def label(name: str) -> str:
    """A name as matplotlib text: at most :data:`LABEL_LIMIT` characters, every ``$`` escaped so
    that nothing in it is read as math text."""
    return shorten(str(name), LABEL_LIMIT).replace("$", "\\$")


@contextlib.contextmanager
def _rendering() -> Iterator[None]:
    """While a figure is drawn: a character missing from the font is drawn as a box, silently
    (a name may use any script; the file is still right)."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Glyph .* missing from", category=UserWarning)
        yield


def new_figure(width: float, height: float) -> Figure:
    """A Figure on its own Agg canvas (no pyplot, no global state)."""
    fig = Figure(figsize=(width, height), dpi=DPI)
    FigureCanvasAgg(fig)
    return fig


def axes_grid(nrows: int, ncols: int, width: float, row_height: float, *, left: float = 0.95,
              right: float = 0.3, top: float = 0.95, bottom: float = 0.55, hgap: float = 0.5,
              wgap: float = 0.85) -> tuple[Figure, NDArray]:
    """A figure with an ``nrows x ncols`` grid of axes sharing x, margins given in inches.

    The layout is fixed rather than "constrained": constrained layout measures every text
    twice and roughly doubles the rendering time of these many-axes figures. ``top`` leaves
    room for the suptitle and the figure legend, ``hgap`` for each axes' title.
    """
    height = top + bottom + nrows * row_height + (nrows - 1) * hgap
    fig = new_figure(width, height)
    axw = (width - left - right - (ncols - 1) * wgap) / ncols
    axs = fig.subplots(nrows, ncols, sharex=True, squeeze=False, gridspec_kw={
        "left": left / width, "right": 1 - right / width, "top": 1 - top / height,
        "bottom": bottom / height, "hspace": hgap / row_height, "wspace": wgap / axw})
    for ax in axs.flat:
        ax.yaxis.set_offset_position("right")  # a "1e-5" multiplier must not hit the title
    return fig, axs


def header(fig: Figure, title: str, handles: list[Any]) -> None:
    """Suptitle and one legend for the whole figure, above the axes (fixed offsets in inches)."""
    h = fig.get_figheight()
    lines = title.count("\n") + 1
    fig.suptitle(title, y=1 - 0.1 / h, va="top", fontweight="bold")
    fig.legend(handles=handles, loc="upper center",
               bbox_to_anchor=(0.5, 1 - (0.12 + 0.24 * lines) / h),
               ncols=min(len(handles), 5), fontsize="small", frameon=False)


def envelope(t: NDArray, y: NDArray, max_points: int = MAX_POINTS) -> tuple[NDArray, NDArray]:
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


def plot_line(ax: Axes, t: NDArray, y: NDArray, **kw: Any) -> Line2D:
    """``ax.plot`` of the series, decimated by :func:`envelope`."""
    tt, yy = envelope(t, y)
    return ax.plot(tt, yy, **kw)[0]


def intervals(t: NDArray, mask: NDArray, dt: float) -> list[tuple[float, float]]:
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


def shade(ax: Axes, t: NDArray, mask: NDArray, dt: float, color: str) -> bool:
    """Shade the intervals where ``mask`` holds over the full height of ``ax``."""
    spans = intervals(t, mask, dt)
    if spans:
        ax.broken_barh(spans, (0, 1), transform=ax.get_xaxis_transform(), facecolor=color,
                       alpha=0.18, linewidth=0, zorder=0)
    return bool(spans)


def peak(a: NDArray) -> float:
    a = np.abs(a[np.isfinite(a)])
    return float(a.max()) if a.size else 0.0


def fit_ylim(ax: Axes, core: Sequence[NDArray],
              optional: Sequence[tuple[str, NDArray]], unit: str = "") -> None:
    """Scale the y axis to ``core`` and to each ``optional`` series unless it would dwarf them.

    An optional series whose peak exceeds :data:`_OFF_SCALE` times the range so far (e.g. the
    one-cycle spike of required effort a velocity step in the program causes, or an effort limit
    of 1e9) is drawn clipped, scaled by its 99.5th percentile if that fits, and its peak is noted
    in the corner of the axes, with ``unit`` (the axis' unit; "" for a ratio).
    """
    top = max((peak(a) for a in core), default=0.0)
    notes = []
    clipped = False
    for label, a in optional:
        finite = np.abs(a[np.isfinite(a)])
        if finite.size == 0:
            continue
        highest = float(finite.max())
        if top == 0.0 or highest <= _OFF_SCALE * top:
            top = max(top, highest)
            continue
        clipped = True
        robust = float(np.quantile(finite, 0.995))
        if robust <= _OFF_SCALE * top:
            top = max(top, robust)
        notes.append(f"{label} peak {fmt_number(highest)}{f' {unit}' if unit else ''} off scale")
    if clipped and top > 0:
        ax.set_ylim(-1.1 * top, 1.1 * top)
        ax.text(0.995, 0.97, "; ".join(notes), transform=ax.transAxes, ha="right", va="top",
                fontsize="x-small", color="0.3",
                bbox={"boxstyle": "round,pad=0.2", "fc": "white", "ec": "0.7", "alpha": 0.85})


def joint_units(robot: Robot) -> list[dict[str, str]]:
    """Per joint: SI units of position, velocity, acceleration and effort (``Joint.unit``, with
    a superscript ²), and of the motor-side torque."""
    return [{**{q: j.unit(q).replace("^2", "²") for q in JOINT_UNITS},
             "motor": "N m or N" if j.is_prismatic else "N m"} for j in robot.joints]


def fmt_number(x: float, sig: int = 4) -> str:
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


def png_bytes(fig: Figure, dpi: float = DPI) -> bytes:
    """``fig`` drawn as a PNG file at ``dpi``, without a version stamp (the bytes
    :func:`save_figure` writes for a ``.png`` path)."""
    buf = io.BytesIO()
    with _rendering():
        fig.savefig(buf, format="png", dpi=dpi, metadata={"Software": None})
    return buf.getvalue()


def png_data_uri(fig: Figure | bytes) -> str:
    """``fig``, or a PNG already drawn by :func:`png_bytes`, as a ``data:image/png;base64,...``
    URI (for a self-contained HTML page)."""
    png = fig if isinstance(fig, bytes) else png_bytes(fig)
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")


def figure_file(path: str | os.PathLike[str]) -> tuple[Path, str]:
    """The file :func:`save_figure` writes for ``path``, and its format.

    The suffix names the format (one of :data:`FORMATS`, any case); without a suffix the figure
    is a PNG and ``.png`` is appended (as matplotlib does), so ``fig`` writes ``fig.png``.

    Raises
    ------
    OutputError
        An unsupported suffix, ``path`` is a directory, or it names one (``"new/"``, ``"x/."``,
        ``"x/.."``: a folder meant, not ``new.png`` beside it).
    """
    text = os.fspath(path)
    if isinstance(text, str) and os.path.basename(text) in ("", ".", ".."):
        raise OutputError(f"path: {quote(text)} names a folder; name the figure file to write "
                          f"(such as {quote(os.path.join(text, 'figure.png'))})")
    path = Path(path)
    fmt = path.suffix[1:].lower()
    if not fmt:
        if os.path.isdir(path):
            raise OutputError(f"{path} is a directory; name the figure file to write")
        return path.with_name(f"{path.name}.png"), "png"
    if fmt not in FORMATS:
        raise OutputError(f"{path}: unsupported figure format {path.suffix!r}; use one of "
                          + ", ".join(f".{f}" for f in FORMATS))
    return path, fmt


def save_figure(fig: Figure, path: str | os.PathLike[str], overwrite: bool = False,
                dpi: float = DPI) -> Path:
    """Write ``fig`` to :func:`figure_file`'s file for ``path`` through
    :func:`mrnea.io.writer.create` (whole or not at all, never through a link, an existing file
    replaced only with ``overwrite``).

    Returns
    -------
    pathlib.Path
        The file written.

    Raises
    ------
    OutputError
        An unsupported suffix, a directory at or named by ``path``, an existing file without
        ``overwrite``.
    """
    path, fmt = figure_file(path)
    meta = {"Software": None} if fmt == "png" else None  # no version stamp: reproducible PNGs
    with create(path, overwrite, binary=True) as fh, _rendering():
        fig.savefig(fh, format=fmt, dpi=dpi, metadata=meta)
    return path
