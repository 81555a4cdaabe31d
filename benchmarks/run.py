"""mrnea's performance benchmark: mrnea against Pinocchio, MuJoCo and Robotics Toolbox, as ratios.

Usage: ``python benchmarks/run.py [--quick] [--out docs/benchmark-results.md]``

Everything runs in this one process, side by side, and the results are ratios: the machine is
shared and noisy (absolute times drift by tens of percent from one minute to the next), but
contenders timed within the same seconds see the same machine. Method (timing.py): every
contender of a comparison (a section: all robots, or all chain sizes, together) is calibrated
to enough calls per round (``timeit``) that one round takes at least 20 ms; the contenders then
run in alternating rounds, the order rotated each round, and each one's figure is its fastest
round. The header reports the noise: how much slower the median round was than the best.
Every call goes through each library's public Python API, as a user makes it, and before
anything is timed the contenders are checked to compute the same thing (the largest deviations
are reported with the tables).

Sections (each a Markdown table; ``--out`` writes them all):

1. per call, one state: inverse dynamics, H + bias, forward dynamics (each mrnea method), on
   UR5, Panda, the SDT and the Puma 560, against Pinocchio, MuJoCo (if installed) and RTB (Puma);
2. per state, batches of 10^4 and 10^5 states against a Python loop over Pinocchio;
3. the simulation loop, ``mrnea.simulate`` against the same cycle in Python with Pinocchio;
4. the ratio to Robotics Toolbox's ``accel`` on the Puma 560;
5. scaling with n on random chains (time and counted flops, fitted exponents);
6. a physical reference: the counted flops of mRNEA forward dynamics (n = 6) against one core's
   scalar peak;
7. start-up: first-call compile time, cached start, import time (fresh processes);
8. retiming (``retime_bench.py``): ``mrnea.retime`` on a Puma 560 path of 400 grid points and the
   SDT's training profile, the verifying simulation included, with the split of its time.

``--quick`` is a smoke run of about a minute (fewer rounds, smaller batches and chains).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import subprocess
import sys
import tempfile
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

import models
import numba as nb
import numpy as np
import pinocchio as pin
import simloop
from retime_bench import TARGET as RETIME_TARGET
from retime_bench import retime_section, retime_table
from timing import SPREAD, compare

import mrnea
from mrnea import compiled
from mrnea.dynamics import _FD, forward_dynamics, inverse_dynamics, mass_matrix_and_bias
from mrnea.kernels.aba import aba as k_aba
from mrnea.kernels.engines import fd_crba, fd_walker_orin
from mrnea.kernels.mrnea import fd_mrnea
from mrnea.kernels.mrnea import mrnea as k_mrnea
from mrnea.robots.sdt_profile import training_profile
from mrnea.simulate import simulate

try:
    import mujoco
    from to_mjcf import mujoco_ready, to_mjcf
except ImportError:  # optional: pip install mujoco
    mujoco = None
try:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        import roboticstoolbox as rtb
except ImportError:  # optional: pip install roboticstoolbox-python (in the test extra)
    rtb = None

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
FD_METHODS = ("mrnea", "walker_orin", "crba", "aba")
KERNELS = {"mrnea": fd_mrnea, "walker_orin": fd_walker_orin, "crba": fd_crba, "aba": k_aba}
SEED = 0  # random chains (models.random_chains) and states
# issue 5's targets (issue 2's floor for the per-call ratio was 2; issue 5 sets 1 for 6-7 DoF arms)
TARGETS = {"batch": 5.0, "simulate": 20.0, "rtb": 30.0, "pin_aba": 1.0, "compile": 15.0}


@dataclass(frozen=True)
class Config:
    rounds: int  # rounds of the per-call comparisons
    batch_sizes: tuple[int, ...]
    batch_rounds: int
    pin_loop_states: int  # states in the Python loops over Pinocchio
    cycles: int  # K, simulation
    sim_rounds: int
    chain_sizes: tuple[int, ...]
    import_repeats: int
    retime_repeats: int


FULL = Config(rounds=21, batch_sizes=(10_000, 100_000), batch_rounds=9, pin_loop_states=10_000,
              cycles=20_000, sim_rounds=7, chain_sizes=(2, 4, 8, 16, 32, 64), import_repeats=7,
              retime_repeats=15)
QUICK = Config(rounds=3, batch_sizes=(10_000,), batch_rounds=2, pin_loop_states=2_000,
               cycles=2_000, sim_rounds=2, chain_sizes=(2, 8, 32), import_repeats=2,
              retime_repeats=3)


# --- formatting ----------------------------------------------------------------------------------

def table(header: list[str], rows: list[list[str]], left: int = 1) -> str:
    """A Markdown table; the first ``left`` columns left-aligned, the rest right-aligned."""
    align = ["---" if k < left else "---:" for k in range(len(header))]
    lines = [header, align, *rows]
    return "\n".join("| " + " | ".join(r) + " |" for r in lines)


def us(t: float) -> str:
    v = t * 1e6
    return f"{v:.3g}" if v < 100 else f"{v:.0f}"


def x(r: float) -> str:
    return f"{r:.2f}" if r < 10 else f"{r:.1f}" if r < 100 else f"{r:.0f}"


def e(v: float) -> str:
    return f"{v:.0e}" if v > 0 else "0"


def slope(ns, ts) -> float:
    """Least-squares exponent p of t ~ n^p."""
    return float(np.polyfit(np.log(ns), np.log(ts), 1)[0])


# --- the machine ---------------------------------------------------------------------------------

def machine() -> dict:
    """CPU (lscpu), nominal GHz, cores, library versions, mrnea's commit, threads, load."""
    info = {"cpu": platform.processor() or platform.machine(), "ghz": None}
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True, check=True).stdout
        fields = dict(line.split(":", 1) for line in out.splitlines() if ":" in line)
        info["cpu"] = fields.get("Model name", info["cpu"]).strip()
        m = re.search(r"@\s*([\d.]+)\s*GHz", info["cpu"])
        if m:
            info["ghz"] = float(m.group(1))
        elif "CPU max MHz" in fields:
            info["ghz"] = float(fields["CPU max MHz"]) / 1000
    except (OSError, subprocess.CalledProcessError):
        pass
    if info["ghz"] is None:  # a VM whose model name has no frequency: the clock it reports
        try:
            m = re.search(r"cpu MHz\s*:\s*([\d.]+)", Path("/proc/cpuinfo").read_text())
            info["ghz"] = float(m.group(1)) / 1000 if m else None
            info["ghz_source"] = "the clock /proc/cpuinfo reports"
        except OSError:
            pass
    info["cores"] = os.cpu_count()
    versions = {"Python": platform.python_version(), "NumPy": np.__version__,
                "Numba": nb.__version__, "Pinocchio": pin.__version__,
                "MuJoCo": mujoco.__version__ if mujoco else "not installed",
                "Robotics Toolbox": rtb.__version__ if rtb else "not installed",
                "mrnea": mrnea.__version__}
    info["versions"] = versions
    try:
        head = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"],
                              capture_output=True, text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(ROOT), "status", "--porcelain", "src"],
                               capture_output=True, text=True, check=True).stdout.strip()
        info["source"] = f"commit {head}" + (" with uncommitted changes in src/" if dirty else "")
    except (OSError, subprocess.CalledProcessError):
        info["source"] = "not a git checkout"
    try:
        layer = f" ({nb.threading_layer()} layer)"
    except ValueError:  # no parallel kernel has run yet
        layer = ""
    info["threads"] = f"{nb.get_num_threads()} Numba threads{layer}"
    info["load"] = os.getloadavg()[0]
    return info


