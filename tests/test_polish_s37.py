"""Inputs a hostile user gives that earlier checks let through (session 37): a bool where a number
is expected, text where a model's number is expected, and the filter cut-off's error in the
words of the call that was made (the library's keyword, the command's option)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import mrnea_cli, one_error_line

import mrnea
from mrnea.errors import ModelError, StateError
from mrnea.model import Link

PUMA = mrnea.robots.puma560()


@pytest.mark.parametrize("q", [np.ones(6, bool), [True] * 6, True])
def test_a_bool_state_is_refused_naming_it(q) -> None:
    """NumPy reads True as 1.0; a joint position given as True is a mistake, not 1 rad."""
    with pytest.raises(StateError, match=r"^q: expected real numbers, got True/False"):
        mrnea.inverse_dynamics(PUMA, q, np.zeros(6), np.zeros(6))


def test_a_bool_jerk_limit_is_refused_not_read_as_one() -> None:
    path = np.linspace(0, 0.1, 5)[:, None] * np.ones(6)
    with pytest.raises(StateError, match=r"^jerk_limit: expected real numbers, got True/False"):
        mrnea.retime(PUMA, path, dt=0.01, jerk_limit=True)


def test_the_states_numbers_still_pass() -> None:
    """Integers and float32 are numbers (the refusal is of bools only): the result equals the
    same state given as float64."""
    ref = mrnea.inverse_dynamics(PUMA, np.zeros(6), np.zeros(6), np.ones(6))
    assert np.array_equal(mrnea.inverse_dynamics(PUMA, [0] * 6, np.zeros(6, np.float32),
                                                 np.ones(6, int)), ref)


@pytest.mark.parametrize("com", [["0", "0", "0.1"], [0, 0, "0.1"], np.array([True, False, True]),
                                 [b"0", 0, 0]])
def test_text_or_bools_in_a_links_array_are_refused(com) -> None:
    """NumPy's float64 conversion reads "0.1" as 0.1: a model built from strings (a parser's
    untouched fields) is refused, naming the field."""
    with pytest.raises(ModelError, match=r"link 'a': centre of mass: not a numeric array "
                                         r"\(expected real numbers"):
        Link(name="a", mass=1.0, com=com, inertia=np.eye(3))


def test_text_gravity_is_refused() -> None:
    with pytest.raises(ModelError, match="gravity: not a numeric array"):
        PUMA.with_gravity(["0", "0", "-9.81"])


def test_a_links_numbers_still_load() -> None:
    link = Link(name="a", mass=1.0, com=[0, np.float32(0.5), 0.1], inertia=np.eye(3))
    assert link.com.tolist() == [0.0, 0.5, 0.1]


def _log(n_samples: int = 200, rate_hz: float = 100.0):
    t = np.arange(n_samples) / rate_hz
    q = 0.3 * np.sin(np.outer(t, np.arange(1, 7)))
    return t, q


def test_the_cutoff_error_names_the_librarys_keyword() -> None:
    """A cut-off at or above half the sample rate (Nyquist: 50 Hz for 100 Hz samples) cannot be
    filtered; the library's error names its keyword, cutoff_hz."""
    from mrnea.identify.log import derivatives

    t, q = _log()
    with pytest.raises(StateError, match=r"^cutoff_hz: .*, 50\) Hz"):
        derivatives(t, q, cutoff_hz=50.0)
    derivatives(t, q, cutoff_hz=49.0)  # below Nyquist: filtered


def test_the_cutoff_error_names_the_commands_option(tmp_path) -> None:
    """The command's line names its option (--cutoff), never the library's keyword."""
    t, q = _log()
    tau = np.ones_like(q)
    header = "time [s]," + ",".join(f"{j.name} [rad]" for j in PUMA.joints) + "," + \
        ",".join(f"tau_{j.name} [N m]" for j in PUMA.joints)
    rows = np.column_stack([t, q, tau])
    log = tmp_path / "log.csv"
    np.savetxt(log, rows, delimiter=",", header=header, comments="")
    res = mrnea_cli("identify", "puma560", log, "--cutoff", "60", "--out", tmp_path / "o")
    one_error_line(res, "--cutoff", "50) Hz")
    assert "cutoff_hz" not in res.stderr


def test_holding_a_joint_that_does_not_carry_the_tool_changes_nothing() -> None:
    """docs/cartesian.md: the left arm's joints do not carry the right hand, so holding them
    gives the path solved without the hold, bit for bit; the right hand reaches the target
    (its pose from the forward kinematics at a known q)."""
    from mrnea.ik import solve_path

    robot = mrnea.load_urdf(Path(__file__).parents[1] / "examples" / "waist_two_arms.urdf")
    q0 = np.zeros(robot.n)
    q_goal = np.array([0.1, 0, 0, 0, 0, 0.3, -0.2, 0.4, 0.1])
    target = mrnea.forward_kinematics(robot, q_goal)[robot.link_names.index("hand_r") + 1]
    free = solve_path(robot, target, q0, tool="hand_r")
    held = solve_path(robot, target, q0, tool="hand_r",
                      hold=["shoulder_pitch_l", "shoulder_roll_l", "elbow_l", "wrist_l"])
    assert np.array_equal(free.q, held.q)
    assert free.position_error.max() < 1e-9


def test_no_commands_summary_stops_at_an_abbreviation() -> None:
    """`mrnea --help` lists each command with its docstring's first sentence, which click cuts at
    the first full stop: "Reproduce the paper's Fig." was fig3's line."""
    from mrnea.cli import main

    for name, cmd in main.commands.items():
        line = cmd.get_short_help_str(limit=200)
        assert not line.endswith(("Fig.", "e.g.", "i.e.", "vs.", "Eq.", "approx.")), (name, line)


def test_a_library_keyword_reads_as_the_commands_option_wherever_it_is_named() -> None:
    from mrnea.cli.base import as_option
    options = {"min_speed": "--min-speed", "dt": "--dt", "starts": "--starts",
               "candidates": "--candidates"}
    assert as_option("starts: at most candidates (3), got 5", options) == \
        "--starts: at most --candidates (3), got 5"
    assert as_option("log: joint 1 moves faster than min_speed in 1 samples", options) == \
        "log: joint 1 moves faster than --min-speed in 1 samples"
    # part of a longer word (dtype, min_speeds) or already an option: left as it is
    assert as_option("dtype min_speeds --dt", options) == "dtype min_speeds --dt"
