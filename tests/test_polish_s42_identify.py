"""Hostile inputs to ``mrnea identify`` and ``mrnea excite`` (session 42): each bad input is one
error naming the file, row, column or argument, never a traceback, a hang, runaway memory or a
wrong number in a written result.

The logs are written here: a two-link arm (both axes along y) moving along sums of sines at
100 Hz, with random efforts (the fit is not the point, the counts and messages are). The
expected numbers come from the documented rules, not from mrnea's output: the fit takes the
first ``round(K (1 - holdout))`` samples and holds out the rest (docs/identification.md), a log
gives its numbers in the grammar of :func:`mrnea.io.source.parse_number`.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import mrnea_cli, one_error_line

import mrnea
from mrnea.errors import LogFileError, StateError
from mrnea.identify import Log, excitation, identify, read_log
from mrnea.identify.log import MIN_SAMPLES
from mrnea.model import Joint, Link, Robot

HEADER = ["time [s]", "j1 [rad]", "j2 [rad]", "tau_j1 [N m]", "tau_j2 [N m]"]
RATE = 100.0  # [Hz]


def arm() -> Robot:
    j1 = Joint("j1", "revolute", "base", "l1", axis=(0, 1, 0))
    j2 = Joint("j2", "revolute", "l1", "l2", origin=mrnea.transform((0.5, 0, 0)), axis=(0, 1, 0))
    links = [Link("l1", 4.0, (0.25, 0, 0), np.diag([0.01, 0.09, 0.09])),
             Link("l2", 2.0, (0.2, 0, 0), np.diag([0.005, 0.03, 0.03]))]
    return Robot([j1, j2], links).with_actuators(gear_ratio=50.0, rotor_inertia=1e-4,
                                                 viscous_friction=1.0, coulomb_friction=0.5)


def samples(K: int, still: int | None = None, seed: int = 0) -> np.ndarray:
    """(K, 5) time [s], q1, q2 [rad], tau1, tau2 [N m]; joint ``still`` (0 or 1) held at 0.1."""
    t = np.arange(K) / RATE
    q = np.column_stack([np.sin(np.pi * t) + 0.3 * np.sin(2.6 * np.pi * t),
                         np.cos(1.4 * np.pi * t)])
    if still is not None:
        q[:, still] = 0.1
    tau = np.random.default_rng(seed).normal(size=(K, 2)) + 5 * q
    return np.column_stack([t, q, tau])


def write(path: Path, data: np.ndarray, delimiter: str = ",", header: list[str] = HEADER
          ) -> Path:
    lines = [delimiter.join(header)] + [delimiter.join(f"{x:.10g}" for x in row) for row in data]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


@pytest.fixture()
def robot_file(tmp_path: Path) -> Path:
    arm().to_toml(tmp_path / "arm.toml")
    return tmp_path / "arm.toml"


# --- 1. the log cut by --holdout -----------------------------------------------------------

def test_holdout_leaving_too_little_names_the_log_the_part_held_out_and_the_part_left(
        tmp_path, robot_file):
    K, holdout = 30, 0.3
    fit = round(K * (1 - holdout))  # the documented cut: the first 1 - holdout is fitted
    log = write(tmp_path / "short.csv", samples(K))
    out = tmp_path / "o"
    res = mrnea_cli("identify", robot_file, log, "--holdout", str(holdout), "--out", out)
    line = one_error_line(res, "short.csv", "--holdout", "--validate")  # before the label
    assert f"of the log's {K} samples" in line and f"holds out {K - fit} " in line
    assert f"leaving {fit} to fit" in line and str(MIN_SAMPLES) in line
    assert "got shape" not in line and not out.exists()


def test_holdout_library_message_and_a_short_held_out_end_is_predicted(tmp_path):
    robot = arm()
    d = samples(30)
    with pytest.raises(StateError, match=r"holdout: 0\.5 holds out 15 of the log's 30 samples, "
                                         r"leaving 15 to fit"):
        identify(robot, Log(d[:, 0], d[:, 1:3], d[:, 3:]), holdout=0.5, physical=False)
    # a held-out end shorter than a log may be (20 of 100 samples) is predicted, not refused
    d = samples(100)
    res = identify(robot, Log(d[:, 0], d[:, 1:3], d[:, 3:]), physical=False)
    assert res.fit.time.size == 80 and res.validation.time.size == 20
    np.testing.assert_array_equal(res.validation.measured, d[80:, 3:])


def test_holdout_short_end_on_the_command_line(tmp_path, robot_file):
    log = write(tmp_path / "log.csv", samples(100))
    res = mrnea_cli("identify", robot_file, log, "--out", tmp_path / "o", "--quiet")
    assert res.returncode == 0, res.stderr
    s = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert (s["validation"], s["fit_samples"], s["validation_samples"]) == ("holdout", 80, 20)


# --- 2. logs that cannot identify the robot: one line, before the progress label -------------

@pytest.mark.parametrize("still, words", [(1, ["'j2'", "0 of the"]), (0, ["'j1'", "0 of the"])])
def test_a_joint_that_never_moves_is_one_line(tmp_path, robot_file, still, words):
    log = write(tmp_path / "still.csv", samples(300, still=still))
    res = mrnea_cli("identify", robot_file, log, "--out", tmp_path / "o")
    one_error_line(res, "still.csv", "--min-speed", *words)
    assert not (tmp_path / "o").exists()


def test_a_huge_min_speed_and_zero_efforts_are_one_line(tmp_path, robot_file):
    log = write(tmp_path / "log.csv", samples(300))
    one_error_line(mrnea_cli("identify", robot_file, log, "--min-speed", "1e300", "--out",
                             tmp_path / "o"), "log.csv", "--min-speed", "'j1'")
    d = samples(300)
    d[:, 4] = 0.0
    one_error_line(mrnea_cli("identify", robot_file, write(tmp_path / "z.csv", d), "--out",
                             tmp_path / "o"), "z.csv", "'j2'", "effort")


def test_a_joint_at_rest_in_the_validation_log_has_no_rms_not_zero(tmp_path, robot_file):
    log = write(tmp_path / "log.csv", samples(300))
    check = write(tmp_path / "check.csv", samples(300, still=1, seed=1))
    res = mrnea_cli("identify", robot_file, log, "--validate", check, "--out", tmp_path / "o",
                    "--quiet")
    assert res.returncode == 0, res.stderr
    s = json.loads((tmp_path / "o" / "summary.json").read_text())
    rms = [j["validation_rms"] for j in s["joints"]]
    assert rms[0] is not None and rms[0] > 0 and rms[1] is None


def test_a_validation_log_of_another_joint_count_is_named():
    d = samples(100)
    three = Log(d[:, 0], np.column_stack([d[:, 1:3], d[:, 1]]),
                np.column_stack([d[:, 3:], d[:, 3]]))
    with pytest.raises(StateError, match=r"validation: expected a mrnea\.identify\.Log of 2 "):
        identify(arm(), Log(d[:, 0], d[:, 1:3], d[:, 3:]), validation=three, physical=False)


# --- 3. the CSV's variants -----------------------------------------------------------------

@pytest.mark.parametrize("delimiter", [";", "\t"])
def test_other_delimiters_read_as_the_header_says(tmp_path, delimiter):
    d = samples(60)
    log = read_log(write(tmp_path / "log.csv", d, delimiter), arm())
    # the file holds the numbers to 10 significant digits
    np.testing.assert_allclose(np.column_stack([log.time, log.q, log.tau]), d, rtol=1e-9,
                               atol=1e-12)


def test_blank_lines_are_skipped_and_rows_keep_the_files_line_numbers(tmp_path):
    d = samples(60)
    text = write(tmp_path / "log.csv", d).read_text().splitlines()
    text.insert(3, "")  # line 4 blank: the data row of line 5 is the file's line 5
    text[8] = text[8].replace(text[8].split(",")[3], "x", 1)  # line 9
    p = tmp_path / "blank.csv"
    p.write_text("\n".join(text) + "\n\n\n", encoding="utf-8")
    with pytest.raises(LogFileError, match=r"blank\.csv: row 9: column 'tau_j1': not a number"):
        read_log(p, arm())
    text[8] = ",".join(f"{x:.10g}" for x in d[6])  # the 7th sample, back in place
    p.write_text("\n".join(text) + "\n\n\n", encoding="utf-8")
    log = read_log(p, arm())
    np.testing.assert_allclose(log.tau, d[:, 3:], rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("cell, words", [
    ("1_0", ["row 5", "'tau_j1'", "'1_0'"]),  # Python's float reads 10; the grammar does not
    ("\u0661", ["row 5", "'tau_j1'"]),  # an Arabic-Indic digit one
    ("nan", ["row 5", "'tau_j1'"]),
    ("1e999", ["row 5", "'tau_j1'"]),
])
def test_a_cell_outside_the_number_grammar_is_named(tmp_path, robot_file, cell, words):
    text = write(tmp_path / "log.csv", samples(60)).read_text(encoding="utf-8").splitlines()
    cells = text[4].split(",")
    cells[3] = cell
    text[4] = ",".join(cells)
    p = tmp_path / "bad.csv"
    p.write_text("\n".join(text) + "\n", encoding="utf-8")
    one_error_line(mrnea_cli("identify", robot_file, p, "--out", tmp_path / "o"), "bad.csv",
                   *words)


def test_a_decimal_comma_and_a_long_row_are_named(tmp_path, robot_file):
    text = write(tmp_path / "log.csv", samples(60), ";").read_text().splitlines()
    cells = text[6].split(";")
    cells[1] = cells[1].replace(".", ",")
    text[6] = ";".join(cells)
    p = tmp_path / "comma.csv"
    p.write_text("\n".join(text) + "\n")
    one_error_line(mrnea_cli("identify", robot_file, p, "--out", tmp_path / "o"), "comma.csv",
                   "row 7", "'j1'", "decimal point")
    text = write(tmp_path / "log.csv", samples(60)).read_text().splitlines()
    text[9] += ",7"
    p.write_text("\n".join(text) + "\n")
    one_error_line(mrnea_cli("identify", robot_file, p, "--out", tmp_path / "o"), "comma.csv",
                   "row 10", "6 columns", "5")


@pytest.mark.parametrize("rows", [0, 1, 3, MIN_SAMPLES - 1])
def test_too_few_rows_say_how_many(tmp_path, robot_file, rows):
    p = write(tmp_path / "few.csv", samples(60)[:rows])
    line = one_error_line(mrnea_cli("identify", robot_file, p, "--out", tmp_path / "o"),
                          "few.csv", f"{rows} data row", f"at least {MIN_SAMPLES}")
    assert "shape" not in line


def test_a_log_beyond_16_mib_is_read(tmp_path):
    K = 300_000  # at 1 kHz, 5 minutes: about 17 MB of CSV
    t = np.arange(K) / 1000.0
    q = np.column_stack([np.sin(t), np.cos(t)])
    d = np.column_stack([t, q, 2 * q + 1])
    p = tmp_path / "long.csv"
    np.savetxt(p, d, fmt="%.8f", delimiter=",", header=",".join(HEADER), comments="")
    assert p.stat().st_size > 16 * 2 ** 20
    log = read_log(p, arm())
    assert log.K == K
    np.testing.assert_allclose(log.tau, 2 * q + 1, atol=1e-8)


def test_a_log_whose_regressor_exceeds_the_memory_budget_is_refused(monkeypatch):
    import mrnea.resources

    monkeypatch.setattr(mrnea.resources, "available_memory", lambda: 2 ** 20)  # budget: 256 MiB
    K = 400_000  # the arm's regressor alone: K x 2 x 30 doubles, 192 MB, and its copies
    t = np.arange(K) / 1000.0
    q = np.column_stack([np.sin(t), np.cos(t)])
    with pytest.raises(StateError, match=r"400000 samples needs about .* of memory"):
        identify(arm(), Log(t, q, q + 1), physical=False)


# --- 4. mrnea excite -----------------------------------------------------------------------

def test_excite_gigantic_candidates_is_one_line_not_a_hang(robot_file, tmp_path):
    res = mrnea_cli("excite", robot_file, "--candidates", "1000000000", "--out", tmp_path / "o",
                    "--quiet", timeout=120)
    one_error_line(res, "--candidates", "1000000000")
    assert not (tmp_path / "o" / "excitation.csv").exists()


def test_excite_names_the_limit_that_leaves_no_motion(robot_file, tmp_path):
    res = mrnea_cli("excite", robot_file, "--acceleration-limit", "1e-300", "--harmonics", "2",
                    "--candidates", "3", "--starts", "0", "--out", tmp_path / "o", "--quiet")
    line = one_error_line(res, "--acceleration-limit")
    assert "--velocity-limit" not in line  # the arm has no velocity limit; none was given


def test_excitation_samples_beyond_memory_are_refused():
    with pytest.raises(StateError, match=r"samples: .* needs about"):
        excitation(arm(), harmonics=2, candidates=1, starts=0, samples=10 ** 12)


def test_an_unsteady_time_step_is_warned_of_once(tmp_path: Path) -> None:
    """A log whose time step leaves [1/2, 3/2] of its median (a gap of dropped samples): one
    warning naming the file, the step range and the first row after such a step (the rates'
    filter takes the samples as equally spaced); a steady log, or one with rate columns, none."""
    import warnings

    data = samples(300)
    data[200:, 0] += 1.0  # a 1 s gap before the file's row 202 (the header is row 1)
    with pytest.warns(UserWarning, match=r"gap\.csv: the time step varies from 0\.01 s to "
                                         r"1\.01 s .*1 step\(s\).*before row 202") as seen:
        read_log(write(tmp_path / "gap.csv", data), arm())
    assert len(seen) == 1
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        read_log(write(tmp_path / "steady.csv", samples(300)), arm())
