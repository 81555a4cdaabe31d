"""Hostile robot inputs (polish session 42): long chains and trees that took quadratic time,
frame names that made a tool ambiguous, a joint named like the base that a native file could not
tell from it, and messages that named their joint or file twice.

* A robot's duplicate-name check counted every name in the list (``list.count``): a
  20,000-joint chain took 20 s in ``Robot()`` alone; the massless-link warning walked every
  massless link's subtree with NumPy (a 3,000-link massless chain: half a minute, 3,000 lines);
  the refusal of a ``<mimic>`` joint walked every leaf's path (a 4,000-link comb: 10 s, a 16 MiB
  file minutes), and so did ``tip=`` with many tips.
* A frame named like a link (or another frame, or the base) was accepted, and a tool of that
  name silently took the first match (the frame, on a tree).
* A native file's ``parent = "base"`` meant the joint named ``base`` where one existed, so a
  tree robot written by ``to_toml`` read back as another robot.
"""

from __future__ import annotations

import time
import warnings
from pathlib import Path

import numpy as np
import pytest
from conftest import PinChain, mrnea_cli, one_error_line, pin_from_urdf, rel_err

import mrnea
from mrnea.errors import ModelError, ModelWarning, RobotFileError
from mrnea.io.native import dumps_native, loads_native
from mrnea.model import Frame, Joint, Link, Robot
from mrnea.tool import tool_frame

HERE = Path(__file__).parent
REFERENCE_TOML = (HERE / "malformed" / "reference_arm.toml").read_text()
INERTIAL = ('<inertial><origin xyz="0 0 0.05"/><mass value="{m}"/><inertia ixx="0.01" ixy="0" '
            'ixz="0" iyy="0.02" iyz="0" izz="0.03"/></inertial>')


def _joint(name: str, parent: str, child: str, extra: str = "", jtype: str = "revolute",
           xyz: str = "0 0 0.1") -> str:
    return (f'<joint name="{name}" type="{jtype}"><parent link="{parent}"/><child '
            f'link="{child}"/><origin xyz="{xyz}"/><axis xyz="0 1 0"/><limit lower="-3" '
            f'upper="3" effort="100" velocity="2"/>{extra}</joint>')


def _link(name: str, mass: float | None = 1.0) -> str:
    return f'<link name="{name}">{"" if mass is None else INERTIAL.format(m=mass)}</link>'


def comb_urdf(n: int, mimic: bool) -> str:
    """A spine of ``n`` revolute joints, each spine link with a leaf on a revolute joint of its
    own; the last spine joint a ``<mimic>`` when ``mimic``."""
    parts = ['<robot name="comb">', _link("s0", None)]
    for i in range(1, n + 1):
        extra = '<mimic joint="j1"/>' if mimic and i == n else ""
        parts += [_joint(f"j{i}", f"s{i - 1}", f"s{i}", extra), _link(f"s{i}"),
                  _joint(f"f{i}", f"s{i}", f"leaf{i}", xyz="0.1 0 0"),
                  _link(f"leaf{i}", 0.5 + i % 7)]
    return "\n".join([*parts, "</robot>"])


# --- linear time in the number of links -------------------------------------------------------

def test_a_long_chain_is_built_in_linear_time() -> None:
    """Robot() on a 30,000-joint chain (its Joint and Link objects made beforehand): well under
    a second or two; the duplicate-name check had taken 40 s. Duplicates are still named."""
    n = 30_000
    joints = [Joint(f"j{i}", "revolute", f"l{i - 1}" if i else "base", f"l{i}",
                    axis=(0.0, 1.0, 0.0)) for i in range(n)]
    links = [Link(f"l{i}", 1.0, (0.0, 0.0, 0.05), np.eye(3) * 0.01) for i in range(n)]
    start = time.perf_counter()
    robot = Robot(joints, links)
    assert time.perf_counter() - start < 8.0
    assert robot.n == n and robot.is_serial
    dup = [Joint(f"j{i % 3}", "revolute", f"l{i - 1}" if i else "base", f"l{i}")
           for i in range(40)]
    with pytest.raises(ModelError, match=r"duplicate joint names: j0, j1, j2$"):
        Robot(dup, links[:40])


