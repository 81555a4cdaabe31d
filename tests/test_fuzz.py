"""Fuzzing the robot-file loaders: nothing but mrnea's own errors may escape.

Hypothesis mutates valid robot files and feeds them to :func:`mrnea.load_robot`:

* URDF (the UR5 of example-robot-data, tests/malformed/reference_arm.urdf and a small file using
  every URDF feature mrnea reads): delete, duplicate, swap or move elements; replace attribute
  values and texts with random strings, numbers, NaN, inf, huge and denormal values, other names
  of the document (duplicates, cycles, dangling references) or other joint types; drop
  attributes; then possibly truncate the bytes, flip bytes or insert garbage.
* Native TOML (tests/malformed/reference_arm.toml, reference_dh_arm.toml and the built-in
  puma560.toml): delete, duplicate, swap or insert lines; replace numbers, strings and keys;
  truncate, flip bytes.

The property: ``load_robot`` raises a :class:`mrnea.errors.MrneaError` or returns a Robot, and
then every dynamics call (inverse and forward dynamics by all methods, mass matrix, joint
reactions, achievable accelerations, single states and a batch) returns finite numbers or raises
a MrneaError; the robot can be described and written to URDF and read back, and written as a
native TOML file and read back equal, bit for bit.

A model that loads must give finite results or a package error from every call, and survive
``to_urdf`` and a reload (the bugs this found, overflowing results, an axis normalised to zero,
names XML cannot hold, are fixed and documented in tests/test_malformed.py).

The fast tests run 50 examples per format; the ``slow`` ones (``-m slow``) a few thousand,
25-50 s per format. Hypothesis runs derandomized (conftest profile), so runs are reproducible.
"""

from __future__ import annotations

import copy
import json
import math
import re
import tempfile
import warnings
import xml.etree.ElementTree as ET
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
from conftest import robots_dir
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import mrnea
import mrnea.errors
from mrnea.achievable import achievable_accelerations
from mrnea.describe import describe
from mrnea.errors import MrneaError
from mrnea.io import load_robot
from mrnea.model import Robot

CORPUS = Path(__file__).resolve().parent / "malformed"
FAST_EXAMPLES = 50
SLOW_EXAMPLES = {"urdf": 2000, "toml": 3000}  # 25-50 s each, depending on the machine
SETTINGS = {"deadline": None, "suppress_health_check": list(HealthCheck)}

FEATURES_URDF = """<?xml version="1.0"?>
<robot name="features">
  <link name="world"/>
  <joint name="world_to_base" type="fixed">
    <parent link="world"/><child link="base"/><origin xyz="0 0 0.1" rpy="0 0 0.3"/>
  </joint>
  <link name="base">
    <inertial><mass value="5"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/>
    </inertial>
    <visual><geometry><box size="0.2 0.2 0.1"/></geometry></visual>
  </link>
  <joint name="turn" type="continuous">
    <parent link="base"/><child link="column"/><origin xyz="0 0 0.2"/><axis xyz="0 0 1"/>
    <limit effort="80" velocity="2"/><dynamics damping="0.5" friction="1.0"/>
  </joint>
  <link name="column">
    <inertial><origin xyz="0 0 0.3" rpy="0.1 0.2 0.3"/><mass value="3"/>
      <inertia ixx="0.1" ixy="0.001" ixz="-0.002" iyy="0.1" iyz="0.003" izz="0.02"/>
    </inertial>
    <collision><geometry><cylinder radius="0.05" length="0.6"/></geometry></collision>
  </link>
  <joint name="lift" type="prismatic">
    <parent link="column"/><child link="carriage"/><origin xyz="0.1 0 0.4" rpy="0 0 0"/>
    <axis xyz="0 0 1"/><limit lower="-0.3" upper="0.3" effort="400" velocity="0.5"/>
  </joint>
  <link name="carriage">
    <inertial><mass value="1.5"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/>
    </inertial>
  </link>
  <joint name="wrist" type="revolute">
    <parent link="carriage"/><child link="hand"/><origin xyz="0.2 0 0" rpy="1.5708 0 0"/>
    <axis xyz="1 0 0"/><limit lower="-1.5" upper="1.5" effort="20" velocity="4"/>
  </joint>
  <link name="hand">
    <inertial><origin xyz="0.05 0 0"/><mass value="0.4"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.002" iyz="0" izz="0.002"/></inertial>
  </link>
  <joint name="flange" type="fixed"><parent link="hand"/><child link="tool"/>
    <origin xyz="0.1 0 0"/></joint>
  <link name="tool">
    <inertial><mass value="0.2"/><inertia ixx="1e-4" ixy="0" ixz="0" iyy="1e-4" iyz="0" izz="1e-4"/>
    </inertial>
  </link>
  <transmission name="turn_trans">
    <type>transmission_interface/SimpleTransmission</type>
    <joint name="turn"><hardwareInterface>EffortJointInterface</hardwareInterface></joint>
    <actuator name="turn_motor"><mechanicalReduction>-120</mechanicalReduction></actuator>
  </transmission>
  <transmission name="lift_trans"><joint name="lift"/><actuator name="lift_motor"/>
    <mechanicalReduction>20</mechanicalReduction></transmission>
</robot>
"""


