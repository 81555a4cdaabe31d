"""Design sweeps: many robot variants x many programs, one summary row each, on Dask.

``mrnea.sweep(robot, programs, grid)`` (:func:`~mrnea.sweep.engine.sweep`) returns a
``pandas.DataFrame``; ``mrnea.sweep.variant(robot, **params)`` rebuilds the robot of any row
from its parameter columns and ``mrnea.sweep.time_scaled(program, factor)`` its program
(docs/sweeps.md).

Since ``mrnea.sweep`` is the function, the function carries ``variant``, ``time_scaled`` and
``check_grid`` as attributes; import this package's modules as ``from mrnea.sweep import
engine``. Modules: :mod:`~mrnea.sweep.variants` (the parameters and their rules, the grid
check), :mod:`~mrnea.sweep.rows` (one run as a row), :mod:`~mrnea.sweep.cluster` (the Dask
cluster, a scheduler address checked), :mod:`~mrnea.sweep.engine` (the engine and
:func:`sweep`). pandas and distributed are imported on the first sweep, not with
mrnea.
"""

from mrnea.sweep.engine import DEMO_PROGRAM, load_programs, sweep
from mrnea.sweep.timescale import time_scaled
from mrnea.sweep.variants import PARAMETERS, check_grid, units, variant

sweep.variant = variant  # type: ignore[attr-defined]
sweep.time_scaled = time_scaled  # type: ignore[attr-defined]
sweep.check_grid = check_grid  # type: ignore[attr-defined]

__all__ = ["DEMO_PROGRAM", "PARAMETERS", "check_grid", "load_programs", "sweep", "time_scaled",
           "units", "variant"]
