"""Figures and the HTML page of a design sweep (``sweep.html``), from :func:`mrnea.sweep`'s rows.

* :func:`feasibility_map` -- achievable or not over two swept parameters, each cell coloured by
  the worst program effort ratio and marked with the limiting joint; a third swept parameter
  gives one panel per value (at most :data:`MAX_PANELS`).
* :func:`load_curves` -- against one swept parameter: the peak motor torque the program asks
  of each joint, and each joint's peak reaction force and moment (the bearing loads).
* :func:`write_sweep_html` -- one self-contained page: counts, both figures (PNG data URIs) and
  the rows.

Over several programs a variant is judged as a whole, as a designer sizes it: achievable when
every program is, its effort ratio and loads the largest over the programs, its limiting joint
that of its worst program. The figures are drawn on Agg without pyplot
(:mod:`mrnea.report.drawing`); names go through :func:`~mrnea.report.drawing.label`.
"""

from __future__ import annotations

import html
import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from matplotlib.colors import TwoSlopeNorm
from matplotlib.figure import Figure
from matplotlib.patches import Patch, Rectangle

from mrnea.errors import OutputError, StateError, quote, shorten
from mrnea.io.source import as_path
from mrnea.io.writer import check_new, write_file
from mrnea.report.drawing import MAX_JOINTS, label, new_figure, png_data_uri
from mrnea.report.html import FIGSCROLL_CSS, page, stamp

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["feasibility_map", "load_curves", "swept_parameters", "write_sweep_html"]

MAX_PANELS = 6
"""At most this many panels of the feasibility map (values of the other swept parameters)."""
MAX_LABELLED_CELLS = 400
"""Cells of a map panel beyond which they are coloured only, not labelled."""
MAX_TABLE_ROWS = 300
"""Rows shown in the page's table (the CSV has them all)."""

_CSS = """body{font-family:-apple-system,"Segoe UI",Helvetica,Arial,sans-serif;max-width:1400px;
margin:0 auto;padding:1em 2em;color:#222}h1{font-size:1.4em}h2{font-size:1.15em;
border-bottom:1px solid #ccc}table{border-collapse:collapse;font-size:0.85em}
td,th{border:1px solid #ccc;padding:2px 6px;text-align:right}th{background:#f0f0f0}
tr.bad td{background:#fdecea}tr.err td{background:#eee}.note{color:#555;font-size:0.88em}
figure img{max-width:100%;height:auto;border:1px solid #ddd}.scroll{overflow-x:auto}
""" + FIGSCROLL_CSS


def _require_frame(df: object) -> None:
    import pandas as pd

    if not isinstance(df, pd.DataFrame) or not {"program", "error", "achievable"} <= set(
            df.columns):
        raise StateError(f"df: expected the DataFrame of mrnea.sweep, got "
                         f"{type(df).__name__}")


def _keys(df: pd.DataFrame, keys: Sequence[str] | None) -> list[str]:
    """The swept parameters: ``keys`` (checked against the columns), else the columns before
    ``program``."""
    cols = list(df.columns)
    if keys is None:
        return cols[:cols.index("program")]
    if not isinstance(keys, (list, tuple)) or not all(isinstance(k, str) for k in keys):
        raise StateError(f"keys: expected a list of swept parameters, got {quote(keys)}")
    for k in keys:
        if k not in cols:
            raise StateError(f"keys: {quote(k)} is not a column of the sweep")
    return list(keys)


def swept_parameters(df: pd.DataFrame, keys: Sequence[str] | None = None) -> list[str]:
    """The swept parameters a figure can use: numeric, more than one value, in grid order."""
    import pandas as pd

    _require_frame(df)
    return [k for k in _keys(df, keys) if pd.api.types.is_numeric_dtype(df[k])
            and df[k].nunique() > 1]


def _axis(df: pd.DataFrame, key: str) -> str:
    """A parameter's axis label: its name and unit (``df.attrs["units"]``, set by the sweep)."""
    unit = df.attrs.get("units", {}).get(key, "")
    return f"{label(key)} [{unit}]" if unit else label(key)