def header(info: dict, args: list[str], seconds: float) -> str:
    """The run's first paragraph: the command, the machine, the versions, the load."""
    v = ", ".join(f"{k} {val}" for k, val in info["versions"].items())
    cmd = " ".join(["python", "benchmarks/run.py", *args])
    return (f"Command: `{cmd}` ({seconds / 60:.1f} min). Machine: {info['cpu']}, "
            f"{info['cores']} cores; {v}; mrnea {info['source']}; batches on "
            f"{info['threads']}. Load average (1 min) {info['load']:.2f} at the start, "
            f"{os.getloadavg()[0]:.2f} at the end (other processes on this shared machine).")


# --- 1. per call ---------------------------------------------------------------------------------

def mujoco_twin(robot: mrnea.Robot):
    """MuJoCo model and data of ``robot`` (as MuJoCo accepts it), and that robot's changes."""
    ready, changed = mujoco_ready(robot)
    m = mujoco.MjModel.from_xml_string(to_mjcf(ready))
    return m, mujoco.MjData(m), ready, changed


def per_call(cases: list[models.Case], cfg: Config) -> dict:
    """Times per call of every contender on every robot (all in one comparison: the rounds
    interleave the robots too), and the checks."""
    contenders, checks = {}, {}
    for case in cases:
        c, checks[case.label] = _per_call_case(case)
        contenders.update({(case.label, *k): fn for k, fn in c.items()})
    t = compare(contenders, cfg.rounds)
    print("  per call done", file=sys.stderr)
    return {"times": {c.label: {k[1:]: v for k, v in t.items() if k[0] == c.label}
                      for c in cases}, "checks": checks}


def _per_call_case(case: models.Case) -> tuple[dict, dict]:
    """The per-call contenders of one robot, and their largest deviations from mrnea."""
    robot, model, data = case.robot, case.model, case.data
    rng = np.random.default_rng(SEED)
    q, qd, xx = rng.uniform(-1.0, 1.0, (3, robot.n))
    qc = case.config(q)
    c = {
        ("ID", "mrnea.inverse_dynamics"): lambda: inverse_dynamics(robot, q, qd, xx),
        ("ID", "pinocchio.rnea"): lambda: pin.rnea(model, data, qc, qd, xx),
        ("HB", "mrnea.mass_matrix_and_bias (mrnea)"):
            lambda: mass_matrix_and_bias(robot, q, qd),
        ("HB", "mrnea.mass_matrix_and_bias (walker_orin)"):
            lambda: mass_matrix_and_bias(robot, q, qd, method="walker_orin"),
        ("HB", "pinocchio.crba + nonLinearEffects"):
            lambda: (pin.crba(model, data, qc), pin.nonLinearEffects(model, data, qc, qd)),
        ("FD", "pinocchio.aba"): lambda: pin.aba(model, data, qc, qd, xx),
    }
    for m in FD_METHODS:
        c[("FD", f"mrnea.forward_dynamics ({m})")] = (
            lambda m=m: forward_dynamics(robot, q, qd, xx, method=m))
    tau = inverse_dynamics(robot, q, qd, xx)
    H, u = mass_matrix_and_bias(robot, q, qd)
    ck = {"pinocchio": max(
        models.rel_err(pin.rnea(model, data, qc, qd, xx), tau),
        models.rel_err(pin.crba(model, data, qc), H),
        models.rel_err(pin.nonLinearEffects(model, data, qc, qd), u),
        models.rel_err(pin.aba(model, data, qc, qd, tau), xx),
        *(models.rel_err(forward_dynamics(robot, q, qd, tau, method=m), xx)
          for m in FD_METHODS))}
    if mujoco:
        mm, md, ready, changed = mujoco_twin(robot)

        def mj_inverse():
            md.qpos[:], md.qvel[:], md.qacc[:] = q, qd, xx
            mujoco.mj_inverse(mm, md)
            return md.qfrc_inverse.copy()

        def mj_forward():
            md.qpos[:], md.qvel[:], md.qfrc_applied[:] = q, qd, xx
            mujoco.mj_forward(mm, md)
            return md.qacc.copy()

        c[("ID", "MuJoCo mj_inverse")] = mj_inverse
        c[("FD", "MuJoCo mj_forward")] = mj_forward
        tau_r = inverse_dynamics(ready, q, qd, xx)
        ck["MuJoCo"] = models.rel_err(mj_inverse(), tau_r)
        md.qpos[:], md.qvel[:], md.qfrc_applied[:] = q, qd, tau_r
        mujoco.mj_forward(mm, md)
        ck["MuJoCo"] = max(ck["MuJoCo"], models.rel_err(md.qacc, xx))
        if changed:
            ck["MuJoCo model vs original"] = models.rel_err(tau_r, tau)
            ck["MuJoCo changed links"] = ", ".join(changed)
    if rtb and case.label == "Puma 560":
        puma = rtb.models.DH.Puma560()
        c[("ID", "RTB rne")] = lambda: puma.rne(q, qd, xx)
        c[("HB", "RTB inertia + rne(qdd = 0)")] = (
            lambda: (puma.inertia(q), puma.rne(q, qd, np.zeros(6))))
        c[("FD", "RTB accel")] = lambda: puma.accel(q, qd, xx)
        ck["RTB"] = rtb_check(puma, robot, q, qd, xx)
    return c, ck


