"""The package's error types.

Every error mrnea raises on bad input is a subclass of :class:`MrneaError`, itself a
:class:`ValueError`, and its message names the offending element (link, joint, file, argument).
"""

from __future__ import annotations


class MrneaError(ValueError):
    """Base class of every mrnea input error."""


class ModelError(MrneaError):
    """A robot description is not physical or not consistent (mass, inertia, axis, limits...)."""


class RobotFileError(ModelError):
    """A robot file (URDF, native TOML/YAML, DH table) cannot be read or parsed."""


class ProgramFileError(MrneaError):
    """A program file (TOML) or path CSV cannot be read, parsed or validated.

    The message names the file and the key, row or column at fault (TOML syntax errors: line
    and column).
    """


class StateError(MrneaError):
    """A state or argument passed to the public API has the wrong shape, type or value."""


class SingularMassMatrixError(MrneaError):
    """The joint-space mass matrix H is singular or not positive definite at this state.

    This happens, for example, when a moving link and everything it carries is massless.
    """


class RetimeError(MrneaError):
    """A program cannot be retimed: its path cannot be followed at any speed (a pose the robot
    cannot hold against gravity or a wrench; the message names the joint, the instant and the
    ratio of need to limit), it leaves the joint's position limits, or no planning margin gives a
    program the verifying simulation accepts."""


class OutputError(MrneaError):
    """An output file cannot be written: it exists (and replacing it was not allowed), its place
    is a directory, its folder is missing or not writable, or another run owns the folder."""


class ModelWarning(UserWarning):
    """A robot description is valid but physically doubtful (an inertia that violates the
    triangle inequality, a massless moving link); mrnea goes on and says so."""


class PathWarning(UserWarning):
    """A commanded path is valid but doubtful: its interpolation between a CSV's rows leaves a
    position limit the rows respect (the simulator would clamp it); mrnea goes on and says so."""