def _urdf_seeds() -> dict[str, bytes]:
    seeds = {"reference_arm": (CORPUS / "reference_arm.urdf").read_bytes(),
             "features": FEATURES_URDF.encode()}
    d = robots_dir()
    if d is not None and (d / "ur_description/urdf/ur5_robot.urdf").is_file():
        seeds["ur5"] = (d / "ur_description/urdf/ur5_robot.urdf").read_bytes()
    return seeds


def _toml_seeds() -> dict[str, str]:
    data = Path(mrnea.robots.__file__).parent / "data"
    return {"reference_arm": (CORPUS / "reference_arm.toml").read_text(encoding="utf-8"),
            "reference_dh_arm": (CORPUS / "reference_dh_arm.toml").read_text(encoding="utf-8"),
            "puma560": (data / "puma560.toml").read_text(encoding="utf-8")}


URDF_SEEDS = _urdf_seeds()
TOML_SEEDS = _toml_seeds()

# --- values a mutation writes ---------------------------------------------------------------------
SPECIAL = ["nan", "-nan", "NaN", "inf", "-inf", "infinity", "1e308", "-1e308",
           "1.7976931348623157e308", "1e400", "1e-320", "5e-324", "0", "-0", "0.0", "1e-13",
           "-1", "1e9", "", " ", "1,5", "0x10", "1_000", "${x}", "true", "none", "1 2",
           "1 2 3 4", "0 0 0", "1e154"]
NUMBERS = st.floats(allow_nan=True, allow_infinity=True).map(repr)
WORDS = st.text(max_size=12)
JOINT_TYPES = ["revolute", "continuous", "prismatic", "fixed", "floating", "planar", "ball",
               "Revolute", ""]


def attribute_value(names: list[str]) -> st.SearchStrategy[str]:
    """What an attribute (or element text) may become: special values, any float, several
    floats, random text, or another name of the document."""
    several = st.lists(st.floats(allow_nan=True, allow_infinity=True, width=32), max_size=5).map(
        lambda xs: " ".join(repr(x) for x in xs))
    plausible = st.floats(-10.0, 10.0)
    plausible_3 = st.tuples(plausible, plausible, plausible).map(
        lambda xs: " ".join(repr(x) for x in xs))
    options = [plausible.map(repr), plausible_3, plausible.map(repr), st.sampled_from(SPECIAL),
               NUMBERS, several, WORDS, st.sampled_from(JOINT_TYPES)]
    if names:
        options.append(st.sampled_from(names))
    return st.one_of(*options)


# --- URDF mutations -------------------------------------------------------------------------------
def _elements(root: ET.Element) -> list[tuple[ET.Element, ET.Element]]:
    """(parent, child) pairs of every element below the root, document order."""
    return [(p, c) for p in root.iter() for c in p]


def _names(root: ET.Element) -> list[str]:
    return sorted({e.get(a) for e in root.iter() for a in ("name", "link")
                   if e.get(a) is not None})


