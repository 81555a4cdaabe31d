"""The argument checks of mrnea.validate, through the public functions that use them.

A time step is checked once, one way, everywhere: a real, finite number > 0; a bool (Python's
or NumPy's), a complex number, a string or an array is not one.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest

import mrnea
from mrnea import validate
from mrnea.achievable import achievable_step
from mrnea.errors import StateError
from mrnea.simulate import simulate

GOOD_DT = [0.01, 1, np.float32(0.01), np.float64(0.01), np.int64(2), Fraction(1, 100)]
BAD_DT = [True, False, np.True_, 0.01 + 0j, np.complex128(0.01), "0.01", b"1", None,
          np.array(0.01), [0.01], 0.0, -0.01, -0.0, math.nan, math.inf, np.float64(np.inf)]


@pytest.mark.parametrize("dt", GOOD_DT, ids=repr)
def test_time_step_accepts_real_numbers(dt) -> None:
    got = validate.time_step(dt)
    assert type(got) is float and got == float(dt)


@pytest.mark.parametrize("dt", BAD_DT, ids=repr)
def test_time_step_rejects_the_rest(dt) -> None:
    with pytest.raises(StateError, match=r"^dt: "):
        validate.time_step(dt)


@pytest.mark.parametrize("dt", [np.True_, 0.01 + 0j, "0.01"], ids=repr)
def test_public_functions_share_the_check(dt) -> None:
    robot = mrnea.robots.sdt()
    z = np.zeros(robot.n)
    with pytest.raises(StateError, match=r"^dt: not a real number"):
        simulate(robot, np.zeros((5, robot.n)), dt)
    with pytest.raises(StateError, match=r"^dt: not a real number"):
        achievable_step(robot, z, z, z, z, dt)


@pytest.mark.parametrize("gain", [True, "5", 1j, None])
def test_catch_up_is_a_real_number(gain) -> None:
    robot = mrnea.robots.sdt()
    with pytest.raises(StateError, match=r"^catch_up: not a real number"):
        simulate(robot, np.zeros((5, robot.n)), 0.01, catch_up=gain)


def test_choice_names_the_argument_and_the_choices() -> None:
    table = {"a": 1, "b": 2}
    assert validate.choice("mode", "b", table) == 2
    for bad in ("c", None, ["a"]):
        with pytest.raises(StateError, match=r"^mode: unknown .*; expected one of 'a', 'b'$"):
            validate.choice("mode", bad, table)
