"""Session 38's changes (issue 22: a first ``mrnea excite`` in seconds; hostile inputs).

The excitation search runs its small SVDs with the BLAS libraries on one thread (threadpoolctl's
own report, read inside the search through its checkpoint), and the limit ends with the call.
An empty ``--out`` (a shell's unset ``"$DIR"``) is refused by every command, as a real process,
and nothing is written where it ran (``retime`` wrote its files into the current folder,
the others into a fresh default folder).
"""

from __future__ import annotations

import pytest
from conftest import mrnea_cli, one_error_line, stop_requested_at
from threadpoolctl import threadpool_info, threadpool_limits

import mrnea
from mrnea.identify.excite import excitation

SMALL = {"base_frequency": 0.1, "harmonics": 3, "dt": 0.01, "velocity_limit": 2.0,
         "acceleration_limit": 10.0, "candidates": 4, "starts": 1, "maxiter": 5}


def _blas_threads() -> set[int]:
    return {p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"}


def test_the_search_runs_blas_on_one_thread_and_gives_the_threads_back() -> None:
    seen: list[set[int]] = []
    with threadpool_limits(limits=2, user_api="blas"):  # a caller's own setting
        excitation(mrnea.robots.puma560(), checkpoint=lambda: seen.append(_blas_threads()),
                   **SMALL)
        after = _blas_threads()
    assert seen and all(s == {1} for s in seen), seen
    assert after == {2}


@pytest.mark.parametrize("args", [
    ["demo"], ["simulate", "puma560", "PICK"], ["retime", "PICK"], ["excite", "puma560"],
    ["identify", "puma560", "LOG"], ["sweep", "--grid", "GRID"],
    ["size", "sdt", "demo", "--catalogue", "CATALOGUE"], ["fig3"]])
def test_an_empty_out_is_refused_and_nothing_is_written(args, tmp_path) -> None:
    from pathlib import Path

    examples = Path(__file__).resolve().parents[1] / "examples"
    files = {"PICK": "puma_pick.toml", "LOG": "puma_identify_log.csv",
             "GRID": "puma_payload_grid.toml", "CATALOGUE": "drives_catalogue.toml"}
    args = [str(examples / files[a]) if a in files else a for a in args]
    res = mrnea_cli(*args, "--out", "", cwd=tmp_path)
    one_error_line(res, "--out", "an empty path")
    assert list(tmp_path.iterdir()) == []


def test_a_payload_name_too_long_for_the_system_names_the_option(tmp_path) -> None:
    from pathlib import Path

    pick = Path(__file__).resolve().parents[1] / "examples" / "puma_pick.toml"
    res = mrnea_cli("check", "puma560", pick, "--payload", "a" * 5000, cwd=tmp_path)
    one_error_line(res, "--payload", "neither a mass")


# a stop request (what SIGINT or SIGTERM sets, cli/base._request_stop) at three moments of
# `mrnea check` / `mrnea simulate`, in process: lost, or "interrupted" after the verdict, before
def _pick() -> str:
    from pathlib import Path

    return str(Path(__file__).resolve().parents[1] / "examples" / "puma_pick.toml")


def _request(_args=None, **_kw) -> None:
    from mrnea.cli import base

    base._request_stop(15, None)


def test_a_stop_in_the_last_chunk_is_not_lost(monkeypatch) -> None:
    """The pick program is one chunk: the request landed in it, the run completed, and the
    request was dropped (exit 0, the verdict printed). Now: no verdict, exit 130."""
    import importlib

    from click.testing import CliRunner

    from mrnea.cli import main

    sim = importlib.import_module("mrnea.simulate")  # the module (mrnea.simulate: the function)

    real = sim.simulate

    def simulate(*args, progress=None, **kw):
        def late(done: int, total: int) -> None:
            _request()  # during the chunk that ends the run
            progress(done, total)
        return real(*args, progress=late, **kw)

    monkeypatch.setattr(sim, "simulate", simulate)
    res = CliRunner().invoke(main, ["check", _pick()])
    assert res.exit_code == 130, res.output
    assert "ACHIEVABLE" not in res.stdout and "mrnea: interrupted" in res.output


def test_a_stop_while_writing_gives_no_verdict(monkeypatch, tmp_path) -> None:
    """After the files, before the verdict: exit 130 and no verdict (it printed ACHIEVABLE,
    then exited 130). The files written are whole."""
    import json

    from click.testing import CliRunner

    from mrnea.cli import main, run

    stop_requested_at(monkeypatch, run, "_write_outputs")
    res = CliRunner().invoke(main, ["simulate", _pick(), "--out", str(tmp_path / "o"),
                                    "--no-3d"])
    assert res.exit_code == 130, res.output
    assert "ACHIEVABLE" not in res.stdout and "mrnea: interrupted" in res.output
    assert json.loads((tmp_path / "o" / "summary.json").read_text())["completed"] is True


def test_a_stop_after_the_verdict_keeps_its_code(monkeypatch) -> None:
    """Once the verdict is printed the answer is given: its exit code, not 130."""
    from click.testing import CliRunner

    from mrnea.cli import main, run

    stop_requested_at(monkeypatch, run, "_print_result")
    res = CliRunner().invoke(main, ["check", _pick()])
    assert res.exit_code == 0, res.output
    assert res.stdout.startswith("ACHIEVABLE") and "interrupted" not in res.output
