"""The command line with real robots, end to end (``python -m mrnea`` in a subprocess).

UR5 and Panda from example-robot-data; the robot options (--actuators, --tip, --payload,
--gravity) and a program's keys of the same names; programs that name their robot by a relative
path; ``info`` with no robot, an unknown one, a xacro file, --json. Efforts are checked against
Pinocchio's gravity torques of the same URDF (a payload appended as a body of the last joint,
the model's gravity set), read back from cycles.csv with pandas.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tomllib
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pandas
import pinocchio as pin
import pytest
from conftest import erd_path, mrnea_cli, one_error_line

from mrnea.io import parse_payload

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
UR5 = "ur_description/urdf/ur5_robot.urdf"
PANDA = "panda_description/urdf/panda.urdf"
HOLD = [0.3, -1.2, 1.4, -0.9, 1.1, 0.4]  # rad: a UR5 pose away from every singular one
PAYLOAD = (2.0, [0.0, 0.0, 0.1])  # kg, m in wrist_3_link's frame


def hold_program(path: Path, robot: str | None, extra: str = "", q=HOLD) -> None:
    """A program holding the robot still at q for 0.1 s (two equal waypoints and a dwell)."""
    head = ["[program]", *([f'robot = "{robot}"'] if robot else []), "dt = 0.01", extra]
    path.write_text("\n".join([*head, "[path]", 'profile = "quintic"',
                               f"waypoints = [{list(q)}, {list(q)}]", "velocity_limit = 1.0",
                               "acceleration_limit = 1.0", "dwell = 0.05"]) + "\n")


def pin_gravity(urdf: Path, q, gravity=(0.0, 0.0, -9.81), payload=PAYLOAD) -> np.ndarray:
    """Pinocchio's static torques of the URDF's arm at q, with the payload on the last joint."""
    model = pin.buildModelFromUrdf(str(urdf))
    if payload is not None:
        m, c = payload
        model.appendBodyToJoint(model.njoints - 1, pin.Inertia(m, np.array(c), np.zeros((3, 3))),
                                pin.SE3.Identity())
    model.gravity = pin.Motion(np.array([*gravity, 0.0, 0.0, 0.0]))
    data = model.createData()
    zero = np.zeros(model.nv)
    return np.array(pin.rnea(model, data, np.array(q, dtype=float), zero, zero))


def efforts(csv: Path, joints) -> np.ndarray:
    """(K, n) joint efforts from a cycles.csv, read with one pandas call."""
    table = pandas.read_csv(csv)
    for j in joints:
        assert table[f"saturated_{j}"].dtype == bool
    return table[[f"tau_{j} [N m]" for j in joints]].to_numpy()


@pytest.fixture(scope="module")
def ur5_site(tmp_path_factory):
    """robots/ur5.urdf, progs/{drives.toml, hold.toml} (hold names ../robots/ur5.urdf, the
    sidecar and a 2 kg payload) and an empty folder elsewhere/ to run from."""
    site = tmp_path_factory.mktemp("ur5")
    (site / "robots").mkdir()
    (site / "progs").mkdir()
    (site / "elsewhere").mkdir()
    urdf = site / "robots" / "ur5.urdf"
    shutil.copy(erd_path(UR5), urdf)
    (site / "progs" / "drives.toml").write_text(
        "[shoulder_pan_joint]\nrotor_inertia = 7e-5\ngear_ratio = 101.0\n"
        "torque_speed = [150.0, 2.1, 3.3]\n"
        "[wrist_3_joint]\nrotor_inertia = 1.3e-5\ngear_ratio = 101.0\neffort_limit = 20.0\n")
    m, c = PAYLOAD
    hold_program(site / "progs" / "hold.toml", "../robots/ur5.urdf",
                 f'actuators = "drives.toml"\npayload = "{m}@{c[0]},{c[1]},{c[2]}"')
    return site


@pytest.fixture(scope="module")
def floor_run(ur5_site: Path) -> Path:
    """The hold program simulated from another folder: its output folder."""
    res = mrnea_cli("simulate", "../progs/hold.toml", "--out", "out", cwd=ur5_site / "elsewhere")
    assert res.returncode == 0, res.stderr
    assert res.stdout.startswith("ACHIEVABLE: ur5 follows the program")
    return ur5_site / "elsewhere" / "out"


def test_ur5_program_with_sidecar_and_payload(ur5_site: Path, floor_run: Path) -> None:
    """The program alone (run from another folder) names the robot, the sidecar and the payload:
    the efforts are Pinocchio's gravity torques with the payload, the limits the sidecar's."""
    robot = json.loads(mrnea_cli("info", "progs/hold.toml", "--json", cwd=ur5_site).stdout)
    names = [j["name"] for j in robot["joints"]]
    tau = efforts(floor_run / "cycles.csv", names)
    expected = pin_gravity(ur5_site / "robots" / "ur5.urdf", HOLD)
    assert np.abs(expected - pin_gravity(ur5_site / "robots" / "ur5.urdf", HOLD,
                                         payload=None)).max() > 1.0  # the payload matters
    np.testing.assert_allclose(tau, np.broadcast_to(expected, tau.shape), rtol=0, atol=1e-9)
    summary = json.loads((floor_run / "summary.json").read_text())
    assert [j["effort_limit"] for j in summary["joints"]][::5] == [150.0, 20.0]
    assert robot["joints"][0]["torque_speed"] == {"peak": 150.0, "corner_speed": 2.1,
                                                  "no_load_speed": 3.3}
    assert robot["joints"][0]["rotor_inertia"] == 7e-5 and robot["joints"][5]["gear_ratio"] == 101


def test_command_line_payload_overrides_the_programs(ur5_site: Path) -> None:
    """--payload replaces the program's payload (here by none), it does not add to it."""
    res = mrnea_cli("check", "progs/hold.toml", "--payload", "0", "--json", cwd=ur5_site)
    assert res.returncode == 0, res.stderr
    peaks = [j["peak_effort"] for j in json.loads(res.stdout)["joints"]]
    bare = pin_gravity(ur5_site / "robots" / "ur5.urdf", HOLD, payload=None)
    np.testing.assert_allclose(peaks, np.abs(bare), rtol=0, atol=1e-9)


