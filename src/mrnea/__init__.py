"""mrnea: robot dynamics with the modified recursive Newton-Euler algorithm (mRNEA).

One pass returns the joint-space mass matrix H and the bias vector u'; on top of it mrnea computes
the joint accelerations the real actuators can achieve and simulates the motion cycle by cycle.

The main functions are at the top level, as ``pinocchio.aba`` is: ``mrnea.forward_dynamics``,
``mrnea.achievable_accelerations``, ``mrnea.simulate``, ``mrnea.load_program``... Note that
``mrnea.simulate`` is the function; its module is imported by name
(``from mrnea.simulate import SimulationResult``), never as ``import mrnea.simulate as m``,
which Python resolves to the attribute, the function.
"""

from mrnea import robots
from mrnea.achievable import achievable_accelerations
from mrnea.cartesian import load_program
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
    NoTimingError,
    OutputError,
    PathWarning,
    ProgramFileError,
    RetimeError,
    RobotFileError,
    SingularMassMatrixError,
    SizingError,
    StateError,
    SweepError,
)
from mrnea.identify import excitation, regressor
from mrnea.ik import inverse_kinematics
from mrnea.io import load_robot, load_urdf
from mrnea.model import Joint, Link, Robot
from mrnea.retime import RetimeResult, retime
from mrnea.rigid import transform
from mrnea.simulate import simulate  # the function: it shadows the module's attribute (above)
from mrnea.sizing import size_drives
from mrnea.sweep import sweep  # the function, as simulate (above)

__version__ = "0.1.0"

__all__ = [
    "Joint",
    "Link",
    "ModelError",
    "ModelWarning",
    "MrneaError",
    "NoTimingError",
    "OutputError",
    "PathWarning",
    "ProgramFileError",
    "RetimeError",
    "RetimeResult",
    "Robot",
    "RobotFileError",
    "SingularMassMatrixError",
    "SizingError",
    "StateError",
    "SweepError",
    "__version__",
    "achievable_accelerations",
    "excitation",
    "forward_dynamics",
    "forward_kinematics",
    "inverse_dynamics",
    "inverse_kinematics",
    "jacobian",
    "joint_reactions",
    "load_program",
    "load_robot",
    "load_urdf",
    "mass_matrix_and_bias",
    "regressor",
    "retime",
    "robots",
    "simulate",
    "size_drives",
    "sweep",
    "transform",
]
