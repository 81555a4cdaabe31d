"""Polish s42, the simulation: the streamed table and ``to_csv`` agree on a truncated run (the
program's own acceleration of the last row held is the program's, not its end's), every bool
argument is refused unless a bool, and hostile arguments end in one MrneaError naming them.

Numbers are checked against closed forms: the program's acceleration is the finite difference
of q_cmd, ``(q[k+1] - 2 q[k] + q[k-1]) / dt^2`` (the program's velocities being backward
differences, ``qd_cmd[k] = (q_cmd[k] - q_cmd[k-1]) / dt``).
"""

from __future__ import annotations

import csv
import importlib
import math
import warnings
from pathlib import Path

import numpy as np
import pytest

import mrnea
from mrnea.errors import MrneaError, OutputError, StateError
from mrnea.model import Joint, Link, Robot
from mrnea.rigid import transform
from mrnea.simulate import CHUNK, RUNAWAY_SPEED, simulate

simulate_module = importlib.import_module("mrnea.simulate")  # mrnea.simulate: the function


def two_link(limit1: float = math.inf) -> Robot:
    """A planar 2R arm in the horizontal plane (no gravity torque)."""
    joints = [
        Joint("j1", "revolute", "base", "l1", axis=(0, 0, 1), effort_limit=limit1),
        Joint("j2", "revolute", "l1", "l2", origin=transform((1.0, 0, 0)), axis=(0, 0, 1)),
    ]
    links = [Link("l1", 3.0, (0.5, 0, 0), np.diag([0.01, 0.25, 0.25])),
             Link("l2", 2.0, (0.4, 0, 0), np.diag([0.01, 0.1, 0.1]))]
    return Robot(joints, links, name="2R")


def parabola(K: int, dt: float, a: tuple[float, float] = (3.0, -2.0)) -> np.ndarray:
    """q_cmd = a t^2 / 2: the program's acceleration is a at every inner cycle (closed form)."""
    t = np.arange(K) * dt
    return 0.5 * np.outer(t**2, a)


def read(path: Path) -> list[list[str]]:
    with open(path, newline="") as fh:
        return list(csv.reader(fh))


def program_qdd_closed_form(q: np.ndarray, k: int, dt: float) -> np.ndarray:
    """The program's acceleration at cycle k, 0 < k < K - 1: the second difference of q_cmd."""
    return (q[k + 1] - 2 * q[k] + q[k - 1]) / dt**2


# --- 1. the streamed table and to_csv agree on a truncated run ----------------------------------

def test_an_interrupted_streams_last_row_is_the_programs_acceleration(tmp_path: Path) -> None:
    """Interrupted after the first chunk: both files hold CHUNK rows, byte for byte the same,
    and the last row's program_qdd is the program's own (its second difference there: 3 and
    -2 rad/s^2), not the deceleration to rest the program's end would need (to_csv had
    -qd_cmd / dt there: about -6e3 and 4e3 rad/s^2), the acceleration program_effort was computed
    for."""
    dt = 1e-3
    q = parabola(3 * CHUNK, dt)

    def stop(done: int, total: int) -> None:
        raise KeyboardInterrupt

    res = simulate(two_link(), q, dt, progress=stop, stream=tmp_path / "stream.csv")
    assert not res.completed and res.K == CHUNK
    res.to_csv(tmp_path / "after.csv")
    streamed, after = read(tmp_path / "stream.csv"), read(tmp_path / "after.csv")
    assert streamed == after and len(after) == 1 + CHUNK
    head = after[0]
    last = dict(zip(head, after[-1], strict=True))
    expect = program_qdd_closed_form(q, CHUNK - 1, dt)
    assert float(last["program_qdd_j1 [rad/s^2]"]) == pytest.approx(expect[0], rel=1e-6)
    assert float(last["program_qdd_j2 [rad/s^2]"]) == pytest.approx(expect[1], rel=1e-6)
    assert expect == pytest.approx([3.0, -2.0], rel=1e-6)
    assert res.program_qdd()[-1] == pytest.approx([3.0, -2.0], rel=1e-6)
    # the requirement of that row is the one the whole program's run computes there
    whole = simulate(two_link(), q[:CHUNK + 1], dt)
    assert whole.program_effort[CHUNK - 1] == pytest.approx(res.program_effort[-1], rel=1e-12)
    # and the program's own end still decelerates to rest: -qd_cmd[-1] / dt
    assert whole.program_qdd()[-1] == pytest.approx(-whole.qd_cmd[-1] / dt, rel=1e-12)