def mutate_urdf(data: st.DataObject, seed: bytes) -> bytes:
    """1-4 structural mutations of the parsed document, then maybe a byte-level one."""
    root = ET.fromstring(seed)
    for _ in range(data.draw(st.integers(1, 4), label="n_mutations")):
        pairs = _elements(root)
        op = data.draw(st.sampled_from(["delete", "duplicate", "swap", "move", "attribute",
                                        "attribute", "attribute", "drop_attribute", "reference",
                                        "joint_type", "text"]), label="op")
        if not pairs:
            break
        if op == "delete":
            parent, child = data.draw(st.sampled_from(pairs))
            parent.remove(child)
        elif op == "duplicate":
            parent, child = data.draw(st.sampled_from(pairs))
            parent.insert(list(parent).index(child), copy.deepcopy(child))
        elif op == "swap":
            (pa, a), (pb, b) = data.draw(st.sampled_from(pairs)), data.draw(st.sampled_from(pairs))
            if a is b or a in b.iter() or b in a.iter():
                continue
            ia, ib = list(pa).index(a), list(pb).index(b)
            pa[ia], pb[ib] = b, a  # item assignment: no removal, works for one parent too
        elif op == "move":
            parent, child = data.draw(st.sampled_from(pairs))
            targets = [e for e in root.iter() if e not in child.iter()]
            target = data.draw(st.sampled_from(targets))
            parent.remove(child)
            target.append(child)
        elif op in ("attribute", "drop_attribute", "reference"):
            keyed = [e for _, e in pairs if e.attrib]
            if op == "reference":
                keyed = [e for e in keyed if e.tag in ("parent", "child", "joint", "link")]
            if not keyed:
                continue
            elem = data.draw(st.sampled_from(keyed))
            attr = data.draw(st.sampled_from(sorted(elem.attrib)))
            if op == "drop_attribute":
                del elem.attrib[attr]
            elif op == "reference":
                elem.set(attr, data.draw(st.sampled_from(_names(root) or ["x"])))
            else:
                elem.set(attr, data.draw(attribute_value(_names(root))))
        elif op == "joint_type":
            joints = [e for e in root.iter("joint") if "type" in e.attrib]
            if joints:
                data.draw(st.sampled_from(joints)).set("type",
                                                       data.draw(st.sampled_from(JOINT_TYPES)))
        else:  # element text, e.g. <mechanicalReduction>
            texts = [e for _, e in pairs if (e.text or "").strip()]
            if texts:
                data.draw(st.sampled_from(texts)).text = data.draw(attribute_value([]))
    out = ET.tostring(root, encoding="utf-8")
    return mutate_bytes(data, out)


def mutate_bytes(data: st.DataObject, raw: bytes) -> bytes:
    """With some probability: truncate, flip a few bytes, or insert garbage."""
    op = data.draw(st.sampled_from(["none"] * 8 + ["truncate", "flip", "insert"]),
                   label="byte_op")
    if op == "none" or not raw:
        return raw
    pos = data.draw(st.integers(0, len(raw) - 1), label="pos")
    if op == "truncate":
        return raw[:pos]
    if op == "flip":
        b = bytearray(raw)
        for _ in range(data.draw(st.integers(1, 4))):
            k = data.draw(st.integers(0, len(b) - 1))
            b[k] ^= data.draw(st.integers(1, 255))
        return bytes(b)
    return raw[:pos] + data.draw(st.binary(min_size=1, max_size=16)) + raw[pos:]


# --- TOML mutations -------------------------------------------------------------------------------
TOKEN = re.compile(r'"(?:[^"\\\n]|\\.)*"|(?<![\w.])[-+]?(?:\d[\d_]*(?:\.\d+)?(?:[eE][-+]?\d+)?|'
                   r'inf|nan)(?![\w.])')
KEY = re.compile(r"^(\s*)([A-Za-z_][\w-]*)(\s*=)", re.M)
TOML_KEYS = ["name", "type", "link", "lower", "upper", "velocity_limit", "effort_limit",
             "gear_ratio", "rotor_inertia", "viscous_friction", "coulomb_friction",
             "torque_speed", "origin", "axis", "a", "alpha", "d", "theta", "mass", "com",
             "inertia", "ixx", "iyy", "izz", "ixy", "gravity", "dh", "base", "xyz", "rpy",
             "joint", "robot", "bogus"]
TOML_LINES = ["[[joint]]", "[joint.link]", "[robot]", 'dh = "standard"', 'dh = "modified"',
              "mass = 1.0", "axis = [0.0, 0.0, 1.0]", 'type = "prismatic"', 'name = "x"',
              "inertia = [[1.0, 0.0], [0.0, 1.0]]", "com = [0.0, 0.0, 1e308]", "upper = -inf",
              "torque_speed = [1.0, 2.0, 3.0]", "gravity = [0.0, 0.0, nan]", "joint = 3"]
