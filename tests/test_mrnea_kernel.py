"""The mRNEA kernel's symmetric fill against the paper's full form (all of n'_ia1..3)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import random_chain

import mrnea
from mrnea.kernels.mrnea import mrnea as mrnea_kernel
from mrnea.kernels.mrnea import mrnea_full


@pytest.mark.parametrize("n, frac", [(1, 0.0), (2, 0.5), (6, 0.0), (7, 0.3), (15, 0.5)])
def test_symmetric_fill_equals_the_papers_full_form(n, frac):
    rng = np.random.default_rng(n)
    robot = random_chain(rng, n, frac)
    for _ in range(20):
        q, qd = rng.uniform(-2, 2, (2, n))
        fe, pe = rng.normal(size=6), rng.normal(size=3)
        H, u = np.empty((n, n)), np.empty(n)
        Hf, uf = np.empty((n, n)), np.empty(n)
        assert mrnea_kernel(robot.compiled, q, qd, fe, pe, H, u) == -1
        assert mrnea_full(robot.compiled, q, qd, fe, pe, Hf, uf) == -1
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
    mrnea_kernel(robot.compiled, q, qd, z6, z3, H, u)
    mrnea_full(robot.compiled, q, qd, z6, z3, Hf, uf)
    assert np.abs(H - Hf).max() <= 1e-13 * np.abs(Hf).max()
