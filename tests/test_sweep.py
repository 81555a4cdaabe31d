"""Sweep rows: a serial loop of simulate(...).summary(), the default local cluster and a cluster
in processes of its own, reached through its scheduler address, give the same rows, bit for
bit. A failed variant is a row with its error; bad input is one error before any work; an
interrupted sweep keeps the rows done.

Each cluster costs a few seconds to start: the default run starts two (the local cluster and
the separate scheduler and worker); the interrupt and the larger grids are ``slow``.
"""

from __future__ import annotations

import dataclasses
import math
import os
import struct
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest
from conftest import environment
from test_cli import EXAMPLES
from test_sweep_variants import two_link_arm

import mrnea
from mrnea.errors import SweepError
from mrnea.io import load_program
from mrnea.io.program import Program
from mrnea.retime import retime
from mrnea.robots import puma560, sdt
from mrnea.robots.sdt_profile import training_program
from mrnea.simulate import simulate
from mrnea.sweep import check_grid, cluster, time_scaled, variant

SDT_GRID = {"gear_ratio.cab_yaw": [60, 120], "motor_torque_limit.cab_yaw": [40, 60],
            "payload": [0.0, 150.0], "time_scale": [1.0, 1.4]}
PUMA_GRID = {"payload": [0.0, 2.5, 6.0], "payload_point": [[0.0, 0.0, 0.05]],
             "time_scale": [0.8, 1.0, 1.7]}


def same(got: object, expected: object) -> bool:
    """A cell equals a summary's value: a float bit for bit (0.0 != -0.0, NaN == NaN), None
    as a missing value (pandas keeps missing text as NaN), anything else by ==."""
    if expected is None:
        return got is None or bool(pd.isna(got))
    if isinstance(expected, float):
        return isinstance(got, (float, np.floating)) and (
            struct.pack("<d", float(got)) == struct.pack("<d", expected))
    return got == expected


def serial(robot, program, grid):
    """What a user's loop gives: one summary per variant, in grid order."""
    out = []
    for params in check_grid(robot, grid)[1]:
        prog = time_scaled(program, params.get("time_scale", 1.0))
        res = simulate(variant(robot, **params), prog.q_cmd, prog.dt, mode=prog.mode or "hybrid",
                       f_ext=prog.f_ext, f_ext_point=prog.f_ext_point)
        out.append((params, res.summary()))
    return out


def check_rows(df, expected, program_name):
    """Every entry of every summary, by name, bit for bit."""
    assert len(df) == len(expected)
    for (_, row), (params, s) in zip(df.iterrows(), expected, strict=True):
        for k, v in params.items():
            assert row[k] == v
        assert row["program"] == program_name and pd.isna(row["error"])
        assert bool(row["achievable"]) is s["achievable"]
        for key in ("duration", "max_tracking_error", "worst_effort_ratio", "worst_joint"):
            assert same(row[key], s[key]), key
        first = s["first_infeasible"] or {"time": math.nan, "joint": None, "reason": None}
        for key in ("time", "joint", "reason"):
            assert same(row[f"first_infeasible_{key}"], first[key])
        for j in s["joints"]:  # every number (text such as the effort's unit is not a column)
            for key, value in j.items():
                if key != "joint" and not isinstance(value, str):
                    assert same(row[f"{key}.{j['joint']}"], value), key


@pytest.fixture(scope="module")
def demo() -> Program:
    return training_program()


@pytest.fixture(scope="module")
def sdt_serial(demo):
    return serial(sdt(), demo, SDT_GRID)


def test_local_cluster_equals_serial_loop(demo, sdt_serial):
    df = mrnea.sweep(sdt(), demo, SDT_GRID, progress=False)
    assert df.attrs["completed"] and df.attrs["threads"] >= 1 and df.attrs["cases"] == 16
    assert list(df.columns[:6]) == [*SDT_GRID, "program", "error"]
    assert df.index.name == "case" and df.index.tolist() == list(range(16))
    assert df.attrs["units"] == {"gear_ratio.cab_yaw": "", "motor_torque_limit.cab_yaw": "N m",
                                 "payload": "kg", "time_scale": ""}
    check_rows(df, sdt_serial, "sdt_training")
    # the designer's question has an answer here: some variants make it, some do not
    assert df["achievable"].any() and not df["achievable"].all()
    # variant() rebuilds the robot of a row from its columns
    row = df.iloc[5]
    params = row[list(SDT_GRID)].to_dict()
    assert variant(sdt(), **params) == variant(sdt(), **sdt_serial[5][0])


def test_scheduler_address_equals_serial_loop(demo, sdt_serial, scheduler_address):
    df = mrnea.sweep(sdt(), demo, SDT_GRID, client=scheduler_address, progress=False)
    assert df.attrs["threads"] == 1
    check_rows(df, sdt_serial, "sdt_training")


