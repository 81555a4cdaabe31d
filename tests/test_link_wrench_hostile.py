"""Hostile input to wrenches on named links (issue 25): each bad wrench, point or table is one
clear MrneaError naming the argument, link or file key (the library), or exactly one
``mrnea: error:`` line and exit 2 (the CLI). And the rule of two tables on one link: no point
and ``point = [0, 0, 0]`` are the same point (the link frame's origin), so they add; the sum is
checked in closed form (twice the wrench).
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import mrnea_cli, one_error_line
from test_link_wrench import URDF, W_L, _hold_program

import mrnea
from mrnea.errors import StateError
from mrnea.retime import scale_estimate

K = 5
Z = np.zeros((K, 6))


@pytest.mark.parametrize(("f_ext", "f_ext_point", "words"), [
    ({"handx": Z}, None, ("f_ext", "'handx'", "did you mean 'hand_")),
    ({"hand_l": np.zeros((K, 5))}, None, ("f_ext['hand_l']", "(6,) or (B, 6)")),
    ({"hand_l": np.zeros((K, 2, 6))}, None, ("f_ext['hand_l']", "(6,) or (B, 6)")),
    ({"hand_l": np.zeros((K + 1, 6))}, None, ("row counts differ", f"{K} rows")),
    ({"hand_l": np.full((K, 6), np.nan)}, None, ("f_ext['hand_l']", "NaN")),
    ({"hand_l": Z}, {"hand_l": [np.inf, 0, 0]}, ("f_ext_point['hand_l']", "NaN or inf")),
    ({"hand_l": Z}, {"hand_r": [0, 0, 0]}, ("f_ext_point", "'hand_r'", "no wrench")),
    (None, {"hand_r": [0, 0, 0]}, ("f_ext_point", "'hand_r'", "no wrench")),
    ({"hand_l": Z}, [0, 0, 0], ("f_ext_point", "mapping")),
    ({"hand_l": "abc"}, None, ("f_ext['hand_l']", "real numbers")),
    ({3: Z}, None, ("f_ext", "no link named 3")),
    ({"hand_l": Z}, {"hand_l": np.zeros((K + 2, 3))}, ("row counts differ",)),
])
def test_bad_wrenches_by_link_are_one_error_naming_them(f_ext, f_ext_point, words) -> None:
    robot = mrnea.load_urdf(URDF)
    q = np.zeros((K, robot.n))
    with pytest.raises(StateError) as exc:
        scale_estimate(robot, q, 0.01, f_ext, f_ext_point)
    for w in words:
        assert w in str(exc.value), str(exc.value)


def test_an_empty_mapping_is_no_wrench() -> None:
    """``f_ext={}`` (and ``f_ext_point={}``) is no wrench on any link: the same as None."""
    robot = mrnea.load_urdf(URDF)
    q = np.linspace(0, 1, K)[:, None] * np.ones(robot.n)
    assert scale_estimate(robot, q, 0.01, {}, {}) == scale_estimate(robot, q, 0.01)


def test_save_program_refuses_a_point_per_cycle_on_a_link(tmp_path) -> None:
    robot = mrnea.load_urdf(URDF)
    t = np.linspace(0.0, 0.5, 51)
    q = np.outer(0.5 - 0.5 * np.cos(np.pi * t / 0.5), np.full(robot.n, 0.2))
    M = t.size
    res = mrnea.retime(robot, (t, q), f_ext={"hand_l": np.tile(W_L, (M, 1))},
                       f_ext_point={"hand_l": np.zeros((M, 3))})
    with pytest.raises(StateError, match="f_ext_point: a program file holds one point"):
        res.save_program(tmp_path / "p.toml", str(URDF), "p.csv")
    assert not (tmp_path / "p.toml").exists()


ONE = 'times = [0.0]\nvalues = [[1, 0, 0, 0, 0, 0]]\n'


@pytest.mark.parametrize(("wrenches", "words"), [
    ('[[wrench]]\nlink = "hand_l"\ntimes = [0.0]\nvalues = [[nan, 0, 0, 0, 0, 0]]\n',
     ("hold.toml", "'values row 1[0]'", "finite")),
    (f'[[wrench]]\nlink = "hand_l"\n{ONE}point = [0, 0]\n', ("hold.toml", "'point'", "3")),
    (f'[[wrench]]\nlink = "hand_l"\n{ONE}point = [inf, 0, 0]\n', ("'point[0]'", "finite")),
    (f'[[wrench]]\nlink = ""\n{ONE}', ("'link'", "non-empty string")),
    (f'[[wrench]]\nlink = 3\n{ONE}', ("'link'", "non-empty string")),
    ('[[wrench]]\nlink = "hand_l"\n', ("[wrench]", "missing required key 'times'")),
    ('[[wrench]]\nlink = "hand_l"\ntimes = [0.0, 0.1]\nvalues = [[1, 0, 0, 0, 0, 0]]\n',
     ("'values' has 1 rows, expected 2",)),
    ('[[wrench]]\nlink = "hand_l"\ntimes = []\nvalues = []\n', ("'times'", "0 entries")),
    (f'[[wrench]]\nlink = "hand_l"\n{ONE}\n[[wrench]]\nlink = "hand_x"\n{ONE}',
     ("hold.toml", "'hand_x'", "did you mean")),
    (f'[[wrench]]\nlink = "hand_l"\n{ONE}point = [0, 0, 0.1]\n\n[[wrench]]\nlink = "hand_l"\n'
     f'{ONE}', ("[[wrench]] 2", "second wrench on link 'hand_l'", "another point")),
])
def test_bad_wrench_tables_are_one_error_line(tmp_path, wrenches, words) -> None:
    one_error_line(mrnea_cli("check", _hold_program(tmp_path, wrenches)), *words)


def test_no_point_and_the_origin_are_one_point(tmp_path) -> None:
    two = (f'[[wrench]]\nlink = "hand_l"\ntimes = [0.0]\nvalues = [{W_L}]\n\n'
           f'[[wrench]]\nlink = "hand_l"\ntimes = [0.0]\nvalues = [{W_L}]\npoint = [0, 0, 0]\n')
    prog = mrnea.load_program(_hold_program(tmp_path, two))
    prog = prog.on(prog.load_robot())
    assert np.array_equal(prog.f_ext["hand_l"], np.tile(2 * np.array(W_L), (prog.K, 1)))
