"""mrnea: robot dynamics with the modified recursive Newton-Euler algorithm (mRNEA).

One pass returns the joint-space mass matrix H and the bias vector u'; on top of it mrnea computes
the joint accelerations the real actuators can achieve and simulates the motion cycle by cycle.
"""

from mrnea import robots
from mrnea.dynamics import (
    forward_dynamics,
    forward_kinematics,
    inverse_dynamics,
    jacobian,
    joint_reactions,
    mass_matrix_and_bias,
)
from mrnea.errors import (
    ModelError,
    ModelWarning,
    MrneaError,
    OutputError,
    PathWarning,
    ProgramFileError,
    RobotFileError,
    SingularMassMatrixError,
    StateError,
    SweepError,
)
from mrnea.io import load_program, load_robot, load_urdf
from mrnea.model import Joint, Link, Robot, transform
from mrnea.sweep import sweep

__version__ = "0.1.0"

__all__ = [
    "Joint",
    "Link",
    "ModelError",
    "ModelWarning",
    "MrneaError",
    "OutputError",
    "PathWarning",
    "ProgramFileError",
    "Robot",
    "RobotFileError",
    "SingularMassMatrixError",
    "StateError",
    "SweepError",
    "__version__",
    "forward_dynamics",
    "forward_kinematics",
    "inverse_dynamics",
    "jacobian",
    "joint_reactions",
    "load_program",
    "load_robot",
    "load_urdf",
    "mass_matrix_and_bias",
    "robots",
    "sweep",
    "transform",
]