def test_a_runaways_stream_and_to_csv_agree(tmp_path: Path) -> None:
    """A runaway (a 1e6 N force the drives cannot hold) stops the run before the program's end:
    the streamed table and to_csv are the same, every column, and the last row's program_qdd is
    the program's second difference there."""
    robot = mrnea.robots.puma560()
    dt = 0.005
    K = 200
    q = np.zeros((K, 6))
    q[:, 0] = 0.5 * 0.8 * (np.arange(K) * dt) ** 2  # 0.8 rad/s^2 on joint 1
    res = simulate(robot, q, dt, f_ext=np.array([1e6, 0, 0, 0, 0, 0]),
                   stream=tmp_path / "stream.csv")
    assert res.runaway_time is not None and 2 <= res.K < K - 1
    res.to_csv(tmp_path / "after.csv")
    streamed, after = read(tmp_path / "stream.csv"), read(tmp_path / "after.csv")
    assert streamed == after and len(after) == 1 + res.K
    last = dict(zip(after[0], after[-1], strict=True))
    k = res.K - 1
    expect = program_qdd_closed_form(q, k, dt)
    assert float(last["program_qdd_joint1 [rad/s^2]"]) == pytest.approx(0.8, rel=1e-6)
    assert float(last["program_qdd_joint1 [rad/s^2]"]) == pytest.approx(expect[0], rel=1e-9)