def test_massless_links_warn_ten_times_and_then_once() -> None:
    """3,000 massless links carrying one massive tip: ten warnings naming what each carries and
    one for the rest (it had printed 3,000, after half a minute)."""
    n = 3000
    joints = [Joint(f"j{i}", "revolute", f"l{i - 1}" if i else "base", f"l{i}")
              for i in range(n)]
    links = [Link(f"l{i}") for i in range(n - 1)] + [Link(f"l{n - 1}", 1.0, (0, 0, 0.1),
                                                          np.eye(3) * 0.01)]
    start = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        Robot(joints, links)
    assert time.perf_counter() - start < 8.0
    messages = [str(w.message) for w in caught if issubclass(w.category, ModelWarning)]
    assert messages[:10] == [f"link 'l{i}' is massless (well-posed: it carries l{n - 1})"
                             for i in range(10)]
    assert messages[10:] == [f"{n - 11} more links are massless: "
                             + ", ".join(f"l{i}" for i in range(10, 20)) + f" and {n - 21} more"]


def test_a_massless_links_warning_names_what_its_subtree_carries() -> None:
    """A tree: the warning names the massive links of the massless link's own subtree only, and
    says when nothing there has mass (its subtree ends where the next branch starts)."""
    def j(name, parent, child):
        return Joint(name, "revolute", parent, child)

    heavy = {"mass": 1.0, "com": (0, 0, 0.1), "inertia": np.eye(3) * 0.01}
    joints = [j("a", "base", "la"), j("b", "la", "lb"), j("c", "lb", "lc"), j("d", "la", "ld"),
              j("e", "base", "le"), j("f", "le", "lf")]
    links = [Link("la"), Link("lb"), Link("lc", **heavy), Link("ld", **heavy), Link("le"),
             Link("lf")]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        robot = Robot(joints, links)
    assert robot.parents == (-1, 0, 1, 0, -1, 4)
    assert [str(w.message) for w in caught] == [
        "link 'la' is massless (well-posed: it carries lc, ld)",
        "link 'lb' is massless (well-posed: it carries lc)",
        "link 'le' is massless (nothing it carries has mass either, so H is singular and "
        "forward dynamics will fail)",
        "link 'lf' is massless (nothing it carries has mass either, so H is singular and "
        "forward dynamics will fail)"]


def test_a_mimic_refusal_on_a_large_comb_is_quick_and_ranks_the_leaves(tmp_path) -> None:
    """The refusal of a kept <mimic> joint on a 10,000-tooth comb (a 7 MB file): seconds (it walked
    every leaf's path: 40 s); its candidates are the leaves whose paths avoid the mimic joint,
    heaviest moved chain first, and the first one loads."""
    path = tmp_path / "comb.urdf"
    path.write_text(comb_urdf(10_000, mimic=True))
    start = time.perf_counter()
    with pytest.raises(RobotFileError, match=r"comb\.urdf: joint 'j10000': <mimic> joints") as e:
        mrnea.load_urdf(path)
    assert time.perf_counter() - start < 15.0
    # the chain to leaf i moves spine links s1..s_i (1 kg each) and leaf i
    masses = {f"leaf{i}": i * 1.0 + 0.5 + i % 7 for i in range(1, 10_000)}
    expected = sorted(masses, key=lambda leaf: (-masses[leaf], leaf))[:10]
    assert f"heaviest chain first: {', '.join(expected)} and 9989 more" in str(e.value)
    small = tmp_path / "small.urdf"
    small.write_text(comb_urdf(5, mimic=True))
    with pytest.raises(RobotFileError, match=r"first: leaf4, leaf3, leaf2, leaf1$"):
        mrnea.load_urdf(small)
    assert mrnea.load_urdf(small, tip="leaf4").joint_names == ("j1", "j2", "j3", "j4", "f4")


