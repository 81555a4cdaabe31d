"""``mrnea fig3``: the paper's figures, reproduced on the built-in SDT."""

from __future__ import annotations

import os

import click
import numpy as np

from mrnea import robots
from mrnea.cli.base import checkpoint, compile_notice, last_checkpoint, main, one_line
from mrnea.cli.options import force_opt
from mrnea.errors import OutputError, quote
from mrnea.io.writer import check_new


@main.command(short_help="Reproduce the paper's Fig. 3 on the SDT (RNEA vs mRNEA torques).")
@click.option("--out", default="fig3.png", show_default=True,
              help="The file to write; its suffix names the format (.png, .pdf, .svg...; "
                   "none: .png is appended). A folder, or a name ending in '/', is refused.")
@force_opt
def fig3(out: str, force: bool) -> None:
    """Reproduce the paper's Fig. 3 on the SDT: RNEA vs mRNEA torques, input vs FD accelerations.

    The trajectory is the demo's training profile; its velocities and accelerations are the
    positions' finite differences. --out names the file, never a folder: an existing folder, or
    a name ending in '/' (not NAME.png beside it), is one error and writes nothing.
    """
    from mrnea.report import fig3 as make_fig3
    from mrnea.report.drawing import figure_file, save_figure
    from mrnea.robots.sdt_profile import training_profile

    if not out.strip():  # an unset "$FILE": not the current folder's name
        raise click.BadParameter("an empty path; name the figure file to write",
                                 param_hint="'--out'")
    if os.path.exists(out) and not (os.path.isfile(out) or os.path.isdir(out)):
        # /dev/null, /dev/stdout, a FIFO: never a NAME.png made next to a device
        raise click.BadParameter(f"{quote(out)} is not a regular file (a device, pipe or socket); "
                                 "name the figure file to write", param_hint="'--out'")
    try:
        path, _ = figure_file(out)
    except OutputError as exc:  # "newdir/" names a folder: the library's argument path is --out
        if not str(exc).startswith("path: "):
            raise
        raise click.BadParameter(str(exc).removeprefix("path: "), param_hint="'--out'") from None
    check_new([path], force)  # before any work
    dt = 0.005
    t, q = training_profile(dt)
    qd = np.gradient(q, dt, axis=0)
    qdd = np.gradient(qd, dt, axis=0)
    with compile_notice():
        fig = make_fig3(robots.sdt(), t, q, qd, qdd)
    checkpoint()  # interrupted while computing: write nothing
    written = save_figure(fig, path, force, dpi=110)
    last_checkpoint()
    click.echo(f"Fig. 3: {one_line(str(written))}")  # a newline in --out: one line
