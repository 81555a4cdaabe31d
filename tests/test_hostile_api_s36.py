"""Hostile inputs to the library API of the newest features (session 36 hunt): each a
MrneaError naming the argument, never a raw TypeError/ValueError or a silent misreading."""

import numpy as np
import pytest

from mrnea.errors import StateError
from mrnea.identify import Log, derivatives, identify
from mrnea.robots import puma560

K, N = 200, 6
T = np.arange(K) * 0.01
Q = np.zeros((K, N))


def _moving_log() -> Log:
    q = 0.3 * np.sin(2 * np.pi * 0.5 * T)[:, None] * np.ones(N)
    return Log(T, q, np.zeros((K, N)))


@pytest.mark.parametrize(("field", "value", "words"), [
    ("time", "abc", "log: time: expected real numbers"),
    ("time", None, "log: time: expected an array of real numbers, got None"),
    ("q", None, "log: q: expected an array of real numbers, got None"),
    ("tau", None, "log: tau: expected an array of real numbers, got None"),
    ("q", Q + 1j, "log: q: expected real numbers, got an array of complex128"),
    ("q", np.array([[object()] * N] * K), "log: q: expected real numbers, got an array of object"),
    ("q", [[0.0] * N] * (K - 1) + [[0.0]], "log: q: not a numeric array"),
    ("tau", [["a"] * N] * K, "log: tau: expected real numbers"),
])
def test_log_rejects_non_numeric_arrays(field, value, words):
    args = {"time": T, "q": Q, "tau": np.zeros((K, N))}
    args[field] = value
    with pytest.raises(StateError, match=words.replace("(", r"\(").replace(")", r"\)")):
        Log(**args)


def test_log_takes_read_only_and_strided_arrays():
    q = np.zeros((K, 2 * N))[:, ::2]
    q.flags.writeable = False
    log = Log(T, q, np.zeros((K, N)))
    assert log.q.flags.c_contiguous and log.q.shape == (K, N)


@pytest.mark.parametrize("cutoff", ["x", None, True, 3 + 0j])
def test_cutoff_not_a_number(cutoff):
    with pytest.raises(StateError, match="cutoff_hz: not a real number"):
        derivatives(T, Q, cutoff)
    with pytest.raises(StateError, match="cutoff_hz: not a real number"):
        identify(puma560(), _moving_log(), cutoff_hz=cutoff)


@pytest.mark.parametrize(("name", "value"), [
    ("min_speed", float("nan")), ("min_speed", -1.0), ("min_speed", float("inf")),
    ("prior_weight", float("nan")), ("prior_weight", -1.0), ("prior_weight", float("inf")),
])
def test_identify_rejects_non_finite_or_negative_settings(name, value):
    with pytest.raises(StateError, match=f"{name}: must be a finite number >= 0, got {value}"):
        identify(puma560(), _moving_log(), **{name: value})


def test_solve_path_rejects_complex_poses():
    from mrnea.ik import solve_path
    with pytest.raises(StateError, match="poses: expected real numbers, got an array of complex"):
        solve_path(puma560(), np.eye(4) + 0j, np.zeros(N))


@pytest.mark.parametrize("hold", [3, None, 2.5, {"joint1": 1}.values()])
def test_solve_path_hold_not_a_list(hold):
    from mrnea.ik import solve_path
    with pytest.raises(StateError, match="hold: expected a list of joint names, got"):
        solve_path(puma560(), np.eye(4), np.zeros(N), hold=hold)


@pytest.mark.parametrize("grid", [2**70, 10_001, 10**9])
def test_retime_grid_too_large_is_refused_before_any_work(grid):
    import mrnea
    program = np.linspace(np.zeros(N), np.full(N, 0.5), 50)
    with pytest.raises(StateError, match=f"grid: expected an int >= 10 and <= 10000, got {grid}"):
        mrnea.retime(puma560(), program, 0.01, grid=grid)


def test_forward_kinematics_rejects_a_complex_tool():
    import mrnea
    from mrnea.errors import MrneaError
    with pytest.raises(MrneaError, match=r"tool.*complex numbers, expected real ones"):
        mrnea.forward_kinematics(puma560(), np.zeros(N), tool=np.eye(4) + 0j)