def test_a_plain_local_cluster_is_tuned_and_warmed(demo):
    """A plain ``LocalCluster`` passed as ``client=`` (none of mrnea's settings at its start):
    the rows are the serial loop's; each worker is tuned on its first task (glibc's heap,
    :func:`mrnea.sweep.rows.tune_worker`) and makes one full-length warm-up run as a task
    before any task of the run phase starts (Dask's task stream: the first task to finish on
    each worker finished before the first run-phase task started), one more task per worker
    than the sweep reports."""
    import importlib
    import logging

    from distributed import Client, LocalCluster, get_task_stream

    grid = {"gear_ratio.cab_yaw": [60, 120], "payload": [0.0, 300.0]}
    lc = LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=":0",
                      silence_logs=logging.CRITICAL)
    with lc, Client(lc) as c:
        c.wait_for_workers(2)
        with get_task_stream(c) as ts:
            df = mrnea.sweep(sdt(), demo, grid, client=c, progress=False, batch=1)
        tuned = c.run(lambda: os.getpid() in importlib.import_module("mrnea.sweep.rows")._TUNED)
    check_rows(df, serial(sdt(), demo, grid), "sdt_training")
    assert list(tuned.values()) == [True, True]
    tasks = sorted((t["startstops"][-1]["stop"], t["startstops"][0]["start"], t["worker"])
                   for t in ts.data if t["key"].startswith("run_batch"))
    assert len(tasks) == df.attrs["tasks"] + 2 == 4 + 2
    warm_ups, runs = tasks[:2], tasks[2:]
    assert len({w for *_, w in warm_ups}) == 2  # one on each worker
    assert max(stop for stop, *_ in warm_ups) <= min(start for _, start, _ in runs)


def test_client_two_programs_and_one_run_per_task(scheduler_address):
    """An existing Client, two programs (one with a wrench), tasks of one run each."""
    from distributed import Client

    robot, pick = puma560(), load_program(EXAMPLES / "puma_pick.toml")
    slow = dataclasses.replace(time_scaled(pick, 1.2), name="slow_pick")
    with Client(scheduler_address) as c:
        df = mrnea.sweep(robot, [pick, slow], PUMA_GRID, client=c, progress=False, batch=1)
    assert df.attrs["tasks"] == len(df) == 2 * 9
    assert df["program"].tolist() == ["puma_pick", "slow_pick"] * 9
    check_rows(df.iloc[0::2], serial(robot, pick, PUMA_GRID), "puma_pick")
    check_rows(df.iloc[1::2], serial(robot, slow, PUMA_GRID), "slow_pick")


def test_a_failed_variant_is_a_row(scheduler_address):
    """In the paper's mode every cycle solves H qdd = tau - u': with no payload the massless
    tip makes H singular (an error row naming j2); a payload off joint 2's axis makes the same
    program run."""
    arm = two_link_arm(0.0)
    q = np.linspace([0.0, 0.0], [1.0, 1.0], 200)
    prog = Program(robot="arm2", dt=0.005, t=np.arange(200) * 0.005, q_cmd=q, f_ext=None,
                   f_ext_point=None, mode="paper", name="ramp")
    grid = {"payload": [0.0, 2.0], "payload_point": [[0.3, 0.0, 0.0]]}
    df = mrnea.sweep(arm, prog, grid, client=scheduler_address, progress=False)
    assert len(df) == 2
    assert df["error"].iloc[0].startswith("SingularMassMatrixError: ")
    assert "j2" in df["error"].iloc[0]
    assert pd.isna(df["achievable"].iloc[0]) and np.isnan(df["worst_effort_ratio"].iloc[0])
    assert pd.isna(df["error"].iloc[1]) and not pd.isna(df["achievable"].iloc[1])


def test_a_failed_task_gives_error_rows(scheduler_address):
    """A task that fails as a whole (an exception outside any run) makes each of its runs a
    row with the error."""
    from distributed import Client, wait

    from mrnea.sweep.engine import _batch_rows

    with Client(scheduler_address) as c:
        fut = c.submit(int, "not a number", pure=False)
        wait(fut)
        rows = _batch_rows([(4, (0, 1.0), {}), (5, (0, 1.0), {})], None, fut)
    assert [k for k, _ in rows] == [4, 5]
    assert all(r["error"].startswith("ValueError: ") and "task failed" in r["error"]
               for _, r in rows)


def test_an_interrupt_keeps_the_rows_done(demo, sdt_serial, scheduler_address):
    """The progress callback raising KeyboardInterrupt (as Ctrl-C on the command line does)
    stops the sweep: the rows done are returned, each as the serial loop's, the rest
    cancelled; the cluster is left as given and runs the next sweep."""
    def stop(done: int, total: int) -> None:
        if done >= 4:
            raise KeyboardInterrupt

    df = mrnea.sweep(sdt(), demo, SDT_GRID, client=scheduler_address, progress=stop, batch=2)
    assert not df.attrs["completed"] and df.attrs["cases"] == 16
    assert 4 <= len(df) < 16
    check_rows(df, [sdt_serial[k] for k in df.index], "sdt_training")
    again = mrnea.sweep(sdt(), demo, {"payload": [0.0]}, client=scheduler_address,
                        progress=False)
    assert again.attrs["completed"] and len(again) == 1


