"""Hostile robot options (session 43): ``--payload``, ``--actuators``, ``--package-path`` and
the library's :class:`mrnea.io.RobotOptions`.

* ``--actuators ""`` (a shell's unset variable): the error did not name the option;
  ``--package-path ""`` searched the current folder, silently.
* ``--package-path`` on a built-in robot printed two ModelWarnings about its curated inertias
  (every link was rebuilt, so validated again, though no mesh moved).
* ``--payload 2@`` said "no link name between '@' and ':'" (there is no ':');
  ``2@link6:`` put the mass at the link's origin, the point forgotten silently;
  ``--payload ""`` said "looked for .".
* ``RobotOptions(payload=5)`` or ``package_path=5`` raised TypeError; ``package_path="abc"``
  searched the folders "a", "b" and "c".
"""

from __future__ import annotations

import pytest
from conftest import mrnea_cli, one_error_line

from mrnea.errors import MrneaError, RobotFileError
from mrnea.io import RobotOptions, load_robot_spec
from mrnea.io.payload import parse_payload

ARGS = ("check", "puma560", "examples/puma_pick.toml", "--quiet")


@pytest.mark.parametrize("option", ["--actuators", "--package-path"])
def test_an_empty_path_option_is_refused_naming_it(option):
    one_error_line(mrnea_cli(*ARGS, option, "", timeout=120), option, "empty")


def test_package_path_on_a_builtin_robot_prints_no_warning(tmp_path):
    res = mrnea_cli(*ARGS, "--package-path", tmp_path, timeout=120)
    assert res.returncode == 0 and res.stderr == "", res.stderr


@pytest.mark.parametrize("spec, words", [
    ("2@", "nothing after '@'"),
    ("2@ ", "nothing after '@'"),
    ("2@link6:", "no point after ':'"),
    ("", "empty"),
    (" ", "empty"),
])
def test_a_payload_missing_its_part_is_refused(spec, words):
    with pytest.raises(MrneaError, match=words):
        parse_payload(spec)


def test_a_payload_without_point_still_means_the_origin():
    assert parse_payload("2@link6").link == "link6"
    assert parse_payload("2@link6:0,0,0.1").com.tolist() == [0, 0, 0.1]


@pytest.mark.parametrize("kw", [{"payload": 5}, {"payload": "2"}, {"package_path": 5},
                                {"package_path": b"x"}])
def test_robot_options_of_the_wrong_type_name_the_field(kw):
    (field,) = kw
    with pytest.raises(RobotFileError, match=field):
        RobotOptions(**kw)


def test_one_package_path_string_is_one_folder():
    opts = RobotOptions(package_path="abc")
    assert opts.package_path == ("abc",)
    assert load_robot_spec("puma560", options=opts).n == 6