def rtb_check(puma, robot: mrnea.Robot, q, qd, tau) -> float:
    """RTB (friction off) against mrnea with the rotor inertia: H_a = H + diag(G^2 J_m)."""
    from mrnea.actuators import actuator_mass_matrix_and_bias

    nofric = puma.nofriction(coulomb=True, viscous=True)
    Ha, ua = actuator_mass_matrix_and_bias(
        robot.with_actuators(viscous_friction=0.0, coulomb_friction=0.0), q, qd)
    return max(models.rel_err(nofric.inertia(q), Ha),
               models.rel_err(nofric.rne(q, qd, np.zeros(6)), ua),
               models.rel_err(nofric.accel(q, qd, tau), np.linalg.solve(Ha, tau - ua)))


def per_call_tables(res: dict, cases: list[models.Case]) -> str:
    labels = [c.label for c in cases]
    times = res["times"]
    groups = {"ID": ("Inverse dynamics", "pinocchio.rnea"),
              "HB": ("Mass matrix H and bias", "pinocchio.crba + nonLinearEffects"),
              "FD": ("Forward dynamics", "pinocchio.aba")}
    out = []
    for g, (title, ref) in groups.items():
        names = list(dict.fromkeys(k[1] for t in times.values() for k in t if k[0] == g))
        rows = []
        for name in names:
            row = [f"`{name}`"]
            for lb in labels:
                t = times[lb].get((g, name))
                row.append("n/a" if t is None else f"{us(t)} ({x(t / times[lb][(g, ref)])})")
            rows.append(row)
        out.append(f"**{title}**: time per call [us] (ratio to `{ref}`; below 1: faster)\n\n"
                   + table(["call", *labels], rows))
    if not mujoco:
        out.append("MuJoCo: not installed (`pip install mujoco` to include it).")
    if not rtb:
        out.append("Robotics Toolbox: not installed (`pip install roboticstoolbox-python`).")
    rows = []
    for lb in labels:
        ck = res["checks"][lb]
        rows.append([lb, e(ck["pinocchio"]), e(ck["MuJoCo"]) if "MuJoCo" in ck else "n/a",
                     e(ck["RTB"]) if "RTB" in ck else "n/a"])
    notes = [f"{lb}: MuJoCo refuses links {ck['MuJoCo changed links']} as published (mass or "
             f"inertia, see benchmarks/to_mjcf.py); on the adjusted robot MuJoCo agrees with "
             f"mrnea as shown, and the adjusted robot's efforts differ from the original's by "
             f"{e(ck['MuJoCo model vs original'])} (relative)."
             for lb, ck in res["checks"].items() if "MuJoCo changed links" in ck]
    out.append("Checked before timing, largest deviation from mrnea (`max|a - b| / max(1, "
               "max|b|)`) over ID, H, bias and FD of the state timed (RTB: friction off, "
               "against mrnea with rotor inertia):\n\n"
               + table(["robot", "Pinocchio", "MuJoCo", "RTB"], rows)
               + ("\n\n" + "\n".join(notes) if notes else ""))
    return "\n\n".join(out)


# --- 2. batches ----------------------------------------------------------------------------------

def single_thread(fn):
    """``fn`` run with Numba's parallel loops on one thread."""

    def run():
        nb.set_num_threads(1)
        try:
            return fn()
        finally:
            nb.set_num_threads(nb.config.NUMBA_NUM_THREADS)

    return run


def batches(cases: list[models.Case], cfg: Config) -> dict:
    """Per-state times of the batches and the Pinocchio loops, all robots in one comparison."""
    contenders, out = {}, {}
    for case in cases:
        c, out[case.label] = _batch_case(case, cfg)
        contenders.update({(case.label, *k): fn for k, fn in c.items()})
    t = compare(contenders, cfg.batch_rounds)
    B1, Bp = min(cfg.batch_sizes), cfg.pin_loop_states
    for k, v in t.items():
        states = k[2] if isinstance(k[2], int) else Bp if k[1] == "pin" else B1
        out[k[0]]["per_state"][k[1:]] = v / states
    print("  batches done", file=sys.stderr)
    return out