TOML_VALUES = ['"x"', '""', "true", "[1.0, 2.0]", "[]", "{}", "[[1.0]]", '{ xyz = [0.0] }',
               "nan", "-nan", "inf", "-inf", "1e308", "-1e308", "1e-320", "0", "-0.0",
               "1_000", "0x10", "1979-05-27", '"revolute"', '"continuous"', '"prismatic"',
               '"fixed"', '"floating"', '"standard"', '"modified"', '"base"']


def mutate_toml(data: st.DataObject, seed: str) -> bytes:
    """1-4 line, value or key mutations of the text, then maybe a byte-level one."""
    text = seed
    for _ in range(data.draw(st.integers(1, 4), label="n_mutations")):
        lines = text.split("\n")
        op = data.draw(st.sampled_from(["delete", "duplicate", "swap", "insert", "value",
                                        "value", "value", "key"]), label="op")
        if op in ("delete", "duplicate", "swap", "insert"):
            i = data.draw(st.integers(0, len(lines) - 1))
            if op == "delete":
                del lines[i]
            elif op == "duplicate":
                lines.insert(i, lines[i])
            elif op == "swap":
                j = data.draw(st.integers(0, len(lines) - 1))
                lines[i], lines[j] = lines[j], lines[i]
            else:
                lines.insert(i, data.draw(st.sampled_from(TOML_LINES)))
            text = "\n".join(lines)
        elif op == "value":
            tokens = list(TOKEN.finditer(text))
            if not tokens:
                continue
            m = data.draw(st.sampled_from(tokens))
            strings = sorted({t.group() for t in tokens if t.group().startswith('"')})
            plausible = st.floats(-10.0, 10.0).map(repr)
            new = data.draw(st.one_of(plausible, plausible, st.sampled_from(TOML_VALUES), NUMBERS,
                                      WORDS.map(json.dumps), st.sampled_from(strings)))
            text = text[:m.start()] + new + text[m.end():]
        else:
            keys = list(KEY.finditer(text))
            if not keys:
                continue
            m = data.draw(st.sampled_from(keys))
            new = data.draw(st.sampled_from(TOML_KEYS))
            text = text[:m.start(2)] + new + text[m.end(2):]
    return mutate_bytes(data, text.encode("utf-8", "surrogatepass"))


# --- the property ---------------------------------------------------------------------------------
XML_INVALID = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ufffe\uffff\ud800-\udfff]")


def _finite(out, what: str, robot: Robot) -> None:
    if hasattr(out, "qdd"):  # an AchievableResult (its limit and margin may be inf: unlimited)
        out = (out.qdd, out.tau, out.tau_required, out.tau_motor)
    arrays = out if isinstance(out, tuple) else (out,)
    if all(np.isfinite(np.asarray(a, dtype=float)).all() for a in arrays):
        return
    pytest.fail(f"{what}: non-finite result without an error for {robot!r}")


