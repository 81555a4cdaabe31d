"""``mrnea identify`` as a real process (issue 28): its files, checked against the known truth.

The oracle is independent of mrnea's dynamics: the logs of a two-link arm in a vertical plane are
made here with Pinocchio's ``rnea`` for the rigid body plus the drive law written out by hand
(``G^2 J_m qdd + F_v qd + F+ [qd > 0] - F- [qd < 0]``), along sums of sines with closed-form
rates, with Gaussian noise on the efforts (0.5 % of each joint's largest) and positions quantised
to 1e-5 rad; the fit log holds motor currents (``--torque-constant``, tau = G k_t i). Checked:
summary.json valid against the schema the package ships (every field documented with its unit);
each drive parameter that is a base parameter of its own within 3 standard errors of the truth,
joint 1's rotor inertia reported as folded into link 1's I_yy (both seen through qdd_1 alone);
the identified robot file plus the sidecar, put through Pinocchio and the drive law again,
predicting the truth's efforts on a third motion within the noise; ``mrnea check`` answering with
the identified robot file and with the sidecar; no file replaced without ``--force``; the page in
headless Chromium at 800 and 1400 px; bad logs as one error line naming the file, row and column.

The shipped example (``examples/puma_identify_*``, simulated by mrnea from a known Puma 560, slow):
every base parameter within 3 standard errors of the truth file's, the identified Puma's efforts
through Pinocchio within the noise of the truth's, and the script regenerating the logs.
"""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import jsonschema
import numpy as np
import pandas as pd
import pytest
from chromium_cdp import Browser, ChromiumUnavailable
from conftest import (
    PinChain,
    environment,
    figure_scales,
    mrnea_cli,
    one_error_line,
    sines_trajectory,
    to_pinocchio,
)

import mrnea
from mrnea.identify.output import schema_path
from mrnea.model import Joint, Link, Robot

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
SCHEMA = jsonschema.Draft202012Validator(json.loads(schema_path().read_text(encoding="utf-8")))
KT = (0.1, 0.2)  # [N m/A] the arm's torque constants
G = 50.0
RATE, QUANTUM, NOISE = 200.0, 1e-5, 0.005
# the arm's truth: per joint reflected rotor inertia G^2 J_m [kg m^2], F_v, F+, F-
ROTOR = (0.3, 0.2)
VISCOUS = (2.0, 1.2)
COULOMB = ((1.5, 1.0), (0.6, 0.9))
PROGRAM = """[program]
name = "swing"
dt = 0.01

[path]
profile = "quintic"
waypoints = [[-0.3, 0.0], [0.6, 1.0], [-0.3, 0.0]]
velocity_limit = [1.5, 1.5]
acceleration_limit = [5.0, 5.0]
"""


def arm(links: list[Link] | None = None, **drives) -> Robot:
    """A two-link arm in a vertical plane (both axes along y, gravity -z); the prior's links and
    drives unless given."""
    j1 = Joint("j1", "revolute", "base", "l1", axis=(0, 1, 0))
    j2 = Joint("j2", "revolute", "l1", "l2", origin=mrnea.transform((0.5, 0, 0)), axis=(0, 1, 0))
    links = links or [Link("l1", 4.0, (0.25, 0, 0), np.diag([0.01, 0.09, 0.09])),
                      Link("l2", 2.0, (0.2, 0, 0), np.diag([0.005, 0.03, 0.03]))]
    return Robot([j1, j2], links).with_actuators(
        **{"gear_ratio": G, "rotor_inertia": 1e-4, "viscous_friction": 1.0,
           "coulomb_friction": 0.5, **drives})


def truth() -> Robot:
    return arm([Link("l1", 4.4, (0.27, 0.01, 0.0), np.diag([0.012, 0.1, 0.095])),
                Link("l2", 2.5, (0.22, 0.0, 0.01), np.diag([0.006, 0.036, 0.033]))],
               rotor_inertia=[r / G ** 2 for r in ROTOR], viscous_friction=list(VISCOUS),
               coulomb_friction=[tuple(c) for c in COULOMB])


