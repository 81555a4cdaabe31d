"""Retiming: the same path, the fastest timing the robot can make (docs/retime.md).

``retime(robot, program, dt=None, method="toppra", margin=0.98, f_ext=None, f_ext_point=None)``
keeps a program's path (its sequence of joint positions) and changes only its timing, with
mrnea's full actuator model (rotor inertia, viscous and Coulomb friction, torque-speed curves,
the wrench), and verifies the result by simulation. It is also ``mrnea.retime``; since that
name is the function, import this package's modules as ``from mrnea.retime import scale``.

Modules: :mod:`~mrnea.retime.path` (pieces, splines, grids, the second-order form of the efforts
from one mRNEA call over the grid), :mod:`~mrnea.retime.rows` (the limits as TOPP-RA's linear rows,
tightened on the safe side), :mod:`~mrnea.retime.toppra` (the solves), :mod:`~mrnea.retime.scale`
(Hollerbach's uniform time scaling and its estimate), :mod:`~mrnea.retime.job` (dwells, the
wrench, verification), :mod:`~mrnea.retime.result` (:class:`RetimeResult`),
:mod:`~mrnea.retime.core` (:func:`retime`).
"""

from mrnea.retime.core import retime
from mrnea.retime.result import PhasePiece, RetimeResult
from mrnea.retime.scale import scale_estimate

__all__ = ["PhasePiece", "RetimeResult", "retime", "scale_estimate"]
