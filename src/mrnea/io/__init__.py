"""Files mrnea reads: robots (URDF, native TOML, DH tables, sidecar actuator files), built-in
robots by name, program files, path CSVs and sweep grid files.

One public entry per task, all importable from here: :func:`load_robot` (a robot file, chosen by
suffix), :func:`load_builtin` (a built-in robot by name), :func:`load_robot_spec` (either),
:func:`load_urdf`, :func:`load_native`, :func:`apply_actuator_file` (a sidecar file),
:func:`load_program` (a program file into a :class:`Program`; :func:`is_program_file` tells a
program from a robot ``.toml``), :func:`from_csv` (a path CSV resampled to dt),
:func:`parse_payload` and :func:`load_grid_file` (a design sweep's grid file).
:class:`RobotOptions` (actuators, tip, payload, gravity) change a robot as
:func:`load_robot_spec` loads it. Every TOML reader checks its document with
:mod:`mrnea.io.tomlcheck`.

The robot writers, :func:`write_urdf` and :func:`write_native`, are also
:meth:`mrnea.Robot.to_urdf` and :meth:`mrnea.Robot.to_toml`: importing this package registers
them in :data:`mrnea.model.WRITERS` (the model imports no io; docs/design.md).
"""

from mrnea import model
from mrnea.io.dispatch import (
    BUILTIN_ROBOTS,
    RobotOptions,
    load_builtin,
    load_robot,
    load_robot_spec,
    resolve_robot,
)
from mrnea.io.gridfile import GridFile, load_grid_file
from mrnea.io.native import dumps_native, load_native, loads_native, write_native
from mrnea.io.pathcsv import from_csv
from mrnea.io.payload import Payload, parse_payload
from mrnea.io.program import Program, is_program_file, load_program, loads_program
from mrnea.io.sidecar import apply_actuator_file
from mrnea.io.urdf import load_urdf
from mrnea.io.urdf_writer import write_urdf

model.WRITERS.update(urdf=write_urdf, toml=write_native)

__all__ = [
    "BUILTIN_ROBOTS",
    "GridFile",
    "Payload",
    "Program",
    "RobotOptions",
    "apply_actuator_file",
    "dumps_native",
    "from_csv",
    "is_program_file",
    "load_builtin",
    "load_grid_file",
    "load_native",
    "load_program",
    "load_robot",
    "load_robot_spec",
    "load_urdf",
    "loads_native",
    "loads_program",
    "parse_payload",
    "resolve_robot",
    "write_native",
    "write_urdf",
]