def test_many_tips_keep_their_subtree(tmp_path) -> None:
    """tip= every leaf of a 1,500-tooth comb (each tip's path is walked up to the first link an
    earlier tip's path holds): every joint kept; a tip of no link, or with no moving joint on
    its path, is still named."""
    path = tmp_path / "comb.urdf"
    path.write_text(comb_urdf(1500, mimic=False))
    tips = [f"leaf{i}" for i in range(1500, 0, -1)]
    robot = mrnea.load_urdf(path, tip=tips)
    assert robot.joint_names == mrnea.load_urdf(path).joint_names and robot.n == 3000
    assert mrnea.load_urdf(path, tip=["leaf2", "leaf1"]).joint_names == ("j1", "f1", "j2", "f2")
    with pytest.raises(RobotFileError, match=r"tip link 'nowhere' does not exist"):
        mrnea.load_urdf(path, tip=[*tips[:3], "nowhere"])
    with pytest.raises(RobotFileError, match=r"to tip link 's0' has no moving joint"):
        mrnea.load_urdf(path, tip=["leaf2", "s0"])


# --- frame names ------------------------------------------------------------------------------

def _tree_with_frame(frame: str) -> str:
    """The reference arm as a tree (the elbow on the base), a frame on the upper arm."""
    text = REFERENCE_TOML.replace('name = "elbow"', 'name = "elbow"\nparent = "base"')
    return text.replace("inertia = { ixx = 0.004, iyy = 0.03, izz = 0.03 }",
                        "inertia = { ixx = 0.004, iyy = 0.03, izz = 0.03 }\n"
                        f'frame = [{{ name = "{frame}", xyz = [1.0, 2.0, 3.0] }}]')


@pytest.mark.parametrize("frame, owner", [("forearm", "link 'forearm'"),
                                          ("base", "link 'base'"),
                                          ("upper_arm", "link 'upper_arm'")])
def test_a_frame_named_like_a_link_is_refused(frame, owner) -> None:
    """A tool named 'forearm' had taken the upper arm's frame of that name, not the link."""
    with pytest.raises(RobotFileError, match=rf"^arm\.toml: link 'upper_arm': frame '{frame}': "
                                             rf"the name is taken by {owner}"):
        loads_native(_tree_with_frame(frame), "arm.toml")
    robot = loads_native(_tree_with_frame("tcp"), "arm.toml")  # a fresh name: fine
    assert tool_frame(robot, "forearm").link == 1
    assert tool_frame(robot, "tcp").link == 0


def test_two_frames_of_one_name_are_refused() -> None:
    links = [Link("a", 1.0, inertia=np.eye(3), frames=(Frame("t"),)),
             Link("b", 1.0, inertia=np.eye(3), frames=(Frame("t"),))]
    joints = [Joint("j1", "revolute", "base", "a"), Joint("j2", "revolute", "a", "b")]
    with pytest.raises(ModelError, match="link 'b': frame 't': the name is taken by a frame of "
                                         "link 'a'"):
        Robot(joints, links)


def test_a_frame_named_like_a_link_is_one_error_line(tmp_path) -> None:
    path = tmp_path / "arm.toml"
    path.write_text(_tree_with_frame("forearm"))
    one_error_line(mrnea_cli("info", path, timeout=120), "arm.toml", "frame 'forearm'",
                   "link 'forearm'")


# --- a joint named like the base --------------------------------------------------------------

def _base_named_joint_urdf() -> str:
    """A tree whose first joint is named like the root link; the second hangs on the root."""
    return "\n".join(['<robot name="t">', _link("base", None),
                      _joint("base", "base", "a", xyz="0.1 0 0.2"), _link("a"),
                      _joint("j2", "base", "b", xyz="0 0.1 0.3"), _link("b", 2.0),
                      _joint("j3", "b", "c", xyz="0 0 0.3", jtype="prismatic"), _link("c"),
                      "</robot>"])