def test_a_run_interrupted_before_its_first_chunk_streams_the_header(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Ctrl-C during the first chunk: no cycle; the stream holds the header row, as to_csv of
    the empty result does (it was an empty file)."""
    def interrupted(*args: object) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(simulate_module, "simulate_cycles", interrupted)
    res = simulate(two_link(), parabola(10, 0.01), 0.01, stream=tmp_path / "stream.csv")
    assert res.K == 0 and not res.completed
    res.to_csv(tmp_path / "after.csv")
    assert (tmp_path / "stream.csv").read_bytes() == (tmp_path / "after.csv").read_bytes()
    assert read(tmp_path / "after.csv")[0][0] == "t [s]"


def test_the_first_infeasible_cycle_of_a_truncated_run_names_the_programs_next_row() -> None:
    """The summary's commanded velocity and position at the last cycle held are the program's
    next row (qd_cmd[K] = (q_cmd[K] - q_cmd[K-1]) / dt of the whole program), not the last row
    held; at the program's own end, zero velocity (the program ends at rest)."""
    dt = 1e-3
    q = parabola(30, dt, (3.0, 0.0))
    res = simulate(two_link(), q, dt)
    cut = res._first(20)  # as an interrupt after 20 cycles leaves it
    cut.saturated[19, 0] = True  # say the last cycle held saturated (a view: writable)
    fi = cut.summary()["first_infeasible"]
    assert fi["cycle"] == 19
    assert fi["commanded_velocity"] == pytest.approx((q[20, 0] - q[19, 0]) / dt, rel=1e-12)
    assert fi["commanded_position"] == q[20, 0]
    whole = simulate(two_link(), q, dt)
    whole.saturated[-1, 0] = True
    fi = whole.summary()["first_infeasible"]
    assert fi["commanded_velocity"] == 0.0 and fi["commanded_position"] == q[-1, 0]


def test_columns_of_a_stepped_slice_are_one_length() -> None:
    """columns(slice(0, K, 2)): every column the same cycles (program_qdd had all K); a
    reversed slice too; rows that are not a slice of integers: a StateError naming rows."""
    dt = 0.01
    q = parabola(10, dt)
    res = simulate(two_link(), q, dt)
    for rows in (slice(0, 10, 2), slice(None, None, -1), slice(3, 7)):
        cols = res.columns(rows)
        assert {len(c) for c in cols.values()} == {len(range(10)[rows])}
        qdd = res.program_qdd(rows)
        for k, value in zip(range(10)[rows], qdd[:, 0], strict=True):
            # the first cycle starts at rest (qd0 = 0); the last ends at rest (velocity 0)
            expect = (program_qdd_closed_form(q, k, dt)[0] if 0 < k < 9 else
                      q[1, 0] / dt**2 if k == 0 else -(q[9, 0] - q[8, 0]) / dt**2)
            assert value == pytest.approx(expect, rel=1e-9)
    for bad in (3, slice("a", None), slice(0, 5, 0), [0, 1]):
        with pytest.raises(StateError, match=r"^rows: "):
            res.columns(bad)
        with pytest.raises(StateError, match=r"^rows: "):
            res.program_qdd(bad)


# --- 2. bool arguments ---------------------------------------------------------------------------

@pytest.mark.parametrize("value", ["x", 1, 0, None, "False", np.array([True])])
def test_a_non_bool_overwrite_is_refused_with_or_without_a_stream(tmp_path: Path,
                                                                  value: object) -> None:
    robot, q = two_link(), parabola(10, 0.01)
    with pytest.raises(OutputError, match=r"^overwrite: expected True or False"):
        simulate(robot, q, 0.01, overwrite=value)
    with pytest.raises(OutputError, match=r"^overwrite: expected True or False"):
        simulate(robot, q, 0.01, overwrite=value, stream=tmp_path / "s.csv")
    with pytest.raises(StateError, match=r"^reactions: expected True or False"):
        simulate(robot, q, 0.01, reactions=value)
    res = simulate(robot, q, 0.01)
    for call in (lambda: res.to_csv(tmp_path / "c.csv", overwrite=value),
                 lambda: res.save_summary(tmp_path / "s.json", overwrite=value),
                 lambda: res.plot(None, overwrite=value)):
        with pytest.raises(OutputError, match=r"^overwrite: expected True or False"):
            call()
    with pytest.raises(StateError, match=r"^view3d: expected True or False"):
        res.report(tmp_path / "r.html", view3d=value)
    assert list(tmp_path.iterdir()) == []
    assert simulate(robot, q, 0.01, overwrite=np.bool_(True), reactions=np.bool_(False)).K == 10


# --- 3. hostile arguments ------------------------------------------------------------------------

def test_a_program_too_large_for_memory_is_refused_before_any_copy() -> None:
    """A broadcast view of 1e10 rows (16 bytes of data) would need TB once copied: refused,
    naming the size, before the copy (it was a MemoryError from NumPy)."""
    huge = np.broadcast_to(np.zeros(2), (10**10, 2))
    with pytest.raises(StateError, match=r"^simulating 1e\+10 cycles of 2 joints needs about"):
        simulate(two_link(), huge, 0.01)
    with pytest.raises(StateError, match=r"^q_cmd: expected \(K, 2\) with K >= 2 cycles, got "
                                         r"\(0, 2\)"):
        simulate(two_link(), np.zeros((0, 2)), 0.01)


@pytest.mark.parametrize("q_cmd, dt, what", [
    (np.outer(np.linspace(0, 1, 10), [1, 1]), 1e-300, r"q_cmd: the program moves joint 'j1' at "
                                                      r"1\.11e\+299 rad/s at cycle 1"),
    (np.outer(np.linspace(0, 1, 10), [1, 1]), 5e-324, "q_cmd: .* at inf rad/s at cycle 1"),
    (np.vstack([np.full((5, 2), 1e308), np.full((5, 2), -1e308)]), 0.01,
     "q_cmd: .* at -inf rad/s at cycle 5"),
    (np.outer(np.linspace(0, 1e5, 10), [0, 1]), 0.01, "q_cmd: .*joint 'j2' at 1\\.11e\\+06"),
])
def test_a_program_faster_than_any_machine_is_refused(q_cmd: np.ndarray, dt: float,
                                                       what: str) -> None:
    """A speed beyond RUNAWAY_SPEED (1e6 rad/s), overflowing included, is a unit mistake: it
    was simulated into a 'runaway at t = 0' with no cycle, with overflow warnings."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no overflow warning on the way
        with pytest.raises(StateError, match=f"^{what}.*beyond 1e\\+06 rad/s"):
            simulate(two_link(), q_cmd, dt)


@pytest.mark.parametrize("qd0", [[1e7, 0.0], [0.0, -1e300]])
def test_a_start_faster_than_any_machine_is_refused(qd0: list[float]) -> None:
    with pytest.raises(StateError, match=r"^qd0: .* beyond 1e\+06 rad/s"):
        simulate(two_link(), np.zeros((10, 2)), 0.01, qd0=qd0)
    ok = simulate(two_link(), np.zeros((10, 2)), 0.01, qd0=[RUNAWAY_SPEED / 2, 0.0])
    assert ok.qd[0, 0] == RUNAWAY_SPEED / 2


@pytest.mark.parametrize("kwargs, match", [
    ({"q0": [0.0, 0.0, 0.0]}, r"^q0: "), ({"q0": [[0.0, 0.0]]}, r"^q0: expected shape \(2,\)"),
    ({"qd0": np.zeros((3, 2))}, r"^qd0: expected shape \(2,\), got \(3, 2\)"),
    ({"q0": [math.nan, 0.0]}, "^q0: contains NaN"), ({"qd0": [0.0, math.inf]}, r"^qd0: "),
    ({"catch_up": math.nan}, r"^catch_up: "), ({"catch_up": math.inf}, r"^catch_up: "),
    ({"catch_up": -0.1}, r"^catch_up: "), ({"catch_up": True}, r"^catch_up: "),
    ({"f_ext": np.zeros((9, 6))}, r"^f_ext: "), ({"f_ext": np.zeros((10, 1, 6))}, r"^f_ext: "),
    ({"f_ext_point": np.zeros((9, 3))}, r"^f_ext_point: "),
    ({"f_ext": {"l2": np.zeros((9, 6))}}, r"^f_ext"),
    ({"progress": lambda: None}, r"^progress: must take two arguments"),
    ({"progress": 3}, r"^progress: "),
    ({"q_cmd": np.zeros((10, 2), dtype=object)}, r"^q_cmd: "),
    ({"q_cmd": [[0.0, 0.0], [0.0]]}, r"^q_cmd: "),
    ({"q_cmd": np.zeros((10, 2), bool)}, r"^q_cmd: "),
    ({"q_cmd": np.zeros((1, 2))}, r"^q_cmd: "), ({"q_cmd": np.zeros((3, 4, 2))}, r"^q_cmd: "),
    ({"dt": 0.0}, r"^dt: "), ({"dt": 1e4}, r"^dt: "), ({"dt": np.array([0.01])}, r"^dt: "),
])
def test_hostile_arguments_end_in_one_error_naming_them(kwargs: dict, match: str) -> None:
    args = {"q_cmd": np.zeros((10, 2)), "dt": 0.01, **kwargs}
    with pytest.raises(MrneaError, match=match):
        simulate(two_link(), **args)


def test_a_progress_callback_of_the_wrong_arity_is_refused_before_any_cycle(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """It was a TypeError from inside the run, after the first chunk's cycles."""
    def no_run(*args: object) -> None:
        raise AssertionError("simulated")

    monkeypatch.setattr(simulate_module, "simulate_cycles", no_run)
    for bad in (lambda done: None, lambda a, b, c: None):
        with pytest.raises(StateError, match=r"^progress: must take two arguments"):
            simulate(two_link(), np.zeros((10, 2)), 0.01, progress=bad)
    # what takes two arguments one way or another is taken
    for good in (lambda *a: None, lambda a, b, c=0: None, print):
        with pytest.raises(AssertionError, match="simulated"):
            simulate(two_link(), np.zeros((10, 2)), 0.01, progress=good)


def test_an_exception_from_progress_reaches_the_caller_and_writes_no_stream(
        tmp_path: Path) -> None:
    """The user's own error, as it is (not a partial result: that is KeyboardInterrupt's), and
    no stream file, no temporary left."""
    class Stop(Exception):
        pass

    def progress(done: int, total: int) -> None:
        raise Stop("mine")

    dt = 1e-3
    with pytest.raises(Stop, match="mine"):
        simulate(two_link(), parabola(2 * CHUNK, dt), dt, progress=progress,
                 stream=tmp_path / "s.csv")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("where", ["dir", "exists", "missing", "empty"])
def test_a_stream_that_cannot_be_written_is_refused_before_the_run(
        tmp_path: Path, where: str, monkeypatch: pytest.MonkeyPatch) -> None:
    def no_run(*args: object) -> None:
        raise AssertionError("simulated")

    monkeypatch.setattr(simulate_module, "simulate_cycles", no_run)
    (tmp_path / "exists.csv").write_text("user data")
    path = {"dir": tmp_path, "exists": tmp_path / "exists.csv",
            "missing": tmp_path / "no" / "s.csv", "empty": ""}[where]
    with pytest.raises(OutputError):
        simulate(two_link(), np.zeros((10, 2)), 0.01, stream=path)
    assert (tmp_path / "exists.csv").read_text() == "user data"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["exists.csv"]


@pytest.mark.parametrize("stream", [3, b"s.csv", "", ["s.csv"]])
def test_a_stream_that_is_no_path_is_named_stream(stream: object) -> None:
    """It was named "path" (the writer's name for every file it writes)."""
    with pytest.raises(OutputError, match=r"^stream: expected a file path"):
        simulate(two_link(), np.zeros((10, 2)), 0.01, stream=stream)