def motion(t: np.ndarray, waves) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q, qd, qdd (K, 2) of ``waves[j] = (c, [(a, l), ...])``: ``q_j = c + sum_l a (sin(l w t) -
    l sin(w t))``, w = 2 pi F0: periodic, at rest with qdd = 0 at every whole period (an
    excitation trajectory's ends; the zero-phase filter sees no edge)."""
    w = 2 * np.pi * F0
    q, qd, qdd = (np.zeros((t.size, 2)) for _ in range(3))
    for j, (c, wave) in enumerate(waves):
        q[:, j] += c
        for a, ell in wave:
            q[:, j] += a * (np.sin(ell * w * t) - ell * np.sin(w * t))
            qd[:, j] += a * ell * w * (np.cos(ell * w * t) - np.cos(w * t))
            qdd[:, j] -= a * ell * w * w * (ell * np.sin(ell * w * t) - np.sin(w * t))
    return q, qd, qdd


F0 = 0.1  # [Hz]
FIT = [(0.2, [(0.25, 2), (0.1, 3), (0.03, 5)]), (-0.3, [(-0.2, 2), (0.08, 4), (0.02, 7)])]
CHECK = [(-0.1, [(0.2, 3), (-0.05, 4)]), (0.4, [(0.15, 2), (0.04, 5)])]
OTHER = [(0.0, [(-0.3, 2), (0.04, 6)]), (0.1, [(0.1, 3), (0.05, 4)])]


def efforts(robot: Robot, rotor, viscous, coulomb, q, qd, qdd) -> np.ndarray:
    """Pinocchio's rnea plus the drive law by hand (module docstring), (K, 2) [N m]."""
    pin = PinChain(robot, to_pinocchio(robot))
    tau = np.array([pin.rnea(*s) for s in zip(q, qd, qdd, strict=True)])
    c = np.asarray(coulomb)
    return (tau + np.asarray(rotor) * qdd + np.asarray(viscous) * qd
            + np.where(qd > 0, c[:, 0], 0.0) - np.where(qd < 0, c[:, 1], 0.0))


def write_log(path: Path, waves, duration: float, seed: int, rates: bool) -> np.ndarray:
    """A log of the truth's motor currents along ``waves`` (with exact qd_, qdd_ columns if
    ``rates``); returns the noise level per joint [N m]."""
    t = np.arange(round(duration * RATE)) / RATE
    q, qd, qdd = motion(t, waves)
    tau = efforts(truth(), ROTOR, VISCOUS, COULOMB, q, qd, qdd)
    noise = NOISE * np.abs(tau).max(axis=0)
    tau = tau + np.random.default_rng(seed).normal(size=tau.shape) * noise
    cols = {"time [s]": t, "j1 [rad]": np.round(q[:, 0] / QUANTUM) * QUANTUM,
            "j2 [rad]": np.round(q[:, 1] / QUANTUM) * QUANTUM}
    for j in range(2):
        cols[f"i_j{j + 1} [A]"] = tau[:, j] / (G * KT[j])
    if rates:
        for j in range(2):
            cols[f"qd_j{j + 1}"], cols[f"qdd_j{j + 1}"] = qd[:, j], qdd[:, j]
    pd.DataFrame(cols).to_csv(path, index=False, float_format="%.10g")
    return noise


def summary_of(folder: Path) -> dict:
    def bad(c):
        raise ValueError(f"not strict JSON: {c}")
    s = json.loads((folder / "summary.json").read_text(), parse_constant=bad)
    errors = sorted(SCHEMA.iter_errors(s), key=str)
    assert not errors, [f"{list(e.absolute_path)}: {e.message}" for e in errors]
    return s


def test_the_schema_documents_every_field_and_every_unit():
    schema = json.loads(schema_path().read_text(encoding="utf-8"))
    jsonschema.Draft202012Validator.check_schema(schema)

    def fields(node: dict, where: str = ""):
        for name, sub in node.get("properties", {}).items():
            yield f"{where}.{name}", sub
            yield from fields(sub.get("items", sub), f"{where}.{name}")

    found = list(fields(schema))
    assert len(found) == 50  # 21 top-level fields, 8 per parameter, 16 per joint, 5 per link
    for path, sub in found:
        assert sub.get("description"), path
        types = sub.get("type", [])
        if "number" in ([types] if isinstance(types, str) else types):
            assert sub.get("unit"), f"{path}: a number without its unit"


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    d = tmp_path_factory.mktemp("identify")
    arm().to_toml(d / "arm.toml")
    noise = write_log(d / "fit.csv", FIT, 30.0, 1, rates=False)
    write_log(d / "check.csv", CHECK, 10.0, 2, rates=True)
    res = mrnea_cli("identify", "arm.toml", "fit.csv", "--validate", "check.csv",
                    "--torque-constant", ",".join(map(str, KT)), "--out", "out", cwd=d)
    return d, res, noise


def test_identify_recovers_the_arm_within_three_standard_errors(work):
    d, res, noise = work
    assert res.returncode == 0, res.stderr
    out = d / "out"
    assert res.stdout.splitlines()[-1].startswith(f"Wrote {out.name}: identified_robot.toml")
    s = summary_of(out)
    assert s["validation"] == "log" and s["validation_samples"] == 10 * RATE
    assert s["torque_constant"] == list(KT) and s["rates"] == "filtered"
    assert s["physically_consistent"]
    checked = 0
    for j, jd in enumerate(s["joints"]):
        truth_values = {"reflected_rotor_inertia": ROTOR[j], "viscous_friction": VISCOUS[j],
                        "coulomb_friction_pos": COULOMB[j][0],
                        "coulomb_friction_neg": COULOMB[j][1]}
        for field, value in truth_values.items():
            se = jd[f"{field}_se"]
            if se is None:
                continue
            checked += 1
            assert abs(jd[field] - value) <= 3 * se, (jd["joint"], field, jd[field], value, se)
        # the residual is the noise, and the validation log is predicted within it
        assert abs(jd["residual_std"] / noise[j] - 1) < 0.15, (jd["residual_std"], noise[j])
        assert jd["validation_rms"] < 1.5 * noise[j]
    assert checked == 7  # all but joint 1's rotor inertia, which only shows with link 1's I_yy
    assert s["joints"][0]["folded"] == {"reflected_rotor_inertia": "l1.Iyy"}


def test_the_identified_files_predict_the_truth_through_pinocchio(work):
    """identified_robot.toml's links and identified_drives.toml's drives, through Pinocchio and
    the drive law by hand, on a third motion: the truth's efforts within the noise."""
    d, _, noise = work
    ident = mrnea.io.load_robot_spec(str(d / "out" / "identified_robot.toml"))
    drives = [tomllib.loads((d / "out" / "identified_drives.toml").read_text())[j]
              for j in ("j1", "j2")]
    t = np.arange(round(10 * RATE)) / RATE
    q, qd, qdd = motion(t, OTHER)
    got = efforts(arm(list(ident.links)), [x["gear_ratio"] ** 2 * x["rotor_inertia"]
                                           for x in drives],
                  [x["viscous_friction"] for x in drives], [x["coulomb_friction"] for x in drives],
                  q, qd, qdd)
    want = efforts(truth(), ROTOR, VISCOUS, COULOMB, q, qd, qdd)
    moving = np.abs(qd) > 0.05
    rms = np.sqrt((np.where(moving, got - want, 0) ** 2).sum(axis=0) / moving.sum(axis=0))
    assert np.all(rms < noise), (rms, noise)
    # the robot file holds the sidecar's drives
    for j, jt in enumerate(ident.joints):
        assert (jt.gear_ratio, jt.rotor_inertia, jt.viscous_friction) == (
            drives[j]["gear_ratio"], drives[j]["rotor_inertia"], drives[j]["viscous_friction"])
        assert list(ident.coulomb_friction[j]) == drives[j]["coulomb_friction"]


def test_check_answers_with_the_identified_model_and_nothing_is_replaced(work):
    d, _, _ = work
    (d / "swing.toml").write_text(PROGRAM)
    ok = mrnea_cli("check", "arm.toml", "swing.toml", "--actuators", "out/identified_drives.toml",
                   cwd=d)
    assert ok.returncode == 0, ok.stdout + ok.stderr
    ok = mrnea_cli("check", "out/identified_robot.toml", "swing.toml", cwd=d)
    assert ok.returncode == 0, ok.stdout + ok.stderr
    again = mrnea_cli("identify", "arm.toml", "fit.csv", "--torque-constant", "0.1,0.2",
                      "--out", "out", cwd=d)
    one_error_line(again, "exists")


def test_holdout_and_efforts_in_the_log(tmp_path):
    """Efforts (tau_ columns) instead of currents, the end of the log held out, and a prior whose
    drives are a hundred times too large: the consistent fit starts the drives from the log's
    estimate, so that it does not stall near the prior (it did: xtol after a few evaluations)."""
    arm(rotor_inertia=0.01, viscous_friction=200.0, coulomb_friction=100.0).to_toml(
        tmp_path / "arm.toml")
    noise = write_log(tmp_path / "fit.csv", FIT, 30.0, 3, rates=False)
    df = pd.read_csv(tmp_path / "fit.csv")
    for j in range(2):
        df[f"tau_j{j + 1} [N m]"] = df.pop(f"i_j{j + 1} [A]") * G * KT[j]
    df.to_csv(tmp_path / "tau.csv", index=False, float_format="%.10g")
    res = mrnea_cli("identify", "arm.toml", "tau.csv", "--holdout", "0.25", "--quiet", "--out",
                    "o", cwd=tmp_path)
    assert res.returncode == 0 and res.stdout == "", res.stderr
    s = summary_of(tmp_path / "o")
    assert (s["validation"], s["fit_samples"], s["validation_samples"]) == ("holdout", 4500, 1500)
    assert s["torque_constant"] is None
    for j, jd in enumerate(s["joints"]):
        for field, value in [("viscous_friction", VISCOUS[j]),
                             ("coulomb_friction_pos", COULOMB[j][0]),
                             ("coulomb_friction_neg", COULOMB[j][1])]:
            assert abs(jd[field] - value) <= 3 * jd[f"{field}_se"], (jd["joint"], field)
        assert jd["validation_rms"] < 1.5 * noise[j]
    assert abs(s["joints"][1]["reflected_rotor_inertia"] - ROTOR[1]) <= 3 * s["joints"][1][
        "reflected_rotor_inertia_se"]
    for p in s["parameters"]:  # the consistent robot is the least squares estimate, to noise
        assert abs(p["identified"] - p["estimate"]) <= 3 * p["standard_error"], p


@pytest.mark.parametrize("width", [800, 1400])
def test_the_page_in_chromium(work, width):
    d, res, _ = work
    assert res.returncode == 0, res.stderr
    try:
        with Browser(width=width, height=1000) as b:
            page = b.open((d / "out" / "identify.html").as_uri())
            shown = page.evaluate(
                "[...document.images].map(i => [i.complete, i.naturalWidth, "
                "i.getBoundingClientRect().width])")
            overflow = page.evaluate("document.documentElement.scrollWidth - innerWidth")
            tables = page.evaluate("document.querySelectorAll('table').length")
            text = page.evaluate("document.body.innerText")
            scales = figure_scales(page)
            assert not page.errors and not page.outside_requests
    except ChromiumUnavailable as exc:
        pytest.skip(str(exc))
    assert len(shown) == 4 and all(c and w >= 600 and 0 < r <= width for c, w, r in shown)
    # below 960 px a figure keeps its own pixels (and pans in its box), as the reports' do
    assert len(scales) == 4 and min(scales) >= (0.999 if width < 960 else 0.7), scales
    assert overflow <= 0 and tables == 3
    assert "(in l1.Iyy)" in text and "condition number" in text


def _bad(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "bad.csv"
    p.write_text(text)
    return p


HEADER = "time [s],j1 [rad],j2 [rad],tau_j1 [N m],tau_j2 [N m]\n"
ROWS = "".join(f"{k / 100:.2f},{0.1 * k},{0.2 * k},1,2\n" for k in range(40))


@pytest.mark.parametrize("text, words", [
    ("time [s],j1 [rad],j2 [rad],tau_j1 [N m]\n0,0,0,0\n", ["bad.csv", "row 1", "tau_j2"]),
    (HEADER + ROWS.replace("0.05,0.5,1.0,1,2", "0.05,0.5,1.0,1"), ["bad.csv", "row 7", "4"]),
    (HEADER + ROWS.replace("0.05,0.5,", "0.03,0.5,"), ["bad.csv", "row 7", "time"]),
    (HEADER + ROWS.replace("0.05,0.5,1.0,1,2", "0.05,0.5,nan,1,2"), ["bad.csv", "row 7", "j2"]),
    (HEADER + ROWS.replace("0.05,0.5,1.0,1,2", "0.05,0.5,1.0,x,2"), ["bad.csv", "row 7",
                                                                     "tau_j1", "'x'"]),
])
def test_bad_logs_one_error_line(tmp_path, text, words):
    arm().to_toml(tmp_path / "arm.toml")
    res = mrnea_cli("identify", tmp_path / "arm.toml", _bad(tmp_path, text), "--out",
                    tmp_path / "o")
    one_error_line(res, *words)
    assert not (tmp_path / "o" / "summary.json").exists()


def test_bad_options_one_error_line(tmp_path):
    arm().to_toml(tmp_path / "arm.toml")
    log = _bad(tmp_path, HEADER.replace("tau_", "i_").replace("N m", "A") + ROWS)
    one_error_line(mrnea_cli("identify", tmp_path / "arm.toml", log, "--torque-constant",
                             "0.1,0.2,0.3"), "torque constant", "3")
    one_error_line(mrnea_cli("identify", tmp_path / "arm.toml", log, "--torque-constant",
                             "-1"), "--torque-constant")
    one_error_line(mrnea_cli("identify", tmp_path / "arm.toml", log, "--torque-constant", "0.1",
                             "--holdout", "1.5", "--out", tmp_path / "o"), "holdout")
    one_error_line(mrnea_cli("identify", tmp_path / "arm.toml", log), "tau_j1")  # currents


# --- the shipped example, simulated by mrnea from a known Puma 560 ----------------------------

@pytest.fixture(scope="module")
def puma(tmp_path_factory):
    d = tmp_path_factory.mktemp("puma")
    res = mrnea_cli("identify", "puma560", EXAMPLES / "puma_identify_log.csv", "--validate",
                    EXAMPLES / "puma_identify_validate.csv", "--out", d / "out", "--quiet")
    assert res.returncode == 0, res.stderr
    return d / "out"


@pytest.mark.slow
def test_the_example_recovers_the_known_puma(puma):
    from mrnea.identify import actuator_parameters, inertial_parameters
    from mrnea.identify.base import base_parameters

    s = summary_of(puma)
    truth_robot = mrnea.io.load_robot_spec(str(EXAMPLES / "puma_identify_truth.toml"))
    theta = np.concatenate([inertial_parameters(truth_robot), actuator_parameters(truth_robot)])
    beta = base_parameters(truth_robot).K @ theta
    est = np.array([p["estimate"] for p in s["parameters"]])
    se = np.array([p["standard_error"] for p in s["parameters"]])
    z = (est - beta) / se
    assert np.all(np.abs(z) <= 3), dict(zip([p["name"] for p in s["parameters"]], z.round(2),
                                            strict=True))
    assert s["physically_consistent"] and s["condition"] < 1e4
    # the drives the truth file holds, joint by joint, where the log sees them on their own
    for jd, jt in zip(s["joints"], truth_robot.joints, strict=True):
        if jd["viscous_friction_se"] is not None:
            assert abs(jd["viscous_friction"] - jt.viscous_friction) <= 3 * jd[
                "viscous_friction_se"]


@pytest.mark.slow
def test_the_example_predicts_the_truth_through_pinocchio(puma):
    truth_robot = mrnea.io.load_robot_spec(str(EXAMPLES / "puma_identify_truth.toml"))
    ident = mrnea.io.load_robot_spec(str(puma / "identified_robot.toml"))
    log = pd.read_csv(EXAMPLES / "puma_identify_log.csv")
    noise = 0.005 * np.abs(log.filter(like="tau_").to_numpy()).max(axis=0)  # the script's
    _, q, qd, qdd = sines_trajectory(truth_robot)

    def model(r: Robot) -> np.ndarray:
        pin = PinChain(r, to_pinocchio(r))
        c = np.asarray(r.coulomb_friction)
        return (np.array([pin.rnea(*x) for x in zip(q, qd, qdd, strict=True)])
                + r.gear_ratio ** 2 * r.rotor_inertia * qdd + r.viscous_friction * qd
                + np.where(qd > 0, c[:, 0], 0) - np.where(qd < 0, c[:, 1], 0))

    moving = np.abs(qd) > 0.05
    err = np.where(moving, model(ident) - model(truth_robot), 0)
    rms = np.sqrt((err ** 2).sum(axis=0) / moving.sum(axis=0))
    assert np.all(rms < noise), (rms, noise)


@pytest.mark.slow
def test_the_script_regenerates_the_example(tmp_path):
    res = subprocess.run([sys.executable, EXAMPLES / "puma_identify.py", "--out", tmp_path],
                         capture_output=True, text=True, env=environment(), timeout=600)
    assert res.returncode == 0, res.stderr
    for name in ("puma_identify_log.csv", "puma_identify_validate.csv"):
        new, old = pd.read_csv(tmp_path / name), pd.read_csv(EXAMPLES / name)
        assert list(new.columns) == list(old.columns)
        np.testing.assert_allclose(new.to_numpy(), old.to_numpy(), rtol=1e-5, atol=1.01e-5)
        assert (EXAMPLES / name).stat().st_size < 500_000


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_identify_interrupted_exits_130_and_writes_nothing(tmp_path, sig):
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "mrnea", "identify", "puma560",
                             EXAMPLES / "puma_identify_log.csv", "--out", out],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline:  # the progress label: the fit is starting
        line = proc.stderr.readline()
        if line.startswith("identifying") or not line:
            break
    proc.send_signal(sig)
    stdout, stderr = proc.communicate(timeout=300)
    assert proc.returncode == 130, stderr
    assert "Traceback" not in stderr and "mrnea: interrupted" in stderr and stdout == ""
    assert not out.exists() or list(out.iterdir()) == []  # a folder it made is removed
