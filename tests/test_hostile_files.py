"""Hostile input files: every file mrnea reads is a regular file of bounded size, read without
blocking; TOML nesting is bounded; URDF needs no DTD, and one that declares entities is refused.

Each reader is tried: robot files (native TOML, URDF), sidecar actuator files, program files and
path CSVs (named by a program or given on the command line). FIFOs are tried in a subprocess
with a timeout, so that a regression hangs nothing but that process.
"""

from __future__ import annotations

import functools
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest
from conftest import mrnea_cli, one_error_line

import mrnea.resources as resources
from mrnea.errors import ProgramFileError, RobotFileError
from mrnea.io import (
    apply_actuator_file,
    from_csv,
    load_native,
    load_program,
    load_robot,
    load_urdf,
    loads_native,
    loads_program,
)
from mrnea.io.source import MAX_CSV_SIZE, MAX_FILE_SIZE
from mrnea.robots import sdt

mrnea = functools.partial(mrnea_cli, timeout=120)  # [s]: the hang guard

MALFORMED = Path(__file__).resolve().parent / "malformed"
PROGRAM = ('[program]\nrobot = "sdt"\ndt = 0.01\n[path]\ncsv = "{csv}"\n')


# --- not a regular file -----------------------------------------------------------------------
@pytest.fixture
def fifo(tmp_path: Path) -> Path:
    p = tmp_path / "pipe"
    os.mkfifo(p)
    return p


@pytest.mark.parametrize("name", ["robot.toml", "robot.urdf"])
def test_a_fifo_robot_file_never_blocks(tmp_path: Path, fifo: Path, name: str) -> None:
    (tmp_path / name).symlink_to(fifo)
    one_error_line(mrnea("info", tmp_path / name), name, "FIFO")


def test_a_fifo_program_never_blocks(tmp_path: Path, fifo: Path) -> None:
    (tmp_path / "prog.toml").symlink_to(fifo)
    one_error_line(mrnea("check", "sdt", tmp_path / "prog.toml"), "prog.toml", "FIFO")


def test_a_fifo_named_by_a_program_never_blocks(tmp_path: Path, fifo: Path) -> None:
    (tmp_path / "prog.toml").write_text(PROGRAM.format(csv=fifo))
    one_error_line(mrnea("check", "sdt", tmp_path / "prog.toml"), "FIFO")


def test_a_fifo_path_csv_and_sidecar_never_block(tmp_path: Path, fifo: Path) -> None:
    (tmp_path / "path.csv").symlink_to(fifo)
    one_error_line(mrnea("check", "sdt", tmp_path / "path.csv", "--dt", "0.01"), "FIFO")
    code = ("import sys, mrnea\nfrom mrnea.io import apply_actuator_file\n"
            "try:\n    apply_actuator_file(mrnea.robots.sdt(), sys.argv[1])\n"
            "except mrnea.RobotFileError as e:\n    print(e)\n")
    out = subprocess.run([sys.executable, "-c", code, str(fifo)], capture_output=True, text=True,
                         timeout=120)
    assert "actuator file: it is a FIFO" in out.stdout, out


@pytest.mark.parametrize("device", ["/dev/zero", "/dev/urandom"])
def test_a_device_is_refused_not_read(tmp_path: Path, device: str) -> None:
    if not os.path.exists(device):
        pytest.skip(f"no {device}")
    start = time.perf_counter()
    (tmp_path / "robot.toml").symlink_to(device)
    (tmp_path / "robot.urdf").symlink_to(device)
    for p in (tmp_path / "robot.toml", tmp_path / "robot.urdf"):
        with pytest.raises(RobotFileError, match="character device, not a regular file"):
            load_robot(p)
    with pytest.raises(RobotFileError, match="character device"):
        apply_actuator_file(sdt(), device)
    with pytest.raises(ProgramFileError, match="character device"):
        load_program(device)
    with pytest.raises(ProgramFileError, match="character device"):
        from_csv(device, 0.01)
    with pytest.raises(ProgramFileError, match="character device"):
        loads_program(PROGRAM.format(csv=device), source="prog.toml")
    assert time.perf_counter() - start < 5.0