class _NoWork:
    """A client that fails the test if the sweep uses it."""

    def submit(self, *a, **k):
        raise AssertionError("the sweep used the cluster before rejecting its input")

    def __getattr__(self, name):
        raise AssertionError(f"the sweep used the cluster ({name}) before rejecting its input")


@pytest.mark.parametrize("grid, programs, words", [
    ({"gear_ratio.cab_yow": [100]}, "demo", ["gear_ratio.cab_yow", "no joint"]),
    ({"gear_ratio.cab_yaw": [100, -80]}, "demo", ["gear_ratio.cab_yaw", "value 2"]),
    ({"payload": []}, "demo", ["'payload'", "empty"]),
    ({"payload": [1]}, [], ["programs", "empty"]),
    ({"payload": [1]}, 42, ["programs", "42"]),
    ({"payload": [1]}, "/nonexistent/prog.toml", ["/nonexistent/prog.toml"]),
    ({"payload": [1]}, ["demo", "demo"], ["the same program given twice"]),
    ({"time_scale": [1e-15]}, "demo", ["'time_scale' value 1 (1e-15)", "less than two cycles"]),
])
def test_bad_input_before_any_work(grid, programs, words):
    with pytest.raises(mrnea.MrneaError) as info:
        mrnea.sweep(sdt(), programs, grid, client=_NoWork(), progress=False)
    for w in words:
        assert w in str(info.value), (w, str(info.value))


def test_a_program_of_another_robot():
    pick = load_program(EXAMPLES / "puma_pick.toml")
    with pytest.raises(SweepError, match=r"'puma_pick'.*6 joints.*'sdt' has 4"):
        mrnea.sweep(sdt(), pick, {"payload": [1.0]}, client=_NoWork(), progress=False)


@pytest.mark.parametrize("kw, words", [
    ({"retime": "yes"}, ["retime", "True or False"]),
    ({"zip": 1}, ["zip", "True or False"]),
    ({"progress": "bar"}, ["progress"]),
    ({"workers": 0}, ["workers", ">= 1"]),
    ({"batch": 2.5}, ["batch"]),
    ({"client": 8786}, ["client", "int"]),
])
def test_bad_arguments(kw, words):
    with pytest.raises(SweepError) as info:
        mrnea.sweep(sdt(), "demo", {"payload": [1.0]}, **{"progress": False, **kw})
    for w in words:
        assert w in str(info.value), (w, str(info.value))


def test_an_unreachable_scheduler_is_one_error(monkeypatch):
    monkeypatch.setattr(cluster, "CONNECT_TIMEOUT", 1)  # the client tries until then
    with pytest.raises(SweepError, match=r"scheduler 'tcp://127\.0\.0\.1:9': cannot connect"):
        mrnea.sweep(sdt(), "demo", {"payload": [1.0]}, client="tcp://127.0.0.1:9",
                    progress=False)


def test_retime_columns_are_mrnea_retime(scheduler_address):
    """retime=True: each row's retimed_duration is mrnea.retime's on that row's variant and
    time-scaled program, bit for bit, from a cluster in processes of its own."""
    robot, pick = puma560(), load_program(EXAMPLES / "puma_pick.toml")
    grid = {"payload": [0.0, 5.0], "time_scale": [1.0, 1.5]}
    df = mrnea.sweep(robot, pick, grid, client=scheduler_address, retime=True, progress=False)
    assert len(df) == 4
    for (_, row), params in zip(df.iterrows(), check_grid(robot, grid)[1], strict=True):
        res = retime(variant(robot, **params), time_scaled(pick, params["time_scale"]))
        assert pd.isna(row["retime_error"]), row["retime_error"]
        assert same(row["retimed_duration"], float(res.duration))


@pytest.mark.slow
def test_no_dask_noise_on_the_terminal(tmp_path):
    """A script that sweeps on the default local cluster prints nothing but its own output, even
    while another server holds the dashboard's usual port."""
    script = tmp_path / "s.py"
    script.write_text(
        "import socket, mrnea\n"
        "if __name__ == '__main__':\n"
        "    s = socket.socket()\n"
        "    try:\n"
        "        s.bind(('', 8787)); s.listen()\n"
        "    except OSError:\n"
        "        pass  # held by someone else: the same situation\n"
        "    df = mrnea.sweep(mrnea.robots.sdt(), 'demo', {'payload': [0.0, 50.0]},\n"
        "                     progress=False, workers=1)\n"
        "    print(len(df), df.attrs['completed'])\n"
        "    s.close()\n")
    r = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                       timeout=600, cwd=tmp_path, env=environment(PYTHONWARNINGS="default"))
    assert r.returncode == 0, r.stderr
    assert r.stdout == "2 True\n" and r.stderr == ""
