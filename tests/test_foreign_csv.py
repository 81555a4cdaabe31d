"""Path CSVs from elsewhere, through the command line as a real process: a controller's log
separated by tabs, semicolons or spaces reads as the comma file it equals; a file in degrees
(mm for prismatic joints) with ``--units deg`` checks as its SI twin; a file in degrees read as
rad gets a hint at ``--units deg``; and a retime is never suggested where no timing can help (a
path starting or going outside a joint's position limits).

Oracles: the same rows written with commas and in SI units by the test (numpy.degrees, x 1000),
and the robots' position limits.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import mrnea_cli, one_error_line

import mrnea
from mrnea.errors import PathWarning
from mrnea.io.pathcsv import from_csv
from mrnea.model import Joint, Link, Robot

ROOT = Path(__file__).resolve().parents[1]
SDT_CSV = ROOT / "examples" / "sdt_profile.csv"
HOME_DEG = [0.0, 45.0, -135.0, 0.0, -45.0, 0.0]  # the Puma pick's home pose


def write_rows(path: Path, header: list[str], rows: np.ndarray, sep: str = ",") -> Path:
    lines = [sep.join(header)] + [sep.join(repr(float(v)) for v in r) for r in rows]
    path.write_text("\n".join(lines) + "\n")
    return path


def sdt_rows() -> tuple[list[str], np.ndarray]:
    lines = [ln for ln in SDT_CSV.read_text().splitlines() if ln and not ln.startswith("#")]
    return lines[0].split(","), np.array([[float(c) for c in ln.split(",")] for ln in lines[1:]])


def puma_move(to_deg: list[float], T: float = 2.0) -> np.ndarray:
    """(t, q1..q6) rows [s, deg]: a cosine ramp from home to ``to_deg`` in T s, every 0.02 s."""
    t = np.arange(0.0, T + 1e-9, 0.02)
    s = 0.5 * (1 - np.cos(np.pi * t / T))
    q = np.array(HOME_DEG) + np.outer(s, np.subtract(to_deg, HOME_DEG))
    return np.column_stack([t, q])


@pytest.mark.parametrize("sep", ["\t", ";", " ", "   "], ids=["tab", "semicolon", "space",
                                                             "spaces"])
def test_a_controller_log_reads_as_its_comma_twin(tmp_path: Path, sep: str) -> None:
    header, rows = sdt_rows()
    comma = write_rows(tmp_path / "comma.csv", header, rows)
    other = write_rows(tmp_path / "log.csv", header, rows, sep)
    want = mrnea_cli("check", "sdt", comma, "--dt", "0.01", "--json")
    got = mrnea_cli("check", "sdt", other, "--dt", "0.01", "--json")
    assert want.returncode == got.returncode == 0, got.stderr
    assert json.loads(got.stdout) == json.loads(want.stdout)


def test_an_unknown_or_mixed_delimiter_is_one_error_naming_them(tmp_path: Path) -> None:
    header, rows = sdt_rows()
    pipes = write_rows(tmp_path / "pipes.csv", header, rows[:5], "|")
    one_error_line(mrnea_cli("check", "sdt", pipes, "--dt", "0.01"), "pipes.csv", "line 1",
                   "comma, a semicolon, a tab or spaces")
    mixed = write_rows(tmp_path / "mixed.csv", header, rows[:5], ";")
    text = mixed.read_text().splitlines()
    text[3] = text[3].replace(";", ",")
    mixed.write_text("\n".join(text) + "\n")
    one_error_line(mrnea_cli("check", "sdt", mixed, "--dt", "0.01"), "mixed.csv", "line 4",
                   "separated by semicolon", "comma")



def test_a_decimal_comma_is_one_error_naming_both_delimiters(tmp_path: Path) -> None:
    """A European controller log: semicolons between the columns and decimal commas. The error
    names the cell, the comma it holds and the semicolon the header uses."""
    header, rows = sdt_rows()
    path = tmp_path / "euro.csv"
    text = ";".join(header) + "\n" + "".join(
        ";".join(f"{v:.4f}".replace(".", ",") for v in r) + "\n" for r in rows[:5])
    path.write_text(text)
    one_error_line(mrnea_cli("check", "sdt", path, "--dt", "0.01"), "euro.csv", "line 2",
                   "column 1", "the cell holds a comma", "separated by semicolon",
                   "decimal point")

def test_degrees_with_units_deg_check_as_radians(tmp_path: Path) -> None:
    deg = puma_move([30.0, 60.0, -120.0, 0.0, -60.0, 30.0])
    rad = deg.copy()
    rad[:, 1:] = np.radians(deg[:, 1:])
    header = ["t", *(f"q{i}" for i in range(1, 7))]
    want = mrnea_cli("check", "puma560", write_rows(tmp_path / "rad.csv", header, rad),
                     "--dt", "0.005")
    got = mrnea_cli("check", "puma560", write_rows(tmp_path / "deg.csv", header, deg),
                    "--dt", "0.005", "--units", "deg")
    assert want.returncode == got.returncode == 0, got.stderr
    assert got.stdout == want.stdout and got.stderr == ""


def test_degrees_read_as_radians_get_a_hint_and_no_retime(tmp_path: Path) -> None:
    deg = puma_move([30.0, 60.0, -120.0, 0.0, -60.0, 30.0])
    path = write_rows(tmp_path / "export_deg.csv", ["t", *(f"q{i}" for i in range(1, 7))], deg)
    res = mrnea_cli("check", "puma560", path, "--dt", "0.008")
    assert res.returncode == 1, res.stderr
    assert "start outside the position limits" in res.stdout
    warning = [ln for ln in res.stderr.splitlines() if ln.startswith("mrnea: warning:")]
    assert len(warning) == 1 and "look like degrees" in warning[0]
    assert "--units deg" in warning[0] and "'joint2' starts at 45" in warning[0]
    assert "units=" not in warning[0]  # the command line's words only
    assert "Retime it" not in res.stdout
    assert ("No timing can make it achievable: joint 'joint2' starts at 45 rad, outside its "
            "position limits [-0.7854, 3.927] rad") in res.stdout
    with pytest.warns(PathWarning, match="look like degrees") as caught:  # the library's words
        from_csv(path, 0.008, robot=mrnea.robots.puma560())
    said = str(caught[0].message)
    assert said.endswith('pass units="deg"') and "--units" not in said, said


def test_a_path_leaving_the_limits_gets_no_retime(tmp_path: Path) -> None:
    deg = puma_move([0.0, 45.0, 60.0, 0.0, -45.0, 0.0], T=0.3)  # joint3 above its 45 deg
    rad = deg.copy()
    rad[:, 1:] = np.radians(deg[:, 1:])
    path = write_rows(tmp_path / "out.csv", ["t", *(f"q{i}" for i in range(1, 7))], rad)
    res = mrnea_cli("check", "puma560", path, "--dt", "0.005")
    assert res.returncode == 1, res.stderr
    assert "Retime it" not in res.stdout + res.stderr
    assert "No timing can make it achievable: joint 'joint3' reaches " in res.stdout
    assert "outside its position limits [-3.927, 0.7854] rad" in res.stdout
    assert "look like degrees" not in res.stderr  # the start is within the limits


def slider(tmp_path: Path) -> Path:
    """A revolute joint and a prismatic one (a vertical slider carrying 2 kg), as a robot file."""
    joints = [Joint("turn", "revolute", "base", "arm", axis=[0, 0, 1], lower=-3.0, upper=3.0,
                    effort_limit=50.0, velocity_limit=3.0),
              Joint("lift", "prismatic", "arm", "carriage", axis=[0, 0, 1], lower=0.0,
                    upper=0.5, effort_limit=200.0, velocity_limit=1.0)]
    links = [Link("arm", mass=5.0, com=[0.2, 0, 0], inertia=np.diag([0.05, 0.2, 0.2])),
             Link("carriage", mass=2.0, com=[0, 0, 0], inertia=np.diag([0.01, 0.01, 0.01]))]
    return Robot(joints, links, name="slider").to_toml(tmp_path / "slider.toml")


def test_units_deg_reads_a_prismatic_column_in_mm(tmp_path: Path) -> None:
    robot = slider(tmp_path)
    t = np.arange(0.0, 2.0 + 1e-9, 0.02)
    s = 0.5 * (1 - np.cos(np.pi * t / 2.0))
    si = np.column_stack([t, 1.2 * s, 0.1 + 0.3 * s])  # rad, m
    mixed = np.column_stack([t, np.degrees(si[:, 1]), 1000.0 * si[:, 2]])  # deg, mm
    want = mrnea_cli("check", robot, write_rows(tmp_path / "si.csv", ["t", "turn", "lift"], si),
                     "--dt", "0.005", "--json")
    got = mrnea_cli("check", robot, write_rows(tmp_path / "mm.csv", ["t", "turn", "lift"],
                                                mixed), "--dt", "0.005", "--json", "--units",
                    "deg")
    assert want.returncode == 0 and got.returncode == 0, got.stderr
    a, b = json.loads(want.stdout), json.loads(got.stdout)
    for ja, jb in zip(a["joints"], b["joints"], strict=True):
        assert jb["program_peak_effort"] == pytest.approx(ja["program_peak_effort"], rel=1e-9)
        assert jb["peak_speed"] == pytest.approx(ja["peak_speed"], rel=1e-9)


def test_units_needs_a_csv_program() -> None:
    one_error_line(mrnea_cli("check", ROOT / "examples" / "puma_pick.toml", "--units", "deg"),
                   "--units", "[path]")


def test_a_program_files_units_deg_reads_a_prismatic_joint_in_mm(tmp_path: Path) -> None:
    """A program file's ``units = "deg"`` means what ``--units deg`` does: degrees for the
    revolute joint, mm for the prismatic one. Oracle: the same program written in SI by the
    test (numpy.radians, / 1000), by waypoints and by a CSV path."""
    robot = slider(tmp_path)
    head = f'[program]\nrobot = "{robot}"\ndt = 0.005\n[path]\nprofile = "trapezoidal"\n'
    (tmp_path / "si.toml").write_text(
        head + f"waypoints = [[0, 0.1], [{float(np.radians(60.0))!r}, 0.4]]\n"
        f"velocity_limit = [{float(np.radians(90.0))!r}, 0.25]\n"
        f"acceleration_limit = [{float(np.radians(180.0))!r}, 0.5]\n")
    (tmp_path / "deg.toml").write_text(
        head + 'units = "deg"\nwaypoints = [[0, 100], [60, 400]]\n'
        "velocity_limit = [90, 250]\nacceleration_limit = [180, 500]\n")
    import mrnea

    si, deg = (mrnea.load_program(tmp_path / f"{k}.toml") for k in ("si", "deg"))
    si.load_robot(), deg.load_robot()
    assert deg.q_cmd.shape == si.q_cmd.shape
    np.testing.assert_allclose(deg.q_cmd, si.q_cmd, rtol=1e-12, atol=1e-15)
    assert deg.q_cmd[:, 1].max() == pytest.approx(0.4, rel=1e-12)  # m, not 400 x pi/180
    want, got = (mrnea_cli("check", tmp_path / f"{k}.toml", "--json") for k in ("si", "deg"))
    assert want.returncode == 0 and got.returncode == 0, got.stderr
    a, b = json.loads(want.stdout), json.loads(got.stdout)
    for ja, jb in zip(a["joints"], b["joints"], strict=True):
        assert jb["program_peak_effort"] == pytest.approx(ja["program_peak_effort"], rel=1e-9)
        assert jb["peak_speed"] == pytest.approx(ja["peak_speed"], rel=1e-9)
    # a CSV path in deg and mm: the program file and --units deg read it alike
    t = np.arange(0.0, 2.0 + 1e-9, 0.02)
    s = 0.5 * (1 - np.cos(np.pi * t / 2.0))
    write_rows(tmp_path / "mm.csv", ["t", "turn", "lift"],
               np.column_stack([t, 70.0 * s, 100.0 + 300.0 * s]))
    (tmp_path / "csv.toml").write_text(f'[program]\nrobot = "{robot}"\ndt = 0.005\n'
                                       '[path]\ncsv = "mm.csv"\nunits = "deg"\n')
    prog = mrnea.load_program(tmp_path / "csv.toml")
    prog.load_robot()
    np.testing.assert_allclose(prog.csv_rows[:, 2], 0.1 + 0.3 * s, rtol=1e-12)
    np.testing.assert_allclose(prog.csv_rows[:, 1], np.radians(70.0 * s), rtol=1e-12)
    a = json.loads(mrnea_cli("check", tmp_path / "csv.toml", "--json").stdout)
    b = json.loads(mrnea_cli("check", robot, tmp_path / "mm.csv", "--dt", "0.005", "--units",
                             "deg", "--json").stdout)
    for ja, jb in zip(a["joints"], b["joints"], strict=True):
        assert jb["program_peak_effort"] == pytest.approx(ja["program_peak_effort"], rel=1e-9)