def _batch_case(case: models.Case, cfg: Config) -> tuple[dict, dict]:
    """The batch contenders of one robot, and the check of the batch against the loop."""
    Bmax, Bp, B1 = max(cfg.batch_sizes), cfg.pin_loop_states, min(cfg.batch_sizes)
    robot, model, data = case.robot, case.model, case.data
    rng = np.random.default_rng(SEED)
    Q, QD, X = rng.uniform(-1.0, 1.0, (3, Bmax, robot.n))
    Qc = case.config(Q[:Bp])
    ops = {"ID": lambda Q, QD, X: inverse_dynamics(robot, Q, QD, X),
           "H + bias": lambda Q, QD, X: mass_matrix_and_bias(robot, Q, QD)}
    for m in FD_METHODS:
        ops[f"FD {m}"] = lambda Q, QD, X, m=m: forward_dynamics(robot, Q, QD, X, method=m)
    c = {}
    for op, fn in ops.items():
        for B in cfg.batch_sizes:
            c[(op, B)] = lambda fn=fn, B=B: fn(Q[:B], QD[:B], X[:B])
        c[(op, "1 thread")] = single_thread(lambda fn=fn: fn(Q[:B1], QD[:B1], X[:B1]))
    rows = list(zip(Qc, QD[:Bp], X[:Bp], strict=True))
    c[("pin", "rnea")] = lambda: np.array([pin.rnea(model, data, a, b, cc)
                                           for a, b, cc in rows])
    c[("pin", "crba + nle")] = lambda: [(pin.crba(model, data, a).copy(),
                                         pin.nonLinearEffects(model, data, a, b))
                                        for a, b, _ in rows]
    c[("pin", "aba")] = lambda: np.array([pin.aba(model, data, a, b, cc)
                                          for a, b, cc in rows])
    # the batch gives what the loop gives
    fd = forward_dynamics(robot, Q[:Bp], QD[:Bp], X[:Bp])
    check = models.rel_err(c[("pin", "aba")](), fd)
    return c, {"per_state": {}, "check": check, "ops": list(ops)}


def batch_table(res: dict, cfg: Config) -> str:
    sizes = cfg.batch_sizes
    ref = {"ID": "rnea", "H + bias": "crba + nle"}
    head = ["robot", "operation", *(f"mrnea, B = {B:,}" for B in sizes),
            f"mrnea, B = {min(sizes):,}, 1 thread", "Pinocchio loop",
            "speed-up", "speed-up, 1 thread"]
    rows = []
    for lb, r in res.items():
        ps = r["per_state"]
        for op in r["ops"]:
            loop = ps[("pin", ref.get(op, "aba"))]
            best = min(ps[(op, B)] for B in sizes)
            rows.append([lb, op, *(us(ps[(op, B)]) for B in sizes), us(ps[(op, "1 thread")]),
                         f"{us(loop)} (`{ref.get(op, 'aba')}`)", x(loop / best),
                         x(loop / ps[(op, "1 thread")])])
    checks = ", ".join(f"{lb} {e(r['check'])}" for lb, r in res.items())
    return ("Time per state [us]; speed-up = Pinocchio Python loop / mrnea batch (the faster "
            f"batch size), for forward dynamics against the loop over `pinocchio.aba`. The "
            f"loops run over {cfg.pin_loop_states:,} states (a list comprehension, one call per "
            f"state). Batches run on all {nb.config.NUMBA_NUM_THREADS} cores unless marked 1 "
            f"thread; the Pinocchio loop runs on one.\n\n" + table(head, rows, left=2)
            + f"\n\nChecked: batched FD against the loop over `pinocchio.aba`: {checks}.")


# --- 3. simulation -------------------------------------------------------------------------------

def simulation(cases: list[models.Case], cfg: Config) -> dict:
    K = cfg.cycles
    puma = next(c for c in cases if c.label == "Puma 560")
    sdt = mrnea.robots.sdt().with_actuators(coulomb_friction=0.0)
    runs = {
        "Puma 560": (puma.robot, pin.Model(puma.model), 0.002, models.puma_program(K, 0.002),
                     "smooth cosine program, 6 joints"),
        "SDT": (sdt, models.to_pinocchio(sdt), 42.0 / K,
                training_profile(42.0 / K)[1][:K], "the demo's training profile, "
                "Coulomb friction off"),
    }
    contenders, out = {}, {}
    for label, run in runs.items():
        c, out[label] = _simulate_case(*run)
        contenders.update({(label, k): fn for k, fn in c.items()})
    for (label, name), v in compare(contenders, cfg.sim_rounds).items():
        out[label]["per_cycle"][name] = v / K
    print("  simulation done", file=sys.stderr)
    return out


def _simulate_case(robot: mrnea.Robot, model: pin.Model, dt: float, q_cmd: np.ndarray,
                   what: str) -> tuple[dict, dict]:
    """The simulation contenders of one robot, and the check of the loop against simulate."""
    robot = robot.with_actuators(effort_limit=1e9)  # generous limits: never saturates
    limit = np.full(robot.n, 1e9)
    model.armature = robot.gear_ratio ** 2 * robot.rotor_inertia
    data = model.createData()
    q_cmd = np.ascontiguousarray(q_cmd)
    check = simloop.check(simulate(robot, q_cmd, dt, mode="paper"),
                          simloop.pinocchio_loop(model, data, robot, q_cmd, dt, limit), robot)
    c = {f"simulate(paper, fd={fd})": lambda fd=fd: simulate(robot, q_cmd, dt, mode="paper",
                                                             fd=fd)
         for fd in ("mrnea", "walker_orin", "crba")}
    c["simulate(hybrid, fd=mrnea)"] = lambda: simulate(robot, q_cmd, dt)
    c["Python loop + Pinocchio"] = lambda: simloop.pinocchio_loop(model, data, robot, q_cmd,
                                                                  dt, limit)
    return c, {"per_cycle": {}, "check": check, "dt": dt, "what": what}