def test_a_joint_named_like_the_base_loads_and_matches_pinocchio(tmp_path) -> None:
    """Valid URDF (a joint and a link may share a name): the whole tree loads, its dynamics equal
    Pinocchio's."""
    path = tmp_path / "t.urdf"
    path.write_text(_base_named_joint_urdf())
    robot = mrnea.load_urdf(path)
    assert robot.joint_names == ("base", "j2", "j3") and robot.parents == (-1, -1, 1)
    pc = PinChain(robot, pin_from_urdf(path, robot))
    rng = np.random.default_rng(42)
    for _ in range(3):
        q, qd, qdd = rng.uniform(-1, 1, 3), rng.normal(0, 1, 3), rng.normal(0, 1, 3)
        assert rel_err(mrnea.inverse_dynamics(robot, q, qd, qdd), pc.rnea(q, qd, qdd)) <= 1e-12
        H, _ = mrnea.mass_matrix_and_bias(robot, q, qd)
        assert rel_err(H, pc.mass_matrix(q)) <= 1e-12


def test_a_native_parent_naming_the_base_and_a_joint_is_refused(tmp_path) -> None:
    """Its native text said parent = "base" for j2, read back as the joint 'base' (another
    robot, silently); now the writer refuses it, and so does the reader."""
    path = tmp_path / "t.urdf"
    path.write_text(_base_named_joint_urdf())
    robot = mrnea.load_urdf(path)
    with pytest.raises(ModelError, match="joint 'j2': its parent cannot be written: an earlier "
                                         "joint has the base link's name 'base'"):
        dumps_native(robot)
    text = REFERENCE_TOML.replace('name = "shoulder"', 'name = "base"').replace(
        'name = "elbow"', 'name = "elbow"\nparent = "base"')
    with pytest.raises(RobotFileError, match=r"^t\.toml: joint 'elbow': parent 'base' names both "
                                             r"the base link and an earlier joint"):
        loads_native(text, "t.toml")
    # the base named before the joint of that name exists: the base, unambiguously
    text = REFERENCE_TOML.replace('name = "elbow"', 'name = "elbow"\nparent = "base"').replace(
        'name = "shoulder"', 'name = "shoulder"\nparent = "base"')
    assert loads_native(text, "t.toml").parents == (-1, -1)
    serial = loads_native(REFERENCE_TOML.replace('name = "shoulder"', 'name = "base"'), "t.toml")
    assert loads_native(dumps_native(serial)) == serial  # a chain writes no parent: fine


# --- each message names its joint and file once -----------------------------------------------

@pytest.mark.parametrize("line, message", [
    ("efficiency = 1.5", "efficiency must be in [0.01, 1], got 1.5"),
    ("gear_ratio = 0.0", "gear_ratio must be > 0, got 0.0"),
    ("rotor_inertia = -1e-4", "rotor_inertia must be >= 0, got -0.0001"),
])
def test_a_native_joint_error_names_the_joint_once(line, message) -> None:
    text = REFERENCE_TOML.replace("gear_ratio = 100.0", line)
    with pytest.raises(RobotFileError) as e:
        loads_native(text, "arm.toml")
    assert str(e.value) == f"arm.toml: joint 'shoulder': {message}"


@pytest.mark.parametrize("body, message", [
    ("torque_speed = [1, 2]", "'torque_speed' must be an array of 3 numbers, got 2 entries: "
                              "[1, 2]"),
    ("efficiency = [0.9]", "'efficiency' must be an array of 2 numbers, got 1 entries: [0.9]"),
    ("efficiency = 2.0", "efficiency must be in [0.01, 1], got 2.0"),
])
def test_a_sidecar_error_names_the_file_once(tmp_path, body, message) -> None:
    sidecar = tmp_path / "act.toml"
    sidecar.write_text(f"[shoulder]\n{body}\n")
    with pytest.raises(RobotFileError) as e:
        mrnea.load_urdf(HERE / "malformed" / "reference_arm.urdf", actuators=sidecar)
    assert str(e.value) == f"{sidecar}: joint 'shoulder': {message}"
