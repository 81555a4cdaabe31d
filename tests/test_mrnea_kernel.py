"""The mRNEA kernel's symmetric fill against the paper's full form (all of n'_ia1..3)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import random_chain

import mrnea
from mrnea.kernels.layout import NOCOM, NOPOS, compile_model, entry_scratch
from mrnea.kernels.mrnea import fd_mrnea, mrnea_full
from mrnea.kernels.mrnea import mrnea as mrnea_kernel
from mrnea.kernels.rnea import reactions, rnea
from mrnea.kernels.status import OK


@pytest.mark.parametrize("n, frac", [(1, 0.0), (2, 0.5), (6, 0.0), (7, 0.3), (15, 0.5)])
def test_symmetric_fill_equals_the_papers_full_form(n, frac):
    rng = np.random.default_rng(n)
    robot = random_chain(rng, n, frac)
    for _ in range(20):
        q, qd = rng.uniform(-2, 2, (2, n))
        fe, pe = rng.normal(size=6), rng.normal(size=3)
        H, u = np.empty((n, n)), np.empty(n)
        Hf, uf = np.empty((n, n)), np.empty(n)
        m = compile_model(robot)
        assert mrnea_kernel(m, q, qd, fe, pe, H, u, entry_scratch(n)) == OK
        assert mrnea_full(m, q, qd, fe, pe, Hf, uf, entry_scratch(n)) == OK
        scale = np.abs(Hf).max()
        assert np.abs(H - Hf).max() <= 1e-13 * scale
        assert np.abs(Hf - Hf.T).max() <= 1e-13 * scale  # the paper's a3 gives the same upper
        np.testing.assert_array_equal(u, uf)


def test_sdt_full_form():
    robot = mrnea.robots.sdt()
    rng = np.random.default_rng(3)
    q, qd = rng.uniform(-2, 2, (2, robot.n))
    H, u = np.empty((4, 4)), np.empty(4)
    Hf, uf = np.empty((4, 4)), np.empty(4)
    z6, z3 = np.zeros(6), np.zeros(3)
    ws = entry_scratch(robot.n)
    mrnea_kernel(compile_model(robot), q, qd, z6, z3, H, u, ws)
    mrnea_full(compile_model(robot), q, qd, z6, z3, Hf, uf, ws)
    assert np.abs(H - Hf).max() <= 1e-13 * np.abs(Hf).max()


def _with_zero_offsets(robot: mrnea.Robot) -> mrnea.Robot:
    """The chain with every other joint origin moved onto the parent's origin (o_i = o_{i-1}:
    intersecting axes, p* = 0) and every third centre of mass on its link's origin."""
    joints, links = [], []
    for i, (j, lk) in enumerate(zip(robot.joints, robot.links, strict=True)):
        origin = j.origin.copy()
        if i % 2 == 0:
            origin[:3, 3] = 0.0
        joints.append(mrnea.Joint(j.name, j.type, j.parent, j.child, origin, axis=j.axis))
        com = (0.0, 0.0, 0.0) if i % 3 == 0 else lk.com
        links.append(mrnea.Link(lk.name, lk.mass, com, lk.inertia))
    return mrnea.Robot(joints, links, gravity=robot.gravity)


@pytest.mark.parametrize("n, frac", [(1, 0.0), (3, 0.5), (6, 0.0), (7, 0.3), (12, 0.4)])
def test_specialised_kernels_equal_the_general_path(n, frac):
    """Skipping the terms of zero offsets (NOPOS, NOCOM; Sec. IV's simplification) changes no
    bit of any result: the specialised model against ``compile_model(specialise=False)``."""
    rng = np.random.default_rng(100 + n)
    robot = _with_zero_offsets(random_chain(rng, n, frac))
    special, general = compile_model(robot), compile_model(robot, specialise=False)
    assert special[1:, NOPOS].sum() + special[1:, NOCOM].sum() > 0
    assert not general[:, [NOPOS, NOCOM]].any()
    for _ in range(10):
        q, qd, x = rng.uniform(-2, 2, (3, n))
        fe, pe = rng.normal(size=6), rng.normal(size=3)
        results = []
        for m in (special, general):
            H, u, tau, qdd, W = (np.empty((n, n)), np.empty(n), np.empty(n), np.empty(n),
                                 np.empty((n, 6)))
            ws = entry_scratch(n)
            assert mrnea_kernel(m, q, qd, fe, pe, H, u, ws) == OK
            assert rnea(m, q, qd, x, fe, pe, tau, ws) == OK
            assert reactions(m, q, qd, x, fe, pe, W, ws) == OK
            status = fd_mrnea(m, q, qd, x, fe, pe, qdd, ws)  # a degenerate chain may be singular
            results.append((H, u, tau, W, qdd if status == OK else status))
        for a, b in zip(*results, strict=True):
            np.testing.assert_array_equal(a, b)