def simulation_table(res: dict, cfg: Config) -> str:
    names = list(next(iter(res.values()))["per_cycle"])
    ref = "Python loop + Pinocchio"
    rows = []
    for name in names:
        row = [f"`{name}`" if name != ref else ref]
        for r in res.values():
            t = r["per_cycle"][name]
            row.append(f"{us(t)} ({x(r['per_cycle'][ref] / t)})")
        rows.append(row)
    checks = []
    for lb, r in res.items():
        ck = r["check"]
        checks.append([lb, r["what"], f"{r['dt'] * 1e3:.3g}", e(ck["q"]), e(ck["qdd"]),
                       e(ck["tau"]), e(ck["reaction"]), str(ck["saturated cycles"])])
    return (f"K = {cfg.cycles:,} cycles; time per cycle [us] (speed-up: the Python loop's time "
            "/ this one's). Paper mode, effort limits 1e9 (generous: nothing saturates, the "
            "clip still runs). mrnea's cycle also clamps the command to position and velocity "
            "limits and solves the cycle exactly (limits, Coulomb friction), and computes the "
            "program's own requirement; the loop (benchmarks/simloop.py) does not.\n\n"
            + table(["loop", *res], rows)
            + "\n\nChecked before timing, largest deviation of the Python loop from "
            "`simulate(paper)` (relative to the largest value, absolute below 1):\n\n"
            + table(["robot", "program", "dt [ms]", "q", "qdd", "tau", "reactions",
                     "saturated cycles"], checks))


# --- 4. Robotics Toolbox -------------------------------------------------------------------------

def rtb_table(per: dict) -> str:
    if not rtb:
        return "Robotics Toolbox for Python: not installed (`pip install roboticstoolbox-python`)."
    t = per["times"]["Puma 560"]
    pairs = [("RTB accel", f"mrnea.forward_dynamics ({m})", "FD") for m in FD_METHODS]
    pairs += [("RTB rne", "mrnea.inverse_dynamics", "ID"),
              ("RTB inertia + rne(qdd = 0)", "mrnea.mass_matrix_and_bias (mrnea)", "HB")]
    rows = []
    for theirs, ours, g in pairs:
        a, b = t[(g, theirs)], t[(g, ours)]
        rows.append([f"`{theirs}`", f"`{ours}`", us(a), us(b), x(a / b)])
    return ("Puma 560 (`rtb.models.DH.Puma560()`, its own parameters: RTB's calls include the "
            "rotor inertia and friction, mrnea's are rigid-body; checked equal with friction "
            "off and the rotor inertia added on mrnea's side), one state per call, the times "
            "of section 1:\n\n"
            + table(["RTB call", "mrnea call", "RTB [us]", "mrnea [us]", "speed-up"], rows,
                    left=2))


# --- 5. scaling ----------------------------------------------------------------------------------

def scaling(cfg: Config) -> dict:
    chains = models.random_chains(cfg.chain_sizes, SEED)
    contenders, out = {}, {}
    for n, robot in chains.items():
        c, out[n] = _scaling_case(robot)
        contenders.update({(n, k): fn for k, fn in c.items()})
    for (n, name), v in compare(contenders, cfg.rounds).items():
        out[n]["times"][name] = v
    print("  scaling done", file=sys.stderr)
    return out


def _scaling_case(robot: mrnea.Robot) -> tuple[dict, dict]:
    """The scaling contenders of one chain, and their largest deviation from pinocchio.aba."""
    n = robot.n
    model = models.to_pinocchio(robot)
    data = model.createData()
    rng = np.random.default_rng(SEED)
    q, qd, tau = rng.uniform(-1.0, 1.0, (3, n))
    c = {m: (lambda m=m: forward_dynamics(robot, q, qd, tau, method=m)) for m in FD_METHODS}
    c["pinocchio.aba"] = lambda: pin.aba(model, data, q, qd, tau)
    c["H+u mrnea"] = lambda: mass_matrix_and_bias(robot, q, qd)
    c["H+u walker_orin"] = lambda: mass_matrix_and_bias(robot, q, qd, method="walker_orin")
    ref = pin.aba(model, data, q, qd, tau)
    err = max(models.rel_err(forward_dynamics(robot, q, qd, tau, method=m), ref)
              for m in FD_METHODS)
    return c, {"times": {}, "check": err, "prismatic": int(robot.is_prismatic.sum())}


