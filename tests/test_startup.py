"""A command that does no computation starts without the heavy libraries: ``mrnea --help``,
``mrnea info`` and an error found before any computation import neither matplotlib, Dask,
pandas, toppra, trimesh nor the scipy subpackages (optimize, signal, stats, spatial, ndimage,
interpolate) that only some commands need (docs/performance.md, "A command's start-up").

Each command runs as a real process under ``python -X importtime``, whose stderr lists every
module the interpreter imported: the oracle is Python's own import log, not mrnea.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

HEAVY = ("matplotlib", "dask", "distributed", "pandas", "toppra", "trimesh", "pyarrow",
         "scipy.optimize", "scipy.signal", "scipy.stats", "scipy.spatial", "scipy.ndimage",
         "scipy.interpolate")


def imported(*args: str, cwd: Path) -> tuple[subprocess.CompletedProcess, set[str]]:
    """``python -X importtime -m mrnea ARGS`` and the names of the modules it imported."""
    res = subprocess.run([sys.executable, "-X", "importtime", "-m", "mrnea", *args], cwd=cwd,
                         capture_output=True, text=True, timeout=300)
    names = {line.rsplit("|", 1)[1].strip() for line in res.stderr.splitlines()
             if line.startswith("import time:") and "|" in line}
    assert "mrnea.cli" in names, res.stderr[-2000:]  # the log is there and lists the CLI
    return res, names


@pytest.mark.parametrize("args, exit_code", [
    (("--help",), 0),
    (("info", "puma560"), 0),
    (("check", "puma560", "missing.toml"), 2),  # the file is looked for before any work
])
def test_a_command_without_computation_imports_no_heavy_library(tmp_path: Path, args,
                                                                exit_code: int):
    res, names = imported(*args, cwd=tmp_path)
    assert res.returncode == exit_code, res.stderr[-2000:]
    heavy = sorted(n for n in names for h in HEAVY if n == h or n.startswith(h + "."))
    assert not heavy, heavy[:20]
