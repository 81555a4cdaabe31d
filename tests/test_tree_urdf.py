"""Tree robots of example-robot-data, loaded whole (or their subtree of several tips) with a
fixed base, against Pinocchio's model of the same URDF (``conftest.pin_from_urdf``: the joints
mrnea leaves out locked at q = 0, as mrnea lumps them): RNEA, H, u', every forward-dynamics
method, the joint reactions, every link's frame and Jacobian, to ``rel_err <= 1e-10`` at random
states within the joint limits. Also: the loading order (depth first, children in file order)
and the refusal of a kept ``<mimic>`` joint.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from conftest import PinChain, erd_path, pin_from_urdf, rel_err

import mrnea
from mrnea.compiled import of
from mrnea.errors import RobotFileError
from mrnea.kernels.kinematics import link_jacobian_ws
from mrnea.kernels.status import OK

TOL = 1e-10
B = 12
FD_METHODS = ("mrnea", "walker_orin", "crba", "aba")

TREES = {  # name: (file, tips or None for the whole tree, joints)
    # Baxter: head, two 7-joint arms, one finger per gripper (the other is a <mimic>)
    "baxter": ("baxter_description/urdf/baxter.urdf",
               ("head", "right_wrist", "left_wrist", "r_gripper_l_finger", "l_gripper_l_finger"),
               17),
    "allegro": ("allegro_hand_description/urdf/allegro_right_hand.urdf", None, 16),
    "talos-upper": ("talos_data/robots/talos_reduced.urdf", None, 32),
    "icub": ("icub_description/robots/icub_reduced.urdf", None, 29),
    # PR2: torso lift, head, laser tilt, both arms and one finger each (the rest are <mimic>s;
    # the casters and wheels are lumped at 0)
    "pr2": ("pr2_description/urdf/pr2.urdf",
            ("head_tilt_link", "laser_tilt_mount_link", "r_gripper_l_finger_link",
             "l_gripper_l_finger_link"), 20),
}


@pytest.fixture(scope="module", params=list(TREES))
def case(request):
    rel, tips, n = TREES[request.param]
    path = erd_path(rel)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # visuals left out of the 3D view
        robot = mrnea.load_urdf(path, tip=tips)
    assert robot.n == n and not robot.is_serial
    pc = PinChain(robot, pin_from_urdf(path, robot))
    rng = np.random.default_rng(3)
    lo = np.where(np.isfinite(robot.lower), robot.lower, -np.pi)
    hi = np.where(np.isfinite(robot.upper), robot.upper, np.pi)
    s = {"q": rng.uniform(lo, hi, size=(B, n)), "qd": rng.normal(0, 1, (B, n)),
         "qdd": rng.normal(0, 2, (B, n)), "tau": rng.normal(0, 5, (B, n)),
         "f_ext": rng.normal(0, 10, (B, 6)), "f_ext_point": rng.normal(0, 0.1, (B, 3))}
    return robot, pc, s


def test_dynamics_equal_pinocchio(case) -> None:
    robot, pc, s = case
    for b in range(B):
        q, qd, qdd, tau = s["q"][b], s["qd"][b], s["qdd"][b], s["tau"][b]
        for w in ((None, None), (s["f_ext"][b], s["f_ext_point"][b])):
            assert rel_err(mrnea.inverse_dynamics(robot, q, qd, qdd, *w),
                           pc.rnea(q, qd, qdd, *w)) <= TOL
            H_ref, u_ref = pc.mass_matrix(q), pc.bias(q, qd, *w)
            for method in ("mrnea", "walker_orin"):
                H, u = mrnea.mass_matrix_and_bias(robot, q, qd, *w, method=method)
                assert rel_err(H, H_ref) <= TOL and rel_err(u, u_ref) <= TOL, method
            qdd_ref = pc.aba(q, qd, tau, *w)
            for method in FD_METHODS:
                assert rel_err(mrnea.forward_dynamics(robot, q, qd, tau, *w, method=method),
                               qdd_ref) <= TOL, method
            assert rel_err(mrnea.joint_reactions(robot, q, qd, qdd, *w),
                           pc.reactions(q, qd, qdd, *w)) <= TOL
    qdd = mrnea.forward_dynamics(robot, s["q"], s["qd"], s["tau"])  # a batch
    for b in range(B):
        assert rel_err(qdd[b], pc.aba(s["q"][b], s["qd"][b], s["tau"][b])) <= TOL


def test_frames_and_jacobians_equal_pinocchio(case) -> None:
    robot, pc, s = case
    pin = pc.pin
    m, _, ws, _ = of(robot)
    J = np.empty((6, robot.n))
    for b in range(3):
        q, pe = s["q"][b], s["f_ext_point"][b]
        pin.computeJointJacobians(pc.model, pc.data, pc.config(q))
        T = mrnea.forward_kinematics(robot, q)
        for t in range(robot.n):
            oMi = pc.data.oMi[pc.ids[t]]
            assert rel_err(T[t + 1], oMi.homogeneous) <= TOL
            Jp = np.array(pin.getJointJacobian(pc.model, pc.data, pc.ids[t],
                                               pin.LOCAL_WORLD_ALIGNED))[:, pc.iv]
            Jp[:3] += np.cross(Jp[3:].T, oMi.rotation @ pe).T
            assert link_jacobian_ws(m, q, t, pe, J, ws) == OK
            assert rel_err(J, Jp) <= TOL
            # the public function, the link by name (any branch)
            assert rel_err(mrnea.jacobian(robot, q, pe, link=robot.link_names[t]), Jp) <= TOL


def test_whole_tree_order_is_depth_first_in_file_order() -> None:
    robot = mrnea.load_urdf(erd_path("allegro_hand_description/urdf/allegro_right_hand.urdf"))
    # four fingers of four joints, each hanging from the palm (the base), in the file's order
    assert robot.parents == (-1, 0, 1, 2) * 1 + (-1, 4, 5, 6) + (-1, 8, 9, 10) + (-1, 12, 13, 14)
    assert robot.joint_names == tuple(f"joint_{k}.0" for k in range(16))


def test_a_kept_mimic_joint_is_refused_naming_it() -> None:
    path = erd_path("baxter_description/urdf/baxter.urdf")
    with pytest.raises(RobotFileError, match=r"joint '[lr]_gripper_r_finger_joint': <mimic> "
                                             r"joints.*tip=<link name> \(command line: --tip"):
        mrnea.load_urdf(path)
    # one tip: the chain to it, as before trees
    arm = mrnea.load_urdf(path, tip="left_wrist")
    assert arm.n == 7 and arm.is_serial


@pytest.mark.parametrize("rel", ["baxter_description/urdf/baxter.urdf",
                                 "pr2_description/urdf/pr2.urdf"])
def test_every_tip_the_mimic_refusal_suggests_loads(rel) -> None:
    """The refusal's advice works: each candidate tip it lists (all of them, and all together)
    loads, and its path crosses no ``<mimic>`` joint of the file (Pinocchio's URDF model: the
    joints supporting the candidate's frame; the file's ``<mimic>`` elements read here with
    ElementTree). Baxter has a mimic finger in each gripper, PR2 several: a candidate must avoid
    them all, not only the one the message names."""
    import xml.etree.ElementTree as ET

    import pinocchio as pin

    path = erd_path(rel)
    with pytest.raises(RobotFileError, match="<mimic>") as info:
        mrnea.load_urdf(path)
    msg = str(info.value)
    listed = msg.split("heaviest chain first: ")[1]
    shown = [t.strip() for t in listed.split(" and ")[0].split(",")]
    assert len(shown) == 10
    mimics = {j.get("name") for j in ET.parse(path).getroot().iter("joint")
              if j.find("mimic") is not None}
    full = pin.buildModelFromUrdf(str(path))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # visuals left out of the 3D view
        for tip in shown:
            support = {full.names[i] for i in full.supports[full.frames[full.getFrameId(tip)]
                                                             .parentJoint]}
            assert not support & mimics, tip
            robot = mrnea.load_urdf(path, tip=tip)
            assert set(robot.joint_names) == support - {"universe"}, tip
        assert mrnea.load_urdf(path, tip=shown).n > 0


def test_a_program_keeps_several_tips(tmp_path) -> None:
    """A program's ``tip`` may list links (the subtree holding them), as --tip repeated."""
    from mrnea.io import RobotOptions, load_robot_spec
    from mrnea.io.program import _options
    from mrnea.io.tomlcheck import TomlCheck

    check = TomlCheck(str(tmp_path / "p.toml"), RobotFileError)
    opts = _options(check, {"tip": ["head", "left_wrist"]}, tmp_path)
    assert opts.tip == ("head", "left_wrist")
    path = erd_path("baxter_description/urdf/baxter.urdf")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = load_robot_spec(str(path), options=RobotOptions(tip=opts.tip))
    assert robot.n == 8 and robot.parents == (-1, -1, 1, 2, 3, 4, 5, 6)
    with pytest.raises(RobotFileError, match="'tip' must be a non-empty string"):
        _options(check, {"tip": ["head", 3]}, tmp_path)