def test_a_directory_is_refused(tmp_path: Path) -> None:
    for name in ("robot.toml", "robot.urdf"):
        (tmp_path / name).mkdir()
        with pytest.raises(RobotFileError, match="directory"):
            load_robot(tmp_path / name)
    with pytest.raises(ProgramFileError, match="directory"):
        loads_program(PROGRAM.format(csv=tmp_path), source="prog.toml")


# --- size -------------------------------------------------------------------------------------
def _sparse(path: Path, size: int) -> Path:
    with open(path, "wb") as fh:
        fh.truncate(size)  # no data blocks: costs no disk
    return path


def test_files_larger_than_the_limit_are_refused_unread(tmp_path: Path, monkeypatch) -> None:
    """The size limit first, whatever the memory: 4 GB available (on a loaded machine the CSV's
    memory check, 9 bytes a byte, refused the file first and named memory instead)."""
    monkeypatch.setattr(resources, "available_memory", lambda: 4e9)
    start = time.perf_counter()
    for name in ("big.toml", "big.urdf"):
        with pytest.raises(RobotFileError, match=r"robot file is too large \(16 MiB; at most 16 "
                                                 r"MiB is read\)"):
            load_robot(_sparse(tmp_path / name, MAX_FILE_SIZE + 1))
    with pytest.raises(RobotFileError, match="actuator file is too large"):
        apply_actuator_file(sdt(), tmp_path / "big.toml")
    with pytest.raises(ProgramFileError, match="program file is too large"):
        load_program(tmp_path / "big.toml")
    with pytest.raises(ProgramFileError, match=r"path CSV file is too large \(1\.02e\+03 MiB"):
        from_csv(_sparse(tmp_path / "big.csv", MAX_CSV_SIZE + 1), 0.01)
    assert time.perf_counter() - start < 5.0


# --- nesting ----------------------------------------------------------------------------------
DEEP = {
    "arrays": "x = " + "[" * 3000 + "]" * 3000 + "\n",
    "inline tables": "x = " + "{a = " * 1500 + "1" + "}" * 1500 + "\n",
    "dotted keys": "x" + ".a" * 3000 + " = 1\n",
    "40 levels": "x = " + "[" * 40 + "]" * 40 + "\n",
}


@pytest.mark.parametrize("doc", list(DEEP), ids=list(DEEP))
def test_deeply_nested_toml_is_one_error_in_every_reader(tmp_path: Path, doc: str) -> None:
    text = DEEP[doc]
    with pytest.raises(RobotFileError, match="nested too deeply"):
        loads_native(text, source="robot.toml")
    (tmp_path / "act.toml").write_text(text)
    with pytest.raises(RobotFileError, match=r"act\.toml: invalid TOML: .*nested too deeply"):
        apply_actuator_file(sdt(), tmp_path / "act.toml")
    with pytest.raises(ProgramFileError, match="nested too deeply"):
        loads_program(text, source="prog.toml")
    one_error_line(mrnea("info", tmp_path / "act.toml"), "nested too deeply")


# --- URDF: no DTD -----------------------------------------------------------------------------
def _arm() -> str:
    return (MALFORMED / "reference_arm.urdf").read_text()


def _with_prolog(prolog: str) -> str:
    text = _arm()
    at = text.index("<robot")
    return text[:at] + prolog + "\n" + text[at:]


def test_entities_are_refused_before_they_expand(tmp_path: Path) -> None:
    """A 62 KB file whose name would expand to 7.2 MB: refused at once."""
    ent = "".join(f'<!ENTITY e{k} "{"&e" + str(k - 1) + ";" * 1 if k else "x" * 60_000}'
                  f'{("&e" + str(k - 1) + ";") * 9 if k else ""}">' for k in range(3))
    text = _with_prolog(f"<!DOCTYPE robot [{ent}]>").replace('<robot name="', '<robot name="&e2;',
                                                             1)
    p = tmp_path / "big_name.urdf"
    p.write_text(text)
    assert p.stat().st_size > 60_000
    start = time.perf_counter()
    with pytest.raises(RobotFileError, match=r"refused: it has a DOCTYPE with an internal subset"):
        load_urdf(p)
    assert time.perf_counter() - start < 1.0


