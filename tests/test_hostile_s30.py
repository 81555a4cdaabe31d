"""Hostile inputs to the newest features (session 30): each was a traceback-like internal error,
a silent wrong answer or an unbounded pool before, and is one clear error (or the right answer)
now.

* ``mrnea identify``: a log column given twice (the first one was used, silently), efforts
  beyond 1e12 (an internal LinAlgError in the consistent fit), time steps of 1e-300 s (an
  internal LinAlgError in the filter's design).
* ``mrnea size``: a catalogue torque of 1e308 (an internal LinAlgError in the plot, after
  summary.json was written).
* ``mrnea retime --jerk-limit J`` with one value (refused: "expected shape (6,)").
* A path CSV whose header names the joints with units, ``waist [rad]``, in another order than
  the robot's (read by position: each joint got another joint's column); a unit that is not the
  joint's is refused.
* A tool ``xyz`` of 1e30 m (blamed on dt). A ragged per-joint value (a ValueError).

The oracle of the path CSV case is the hand-written array (the waist's column holds 0.5, every
other joint 0); the others check the one error line (exit 2) naming the file, the column or the
field, and that no output file was written.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import mrnea_cli, one_error_line

import mrnea
from mrnea.errors import MrneaError
from mrnea.identify.log import derivatives
from mrnea.io.pathcsv import from_csv
from mrnea.model import Joint, Link, Robot
from mrnea.sizing.catalogue import loads_catalogue
from mrnea.validate import per_joint

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
HEADER = "time [s],j1 [rad],j2 [rad],tau_j1 [N m],tau_j2 [N m]"


def _arm() -> Robot:
    """A two-link arm in a vertical plane, drives on both joints."""
    j1 = Joint("j1", "revolute", "base", "l1", axis=(0, 1, 0))
    j2 = Joint("j2", "revolute", "l1", "l2", origin=mrnea.transform((0.5, 0, 0)), axis=(0, 1, 0))
    return Robot([j1, j2], [Link("l1", 4.0, (0.25, 0, 0), np.diag([0.01, 0.09, 0.09])),
                            Link("l2", 2.0, (0.2, 0, 0), np.diag([0.005, 0.03, 0.03]))]
                 ).with_actuators(gear_ratio=50.0, rotor_inertia=1e-4)


def _log(path: Path, header: str, row) -> Path:
    path.write_text(header + "\n" + "".join(",".join(map(str, row(k))) + "\n"
                                            for k in range(60)))
    return path


def test_identify_hostile_logs_one_error_line(tmp_path):
    _arm().to_toml(tmp_path / "arm.toml")
    cases = [  # (log, words the error names)
        (_log(tmp_path / "twice.csv", HEADER + ",j1 [rad]",
              lambda k: (k / 100, 0.1 * np.sin(k / 9), 0.2, 1, 2, 5.0)),
         ["twice.csv", "row 1", "'j1'", "twice", "2", "6"]),
        (_log(tmp_path / "huge.csv", HEADER,
              lambda k: (k / 100, 0.1 * np.sin(k / 9), 0.2, 1e200, 2)),
         ["huge.csv", "tau", "1e+12"]),
    ]
    for log, words in cases:
        res = mrnea_cli("identify", tmp_path / "arm.toml", log, "--out", tmp_path / "o")
        one_error_line(res, *words)
        assert not (tmp_path / "o").exists()


def test_identify_hostile_time_and_cutoff_through_the_api(tmp_path):
    robot = _arm()
    tiny = _log(tmp_path / "tiny.csv", HEADER,
                lambda k: (k * 1e-300, 0.1 * np.sin(k / 9), 0.2, 1, 2))
    log = mrnea.identify.read_log(tiny, robot)  # time strictly increasing: a valid log
    with pytest.raises(MrneaError, match=r"cut-off 10.0 Hz must be in \[1e\+294"):
        mrnea.identify.identify(robot, log)
    with pytest.raises(MrneaError, match=r"late.csv: row 61: column 'time' is 1e\+300, beyond "
                                         r"1e\+12"):
        mrnea.identify.read_log(_log(tmp_path / "late.csv", HEADER, lambda k: (
            1e300 if k == 59 else k / 100, 0.0, 0.0, 1, 2)), robot)
    t = np.arange(60) / 100
    with pytest.raises(MrneaError, match="cut-off"):  # 1e-9 Hz at 100 Hz: the design fails
        derivatives(t, np.zeros((60, 2)), 1e-9)


def test_catalogue_beyond_the_bound_is_refused_before_any_file(tmp_path):
    text = (EXAMPLES / "drives_catalogue.toml").read_text()
    bad = tmp_path / "cat.toml"
    bad.write_text(text.replace("peak_torque = 40.0", "peak_torque = 1e308")
                   .replace("rated_torque = 13.0", "rated_torque = 1e308"))
    res = mrnea_cli("size", "sdt", EXAMPLES / "sdt_training.toml", "--catalogue", bad,
                    "--joints", "cab_yaw", "--out", tmp_path / "o")
    one_error_line(res, "cat.toml", "motor 'M-40'", "rated_torque", "1e+09")
    assert not (tmp_path / "o").exists()
    with pytest.raises(MrneaError, match="'mass' 1e\\+300 is beyond 1e\\+07"):
        loads_catalogue(text.replace("mass = 12.0", "mass = 1e300"))


def test_one_jerk_limit_for_every_joint(tmp_path):
    still = tmp_path / "still.toml"
    still.write_text('[program]\nname = "still"\nrobot = "puma560"\ndt = 0.01\n\n[path]\n'
                     'profile = "quintic"\nwaypoints = [[0.0, 0.5, -0.5, 0.0, 0.0, 0.0], '
                     '[0.0, 0.5, -0.5, 0.0, 0.0, 0.0]]\nvelocity_limit = 1.0\n'
                     'acceleration_limit = 1.0\ndwell = 0.1\n')
    # the one value is taken (the check after it answers), not refused for its shape;
    # --quiet: a cold Numba cache would add the compile notice to stderr
    res = mrnea_cli("retime", still, "--jerk-limit", "5", "--out", tmp_path / "o", "--quiet")
    one_error_line(res, "never moves")
    assert per_joint([5.0], "jerk_limit", 3).tolist() == [5.0, 5.0, 5.0]
    with pytest.raises(MrneaError, match="not a numeric array"):
        per_joint([[1.0], [2.0, 3.0]], "jerk_limit", 2)


NAMES = ["waist", "shoulder_pitch_l", "shoulder_roll_l", "elbow_l", "wrist_l",
         "shoulder_pitch_r", "shoulder_roll_r", "elbow_r", "wrist_r"]


def _named_csv(path: Path, header: list[str]) -> Path:
    """A path CSV of the waist robot whose waist column holds 0.5, every other joint 0, its
    columns in the reversed order, headed by ``header`` (the joint names reversed)."""
    rows = [",".join([f"{k / 10}"] + ["0.5" if h.startswith("waist") else "0.0"
                                      for h in header]) for k in range(3)]
    path.write_text(",".join(["time [s]", *header]) + "\n" + "\n".join(rows) + "\n")
    return path


def test_csv_header_with_units_is_matched_by_name(tmp_path):
    robot = mrnea.load_robot(EXAMPLES / "waist_two_arms.urdf")
    expected = np.zeros(robot.n)
    expected[NAMES.index("waist")] = 0.5
    assert list(robot.joint_names) == NAMES
    for header in ([n for n in NAMES[::-1]], [f"{n} [rad]" for n in NAMES[::-1]]):
        _, q = from_csv(_named_csv(tmp_path / "p.csv", header), 0.01, robot=robot)
        np.testing.assert_array_equal(q[0], expected)
    _, q = from_csv(_named_csv(tmp_path / "d.csv", [f"{n} [deg]" for n in NAMES[::-1]]), 0.01,
                    robot=robot, units="deg")
    np.testing.assert_allclose(q[0], np.radians(expected), rtol=1e-15)
    with pytest.raises(MrneaError, match=r"'wrist_r \[deg\]'.*read in 'rad'"):
        from_csv(_named_csv(tmp_path / "w.csv", [f"{n} [deg]" for n in NAMES[::-1]]), 0.01,
                 robot=robot)
    res = mrnea_cli("check", EXAMPLES / "waist_two_arms.urdf", tmp_path / "w.csv", "--dt",
                    "0.01")
    one_error_line(res, "w.csv", "line 1", "wrist_r [deg]", "'rad'")


def test_tool_beyond_the_length_bound():
    with pytest.raises(MrneaError, match="tool: 'xyz': length 1e\\+30 m is beyond"):
        mrnea.forward_kinematics(mrnea.robots.puma560(), np.zeros(6),
                                 tool={"xyz": [0.0, 0.0, 1e30]})