def exercise(robot: Robot, tmp: Path) -> Counter:
    """Every dynamics entry point returns finite numbers or raises a MrneaError. Returns how many
    calls gave results and how many raised."""
    n = robot.n
    rng = np.random.default_rng(n)
    lo = np.where(np.isfinite(robot.lower), robot.lower, -math.pi)
    hi = np.where(np.isfinite(robot.upper), robot.upper, math.pi)
    Q = lo + (hi - lo) * rng.uniform(0.0, 1.0, (3, n))
    QD, X = rng.normal(0.0, 1.0, (3, n)), rng.normal(0.0, 5.0, (3, n))
    fe = rng.normal(0.0, 5.0, 6)
    calls = {
        "inverse_dynamics": lambda: mrnea.inverse_dynamics(robot, Q[0], QD[0], X[0]),
        "inverse_dynamics wrench": lambda: mrnea.inverse_dynamics(robot, Q[0], QD[0], X[0], fe),
        "mass_matrix_and_bias": lambda: mrnea.mass_matrix_and_bias(robot, Q[0], QD[0]),
        "mass_matrix_and_bias walker_orin":
            lambda: mrnea.mass_matrix_and_bias(robot, Q[1], QD[1], method="walker_orin"),
        "joint_reactions": lambda: mrnea.joint_reactions(robot, Q[2], QD[2], X[2]),
        "forward_dynamics batch": lambda: mrnea.forward_dynamics(robot, Q, QD, X),
        "achievable hybrid": lambda: achievable_accelerations(robot, Q[0], QD[0], X[0]),
        "achievable paper": lambda: achievable_accelerations(robot, Q[1], 0 * QD[1], X[1],
                                                             mode="paper"),
    }
    for method in ("mrnea", "walker_orin", "crba", "aba"):
        calls[f"forward_dynamics {method}"] = (
            lambda m=method: mrnea.forward_dynamics(robot, Q[1], QD[1], X[1], method=m))
    counts: Counter = Counter()
    for what, call in calls.items():
        try:
            out = call()
        except MrneaError:
            counts["call raised"] += 1
            continue
        counts["call returned"] += 1
        _finite(out, what, robot)
    # head line, a tree's branches line, header row, a row per joint
    head = describe(robot, width=10**6).split("\n\n")[0].splitlines()
    assert len(head) == n + 2 + (not robot.is_serial)
    # what loaded can be written as URDF and read back; as a native file, read back equal
    back = load_robot(robot.to_urdf(tmp / "roundtrip.urdf", overwrite=True))
    assert back.joint_names == robot.joint_names and back.n == n
    assert load_robot(robot.to_toml(tmp / "roundtrip.toml", overwrite=True)) == robot
    return counts


def run_fuzz(fmt: str, max_examples: int) -> Counter:
    """Run the property on ``max_examples`` mutated files of format ``fmt``; count outcomes."""
    seeds = URDF_SEEDS if fmt == "urdf" else TOML_SEEDS
    mutate = mutate_urdf if fmt == "urdf" else mutate_toml
    outcomes: Counter = Counter()
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)

        @settings(max_examples=max_examples, **SETTINGS)
        @given(data=st.data())
        def prop(data: st.DataObject) -> None:
            name = data.draw(st.sampled_from(sorted(seeds)), label="seed")
            raw = mutate(data, seeds[name])
            path = tmp / f"fuzzed.{fmt}"
            path.write_bytes(raw)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # ModelWarning, numpy overflow warnings
                try:
                    robot = load_robot(path)
                except MrneaError:
                    outcomes["rejected"] += 1
                    return
                outcomes["loaded"] += 1
                outcomes.update(exercise(robot, tmp))

        prop()
    return outcomes


def _check_mix(outcomes: Counter, examples: int) -> None:
    """The fuzz is not vacuous: both rejected and loaded files occur (5 % at least; about 12 %
    load), and most dynamics calls on loaded robots return results."""
    total = outcomes["loaded"] + outcomes["rejected"]
    assert total >= examples
    for k in ("loaded", "rejected"):
        assert outcomes[k] >= 0.05 * total, outcomes
    assert outcomes["call returned"] >= 0.5 * (outcomes["call returned"]
                                               + outcomes["call raised"]), outcomes
    print(f"fuzz outcomes: {dict(outcomes)}")


@pytest.mark.parametrize("fmt", ["urdf", "toml"])
def test_fuzz_loaders_fast(fmt: str) -> None:
    _check_mix(run_fuzz(fmt, FAST_EXAMPLES), FAST_EXAMPLES)


@pytest.mark.slow
@pytest.mark.parametrize("fmt", ["urdf", "toml"])
def test_fuzz_loaders_slow(fmt: str) -> None:
    _check_mix(run_fuzz(fmt, SLOW_EXAMPLES[fmt]), SLOW_EXAMPLES[fmt])


def test_seeds_are_valid() -> None:
    """Every seed loads cleanly, so a rejection is the mutation's doing."""
    assert "reference_arm" in URDF_SEEDS and len(TOML_SEEDS) == 3
    with tempfile.TemporaryDirectory() as d:
        for fmt, seeds in (("urdf", URDF_SEEDS), ("toml", TOML_SEEDS)):
            for name, raw in seeds.items():
                p = Path(d) / f"{name}.{fmt}"
                p.write_bytes(raw if isinstance(raw, bytes) else raw.encode())
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", mrnea.errors.ModelWarning)  # Puma's data
                    robot = load_robot(p)
                    assert robot.n >= 2, name
                    exercise(robot, Path(d))
