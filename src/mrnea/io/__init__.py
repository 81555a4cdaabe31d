"""Loaders: every robot file format mrnea reads produces a validated :class:`mrnea.Robot`."""

from mrnea.io.dispatch import load_robot
from mrnea.io.native import load_native
from mrnea.io.urdf import load_urdf

__all__ = ["load_native", "load_robot", "load_urdf"]
