"""Hostile catalogue and grid files (session 43): each defect found, refused with one error.

* A catalogue name with a control character: the chosen drive's name went into
  chosen_drives.toml's comment and table header, and a newline made that file invalid TOML.
* A catalogue of 5000 motors x 5000 gearboxes listed 25 million combinations (25 s, 3 GB)
  before the memory check refused them; now refused when read, by their count.
* Two trains of one name (a drive unit 'A + B' beside motor 'A' and gearbox 'B'; motors 'A' and
  'A + B' with gearboxes 'B + C' and 'C'): the chosen one could not be told from the other.
* A grid file's robot or program under '~nosuchuser/': Path.expanduser's RuntimeError reached
  the command line as an internal error.
"""

from __future__ import annotations

import pytest

from mrnea.errors import SizingError, SweepError
from mrnea.io.gridfile import load_grid_file
from mrnea.sizing.catalogue import MAX_COMBINATIONS, loads_catalogue


def _motor(name: str) -> str:
    return (f'[[motor]]\nname = "{name}"\nrated_torque = 22.0\npeak_torque = 70.0\n'
            f'max_speed = 400.0\nrotor_inertia = 0.008\n')


def _gearbox(name: str) -> str:
    return f'[[gearbox]]\nname = "{name}"\nratio = 120\n'


def test_name_with_newline_refused():
    with pytest.raises(SizingError, match=r"c\.toml: motor #1: 'name' 'a\\nb' holds a control"):
        loads_catalogue(_motor("a\\nb") + _gearbox("G"), "c.toml")
    with pytest.raises(SizingError, match=r"gearbox #1: 'name' 'G\\t' holds a control"):
        loads_catalogue(_motor("M") + _gearbox("G\\t"), "c.toml")


def test_unicode_name_kept():
    cat = loads_catalogue(_motor("Мотор 💥 <b>") + _gearbox("G"), "c.toml")
    assert cat.combinations()[0].name == "Мотор 💥 <b> + G"


def test_too_many_combinations_refused_when_read():
    n = 1001
    text = "".join(_motor(f"M{k}") for k in range(n)) + "".join(
        _gearbox(f"G{k}") for k in range(MAX_COMBINATIONS // n + 1))
    with pytest.raises(SizingError, match=r"c\.toml: 1001 motors x 1000 gearboxes \+ 0 drives "
                                          r"make 1001000 combinations, more than 1000000"):
        loads_catalogue(text, "c.toml")


def test_drive_named_like_a_combination_refused():
    drive = ('[[drive]]\nname = "A + B"\nrated_torque = 10.0\npeak_torque = 20.0\n'
             'max_speed = 400.0\nrotor_inertia = 0.008\nratio = 120\n')
    with pytest.raises(SizingError, match=r"drive 'A \+ B': its name is also that of motor 'A' "
                                          r"with gearbox 'B'"):
        loads_catalogue(_motor("A") + _gearbox("B") + drive, "c.toml")


def test_two_combinations_of_one_name_refused():
    text = _motor("A") + _motor("A + B") + _gearbox("B + C") + _gearbox("C")
    with pytest.raises(SizingError, match=r"motor 'A \+ B': with gearbox 'C' it is named as "
                                          r"motor 'A' with gearbox 'B \+ C'"):
        loads_catalogue(text, "c.toml")
    names = [t.name for t in loads_catalogue(_motor("A + B") + _gearbox("C"), "c").combinations()]
    assert names == ["A + B + C"]  # ' + ' in a name alone is fine


@pytest.mark.parametrize("sweep", ['robot = "~mrnea_no_such_user/r.toml"',
                                   'robot = "sdt"\nprograms = ["~mrnea_no_such_user/p.toml"]'])
def test_grid_tilde_of_unknown_user(tmp_path, sweep):
    f = tmp_path / "g.toml"
    f.write_text(f'[sweep]\n{sweep}\n[grid]\n"gear_ratio.cab_yaw" = [60]\n')
    key = "programs" if "programs" in sweep else "robot"
    with pytest.raises(SweepError, match=rf"g\.toml: \[sweep\]: '{key}': cannot expand '~' in "
                                         rf"'~mrnea_no_such_user/\w\.toml'"):
        load_grid_file(f)