def assert_frame_jacobian(robot: mrnea.Robot, pc: PinChain, q: np.ndarray, p: np.ndarray,
                          name: str) -> None:
    """``mrnea.jacobian(robot, q, link=name)`` is Pinocchio's ``computeFrameJacobian`` of the
    frame of that name in ``LOCAL_WORLD_ALIGNED`` (velocity of the frame's origin, base axes),
    and at the point p (the frame's axes) that Jacobian with v_p = v_o + w x (R p)."""
    import pinocchio as pin

    fid = pc.model.getFrameId(name)
    assert fid < len(pc.model.frames), name
    Jo = np.array(pin.computeFrameJacobian(pc.model, pc.data, pc.config(q), fid,
                                           pin.LOCAL_WORLD_ALIGNED))[:, pc.iv]
    pin.updateFramePlacements(pc.model, pc.data)
    assert rel_err(mrnea.jacobian(robot, q, link=name), Jo) <= TOL, name
    Jp = Jo.copy()
    Jp[:3] += np.cross(Jp[3:].T, pc.data.oMf[fid].rotation @ p).T
    assert rel_err(mrnea.jacobian(robot, q, p, link=name), Jp) <= TOL, name


def test_jacobian_of_a_named_link_equals_pinocchios_frame_jacobian() -> None:
    """``mrnea.jacobian(robot, q, point, link=...)`` on Baxter: at the origin of the head's,
    either wrist's and the left finger's link frame it equals Pinocchio's
    ``computeFrameJacobian`` of that body frame in ``LOCAL_WORLD_ALIGNED`` (base axes, velocity
    of the frame's origin); at a point p of the link (link frame), that Jacobian with
    v_p = v_o + w x (R p). A batch equals its states; an unknown link is one StateError."""

    from mrnea.errors import StateError

    rel, tips, _ = TREES["baxter"]
    path = erd_path(rel)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = mrnea.load_urdf(path, tip=tips)
    pc = PinChain(robot, pin_from_urdf(path, robot))
    rng = np.random.default_rng(11)
    lo = np.where(np.isfinite(robot.lower), robot.lower, -np.pi)
    hi = np.where(np.isfinite(robot.upper), robot.upper, np.pi)
    Q = rng.uniform(lo, hi, size=(4, robot.n))
    P = rng.normal(0, 0.1, size=(4, 3))
    for link in ("head", "right_wrist", "left_wrist", "l_gripper_l_finger"):
        for q, p in zip(Q, P, strict=True):
            assert_frame_jacobian(robot, pc, q, p, link)
        batch = mrnea.jacobian(robot, Q, P, link=link)
        assert batch.shape == (4, 6, robot.n)
        for b in range(4):
            assert np.array_equal(batch[b], mrnea.jacobian(robot, Q[b], P[b], link=link))
    # the last link's, as without ``link``
    assert np.array_equal(mrnea.jacobian(robot, Q[0], P[0], link=robot.link_names[-1]),
                          mrnea.jacobian(robot, Q[0], P[0]))
    with pytest.raises(StateError, match="link: 'nowhere' is neither a link of robot 'baxter'"
                                         r".*nor a frame fixed to one \(its frames: .*left_hand"):
        mrnea.jacobian(robot, Q[0], link="nowhere")