def _per_variant(df: pd.DataFrame, keys: Sequence[str]) -> pd.DataFrame:
    """One row per variant (over its programs): ``achievable`` (all), ``failed`` (any error),
    ``ratio`` (the largest worst effort ratio), ``limit`` (the limiting joint of the worst
    program: its first infeasible joint, else its worst joint)."""
    import pandas as pd

    d = df.assign(_limit=df["first_infeasible_joint"].where(
        df["first_infeasible_joint"].notna(), df["worst_joint"]))
    ratio = pd.to_numeric(d["worst_effort_ratio"], errors="coerce")
    group = [d[k].map(repr) for k in keys] if keys else np.zeros(len(d))
    out = []
    for _, g in d.groupby(group, sort=False):
        r = ratio.loc[g.index]
        worst = r.idxmax() if r.notna().any() else None
        out.append({**{k: g[k].iloc[0] for k in keys},
                    "achievable": bool(g["achievable"].fillna(False).all()),
                    "failed": bool(g["error"].notna().any()),
                    "ratio": r.max() if worst is not None else math.nan,
                    "limit": None if worst is None else g.loc[worst, "_limit"]})
    return pd.DataFrame(out)


def _facets(v: pd.DataFrame, others: Sequence[str]) -> tuple[list[tuple[str, pd.DataFrame]],
                                                             str]:
    """Panels over the other swept parameters (at most :data:`MAX_PANELS`; beyond that, only
    their first values, said in the title)."""
    if not others:
        return [("", v)], ""
    groups = list(v.groupby([v[k].map(repr) for k in others], sort=False))
    if len(groups) <= MAX_PANELS:
        return [(", ".join(f"{label(k)} = {g[k].iloc[0]}" for k in others), g)
                for _, g in groups], ""
    g = groups[0][1]
    note = ", ".join(f"{label(k)} = {g[k].iloc[0]}" for k in others)
    return [(note, g)], f" (only {note}: {len(groups)} combinations of the others)"


