"""Identification of a robot's dynamic model from its own measurements (issue 28):
the joint torque regressor, base parameters, friction and rotor inertia, physically consistent
estimates, excitation trajectories. docs/identification.md."""

from mrnea.identify.estimate import IdentificationResult, identify
from mrnea.identify.excite import Excitation, excitation
from mrnea.identify.log import Log, derivatives, read_log
from mrnea.identify.regressor import (
    actuator_parameters,
    actuator_regressor,
    inertial_parameters,
    regressor,
    with_inertial_parameters,
)

__all__ = [
    "Excitation",
    "IdentificationResult",
    "Log",
    "actuator_parameters",
    "actuator_regressor",
    "derivatives",
    "excitation",
    "identify",
    "inertial_parameters",
    "read_log",
    "regressor",
    "with_inertial_parameters",
]