def test_ceiling_mounted_ur5(ur5_site: Path, floor_run: Path) -> None:
    """--gravity 0,0,9.81 hangs the robot: Pinocchio's torques with model.gravity set so, and
    the floor-mounted ones with the sign flipped. ROBOT is the program's file by another path."""
    res = mrnea_cli("simulate", "../robots/ur5.urdf", "hold.toml", "--gravity", "0,0,9.81",
                "--out", "up", cwd=ur5_site / "progs")
    assert res.returncode == 0, res.stderr
    names = [j["name"] for j in json.loads(
        mrnea_cli("info", "robots/ur5.urdf", "--json", cwd=ur5_site).stdout)["joints"]]
    up = efforts(ur5_site / "progs" / "up" / "cycles.csv", names)
    down = efforts(floor_run / "cycles.csv", names)
    expected = pin_gravity(ur5_site / "robots" / "ur5.urdf", HOLD, gravity=(0.0, 0.0, 9.81))
    np.testing.assert_allclose(up, np.broadcast_to(expected, up.shape), rtol=0, atol=1e-9)
    np.testing.assert_allclose(up, -down, rtol=0, atol=1e-9)
    assert np.abs(up).max() > 10.0


def test_robot_other_than_the_programs_is_an_error(ur5_site: Path) -> None:
    line = one_error_line(mrnea_cli("check", "puma560", "progs/hold.toml", cwd=ur5_site))
    assert "robot 'puma560' is not the robot progs/hold.toml names" in line
    assert "ur5.urdf" in line


