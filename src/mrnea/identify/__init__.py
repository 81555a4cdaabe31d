"""Identification of a robot's dynamic model from its own measurements (issue 28):
the joint torque regressor, base parameters, friction and rotor inertia, physically consistent
estimates, excitation trajectories. docs/identification.md."""

from mrnea.identify.regressor import (
    actuator_parameters,
    actuator_regressor,
    inertial_parameters,
    regressor,
    with_inertial_parameters,
)

__all__ = [
    "actuator_parameters",
    "actuator_regressor",
    "inertial_parameters",
    "regressor",
    "with_inertial_parameters",
]