def scaling_tables(res: dict, flops: dict) -> str:
    ns = sorted(res)
    names = list(res[ns[0]]["times"])
    big = [n for n in ns if n >= 8]
    head = ["n (prismatic)", *(f"`{k}`" for k in names)]
    rows = [[f"{n} ({res[n]['prismatic']})", *(us(res[n]["times"][k]) for k in names)]
            for n in ns]
    if len(big) >= 2:
        rows.append([f"exponent, n >= {big[0]}",
                     *(f"{slope(big, [res[n]['times'][k] for n in big]):.2f}" for k in names)])
    t1 = ("Time per call [us], one state through the public API (`forward_dynamics(method=...)`,"
          " `pinocchio.aba`, and `mass_matrix_and_bias` for H and u' alone), random chains "
          "(benchmarks/models.py, 30 % prismatic joints), exponent p of t ~ n^p by least "
          "squares on log-log:\n\n" + table(head, rows))
    rrows = [[str(n), *(x(res[n]["times"][k] / res[n]["times"]["mrnea"])
                        for k in ("walker_orin", "crba", "aba", "pinocchio.aba")),
              x(res[n]["times"]["H+u walker_orin"] / res[n]["times"]["H+u mrnea"])]
             for n in ns]
    t2 = ("The paper's comparison: time of each method / time of mRNEA forward dynamics (above "
          "1: mRNEA is faster), and Walker-Orin method 1 / mRNEA for H and u' alone:\n\n"
          + table(["n", "Walker-Orin 1", "CRBA", "ABA", "pinocchio.aba", "H + u': WO / mRNEA"],
                  rrows))
    fr = flops.get("random", {})
    fns = sorted(int(n) for n in fr)
    def solve_share(n: int) -> str:
        st = fr[str(n)]["mrnea stages"]
        return f"{100 * st.get('Cholesky solve', 0) / sum(st.values()):.0f} %"

    frows = [[str(n), *(f"{fr[str(n)][m]:,}" for m in FD_METHODS), solve_share(n)]
             for n in fns]
    fbig = [n for n in fns if n >= 8]
    if len(fbig) >= 2:
        frows.append([f"exponent, n >= {fbig[0]}",
                      *(f"{slope(fbig, [fr[str(n)][m] for n in fbig]):.2f}"
                        for m in FD_METHODS), ""])
    t3 = ("Floating-point operations per forward-dynamics call, counted by running each kernel's"
          " source (benchmarks/flops.py), same chains, and the Cholesky solve's share of "
          "mRNEA's:\n\n"
          + table(["n", *(f"`{m}`" for m in FD_METHODS), "mRNEA: solve"], frows)) if fns else ""
    checks = max(r["check"] for r in res.values())
    return "\n\n".join([t1, t2, t3, f"Checked: every method against `pinocchio.aba` on every "
                        f"chain, largest deviation {e(checks)}."])


# --- 6. flops and the machine's peak -------------------------------------------------------------

@nb.njit
def _repeat(kernel, model, Q, QD, TAU, fe, pe, qdd, ws, reps):  # pragma: no cover - compiled
    """Call a forward-dynamics kernel reps times, cycling through the states: kernel time."""
    s = 0
    for r in range(reps):
        b = r % Q.shape[0]
        s += kernel(model, Q[b], QD[b], TAU[b], fe, pe, qdd, ws)
    return s


def count_flops(cfg: Config) -> dict:
    env = {**os.environ, "NUMBA_DISABLE_JIT": "1"}
    cmd = [sys.executable, str(HERE / "flops.py"), "--seed", str(SEED),
           "--n", *map(str, cfg.chain_sizes)]
    r = subprocess.run(cmd, env=env, capture_output=True, text=True)
    if r.returncode != 0:
        print(f"  flop count failed: {r.stderr[-2000:]}", file=sys.stderr)
        return {}
    print("  flop count done", file=sys.stderr)
    return json.loads(r.stdout)


@nb.njit
def _repeat_pass(model, Q, QD, fe, pe, H, u, ws, reps):  # pragma: no cover - compiled
    """The mRNEA pass alone (H and u'), reps times: its share of the forward-dynamics time."""
    s = 0
    for r in range(reps):
        b = r % Q.shape[0]
        s += k_mrnea(model, Q[b], QD[b], fe, pe, H, u, ws)
    return s


def kernel_times(case: models.Case, cfg: Config) -> dict:
    """Where the time of a forward-dynamics call goes: the kernel in a compiled loop (no Python,
    no dispatch), the kernel's compiled entry called from Python with ready arrays (adds the
    arguments' unboxing: what the public call uses), the same through Numba's dispatcher (adds
    typing every argument), and the public call (adds the wrapper); for mRNEA also the pass
    alone (H and u')."""
    robot = case.robot
    model, (n,), ws, _ = compiled.of(robot)  # the arrays and scratch the public call uses
    rng = np.random.default_rng(SEED)
    Q, QD, TAU = rng.uniform(-1.0, 1.0, (3, 64, robot.n))
    qdd = np.empty(n)
    H, u = np.empty((n, n)), np.empty(n)
    reps = 1000
    c = {("kernel", m): (lambda k=k: _repeat(k, model, Q, QD, TAU, None, None, qdd, ws, reps))
         for m, k in KERNELS.items()}
    c[("kernel", "mrnea pass")] = lambda: _repeat_pass(model, Q, QD, None, None, H, u, ws, reps)
    q, qd, tau = Q[0], QD[0], TAU[0]
    for m, k in KERNELS.items():
        c[("direct", m)] = lambda k=k: k(model, q, qd, tau, None, None, qdd, ws)
        c[("entry", m)] = lambda e=_FD[m][0]: e.free(model, q, qd, tau, None, None, qdd, ws)
        c[("api", m)] = lambda m=m: forward_dynamics(robot, q, qd, tau, method=m)
    t = compare(c, cfg.rounds)
    return {k: (v / reps if k[0] == "kernel" else v) for k, v in t.items()}