@pytest.mark.parametrize("name", ["baxter", "talos-upper", "pr2"])
def test_jacobian_of_every_named_frame_equals_pinocchios(name) -> None:
    """``mrnea.jacobian(robot, q, point, link=FRAME)`` for every frame a tree robot keeps on its
    links (``Link.frames``: the URDF links merged by fixed joints, e.g. Baxter's ``left_hand``,
    its cameras): Pinocchio's ``computeFrameJacobian`` of the frame of that name in
    ``LOCAL_WORLD_ALIGNED``, at the frame's origin and at a point given in the frame's axes."""

    rel, tips, _ = TREES[name]
    path = erd_path(rel)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = mrnea.load_urdf(path, tip=tips)
    pc = PinChain(robot, pin_from_urdf(path, robot))
    frames = [f.name for lk in robot.links for f in lk.frames]
    assert len(frames) >= 5
    rng = np.random.default_rng(12)
    lo = np.where(np.isfinite(robot.lower), robot.lower, -np.pi)
    hi = np.where(np.isfinite(robot.upper), robot.upper, np.pi)
    for q in rng.uniform(lo, hi, size=(2, robot.n)):
        p = rng.normal(0, 0.1, 3)
        for f in frames:
            assert_frame_jacobian(robot, pc, q, p, f)


