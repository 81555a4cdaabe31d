"""The ``mrnea`` command: will the robot really make the programmed motion?

``mrnea demo`` runs the built-in SDT's training profile and writes the report;
``mrnea simulate ROBOT PROGRAM`` does the same for any robot and program; ``mrnea check`` prints
the verdict alone (exit 0 achievable, 1 not, 2 bad input, 130 interrupted); ``mrnea info ROBOT``
lists joints, masses, limits and actuators; ``mrnea fig3`` reproduces the paper's Fig. 3;
``mrnea retime [ROBOT] PROGRAM --out DIR`` gives a program the fastest timing the robot can make.
``mrnea sweep [ROBOT] PROGRAM... --grid GRID.toml`` runs every program on every robot variant of
a grid, on Dask (docs/sweeps.md).
``mrnea excite ROBOT --out DIR`` writes an optimised excitation trajectory for identification
(docs/identification.md).
``mrnea size [ROBOT] PROGRAM... --catalogue FILE`` chooses each joint's motor and gearbox from a
catalogue (docs/sizing.md).
``mrnea identify ROBOT LOG --out DIR`` identifies the links, friction and rotor inertia from a log
of the robot's own motion (:mod:`~mrnea.cli.identify`; docs/identification.md).

ROBOT is a built-in name (sdt, puma560), a URDF or a native ``.toml`` robot file. PROGRAM is a
program ``.toml`` file or a CSV of (time, q1..qn) (docs/programs.md). Bad input ends with one
clear line on stderr and exit code 2 (``--debug`` shows the traceback). Output files are never
overwritten unless ``--force`` is given; without ``--out`` a fresh folder is chosen.

Layout: :mod:`mrnea.cli.base` holds the group (:data:`main`), error and interrupt handling,
exit codes; :mod:`mrnea.cli.options` the options and arguments several commands share (and
:func:`~mrnea.cli.options.load_run`, what they name); each other module adds the commands of one
theme (:mod:`~mrnea.cli.run`: demo, simulate, check; :mod:`~mrnea.cli.info`;
:mod:`~mrnea.cli.paper`: fig3; :mod:`~mrnea.cli.retime`: retime; :mod:`~mrnea.cli.sweep`). A new
command goes in a module
of its own, imported below.
"""

from mrnea.cli import excite, identify, info, paper, retime, run, size, sweep
from mrnea.cli.base import main

__all__ = ["excite", "identify", "info", "main", "paper", "retime", "run", "size", "sweep"]