@pytest.mark.parametrize(("prolog", "encoding"), [
    ('<!DOCTYPE robot [<!ENTITY n "arm">]>', "utf-8"),
    ("<!DOCTYPE robot []>", "utf-8"),  # an internal subset, even empty
    ('<!DOCTYPE robot [<!ENTITY n "arm">]>', "utf-16"),
    ('<!DOCTYPE robot SYSTEM "robot.dtd" [<!ENTITY n "arm">]>', "utf-8"),
])
def test_a_dtd_with_declarations_is_refused(tmp_path: Path, prolog: str, encoding: str) -> None:
    p = tmp_path / "arm.urdf"
    text = _with_prolog(prolog)
    if encoding != "utf-8":
        text = text.replace('encoding="utf-8"', f'encoding="{encoding}"')
    p.write_bytes(text.encode(encoding))
    with pytest.raises(RobotFileError, match="refused: it has a DOCTYPE with an internal subset"):
        load_urdf(p)


@pytest.mark.parametrize(("encoding", "match"), [
    ("koi8-r", "refused: it has a DOCTYPE"),  # decoded through Python's codecs
    ("shift_jis", "refused: it declares entities"),  # expat cannot: the raw text is searched
])
def test_declarations_in_other_encodings_are_refused(tmp_path: Path, encoding: str,
                                                     match: str) -> None:
    p = tmp_path / "arm.urdf"
    text = _with_prolog('<!DOCTYPE robot [<!ENTITY n "arm">]>')
    text = f"<?xml version='1.0' encoding='{encoding}'?>\n" + text[text.index("?>") + 2:]
    p.write_bytes(text.encode(encoding))
    with pytest.raises(RobotFileError, match=match):
        load_urdf(p)


def test_a_doctype_without_declarations_is_accepted(tmp_path: Path) -> None:
    p = tmp_path / "arm.urdf"
    p.write_text(_with_prolog('<!DOCTYPE robot SYSTEM "urdf.dtd">'))
    assert load_urdf(p).n == load_urdf(MALFORMED / "reference_arm.urdf").n


# --- lists and quotes in messages ---------------------------------------------------------------
def test_twenty_thousand_unconnected_links_give_a_short_message(tmp_path: Path) -> None:
    text = _arm()
    at = text.rindex("</robot>")
    extra = "".join(f'<link name="stray_{k}"/>' for k in range(20_000))
    p = tmp_path / "stray.urdf"
    p.write_text(text[:at] + extra + text[at:])
    with pytest.raises(RobotFileError) as info:
        load_urdf(p)
    message = str(info.value)
    assert "20001 root links" in message and "and 19991 more" in message
    assert len(message) < 500, len(message)


def test_a_program_naming_another_file_does_not_print_it(tmp_path: Path) -> None:
    secret = "password = hunter2, do not print me"
    (tmp_path / "notes.txt").write_text(secret + "\n" + "more\n" * 3)
    shutil.copy(MALFORMED / "reference_arm.toml", tmp_path / "arm.toml")
    for name in ("notes.txt", "arm.toml"):
        first = (tmp_path / name).read_text().splitlines()[0]
        (tmp_path / "prog.toml").write_text(PROGRAM.format(csv=name))
        with pytest.raises(ProgramFileError) as info:
            load_program(tmp_path / "prog.toml")
        assert first.strip() not in str(info.value), str(info.value)
        line = one_error_line(mrnea("check", "sdt", tmp_path / "prog.toml"), name)
        assert first.strip() not in line
    assert "hunter2" not in line


def test_a_symbolic_link_to_a_robot_file_is_read(tmp_path: Path) -> None:
    (tmp_path / "link.toml").symlink_to(MALFORMED / "reference_arm.toml")
    assert load_native(tmp_path / "link.toml").n == load_native(
        MALFORMED / "reference_arm.toml").n