def test_wrong_joint_count_names_file_and_counts(ur5_site: Path) -> None:
    hold_program(ur5_site / "progs" / "ur5_fast.toml", "../robots/ur5.urdf", q=HOLD[:5])
    line = one_error_line(mrnea_cli("check", "progs/ur5_fast.toml", cwd=ur5_site))
    assert line.endswith("progs/ur5_fast.toml: 5 joint values per waypoint, robot ur5 has 6")


def test_program_naming_no_robot(ur5_site: Path) -> None:
    hold_program(ur5_site / "progs" / "anyrobot.toml", None)
    line = one_error_line(mrnea_cli("check", "progs/anyrobot.toml", cwd=ur5_site))
    assert "names no robot" in line
    res = mrnea_cli("check", "robots/ur5.urdf", "progs/anyrobot.toml", cwd=ur5_site)
    assert res.returncode == 0, res.stderr


def test_panda_tip(tmp_path: Path) -> None:
    """Without --tip the Panda loads whole and its second finger, a <mimic> joint, is an error
    naming it, the option and the candidate tips that avoid it; with --tip, the arm ends at the
    chosen link, the rest lumped into link 7."""
    urdf = erd_path(PANDA)
    line = one_error_line(mrnea_cli("info", str(urdf), cwd=tmp_path))
    assert "'panda_finger_joint2': <mimic>" in line and "--tip LINK" in line
    assert line.endswith("panda_leftfinger, panda_hand_tcp")
    res = mrnea_cli("info", str(urdf), "--tip", "panda_hand_tcp", "--json", cwd=tmp_path)
    data = json.loads(res.stdout)
    assert data["n"] == 7 and [j["name"] for j in data["joints"]] == [
        f"panda_joint{i}" for i in range(1, 8)]
    # link 7 carries everything after joint 7 (fixed joints and the fingers, frozen at 0)
    root = ET.parse(urdf).getroot()
    mass = {lk.get("name"): float(lk.find("inertial/mass").get("value"))
            for lk in root.findall("link") if lk.find("inertial/mass") is not None}
    after = ["panda_link7", "panda_link8", "panda_hand", "panda_hand_tcp", "panda_leftfinger",
             "panda_rightfinger"]
    assert data["joints"][-1]["link"]["mass"] == pytest.approx(
        sum(mass.get(n, 0.0) for n in after), rel=1e-12)
    prog = tmp_path / "panda.toml"
    hold_program(prog, str(urdf), 'tip = "panda_hand_tcp"',
                 q=[0.0, -0.5, 0.0, -2.0, 0.0, 1.5, 0.8])
    res = mrnea_cli("check", "panda.toml", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    line = one_error_line(mrnea_cli("check", "panda.toml", "--tip", "panda_leftfinger",
                                cwd=tmp_path))
    assert "7 joint values per waypoint, robot panda has 8" in line


def test_info_without_robot_unknown_and_xacro(tmp_path: Path) -> None:
    res = mrnea_cli("info", cwd=tmp_path)
    assert res.returncode == 0 and "sdt" in res.stdout and "puma560" in res.stdout
    line = one_error_line(mrnea_cli("info", "ur5", cwd=tmp_path))
    assert "'ur5' is neither a built-in robot (sdt, puma560) nor a file" in line
    (tmp_path / "arm.urdf.xacro").write_text("<robot/>")
    line = one_error_line(mrnea_cli("info", "arm.urdf.xacro", cwd=tmp_path))
    assert "xacro arm.urdf.xacro > arm.urdf" in line


def test_info_json_is_strict_and_the_table_fits(tmp_path: Path) -> None:
    def refuse(token: str) -> None:
        raise AssertionError(f"not strict JSON: {token}")

    res = mrnea_cli("info", "sdt", "--json", cwd=tmp_path)
    data = json.loads(res.stdout, parse_constant=refuse)
    assert data["joints"][0]["upper"] is None and data["joints"][3]["upper"] == pytest.approx(
        np.pi / 2)
    for columns in ("60", "100"):
        env = dict(os.environ, COLUMNS=columns)
        out = subprocess.run([sys.executable, "-m", "mrnea", "info", "sdt"], cwd=tmp_path,
                             capture_output=True, text=True, timeout=600, env=env).stdout
        assert max(map(len, out.splitlines())) <= int(columns)
        assert "effort [N m]" in out and "curve [N m, rad/s]" in out


def test_examples_ur5_program_and_sidecar(tmp_path: Path) -> None:
    """examples/ur5_pick.toml with its sidecar is achievable; 12 kg instead of its 3 saturates a
    wrist: the verdict and the final position error carry units."""
    urdf = str(erd_path(UR5))
    res = mrnea_cli("check", urdf, str(EXAMPLES / "ur5_pick.toml"), cwd=tmp_path)
    assert res.returncode == 0 and res.stdout.startswith("ACHIEVABLE"), res.stderr
    res = mrnea_cli("check", urdf, str(EXAMPLES / "ur5_pick.toml"), "--payload", "12@0,0,0.1",
                cwd=tmp_path)
    assert res.returncode == 1, res.stderr
    assert "NOT ACHIEVABLE" in res.stdout and "wrist_1_joint" in res.stdout
    assert " N m" in res.stdout and "final position error" in res.stdout and " rad" in res.stdout


def test_docs_sidecar_and_payload_examples(tmp_path: Path) -> None:
    """robot-format.md's sidecar example is examples/ur5_drives.toml; its payload file reads."""
    doc = (ROOT / "docs" / "robot-format.md").read_text()
    block = doc.split("## Sidecar actuator files", 1)[1].split("```toml\n", 1)[1].split("```")[0]
    assert tomllib.loads(block) == tomllib.loads((EXAMPLES / "ur5_drives.toml").read_text())
    block = doc.split("## Payloads, tips and gravity", 1)[1].split("```toml\n", 1)[1]
    (tmp_path / "payload.toml").write_text(block.split("```")[0].replace("\n  ", "\n"))
    payload = parse_payload(str(tmp_path / "payload.toml"))
    assert payload.mass == 2.5 and payload.com.tolist() == [0.0, 0.0, 0.08]
    assert np.diag(payload.inertia).tolist() == [0.004, 0.004, 0.002]


def test_readme_library_example_prints_what_it_says(tmp_path: Path) -> None:
    """The README's library example runs (with the UR5 URDF next to it) and prints the verdict
    the text after it quotes."""
    readme = (ROOT / "README.md").read_text()
    part = readme.split("## The library", 1)[1]
    code = part.split("```python\n", 1)[1].split("```")[0]
    said = part.split("the example prints `", 1)[1].split("`")[0]
    shutil.copy(erd_path(UR5), tmp_path / "ur5_robot.urdf")
    res = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                         text=True, timeout=600, env=dict(os.environ))
    assert res.returncode == 0, res.stderr
    assert res.stdout.strip() == " ".join(said.split())


def test_several_tips_keep_the_subtree_holding_them(tmp_path: Path) -> None:
    """Baxter (a head and two arms on a fixed torso; mimic fingers): --tip repeated keeps the
    subtree holding the tips, depth first in file order, each joint's parent given."""
    urdf = erd_path("baxter_description/urdf/baxter.urdf")
    res = mrnea_cli("info", str(urdf), "--tip", "head", "--tip", "right_wrist", "--tip",
                    "left_wrist", "--json", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    names = [j["name"] for j in json.loads(res.stdout)["joints"]]
    arm = ["s0", "s1", "e0", "e1", "w0", "w1", "w2"]
    assert names == ["head_pan"] + [f"right_{j}" for j in arm] + [f"left_{j}" for j in arm]
