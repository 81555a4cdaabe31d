"""The ``mrnea`` command's entry point ([project.scripts] in pyproject.toml).

A module of its own, outside the ``mrnea`` package: importing the package (NumPy, Numba, the
kernels' modules) takes about half a second, and a Ctrl-C then would end the command with a
traceback through the imports. Here it ends as a stop request before any work does:
``mrnea: interrupted`` on stderr, exit 130, nothing written (mrnea.cli.base). Once the command
has returned (its answer given, its exit code set), SIGINT and SIGTERM are ignored for the rest
of the interpreter's teardown: a signal there had turned an answer already printed into exit
130 (or 143). Then every object alive is frozen (:func:`gc.freeze`): the teardown's garbage
collections, which walked every object of NumPy's, Numba's, matplotlib's and the command's
(0.6-0.8 s after a ``mrnea demo``, warm or fresh: a fifth of a warm one), skip them; the
command and its exit handlers close its files and processes as before. ``python -m mrnea``
runs it too, but Python imports the package before that (``-m`` imports a module's package
first): there only the teardown is covered.
"""

import gc
import signal
import sys


def main() -> None:
    """Import the command (:data:`mrnea.cli.main`) and run it."""
    try:
        from mrnea.cli import main as command
    except KeyboardInterrupt:
        sys.stderr.write("mrnea: interrupted\n")
        raise SystemExit(130) from None
    try:
        command()
    finally:  # the command's exit code is set: nothing may change it now
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, signal.SIG_IGN)
        gc.freeze()
