"""The single-state fast path of the public dynamics API (mrnea.dynamics, module docstring).

Without a wrench, one state of 1-D float64 ndarrays goes straight to a compiled entry that checks
lengths and finiteness itself; anything it cannot take must reach the validated path, with the
same result or the same named error. The free-motion entry (compiled without the wrench terms)
equals the general one with a zero wrench, bit for bit, and the one scratch per n that the
entries share is safe between Python threads. Its speed: docs/performance.md, benchmarks/.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import random_chain
from test_api_errors import FUNCTIONS, N, _state_args, names_argument

import mrnea


@pytest.fixture(scope="module")
def robot() -> mrnea.Robot:
    return random_chain(np.random.default_rng(5), N, 0.5)


@pytest.mark.parametrize("fn", FUNCTIONS)
def test_fast_path_wrong_length_names_the_argument(robot, fn: str) -> None:
    for arg in _state_args(fn):
        for bad in (np.zeros(N - 1), np.zeros(N + 1)):
            kw = {a: np.full(N, 0.1) for a in _state_args(fn)}
            kw[arg] = bad
            with names_argument(arg) as info:
                getattr(mrnea, fn)(robot, **kw)
            assert str(bad.shape) in str(info.value)


@pytest.mark.parametrize("fn", FUNCTIONS)
def test_fast_path_hands_other_inputs_to_the_validated_path(robot, fn: str) -> None:
    """Integer arrays, array-likes that are not ndarrays (here an object with a float64 dtype
    and ndim 1, as a pandas Series has), and a non-Robot: the same result or a named error."""

    class Duck:
        dtype, ndim = np.dtype(np.float64), 1

        def __init__(self, a):
            self.a = a

        def __array__(self, dtype=None, copy=None):
            return self.a

    args = _state_args(fn)
    ints = {a: np.arange(N) for a in args}
    floats = {a: np.arange(N, dtype=float) for a in args}
    expect = getattr(mrnea, fn)(robot, **floats)
    for kw in (ints, {a: Duck(v) for a, v in floats.items()}):
        got = getattr(mrnea, fn)(robot, **kw)
        for x, y in zip(got if isinstance(got, tuple) else (got,),
                        expect if isinstance(expect, tuple) else (expect,), strict=True):
            np.testing.assert_array_equal(x, y)
    with names_argument("robot"):
        getattr(mrnea, fn)("not a robot", **floats)


@pytest.mark.parametrize("fn", FUNCTIONS)
def test_free_motion_entry_equals_a_zero_wrench(robot, fn: str) -> None:
    """The free-motion entry (``fext=None``: the entry passes the zero wrench itself,
    kernels/entry.py) gives the results of the general entry with a zero wrench, bit for bit."""
    rng = np.random.default_rng(8)
    for _ in range(5):
        kw = {a: rng.uniform(-2, 2, N) for a in _state_args(fn)}
        free = getattr(mrnea, fn)(robot, **kw)
        zero = getattr(mrnea, fn)(robot, **kw, f_ext=np.zeros(6), f_ext_point=np.zeros(3))
        for x, y in zip(free if isinstance(free, tuple) else (free,),
                        zero if isinstance(zero, tuple) else (zero,), strict=True):
            np.testing.assert_array_equal(x, y)


def test_threads_share_the_entry_scratch(robot) -> None:
    """Single-state calls from several Python threads on two Robots of the same n (one shared
    scratch per n, safe because the entries hold the GIL) give the results of the same calls
    made in turn."""
    import threading

    rng = np.random.default_rng(9)
    Q, QD, TAU = rng.uniform(-2, 2, (3, 200, N))
    robots = (robot, robot.with_gravity((1.0, 2.0, -9.0)))
    expect = [[(mrnea.forward_dynamics(r, Q[b], QD[b], TAU[b]),
                mrnea.mass_matrix_and_bias(r, Q[b], QD[b])[0]) for b in range(200)]
              for r in robots]
    results: dict[int, list] = {}

    def work(k: int) -> None:
        r = robots[k % 2]
        results[k] = [(mrnea.forward_dynamics(r, Q[b], QD[b], TAU[b]),
                       mrnea.mass_matrix_and_bias(r, Q[b], QD[b])[0]) for b in range(200)]

    threads = [threading.Thread(target=work, args=(k,)) for k in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for k in range(4):
        for b, (qdd, H) in enumerate(results[k]):
            np.testing.assert_array_equal(qdd, expect[k % 2][b][0])
            np.testing.assert_array_equal(H, expect[k % 2][b][1])
