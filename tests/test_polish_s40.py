"""Session 40: a stop request during a simulation's last chunk is never swallowed.

``simulate`` calls ``progress(done, K)`` after every chunk, the last one included; a progress
callback that raises KeyboardInterrupt there (the retime's verification calls the command's
checkpoint from it) used to end in a *completed* result: the request was used up by the
checkpoint that raised, and ``mrnea retime`` went on to write its files and exit 0 (seen on CI:
SIGINT landed during the verification's last chunk of ``tests/test_retime_stop.py``'s program).
Now ``simulate`` returns ``completed=False`` whenever it caught the interrupt.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import mrnea
from mrnea.cli import main

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def test_an_interrupt_after_the_last_chunk_is_not_a_completed_run(tmp_path: Path) -> None:
    robot = mrnea.robots.puma560()
    q = np.zeros((50, robot.n))
    q[:, 0] = np.linspace(0.0, 0.2, 50)
    seen = []

    def progress(done: int, total: int) -> None:
        seen.append(done)
        if done == total:
            raise KeyboardInterrupt

    res = mrnea.simulate(robot, q, 0.01, progress=progress, stream=tmp_path / "cycles.csv")
    assert seen == [50]  # one chunk: the interrupt landed after it
    assert res.completed is False and res.K == 50
    rows = (tmp_path / "cycles.csv").read_text().splitlines()
    assert len(rows) == 1 + 50  # the header and every cycle done


@pytest.mark.parametrize("at", ["before", "last"])
def test_a_retime_stopped_in_its_verification_writes_nothing(monkeypatch, tmp_path: Path,
                                                             at: str) -> None:
    """The request lands just before the verification's simulation or after its last chunk:
    exit 130, no file (before the fix, "last" exited 0 with every file written)."""
    from mrnea.cli import base
    from mrnea.retime import job

    real = job.simulate

    def simulate(*args, progress, **kw):
        def stop_then_report(done: int, total: int) -> None:
            if at == "last" and done == total:
                base._request_stop(15, None)
            progress(done, total)

        if at == "before":
            base._request_stop(15, None)
        return real(*args, progress=stop_then_report, **kw)

    monkeypatch.setattr(job, "simulate", simulate)
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["retime", str(EXAMPLES / "puma_pick.toml"), "--out",
                                    str(out), "--no-3d"])
    assert res.exit_code == 130, res.output
    assert "mrnea: interrupted" in res.output and "RETIMED" not in res.output
    assert not out.exists() or not any(out.iterdir()), list(out.iterdir())
