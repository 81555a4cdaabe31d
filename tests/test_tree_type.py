"""Chain or tree as a compile-time type (kernels/layout.py): a serial chain's compiled model is
C order, a tree's F order, and each compiles only its own copies of the passes; the tree's
copies, given a chain, give the chain's numbers bit for bit (the oracle for both is Pinocchio:
tests/test_dynamics_pinocchio.py, tests/test_tree_pinocchio.py)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import random_chain, random_states
from test_tree_pinocchio import random_tree

from mrnea.kernels.aba import aba
from mrnea.kernels.crba import crba, crba_bias
from mrnea.kernels.kinematics import frames
from mrnea.kernels.layout import TREE, compile_model, entry_scratch
from mrnea.kernels.mrnea import mrnea, mrnea_full
from mrnea.kernels.rnea import reactions, rnea
from mrnea.kernels.status import OK


def test_the_model_type_says_chain_or_tree():
    chain = compile_model(random_chain(np.random.default_rng(1), 6))
    tree = compile_model(random_tree(np.random.default_rng(2), 7))
    assert chain[0, TREE] == 0 and chain.flags.c_contiguous and not chain.flags.writeable
    assert tree[0, TREE] == 1 and tree.flags.f_contiguous and not tree.flags.c_contiguous
    assert not tree.flags.writeable


def test_a_chain_through_the_trees_copies_is_bit_identical():
    """The chain's model in F order runs the tree's copies (parent look-ups, stashes never
    taken); every output equals the chain's copies' bit for bit. (Not forward dynamics through
    a solve: the tree's is the LTL factorisation, another order of operations.)"""
    for seed, n in ((3, 6), (4, 9)):
        robot = random_chain(np.random.default_rng(seed), n, 0.3)
        s = random_states(np.random.default_rng(seed + 10), robot)
        c = compile_model(robot)
        f = np.asfortranarray(c)
        f.setflags(write=False)
        assert f[0, TREE] == 0 and not f.flags.c_contiguous
        for fe, pe in ((None, None), (s["f_ext"], s["f_ext_point"])):
            outs = []
            for m in (c, f):
                ws = entry_scratch(n)
                H, u, Hf, uf = np.empty((n, n)), np.empty(n), np.empty((n, n)), np.empty(n)
                tau, W, T = np.empty(n), np.empty((n, 6)), np.empty((n + 1, 4, 4))
                Hc, uc, Hk, qa = np.empty((n, n)), np.empty(n), np.empty((n, n)), np.empty(n)
                assert mrnea(m, s["q"], s["qd"], fe, pe, H, u, ws) == OK
                assert mrnea_full(m, s["q"], s["qd"], fe, pe, Hf, uf, ws) == OK
                assert rnea(m, s["q"], s["qd"], s["qdd"], fe, pe, tau, ws) == OK
                assert reactions(m, s["q"], s["qd"], s["qdd"], fe, pe, W, ws) == OK
                assert frames(m, s["q"], T, ws) == OK
                assert crba_bias(m, s["q"], s["qd"], fe, pe, Hc, uc, ws) == OK
                crba(m, s["q"], Hk)
                assert aba(m, s["q"], s["qd"], s["tau"], fe, pe, qa, ws) == OK
                outs.append((H, u, Hf, uf, tau, W, T, Hc, uc, Hk, qa))
            for a, b in zip(*outs, strict=True):
                assert np.array_equal(a, b)


CHILD = r"""
import json, sys
import numpy as np
import mrnea
from mrnea.kernels import common, crba as C, mrnea as K, rnea as R, solve as S
robot = mrnea.load_urdf(sys.argv[1]) if len(sys.argv) > 1 else mrnea.robots.puma560()
q = np.linspace(0.1, 0.5, robot.n)
mrnea.mass_matrix_and_bias(robot, q, q)
mrnea.forward_dynamics(robot, q, q, q)
mrnea.inverse_dynamics(robot, q, q, q)
mrnea.joint_reactions(robot, q, q, q)
mrnea.forward_kinematics(robot, q)
for method in ("crba", "aba"):
    mrnea.forward_dynamics(robot, q, q, q, method=method)
sig = lambda d: sorted({str(s[-1]) for s in d.signatures})
print(json.dumps({"tree_pass": len(K.tree_pass.signatures),
                  "kinematics_tree": sig(common.kinematics),
                  "newton_euler_ws": sig(R.newton_euler), "link_forces_ws": sig(R.link_forces),
                  "composite": sig(C.composite), "ltl_solve": len(S.ltl_solve.signatures),
                  "cholesky_solve": len(S.cholesky_solve.signatures)}))
"""


def compiled_copies(cache: Path, *args: str) -> dict:
    """What a fresh process compiles for one robot's calls, on an empty Numba cache (a kernel
    loaded from the cache does not list the kernels compiled into it)."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache)}
    out = subprocess.run([sys.executable, "-c", CHILD, *args], capture_output=True, text=True,
                         env=env, check=True, timeout=900)
    return json.loads(out.stdout.splitlines()[-1])


@pytest.mark.slow
def test_a_chain_compiles_only_the_chains_copies(tmp_path):
    got = compiled_copies(tmp_path)
    assert got["tree_pass"] == 0 and got["ltl_solve"] == 0 and got["cholesky_solve"] >= 1
    assert got["kinematics_tree"] == ["none"] and got["composite"] == ["none"]
    assert got["newton_euler_ws"] == ["none"] and got["link_forces_ws"] == ["none"]


@pytest.mark.slow
def test_a_tree_compiles_only_the_trees_copies(tmp_path):
    urdf = Path(__file__).parents[1] / "examples" / "waist_two_arms.urdf"
    got = compiled_copies(tmp_path, str(urdf))
    assert got["tree_pass"] >= 1 and got["ltl_solve"] >= 1 and got["cholesky_solve"] == 0
    assert len(got["kinematics_tree"]) == 1 and got["kinematics_tree"] != ["none"]  # one copy
    assert len(got["composite"]) == 1 and got["composite"] != ["none"]
    assert "none" not in got["newton_euler_ws"] and "none" not in got["link_forces_ws"]
