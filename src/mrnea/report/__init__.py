"""Figures and a self-contained HTML report of a simulation (paper Secs. II, IV and VI).

* :func:`plot_result` (:mod:`mrnea.report.figures`) -- the four figures a designer reads after
  :func:`mrnea.simulate.simulate`: ``"motion"``, ``"efforts"``, ``"reactions"``, ``"tracking"``
  (names in :data:`FIGURES`).
* :func:`fig3` (:mod:`mrnea.report.paper`) -- the paper's Fig. 3: joint torques by the RNEA and
  by the mRNEA along a trajectory, and the input accelerations against forward dynamics.
* :func:`write_report` (:mod:`mrnea.report.html`) -- one HTML file, verdict first, then the
  interactive 3D view of the motion (:mod:`mrnea.report.view3d` its data,
  :mod:`mrnea.report.view3d_html` the page fragment with the vendored three.js,
  :mod:`mrnea.report.shapes` the robot's shapes), figures embedded as PNG data URIs: no
  external resource, no request, works from ``file://``.

Drawing helpers, decimation (:data:`MAX_POINTS`) and :func:`~mrnea.report.drawing.save_figure`
are in :mod:`mrnea.report.drawing`; every file is written through :mod:`mrnea.io.writer`.

The package imports matplotlib only when one of these is first asked for (PEP 562): a command
names its output files (:data:`FIGURES`) before its simulation, and matplotlib's import
(about 0.8 s) then waits until the figures are drawn.
"""

from importlib import import_module
from typing import Any

FIGURES = ("motion", "efforts", "reactions", "tracking")
"""The names of :func:`plot_result`'s figures (and of their PNG files)."""

_WHERE = {"MAX_POINTS": "drawing", "fig3": "paper", "plot_result": "figures",
          "write_report": "html"}

__all__ = ["FIGURES", "MAX_POINTS", "fig3", "plot_result", "write_report"]


def __getattr__(name: str) -> Any:
    if name not in _WHERE:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(import_module(f"mrnea.report.{_WHERE[name]}"), name)