def flops_tables(flops: dict, kt: dict, info: dict) -> str:
    if not flops:
        return "The flop count failed (see the run's stderr)."
    ur5 = flops["ur5"]
    st = ur5["mrnea"]["flops"]
    order = ["kinematics", "forward pass", "backward pass", "other", "Cholesky solve"]
    names = {"other": "tau - u' (and other lines)"}
    total = ur5["mrnea"]["total"]
    rows = [[names.get(s, s), f"{st[s]:,}", f"{100 * st[s] / total:.0f} %"]
            for s in order + sorted(set(st) - set(order)) if s in st]
    rows.append(["**total**", f"**{total:,}**", "100 %"])
    t1 = ("mRNEA forward dynamics (`fd_mrnea`), UR5 (n = 6, all revolute), floating-point "
          "operations per call by stage (+, -, *, / and sqrt as written in the source, counted by"
          f" running it: benchmarks/flops.py), plus {ur5['mrnea']['trig_total']} sin/cos (one "
          "pair per joint, in the kinematics):\n\n"
          + table(["stage", "flops", "share"], rows))
    ghz = info.get("ghz")
    peak = 2.0 * ghz if ghz else None
    rows = []
    for m in FD_METHODS:
        f = ur5[m]["total"]
        tk, te, td, ta = kt[("kernel", m)], kt[("entry", m)], kt[("direct", m)], kt[("api", m)]
        row = [f"`{m}`", f"{f:,}", us(tk), us(te), us(td), us(ta), f"{f / tk / 1e9:.2f}"]
        if peak:
            row += [f"{100 * f / tk / 1e9 / peak:.0f} %", f"{f / peak / 1e3:.2f}",
                    x(tk / (f / peak / 1e9))]
        rows.append(row)
    head = ["method", "flops", "kernel [us]", "+ entry call [us]", "via dispatcher [us]",
            "public call [us]", "Gflop/s (kernel)"]
    if peak:
        head += ["of peak", "at peak [us]", "kernel / peak time"]
    where = info.get("ghz_source", "the nominal")
    assume = (f"one core's scalar peak taken as 2 flops per cycle at {where} {ghz:.2f} GHz = "
              f"{peak:.2f} Gflop/s (two scalar floating-point operations issued per cycle; Numba "
              "compiles without fastmath, so no fused multiply-adds and no vectorised "
              "arithmetic across the 3-vectors; a core that issues two additions and two "
              "multiplications per cycle, or a turbo clock, would double or raise it)"
              if peak else "the CPU frequency is unknown, so no peak is given")
    t2 = ("Measured against the machine, UR5: the kernel in a compiled loop over 64 states (no "
          "Python, no dispatch), the kernel's compiled entry called from Python with ready "
          "arrays (+ unboxing its arguments: the public call's path), the same kernel "
          "through Numba's dispatcher (+ typing every argument: the path the public call "
          "skips), the public call (entry + the wrapper), and " + assume + ":\n\n"
          + table(head, rows))
    tp, tf = kt[("kernel", "mrnea pass")], kt[("kernel", "mrnea")]
    te, td, ta = kt[("entry", "mrnea")], kt[("direct", "mrnea")], kt[("api", "mrnea")]
    t2 += (f"\n\nWhere the {us(ta)} us of `forward_dynamics(method='mrnea')` go (UR5): "
           f"{us(tp)} us in the mRNEA pass (H and u'), {us(tf - tp)} us in the rest of the "
           f"kernel (tau - u' and the Cholesky solve), {us(te - tf)} us in the call of the "
           f"compiled entry (unboxing the model, three states, the output and the scratch), "
           f"{us(ta - te)} us in the Python wrapper (dtype and ndim checks, the output array). "
           f"Numba's dispatcher would add "
           f"{us(td - te)} us on top of the entry call.")
    return t1 + "\n\n" + t2


# --- 7. start-up ---------------------------------------------------------------------------------

_STARTUP = """
import json, time
t0 = time.perf_counter()
import mrnea
t1 = time.perf_counter()
import numpy as np
robot = mrnea.robots.puma560()
q = np.zeros(robot.n)
t2 = time.perf_counter()
mrnea.forward_dynamics(robot, q, q, q)
t3 = time.perf_counter()
print(json.dumps({"import": t1 - t0, "first_call": t3 - t2}))
"""


def _python(code: str, env: dict) -> tuple[float, str]:
    t0 = time.perf_counter()
    r = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                       check=True)
    return time.perf_counter() - t0, r.stdout


def startup(cfg: Config) -> dict:
    out = {}
    with tempfile.TemporaryDirectory(prefix="mrnea-numba-cache-") as cache:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache}
        for state in ("cold", "cached"):
            wall, stdout = _python(_STARTUP, env)
            out[state] = {**json.loads(stdout), "process": wall}
        for mod in ("numpy", "numba", "mrnea"):
            code = f"import time; t = time.perf_counter(); import {mod}; " \
                   "print(time.perf_counter() - t)"
            out[f"import {mod}"] = min(float(_python(code, env)[1])
                                       for _ in range(cfg.import_repeats))
            out[f"process {mod}"] = min(_python(f"import {mod}", env)[0]
                                        for _ in range(cfg.import_repeats))
        out["process python"] = min(_python("pass", env)[0] for _ in range(cfg.import_repeats))
    print("  start-up done", file=sys.stderr)
    return out


def startup_table(res: dict, cfg: Config) -> str:
    rows = [["first process (empty cache: compiles)", f"{res['cold']['import']:.2f}",
             f"{res['cold']['first_call']:.2f}", f"{res['cold']['process']:.2f}"],
            ["second process (cached kernels)", f"{res['cached']['import']:.2f}",
             f"{res['cached']['first_call']:.3f}", f"{res['cached']['process']:.2f}"]]
    t1 = ("Fresh processes with `NUMBA_CACHE_DIR` set to a new temporary folder (the package's "
          "own cache is not touched): `import mrnea`, then the first `forward_dynamics` call "
          "(Puma 560) [s]:\n\n" + table(["process", "import mrnea", "first call", "whole process"],
                                         rows))
    rows = [[m, f"{res[f'import {m}'] * 1e3:.0f}", f"{res[f'process {m}'] * 1e3:.0f}"]
            for m in ("numpy", "numba", "mrnea")]
    rows.append(["(nothing: `python -c pass`)", "n/a", f"{res['process python'] * 1e3:.0f}"])
    t2 = (f"Import time, best of {cfg.import_repeats} fresh processes [ms] (mrnea imports NumPy "
          "and Numba):\n\n" + table(["module", "import", "whole process"], rows))
    return t1 + "\n\n" + t2


