"""Hostile inputs found in session 36: each was an internal error or a silent NaN before, and
is one clear error now.

* ``mrnea identify`` on a log too short to determine every base parameter (the first 400 of the
  shipped Puma log's 2000 samples): the standard errors came out NaN, summary.json wrote null
  and the page's writer failed on it ("internal error"). The oracle that the log cannot
  determine them: numpy's rank of the base regressor over the fitted rows is below its number
  of columns.
* ``mrnea identify`` on a log whose efforts are all 0 (a log recorded without them): the
  weights overflowed and numpy's SVD did not converge ("internal error").
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import mrnea_cli, one_error_line

import mrnea
from mrnea.errors import MrneaError
from mrnea.identify import identify, read_log
from mrnea.identify.base import base_parameters
from mrnea.identify.estimate import base_rows

LOG = Path(__file__).resolve().parents[1] / "examples" / "puma_identify_log.csv"


def _part(tmp_path: Path, rows: int, zero_efforts: bool = False) -> Path:
    lines = LOG.read_text().splitlines()[:rows + 1]
    if zero_efforts:
        n = 6
        lines = lines[:1] + [",".join(c.split(",")[:1 + n] + ["0"] * n) for c in lines[1:]]
    path = tmp_path / "log.csv"
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.slow
def test_a_log_too_short_to_determine_the_parameters_is_one_error(tmp_path: Path) -> None:
    path = _part(tmp_path, 400)
    robot = mrnea.robots.puma560()
    log = read_log(path, robot)
    base = base_parameters(robot)
    W, used = base_rows(robot, base, log, 10.0, 1e-2)
    K_fit = round(log.K * 0.8)
    A = W[:K_fit][used[:K_fit]]
    scaled = A / np.maximum(np.linalg.norm(A, axis=0), 1e-300)  # a column of zeros stays one
    assert np.linalg.matrix_rank(scaled) < A.shape[1]  # the oracle
    with pytest.raises(MrneaError, match="do not determine every base parameter"):
        identify(robot, log)
    res = mrnea_cli("identify", "puma560", path, "--out", tmp_path / "out", "--quiet")
    one_error_line(res, "log.csv", "do not determine every base parameter", "mrnea excite")
    assert not (tmp_path / "out").exists()


@pytest.mark.slow
def test_a_log_without_efforts_is_one_error(tmp_path: Path) -> None:
    path = _part(tmp_path, 300, zero_efforts=True)
    res = mrnea_cli("identify", "puma560", path, "--out", tmp_path / "out", "--quiet")
    one_error_line(res, "log.csv", "joint 1's effort is 0")
    assert not (tmp_path / "out").exists()
