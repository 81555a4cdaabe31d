"""The report's 3D view as an HTML fragment: canvas, controls, the embedded scene
(:mod:`mrnea.report.view3d`) and two inline scripts, the vendored three.js subset and the
viewer (``assets/view3d.js``). It works from ``file://`` and makes no request.

The viewer: orbit, zoom and pan (three.js's OrbitControls), play and pause, a time slider
(``<input type="range">`` labelled "time [s]") on the cycle clock, the playback speed, and
``#t=SECONDS`` in the page's address opens the view paused at that instant (links to instants
elsewhere in the report use it). The robot as it really moves is drawn solid, as the program
commands it translucent (the ghost); the end-effector paths of both; a saturating joint's link
in red while it saturates. The report's figures carry ``data-xaxes`` (:func:`figure_axes`): the
viewer marks the slider's time on every time axis, and a click on an axes moves the view there.

Assets (``mrnea/report/assets``): ``three-subset.min.js.gz`` is three.js r187 (MIT licence,
``LICENSE-three.txt``: the report carries the notice), the part ``entry.js`` lists bundled into
one classic script by ``build-three.sh`` (pinned versions; it rebuilds the script byte for
byte), stored gzip-compressed (third-party minified code, 0.57 MB plain) and inlined plain.
"""

from __future__ import annotations

import gzip
import html
import json
import math
from functools import cache
from importlib import resources
from typing import Any

from matplotlib.figure import Figure

SPEEDS = (0.1, 0.25, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0)
"""Playback speeds offered; the default is the smallest >= 1 that plays the run in <= 90 s."""
THREE_VERSION = "r187"

CSS = """
.mv3d { margin: 0.6em 0 1.4em 0; }
.mv3d-stage { position: relative; width: 100%; height: clamp(320px, 62vh, 600px);
              border: 1px solid #ddd; border-radius: 4px; overflow: hidden; background: #fafbfc; }
.mv3d-stage canvas { display: block; width: 100%; height: 100%; touch-action: none; }
.mv3d-legend { position: absolute; left: 0.6em; top: 0.6em; background: rgba(255,255,255,0.88);
               border: 1px solid #ddd; border-radius: 4px; padding: 0.35em 0.6em;
               font-size: 0.82em; line-height: 1.55; pointer-events: none; }
.mv3d-legend i { display: inline-block; width: 1.6em; height: 0.75em; margin-right: 0.45em;
                 vertical-align: -0.05em; border-radius: 2px; }
.mv3d-legend i.real { background: #5b7fa6; }
.mv3d-legend i.ghost { background: rgba(140,140,140,0.25); border: 1px solid #8c8c8c; }
.mv3d-legend i.sat { background: #d62728; }
.mv3d-legend i.tr { height: 0; border-radius: 0; border-top: 2px solid #1f77b4; }
.mv3d-legend i.tc { height: 0; border-radius: 0; border-top: 2px dashed #595959; }
.mv3d-legend i.tg { background: #c51b8a; width: 0.75em; border-radius: 50%; }
.mv3d-legend .mv3d-axes { color: #666; }
.mv3d-sat { position: absolute; right: 0.7em; top: 0.6em; color: #fff; background: #d62728;
            border-radius: 4px; padding: 0.2em 0.6em; font-weight: bold; font-size: 0.9em; }
.mv3d-sat:empty { display: none; }
.mv3d-hint { position: absolute; right: 0.7em; bottom: 0.5em; color: #777; font-size: 0.78em;
             pointer-events: none; }
.mv3d-nogl-msg { display: none; padding: 1.5em 2em; color: #555; }
.mv3d-nogl canvas { display: none; }
.mv3d-nogl .mv3d-nogl-msg { display: block; }
.mv3d-stage.mv3d-nogl { height: auto; min-height: 5em; }
.mv3d-nogl .mv3d-legend, .mv3d-nogl .mv3d-hint, .mv3d-nogl ~ .mv3d-controls { display: none; }
.mv3d-controls { display: flex; flex-wrap: wrap; align-items: center; gap: 0.4em 0.8em;
                 margin-top: 0.45em; font-size: 0.92em; }
.mv3d-controls input[type=range] { flex: 1 1 18em; min-width: 12em; }
.mv3d-controls output { font-variant-numeric: tabular-nums; min-width: 6.5em; }
.mv3d-controls button, .mv3d-controls select { font: inherit; padding: 0.15em 0.6em; }
.mv3d-play { min-width: 6.2em; }
.mv3d-figwrap { position: relative; display: inline-block; max-width: 100%; line-height: 0; }
.mv3d-figwrap img { cursor: crosshair; }
.mv3d-tline { position: absolute; width: 0; border-left: 2px solid rgba(123,44,191,0.85);
              pointer-events: none; display: none; }
"""

_LEGEND = """<div class="mv3d-legend">
<div><i class="real"></i>real motion</div>
<div><i class="ghost"></i>commanded (ghost)</div>
<div><i class="sat"></i>drive saturated</div>
<div><i class="tr"></i>end-effector path, real</div>
<div><i class="tc"></i>end-effector path, commanded</div>
{targets}<div class="mv3d-axes">base axes <b style="color:#e0301e">x</b>
<b style="color:#2ca02c">y</b> <b style="color:#1f5fd6">z</b> ·
<span class="mv3d-grid"></span></div>
</div>"""


