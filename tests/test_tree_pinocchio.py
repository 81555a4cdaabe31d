"""Kinematic trees (issue 25) against Pinocchio: random trees built in both libraries from the
same parameters (``conftest.to_pinocchio`` with the parent array), at random states.

Every kernel walks the parent array: RNEA, mRNEA (and the paper's full form), Walker-Orin, CRBA,
ABA, the joint reactions, the frames and the Jacobian of any link. Each result equals
Pinocchio's to ``rel_err <= 1e-10`` (``conftest.rel_err``), and H has the branch-induced zeros
exactly (H_ik = 0 when neither joint carries the other).
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import PinChain, random_inertia, random_rotation, random_states, rel_err, to_pinocchio

import mrnea
from mrnea.compiled import of
from mrnea.errors import ModelError, SingularMassMatrixError
from mrnea.kernels.kinematics import link_jacobian_ws
from mrnea.kernels.layout import entry_scratch
from mrnea.kernels.mrnea import mrnea_full
from mrnea.kernels.solve import ltl_solve
from mrnea.kernels.status import OK
from mrnea.robots import puma560

TOL = 1e-10
B = 40  # random states per tree
FD_METHODS = ("mrnea", "walker_orin", "crba", "aba")


def random_tree(rng: np.random.Generator, n: int, prismatic_fraction: float = 0.2,
                base_children: bool = True) -> mrnea.Robot:
    """A random tree of n joints in depth-first order: each joint hangs from the base (if
    ``base_children``) or from a link on the path to the previous joint; random origins, axes,
    inertias as ``conftest.random_chain``."""
    joints, links, parents = [], [], []
    for i in range(n):
        path = []  # the previous link and its ancestors
        k = i - 1
        while k >= 0:
            path.append(k)
            k = parents[k]
        choices = path + ([-1] if base_children or i == 0 else [])
        p = int(rng.choice(choices))
        parents.append(p)
        typ = "prismatic" if rng.random() < prismatic_fraction else "revolute"
        origin = np.eye(4)
        origin[:3, :3] = random_rotation(rng)
        origin[:3, 3] = rng.uniform(-0.5, 0.5, size=3)
        axis = rng.normal(size=3)
        mass = float(rng.uniform(0.5, 5.0))
        joints.append(mrnea.Joint(f"j{i}", typ, "base" if p < 0 else f"l{p}", f"l{i}",
                                  origin=origin, axis=axis / np.linalg.norm(axis)))
        links.append(mrnea.Link(f"l{i}", mass=mass, com=rng.uniform(-0.2, 0.2, size=3),
                                inertia=random_inertia(rng, mass)))
    robot = mrnea.Robot(joints, links, name=f"tree{n}")
    assert robot.parents == tuple(parents)
    return robot


def two_arms() -> mrnea.Robot:
    """A waist joint carrying two 3-joint arms (a branch point at joint 0), one of them
    prismatic-tipped, with zero offsets so that the Sec. IV flags are exercised too."""
    J, L = mrnea.Joint, mrnea.Link
    inertia = np.diag([0.02, 0.03, 0.04])
    shift = np.eye(4)
    shift[:3, 3] = (0.0, 0.0, 0.3)
    left, right = shift.copy(), shift.copy()
    left[:3, 3], right[:3, 3] = (0.0, 0.2, 0.1), (0.0, -0.2, 0.1)
    joints = [J("waist", "revolute", "base", "torso", origin=shift, axis=(0, 0, 1)),
              J("l1", "revolute", "torso", "la1", origin=left, axis=(0, 1, 0)),
              J("l2", "revolute", "la1", "la2", axis=(1, 0, 0)),
              J("l3", "revolute", "la2", "la3", origin=shift, axis=(0, 1, 0)),
              J("r1", "revolute", "torso", "ra1", origin=right, axis=(0, 1, 0)),
              J("r2", "revolute", "ra1", "ra2", origin=shift, axis=(1, 0, 0)),
              J("r3", "prismatic", "ra2", "ra3", origin=shift, axis=(0, 0, 1))]
    links = [L(j.child, mass=1.0 + k, com=(0.0, 0.0, 0.1) if k % 2 else (0.0, 0.0, 0.0),
               inertia=inertia) for k, j in enumerate(joints)]
    return mrnea.Robot(joints, links, name="two_arms")


TREES = {
    "two-arms": two_arms,
    "n5": lambda: random_tree(np.random.default_rng(51), 5),
    "n9": lambda: random_tree(np.random.default_rng(52), 9, 0.3),
    "n16-one-root": lambda: random_tree(np.random.default_rng(53), 16, 0.1, False),
    "n24": lambda: random_tree(np.random.default_rng(54), 24),
}


@pytest.fixture(scope="module", params=list(TREES))
def case(request):
    robot = TREES[request.param]()
    assert not robot.is_serial
    rng = np.random.default_rng(7)
    return robot, PinChain(robot, to_pinocchio(robot)), random_states(rng, robot, B)


def carries(robot: mrnea.Robot, k: int, i: int) -> bool:
    """Whether joint k carries link i (k is i or one of its ancestors), from the parent array."""
    while i > k:
        i = robot.parents[i]
    return i == k


def test_every_kernel_equals_pinocchio_on_trees(case) -> None:
    robot, pc, s = case
    n = robot.n
    related = np.array([[carries(robot, k, i) or carries(robot, i, k) for k in range(n)]
                        for i in range(n)])
    assert not related.all()  # a tree: some pairs are on different branches
    m, _, _, _ = of(robot)
    for b in range(B):
        q, qd, qdd, tau = s["q"][b], s["qd"][b], s["qdd"][b], s["tau"][b]
        fe, pe = s["f_ext"][b], s["f_ext_point"][b]
        for w in ((None, None), (fe, pe)):
            assert rel_err(mrnea.inverse_dynamics(robot, q, qd, qdd, *w),
                           pc.rnea(q, qd, qdd, *w)) <= TOL
            H_ref, u_ref = pc.mass_matrix(q), pc.bias(q, qd, *w)
            for method in ("mrnea", "walker_orin"):
                H, u = mrnea.mass_matrix_and_bias(robot, q, qd, *w, method=method)
                assert rel_err(H, H_ref) <= TOL, method
                assert rel_err(u, u_ref) <= TOL, method
                assert np.all(H[~related] == 0.0), method  # the branch-induced zeros
            Hf, uf = np.empty((n, n)), np.empty(n)
            fe_w = np.zeros(6) if w[0] is None else w[0]
            pe_w = np.zeros(3) if w[1] is None else w[1]
            assert mrnea_full(m, q, qd, fe_w, pe_w, Hf, uf, entry_scratch(n)) == OK
            assert rel_err(Hf, H_ref) <= TOL and rel_err(uf, u_ref) <= TOL
            assert np.all(Hf[~related] == 0.0)
            qdd_ref = pc.aba(q, qd, tau, *w)
            for method in FD_METHODS:
                assert rel_err(mrnea.forward_dynamics(robot, q, qd, tau, *w, method=method),
                               qdd_ref) <= TOL, method
            assert rel_err(mrnea.joint_reactions(robot, q, qd, qdd, *w),
                           pc.reactions(q, qd, qdd, *w)) <= TOL


def test_batches_equal_pinocchio_on_trees(case) -> None:
    robot, pc, s = case
    tau = mrnea.inverse_dynamics(robot, s["q"], s["qd"], s["qdd"], s["f_ext"], s["f_ext_point"])
    for method in FD_METHODS:
        qdd = mrnea.forward_dynamics(robot, s["q"], s["qd"], s["tau"], method=method)
        for b in range(B):
            assert rel_err(qdd[b], pc.aba(s["q"][b], s["qd"][b], s["tau"][b])) <= TOL, method
    for b in range(B):
        assert rel_err(tau[b], pc.rnea(s["q"][b], s["qd"][b], s["qdd"][b], s["f_ext"][b],
                                       s["f_ext_point"][b])) <= TOL


def test_sparse_ltl_solves_pinocchios_mass_matrix(case) -> None:
    """The tree's L^T L solve (kernels/solve.py ``ltl_solve``, forward dynamics on a tree) on
    Pinocchio's H (CRBA): x equals NumPy's dense solve, and the factor reads and writes only
    L's entries L_ik with k carrying i (L filled with NaN first: every other entry stays NaN
    and none reached x), the sparsity without fill-in."""
    robot, pc, s = case
    n = robot.n
    own = np.array([[k <= i and carries(robot, k, i) for k in range(n)] for i in range(n)])
    m = of(robot)[0]
    for b in range(8):
        H, rhs = pc.mass_matrix(s["q"][b]), s["tau"][b]
        L, x = np.full((n, n), np.nan), np.empty(n)
        assert ltl_solve(m, H, rhs, L, x) == OK
        assert rel_err(x, np.linalg.solve(H, rhs)) <= TOL
        assert np.isnan(L[~own]).all() and np.isfinite(L[own]).all()


def test_a_massless_leaf_of_a_tree_is_named() -> None:
    """A massless leaf link on one branch (two_arms' left tip link, of joint 'l3', index 3 of
    7) leaves H singular: every forward-dynamics method raises and names that joint, the
    tree's L^T L solve too (its pivots are taken tip to base: the right arm's first)."""
    robot = two_arms()
    links = [mrnea.Link("la3") if lk.name == "la3" else lk for lk in robot.links]
    bad = mrnea.Robot(robot.joints, links, name="two_arms_massless_tip")
    n = robot.n
    for method in FD_METHODS:
        with pytest.raises(SingularMassMatrixError, match="'l3'"):
            mrnea.forward_dynamics(bad, np.full(n, 0.3), np.zeros(n), np.ones(n), method=method)


def test_frames_and_jacobians_of_every_link_equal_pinocchio(case) -> None:
    robot, pc, s = case
    pin = pc.pin
    n = robot.n
    m, _, ws, _ = of(robot)
    J = np.empty((6, n))
    for b in range(8):
        q, pe = s["q"][b], s["f_ext_point"][b]
        conf = pc.config(q)
        pin.computeJointJacobians(pc.model, pc.data, conf)
        pin.updateFramePlacements(pc.model, pc.data)
        T = mrnea.forward_kinematics(robot, q)
        assert rel_err(T[0], np.eye(4)) == 0.0
        for t in range(n):
            oMi = pc.data.oMi[pc.ids[t]]
            assert rel_err(T[t + 1], oMi.homogeneous) <= TOL
            # the Jacobian of the point pe of link t, base axes: Pinocchio's joint Jacobian
            # (LOCAL_WORLD_ALIGNED, about the joint origin) moved to the point
            Jp = np.array(pin.getJointJacobian(pc.model, pc.data, pc.ids[t],
                                               pin.LOCAL_WORLD_ALIGNED))[:, pc.iv]
            r = oMi.rotation @ pe
            Jp[:3] += np.cross(Jp[3:].T, r).T  # v_p = v_o + w x r
            assert link_jacobian_ws(m, q, t, pe, J, ws) == OK
            assert rel_err(J, Jp) <= TOL, t
        assert rel_err(mrnea.jacobian(robot, q, pe), J) == 0.0  # the last link's, as t = n - 1


def test_tree_order_is_checked() -> None:
    J, L = mrnea.Joint, mrnea.Link
    links = [L(f"l{i}", mass=1.0, inertia=np.eye(3) * 0.01) for i in range(3)]
    ok = [J("a", "revolute", "base", "l0"), J("b", "revolute", "l0", "l1"),
          J("c", "revolute", "l0", "l2")]
    assert mrnea.Robot(ok, links).parents == (-1, 0, 0)
    with pytest.raises(ModelError, match="joint 'c': parent is 'nowhere', which is neither"):
        mrnea.Robot([*ok[:2], J("c", "revolute", "nowhere", "l2")], links)
    with pytest.raises(ModelError, match="joint 'c': parent is 'l2', which is neither"):
        mrnea.Robot([*ok[:2], J("c", "revolute", "l2", "l2")], links)
    # l0's subtree was closed when joint c hung from the base: d cannot come back to l1
    links4 = [*links, L("l3", mass=1.0, inertia=np.eye(3) * 0.01)]
    bad = [ok[0], ok[1], J("c", "revolute", "base", "l2"), J("d", "revolute", "l1", "l3")]
    with pytest.raises(ModelError, match=r"joint 'd'.*depth-first order"):
        mrnea.Robot(bad, links4)


def test_a_chain_is_the_tree_with_parents_i_minus_1() -> None:
    robot = puma560()
    assert robot.parents == tuple(range(-1, robot.n - 1)) and robot.is_serial


def _depth_first_parent_arrays(n: int):
    """Every parent array of n joints in depth-first order (each joint hangs from the base or
    from a link on the path to the previous joint)."""
    def grow(parents):
        if len(parents) == n:
            yield tuple(parents)
            return
        k, path = len(parents) - 1, [-1]
        while k >= 0:
            path.append(k)
            k = parents[k]
        for p in path:
            yield from grow([*parents, p])
    yield from grow([])


def test_the_stash_stack_fits_its_slot_for_every_tree() -> None:
    """mRNEA's column stash (layout.tree_columns): a stack of 6-float slots that must fit the
    n x n floats of the L slot, for every tree of up to 8 joints and for combs (a spine with a
    leaf on every joint, the deepest stack) up to 60 joints."""
    from mrnea.kernels.layout import PARENT, STASH, tree_columns

    for n in range(1, 9):
        for parents in _depth_first_parent_arrays(n):
            tree_columns(parents)  # asserts 6 * (open slots) <= n * n
    for m in range(2, 31):
        # a spine of m joints, then a leaf on each spine joint, deepest first: every spine
        # joint but the last is a branch point, and all their stashes are open at once
        cols = tree_columns(tuple(range(-1, m - 1)) + tuple(range(m - 1, -1, -1)))
        assert (cols[:m - 1, STASH - PARENT] >= 0).all()


def test_native_toml_round_trips_a_tree_with_parent_keys(tmp_path) -> None:
    """The native format's ``parent`` (the joint carrying this one; default the previous):
    written only where it is not the previous joint, read back equal, and checked."""
    from mrnea.errors import RobotFileError
    from mrnea.io import load_robot

    robot = two_arms()
    path = robot.to_toml(tmp_path / "two_arms.toml")
    text = path.read_text()
    assert text.count("\nparent = ") == 1 and '\nparent = "waist"' in text  # joint r1
    assert load_robot(path) == robot
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace('parent = "waist"', 'parent = "r2"'))
    with pytest.raises(RobotFileError, match=r"joint 'r1'.*parent 'r2' is neither the base"):
        load_robot(bad)