@pytest.mark.parametrize("rel", ["pr2_description/urdf/pr2.urdf",
                                 "talos_data/robots/talos_reduced.urdf",
                                 "baxter_description/urdf/baxter.urdf"])
def test_several_tips_keep_the_subtree_pinocchio_supports(rel) -> None:
    """Several tips (``load_urdf(tip=[...])``; ``--tip`` repeated on the command line) keep the
    union of the root-to-tip paths: for random sets of 1-4 links whose paths cross no
    ``<mimic>``, the kept joints are the union of Pinocchio's ``supports`` of each link's
    frame, depth first with siblings in file order, each with Pinocchio's parent joint. The
    command line's ``info --json`` with the same ``--tip``s lists the same joints."""
    import json
    import xml.etree.ElementTree as ET

    import pinocchio as pin
    from conftest import mrnea_cli

    path = erd_path(rel)
    full = pin.buildModelFromUrdf(str(path))
    mimics = {j.get("name") for j in ET.parse(path).getroot().iter("joint")
              if j.find("mimic") is not None}

    def support(frame: str) -> set[int]:
        return {i for i in full.supports[full.frames[full.getFrameId(frame)].parentJoint]
                if i > 0}

    links = [f.name for f in full.frames if f.type == pin.FrameType.BODY and support(f.name)
             and not {full.names[i] for i in support(f.name)} & mimics]
    rng = np.random.default_rng(25)
    sets = [list(rng.choice(links, size=k, replace=False)) for k in (1, 2, 2, 3, 4, 4)]
    # depth first from the root, a joint's children in the order of the file's <joint>
    # elements (Pinocchio orders siblings by name: its ids give the tree, not the order)
    line = {j.get("name"): k for k, j in enumerate(ET.parse(path).getroot().iter("joint"))}

    def depth_first(kept: set[int], parent: int = 0) -> list[int]:
        kids = sorted((i for i in kept if full.parents[i] == parent),
                      key=lambda i: line[full.names[i]])
        return [x for i in kids for x in (i, *depth_first(kept, i))]

    for tips in sets:
        ids = depth_first(set().union(*map(support, tips)))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # visuals left out of the 3D view
            robot = mrnea.load_urdf(path, tip=tips)
        assert robot.joint_names == tuple(full.names[i] for i in ids), tips
        names = [None if full.parents[i] == 0 else full.names[full.parents[i]] for i in ids]
        assert [None if p < 0 else robot.joint_names[p] for p in robot.parents] == names, tips
    res = mrnea_cli("info", path, "--json", *[a for t in tips for a in ("--tip", t)])
    assert res.returncode == 0, res.stderr
    assert [j["name"] for j in json.loads(res.stdout)["joints"]] == list(robot.joint_names)