# --- summary and main ----------------------------------------------------------------------------

def summary(per: dict, bat: dict, sim: dict, sup: dict, cases: list[models.Case],
            rt: list[dict]) -> str:
    rows = []
    for c in cases:
        t = per["times"][c.label]
        r = t[("FD", "mrnea.forward_dynamics (mrnea)")] / t[("FD", "pinocchio.aba")]
        arm = c.robot.n in (6, 7)  # the target names 6-7 DoF arms
        rows.append([f"FD per call, {c.label}: mrnea / `pinocchio.aba`", x(r),
                     f"<= {TARGETS['pin_aba']:g}" if arm else "(n = 4: none)",
                     ("yes" if r <= TARGETS["pin_aba"] else "no") if arm else ""])
    for lb, r in bat.items():
        ps = r["per_state"]
        best = min(v for k, v in ps.items() if k[0] == "FD mrnea" and isinstance(k[1], int))
        s = ps[("pin", "aba")] / best
        rows.append([f"batched FD per state, {lb}: loop over `pinocchio.aba` / mrnea", x(s),
                     f">= {TARGETS['batch']:g}", "yes" if s >= TARGETS["batch"] else "no"])
    for lb, r in sim.items():
        pc = r["per_cycle"]
        s = pc["Python loop + Pinocchio"] / pc["simulate(paper, fd=mrnea)"]
        rows.append([f"simulation, {lb}: Python + Pinocchio loop / `simulate`", x(s),
                     f">= {TARGETS['simulate']:g}", "yes" if s >= TARGETS["simulate"] else "no"])
    if rtb:
        t = per["times"]["Puma 560"]
        s = t[("FD", "RTB accel")] / t[("FD", "mrnea.forward_dynamics (mrnea)")]
        rows.append(["Puma 560 per call: RTB `accel` / mrnea FD", x(s), f">= {TARGETS['rtb']:g}",
                     "yes" if s >= TARGETS["rtb"] else "no"])
    if sup.get("cold"):
        first = sup["cold"]["first_call"]
        rows.append(["first call after install (compiles), [s]", f"{first:.1f}",
                     f"<= {TARGETS['compile']:g}", "yes" if first <= TARGETS["compile"] else "no"])
    for r in rt:
        if r["label"].startswith("Puma"):
            rows.append([f"retime, {r['label']}, 400 grid points, median [s]",
                         f"{r['wall']:.3f}", f"< {RETIME_TARGET:g}",
                         "yes" if r["wall"] < RETIME_TARGET else "no"])
    return table(["ratio", "measured", "target", "met"], rows)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="a smoke run of about a minute")
    ap.add_argument("--out", type=Path, help="also write the Markdown tables to this file")
    args = ap.parse_args()
    cfg = QUICK if args.quick else FULL
    t0 = time.perf_counter()
    info = machine()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the Puma's published inertias draw a ModelWarning
        cases = models.cases()
    print(f"mrnea benchmark ({'quick' if args.quick else 'full'}): {info['cpu']}", file=sys.stderr)
    t = time.perf_counter()
    for case in cases:  # compile or load every kernel before anything is timed
        z = np.zeros((2, case.robot.n))
        for m in FD_METHODS:
            forward_dynamics(case.robot, z[0], z[0], z[0], method=m)
            forward_dynamics(case.robot, z, z, z, method=m)
        inverse_dynamics(case.robot, z, z, z)
        mass_matrix_and_bias(case.robot, z, z)
        mass_matrix_and_bias(case.robot, z, z, method="walker_orin")
    warm = time.perf_counter() - t
    print(f"  kernels ready in {warm:.1f} s", file=sys.stderr)

    info = {**info, **{k: v for k, v in machine().items() if k == "threads"}}
    per = per_call(cases, cfg)
    bat = batches(cases, cfg)
    sim = simulation(cases, cfg)
    flops = count_flops(cfg)
    scl = scaling(cfg)
    kt = kernel_times(cases[0], cfg)
    sup = startup(cfg)
    rt = retime_section(cfg.retime_repeats)
    argv = list(sys.argv[1:])
    sections = [
        ("Summary: the issue's targets", summary(per, bat, sim, sup, cases, rt)),
        ("1. Per call, one state", per_call_tables(per, cases)),
        ("2. Per state, batches", batch_table(bat, cfg)),
        ("3. The simulation loop", simulation_table(sim, cfg)),
        ("4. Robotics Toolbox for Python", rtb_table(per)),
        ("5. Scaling with n", scaling_tables(scl, flops)),
        ("6. Flops and the machine's peak", flops_tables(flops, kt, info)),
        ("7. Start-up", startup_table(sup, cfg)),
        ("8. Retiming", retime_table(rt, cfg.retime_repeats)),
    ]
    spread = np.percentile(SPREAD, [50, 90]) - 1.0
    text = header(info, argv, time.perf_counter() - t0) + (
        f" Kernels were loaded or compiled in {warm:.1f} s before timing. Noise: a "
        f"contender's median round was {100 * spread[0]:.0f} % slower than its best round "
        f"(median over the {len(SPREAD)} contenders; 90th percentile {100 * spread[1]:.0f} %)."
        "\n\n")
    text += "\n\n".join(f"### {title}\n\n{body}" for title, body in sections) + "\n"
    print(text)
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(text, encoding="utf-8")


if __name__ == "__main__":
    main()