_TARGETS = '<div><i class="tg"></i>move targets (tool point, z axis)</div>\n'


@cache
def asset(name: str) -> str:
    """The text of ``mrnea/report/assets/<name>`` (decompressed if ``name`` ends in ``.gz``),
    checked to be safe inside ``<script>``."""
    data = resources.files("mrnea.report").joinpath("assets", name).read_bytes()
    text = (gzip.decompress(data) if name.endswith(".gz") else data).decode("utf-8")
    if "</script" in text.lower() or "<!--" in text:
        raise ValueError(f"asset {name} holds '</script' or '<!--' and cannot be inlined")
    return text


def _json_for_script(obj: Any) -> str:
    """JSON safe inside ``<script type="application/json">``: no ``<`` at all, so nothing in
    it (a joint's name) can close the element."""
    return json.dumps(obj, separators=(",", ":")).replace("<", "\\u003c")


def decimals(dt: float) -> int:
    """Decimals that show a time on the cycle clock of step ``dt`` [s] (at least 3)."""
    return max(3, math.ceil(-math.log10(dt) - 1e-9)) if dt > 0 else 6


def scene_html(spec: dict[str, Any], element_id: str = "view3d") -> str:
    """The 3D view of the scene ``spec`` (:func:`mrnea.report.view3d.scene_data`) as one
    self-contained HTML fragment: ``<style>``, ``<section class="mv3d">`` (canvas, legend,
    controls, the data) and two ``<script>`` elements. One view per page.

    ``element_id`` is the ``<section>``'s id; its controls' ids derive from it.
    """
    t0, t1, dt = spec["clock"]["t0"], spec["clock"]["t1"], spec["clock"]["dt"]
    speed = next((s for s in SPEEDS if s >= 1.0 and (t1 - t0) / s <= 90.0), SPEEDS[-1])
    options = "".join(f'<option value="{s:g}"{" selected" * (s == speed)}>{s:g}&times;</option>'
                      for s in SPEEDS)
    nd = decimals(dt)
    eid = html.escape(element_id, quote=True)
    return f"""<style>{CSS}</style>
<section class="mv3d" id="{eid}" aria-label="3D view of the motion">
<div class="mv3d-stage">
<canvas aria-label="3D view: the robot as it really moves and, translucent, as the program
commands it. Drag to orbit, wheel to zoom, right-drag to pan."></canvas>
{_LEGEND.format(targets=_TARGETS if spec.get("targets") else "")}
<div class="mv3d-sat" aria-live="polite"></div>
<div class="mv3d-hint">drag: orbit · wheel: zoom · right-drag: pan</div>
<div class="mv3d-nogl-msg">This browser gives the page no WebGL, so the 3D view is off; the
figures below show the same motion.</div>
</div>
<div class="mv3d-controls">
<button type="button" class="mv3d-play" aria-pressed="false">▶ play</button>
<label for="{eid}-time">time [s]</label>
<input type="range" id="{eid}-time" min="{t0!r}" max="{t1!r}" step="{dt!r}" value="{t0!r}">
<output for="{eid}-time">{t0:.{nd}f} s</output>
<label for="{eid}-speed">speed</label>
<select id="{eid}-speed">{options}</select>
<button type="button" class="mv3d-home">reset view</button>
<a class="mv3d-link" href="#t={t0:.{nd}f}">link to this instant</a>
</div>
<script type="application/json" class="mv3d-data">{_json_for_script(spec)}</script>
</section>
<script>/* three.js {THREE_VERSION} (subset), MIT licence: see "Third-party software" */
{asset("three-subset.min.js.gz")}</script>
<script>{asset("view3d.js")}</script>
"""


def license_html() -> str:
    """The notice the MIT licence of the embedded three.js asks the report to carry."""
    return (f"<details><summary>Third-party software in this page</summary><p>The 3D view uses "
            f"three.js {THREE_VERSION} (a subset, built into the page):</p>"
            f"<pre>{html.escape(asset('LICENSE-three.txt'))}</pre></details>")


def figure_axes(fig: Figure) -> str:
    """``data-xaxes`` of a report figure: per time axes ``[x0, x1, y0, y1, xmin, xmax]``.

    The axes' box in figure fractions (y up) and its x limits [s]; valid for the PNG as the
    report saves it (at the figure's own size, no ``bbox_inches``). Read it after the figure is
    saved: a layout engine (constrained, tight) places the axes when the figure is drawn (the
    report's figures have a fixed layout). Axes whose x label, or that of an axes sharing its x
    axis, does not start with "time" (a secondary y axis, a histogram) are left out.
    """
    out = []
    for ax in fig.axes:
        if not any(a.get_xlabel().startswith("time")
                   for a in ax.get_shared_x_axes().get_siblings(ax)):
            continue
        b = ax.get_position()
        lo, hi = ax.get_xlim()
        out.append([round(b.x0, 5), round(b.x1, 5), round(b.y0, 5), round(b.y1, 5), lo, hi])
    return json.dumps(out, separators=(",", ":"))