def feasibility_map(df: pd.DataFrame, x: str, y: str, keys: Sequence[str] | None = None
                    ) -> Figure:
    """Achievable or not over two swept parameters ``x`` and ``y``.

    Each cell is a variant, coloured by its worst program effort ratio (green below 1, red
    above; the largest over its programs) and labelled with its limiting joint and that ratio
    (up to :data:`MAX_LABELLED_CELLS` cells); not achievable: hatched; a failed variant: grey.
    The other swept parameters of ``keys`` (default: every parameter column) give one panel per
    combination.
    """
    keys = _keys(df, keys)
    for name, k in (("x", x), ("y", y)):
        if k not in swept_parameters(df, keys):
            raise StateError(f"{name}: {quote(k)} is not a swept numeric parameter with two "
                             f"values or more")
    keys = list(dict.fromkeys([x, y, *keys]))
    v = _per_variant(df, keys)
    others = [k for k in keys if k not in (x, y) and v[k].map(repr).nunique() > 1]
    panels, note = _facets(v, others)
    xs, ys = sorted(v[x].unique()), sorted(v[y].unique())
    ratios = v["ratio"].to_numpy(dtype=float)
    finite = ratios[np.isfinite(ratios)]
    lo = float(finite.min()) if finite.size else 0.5
    hi = float(finite.max()) if finite.size else 1.5
    norm = TwoSlopeNorm(vcenter=1.0, vmin=min(lo, 0.99), vmax=max(hi, 1.01))
    cols = min(len(panels), 3)
    rows = -(-len(panels) // cols)
    width = min(6.0, 0.9 * len(xs) + 1.6)
    height = min(6.0, 0.55 * len(ys) + 1.6)
    fig = new_figure(cols * width + 1.6, rows * height + 1.0)
    fig.set_layout_engine("constrained")
    axes = fig.subplots(rows, cols, squeeze=False)
    labelled = len(xs) * len(ys) <= MAX_LABELLED_CELLS
    mesh = None
    for ax, (title, g) in zip(axes.flat, panels, strict=False):
        grid = np.full((len(ys), len(xs)), np.nan)
        for _, r in g.iterrows():
            i, j = ys.index(r[y]), xs.index(r[x])
            grid[i, j] = r["ratio"]
            if not math.isfinite(r["ratio"]):
                ax.add_patch(Rectangle((j - 0.5, i - 0.5), 1, 1, color="0.75"))
                if labelled:
                    ax.text(j, i, "error" if r["failed"] else "no limit", ha="center",
                            va="center", fontsize=7)
                continue
            if not r["achievable"]:
                ax.add_patch(Rectangle((j - 0.5, i - 0.5), 1, 1, fill=False, hatch="///",
                                       edgecolor="0.3", linewidth=0))
            if labelled:
                ax.text(j, i, f"{label(shorten(str(r['limit'] or ''), 16))}\n{r['ratio']:.2f}",
                        ha="center", va="center", fontsize=7,
                        fontweight="normal" if r["achievable"] else "bold")
        mesh = ax.imshow(np.ma.masked_invalid(grid), origin="lower", cmap="RdYlGn_r",
                         norm=norm, aspect="auto",
                         extent=(-0.5, len(xs) - 0.5, -0.5, len(ys) - 0.5))
        step_x, step_y = max(1, len(xs) // 12), max(1, len(ys) // 12)
        ax.set_xticks(range(0, len(xs), step_x), [f"{a:g}" for a in xs[::step_x]], fontsize=8)
        ax.set_yticks(range(0, len(ys), step_y), [f"{a:g}" for a in ys[::step_y]], fontsize=8)
        ax.set_xlabel(_axis(df, x))
        ax.set_ylabel(_axis(df, y))
        ax.set_title(title, fontsize=9)
    for ax in axes.flat[len(panels):]:
        ax.set_visible(False)
    fig.colorbar(mesh, ax=axes.ravel().tolist(), label="worst program effort ratio",
                 shrink=0.9)
    fig.legend(handles=[Patch(facecolor="white", edgecolor="0.3", hatch="///",
                              label="not achievable"),
                        Patch(facecolor="white", edgecolor="0.3", label="achievable"),
                        Patch(color="0.75", label="failed, or no effort limit")],
               loc="outside lower center", ncols=3, fontsize=8, frameon=False)
    fig.suptitle(f"Feasibility: {label(y)} vs {label(x)}{note}", fontsize=10)
    return fig


def _joint_columns(df: pd.DataFrame, *names: str) -> tuple[str, dict[str, str]]:
    """The first of ``names`` the rows have, and its column per joint (by joint name)."""
    for name in names:
        cols = {c.split(".", 1)[1]: c for c in df.columns if c.startswith(f"{name}.")}
        if cols:
            return name, cols
    return names[0], {}


def _shown(df: pd.DataFrame, joints: Sequence[str]) -> list[str]:
    """The joints the curves draw: all, or the :data:`MAX_JOINTS` whose program effort ratio
    comes closest to (or goes furthest over) their limit, in chain order."""
    if len(joints) <= MAX_JOINTS:
        return list(joints)
    import pandas as pd

    def worst(j: str) -> float:
        col = f"program_effort_ratio.{j}"
        v = pd.to_numeric(df[col], errors="coerce").max() if col in df else math.nan
        return -math.inf if not math.isfinite(v) else float(v)

    top = set(sorted(joints, key=worst, reverse=True)[:MAX_JOINTS])
    return [j for j in joints if j in top]


def load_curves(df: pd.DataFrame, x: str, keys: Sequence[str] | None = None) -> Figure:
    """Against the swept parameter ``x``: the peak motor torque the program asks of each joint
    (the largest over the programs), and each joint's peak reaction force and moment.

    The other swept parameters of ``keys`` are held at the combination with the most
    achievable rows (the first such; said in the title). Values of ``x`` where the variant is
    not achievable are shaded red. At most :data:`MAX_JOINTS` joints are drawn.
    """
    import pandas as pd

    keys = _keys(df, keys)
    if x not in swept_parameters(df, keys):
        raise StateError(f"x: {quote(x)} is not a swept numeric parameter with two values or "
                         "more")
    others = [k for k in keys if k != x and df[k].map(repr).nunique() > 1]
    sel, fixed = df, ""
    if others:
        combo = pd.Series(list(zip(*(df[k].map(repr) for k in others), strict=True)),
                          index=df.index)
        best = df["achievable"].fillna(False).astype(bool).groupby(combo, sort=False).sum()
        sel = df[combo == best.idxmax()]
        fixed = ", ".join(f"{label(k)} = {sel[k].iloc[0]}" for k in others)
    sel = sel[sel["error"].isna()]
    panels = [(*_joint_columns(sel, "program_peak_motor_torque", "peak_motor_torque"), "N m"),
              (*_joint_columns(sel, "peak_reaction_force"), "N"),
              (*_joint_columns(sel, "peak_reaction_moment"), "N m")]
    fig = new_figure(12.0, 3.8)
    axes = fig.subplots(1, 3)
    fig.subplots_adjust(left=0.06, right=0.99, bottom=0.15, top=0.8, wspace=0.3)
    grouped = sel.groupby(x, sort=True)
    ok = grouped["achievable"].apply(lambda s: bool(s.fillna(False).all()))
    xs = ok.index.to_numpy(dtype=float)
    half = float(np.diff(xs).min()) / 2 if len(xs) > 1 else 0.5
    shown = _shown(sel, list(panels[0][1]))
    for ax, (name, cols, unit) in zip(axes, panels, strict=True):
        top = 0.0
        for joint in shown:
            if joint in cols:
                ys = pd.to_numeric(grouped[cols[joint]].max(), errors="coerce").to_numpy(
                    dtype=float)
                ax.plot(xs, ys, marker="o", ms=3, label=label(joint))
                top = max(top, float(np.nanmax(ys, initial=0.0)))
        for k in np.flatnonzero(~ok.to_numpy()):
            ax.axvspan(xs[k] - half, xs[k] + half, color="#d62728", alpha=0.12, lw=0)
        ax.set_title(f"{name} [{unit}]", fontsize=9)
        ax.set_xlabel(_axis(df, x))
        ax.grid(alpha=0.3)
        low = [ln.get_ydata().min() for ln in ax.get_lines()]
        if name.endswith("motor_torque") and low and min(low) > 0 and top > 30 * min(low):
            ax.set_yscale("log")  # the drives' torques differ by orders of magnitude
    if shown:
        axes[0].legend(fontsize=7)
    joints = len(panels[0][1])
    more = "" if len(shown) == joints else f"; {len(shown)} joints of {joints}"
    note = f" ({fixed}{more})" if fixed or more else ""
    fig.suptitle(f"Peak motor torque and bearing loads vs {label(x)}{note}; red: not "
                 "achievable", fontsize=10)
    return fig


def _fmt(v: Any) -> str:
    """A table cell: empty for a missing value, 4 significant digits for a float."""
    import pandas as pd

    if v is None or (np.ndim(v) == 0 and not isinstance(v, str) and pd.isna(v)):
        return ""
    if isinstance(v, (float, np.floating)):
        return f"{v:.4g}"
    return str(v)


def write_sweep_html(df: pd.DataFrame, path: str | os.PathLike[str], robot: str,
                     keys: Sequence[str] | None = None,
                     map_axes: tuple[str, str] | None = None, curves: str | None = None,
                     overwrite: bool = False) -> Path:
    """Write ``sweep.html``: the counts, the feasibility map, the load curves and the rows.

    Parameters
    ----------
    df : pandas.DataFrame
        :func:`mrnea.sweep`'s rows.
    path : str or path-like
        The file to write (its folder must exist).
    robot : str
        The base robot's name, for the title.
    keys : list of str, optional
        The swept parameters (default: the columns before ``program``).
    map_axes : (str, str), optional
        The map's two parameters (default: the first two numeric swept parameters; no map if
        there are fewer).
    curves : str, optional
        The curves' parameter (default: the first numeric swept parameter).
    overwrite : bool
        Replace an existing file (written through :func:`mrnea.io.writer.write_file`).

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    _require_frame(df)
    path = as_path(path, "path", OutputError)
    if not isinstance(robot, str):
        raise StateError(f"robot: expected the robot's name (str), got {quote(robot)}")
    check_new([path], overwrite)  # before any rendering
    keys = _keys(df, keys)
    num = swept_parameters(df, keys)
    if map_axes is not None and (not isinstance(map_axes, (tuple, list)) or len(map_axes) != 2
                                 or not all(k in keys for k in map_axes)):
        raise StateError(f"map_axes: expected two of the swept parameters ({', '.join(keys)}), "
                         f"got {quote(map_axes)}")
    if curves is not None and curves not in keys:
        raise StateError(f"curves: expected one of the swept parameters ({', '.join(keys)}), "
                         f"got {quote(curves)}")
    map_axes = tuple(map_axes) if map_axes else (tuple(num[:2]) if len(num) >= 2 else ())
    curves = curves if curves is not None else (num[0] if num else None)
    ran = df["error"].isna().any()  # else all failed, or interrupted before a row
    figs, skipped = [], []
    for name, params, draw in (("Feasibility map", map_axes, feasibility_map),
                               ("Loads", (curves,) if curves else (), load_curves)):
        if ran and params and all(k in num for k in params):
            figs.append((name, draw(df, *params, keys=keys)))
        elif params:  # the rows done do not vary it (an interrupted sweep), or none ran
            skipped.append(f"{name} over {', '.join(params)}: not drawn, the rows hold fewer "
                           "than two of its values")
    e = html.escape
    shown = [*keys, "program", "achievable", "worst_joint", "worst_effort_ratio",
             "first_infeasible_time", "first_infeasible_joint", "error"]
    head = "".join(f"<th>{e(c)}</th>" for c in shown)
    body = []
    for _, r in df.head(MAX_TABLE_ROWS).iterrows():
        cls = ' class="err"' if isinstance(r["error"], str) else (
            "" if r["achievable"] is True else ' class="bad"')
        body.append(f"<tr{cls}>" + "".join(f"<td>{e(_fmt(r.get(c)))}</td>" for c in shown)
                    + "</tr>")
    done = df.attrs.get("completed", True)
    counts = (f"{len(df)} rows ({df['program'].nunique()} program(s)); "
              f"{int(df['achievable'].fillna(False).sum())} achievable, "
              f"{int(df['error'].notna().sum())} failed"
              + ("" if done else f"; INTERRUPTED: {len(df)} of {df.attrs.get('cases')} done"))
    more = (f'<p class="note">The first {MAX_TABLE_ROWS} of {len(df)} rows; sweep.csv has all '
            "of them.</p>" if len(df) > MAX_TABLE_ROWS else "")
    images = "".join(f'<figure><div class="figscroll"><img alt="{e(n)}" '
                     f'src="{png_data_uri(f)}"></div><figcaption>{e(n)}</figcaption></figure>'
                     for n, f in figs)
    content = f"""<p>{e(counts)}</p>
<p class="note">Generated {e(stamp())} by mrnea. Effort ratio: the largest |effort the program
asks for| / the limit at that speed, over the cycles and the joints; above 1 the program needs
more than a drive has. Map cells: the limiting joint (the first infeasible one, else the one
closest to its limit) and the ratio; a variant is judged over all its programs.</p>
{images}{"".join(f'<p class="note">{e(x)}</p>' for x in skipped)}
<h2>Rows</h2>
{more}<div class="scroll"><table><tr>{head}</tr>
{"".join(body)}
</table></div>"""
    return write_file(path, page(f"mrnea sweep: {robot}", f"Design sweep: {robot}", content,
                                 css=_CSS), overwrite)
