"""Shared test helpers: random chains, the Pinocchio twin of a Robot, example-robot-data files.

* :func:`random_chain` builds a random, physically consistent serial :class:`mrnea.Robot`.
* :func:`random_states` draws random (q, qd, qdd/tau, f_ext, f_ext_point) batches.
* :func:`to_pinocchio` builds the same chain as a ``pinocchio.Model``; :class:`PinChain` wraps a
  Pinocchio model (built by :func:`to_pinocchio` or from a URDF) with our joint order and
  conventions, so that tests compare like with like; :func:`pin_fext` converts our external wrench.
* :func:`erd_path` locates an example-robot-data file (skipping the test if it is missing).
* :func:`rel_err` is the error measure every comparison uses.

Hypothesis runs derandomized (profile ``mrnea``, selected unless ``HYPOTHESIS_PROFILE`` is set),
so the suite is deterministic in CI.
"""

from __future__ import annotations

import json
import os
import site
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

import mrnea
from mrnea.model import Joint, Link, Robot

try:
    from hypothesis import HealthCheck, settings

    settings.register_profile(
        "mrnea",
        derandomize=True,
        deadline=None,
        print_blob=True,
        suppress_health_check=[HealthCheck.too_slow],
    )
    settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "mrnea"))
except ImportError:  # pragma: no cover - hypothesis is a test dependency
    pass


# --- error measure --------------------------------------------------------------------------------
def rel_err(a, b) -> float:
    """``max|a - b| / max(1, max|b|)``: the largest absolute deviation of ``a`` from the reference
    ``b``, relative to the largest entry of ``b`` when that exceeds 1 and absolute below (so that
    entries near zero, e.g. a torque of 1e-17 N m, are not judged relatively)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    assert a.shape == b.shape, f"shapes differ: {a.shape} vs {b.shape}"
    if a.size == 0:
        return 0.0
    return float(np.max(np.abs(a - b)) / max(1.0, float(np.max(np.abs(b)))))


# --- random robots and states ---------------------------------------------------------------------
def random_rotation(rng: np.random.Generator) -> np.ndarray:
    """A uniformly random rotation matrix (QR of a Gaussian matrix, sign-fixed)."""
    Q, R = np.linalg.qr(rng.normal(size=(3, 3)))
    Q = Q * np.sign(np.diag(R))
    if np.linalg.det(Q) < 0:
        Q[:, 0] = -Q[:, 0]
    return Q


def random_inertia(rng: np.random.Generator, mass: float) -> np.ndarray:
    """Inertia about the centre of mass of a solid ellipsoid (semi-axes 0.05-0.4 m) of ``mass``,
    randomly oriented: symmetric positive definite and physically consistent."""
    a, b, c = rng.uniform(0.05, 0.4, size=3)
    principal = mass / 5.0 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])
    R = random_rotation(rng)
    Iner = R @ np.diag(principal) @ R.T
    return 0.5 * (Iner + Iner.T)


def random_chain(
    rng: np.random.Generator,
    n: int,
    prismatic_fraction: float = 0.3,
    gravity=(0.0, 0.0, -9.81),
) -> Robot:
    """A random serial chain of ``n`` joints: random joint origins (translation up to 0.5 m per
    axis, random rotation), random unit axes, each joint prismatic with probability
    ``prismatic_fraction``, masses 0.5-5 kg, centres of mass within ~0.2 m of the link frame, and
    positive-definite, physically consistent inertias."""
    joints, links = [], []
    parent = "base"
    for i in range(n):
        typ = "prismatic" if rng.random() < prismatic_fraction else "revolute"
        origin = np.eye(4)
        origin[:3, :3] = random_rotation(rng)
        origin[:3, 3] = rng.uniform(-0.5, 0.5, size=3)
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        mass = float(rng.uniform(0.5, 5.0))
        joints.append(Joint(f"j{i}", typ, parent, f"l{i}", origin=origin, axis=axis))
        links.append(Link(f"l{i}", mass=mass, com=rng.uniform(-0.2, 0.2, size=3),
                          inertia=random_inertia(rng, mass)))
        parent = f"l{i}"
    return Robot(joints, links, gravity=gravity, name=f"random{n}")


def random_states(rng: np.random.Generator, robot: Robot, B: int | None = None) -> dict:
    """Random q (revolute: [-pi, pi] rad, prismatic: [-0.5, 0.5] m), qd, qdd, tau, f_ext [N, N m]
    and f_ext_point [m]; each (n,) / (6,) / (3,) if ``B`` is None, else with a leading B axis."""
    shape = () if B is None else (B,)
    n = robot.n
    pris = robot.is_prismatic
    q = np.where(pris, rng.uniform(-0.5, 0.5, size=(*shape, n)),
                 rng.uniform(-np.pi, np.pi, size=(*shape, n)))
    return {
        "q": q,
        "qd": rng.normal(0.0, 2.0, size=(*shape, n)),
        "qdd": rng.normal(0.0, 3.0, size=(*shape, n)),
        "tau": rng.normal(0.0, 20.0, size=(*shape, n)),
        "f_ext": rng.normal(0.0, 10.0, size=(*shape, 6)),
        "f_ext_point": rng.normal(0.0, 0.2, size=(*shape, 3)),
    }


# --- example-robot-data ---------------------------------------------------------------------------
def robots_dir() -> Path | None:
    """example-robot-data's ``robots`` directory (installed by the ``example-robot-data`` wheel)."""
    for sp in [*site.getsitepackages(), site.getusersitepackages()]:
        d = Path(sp) / "cmeel.prefix" / "share" / "example-robot-data" / "robots"
        if d.is_dir():
            return d
    return None


def erd_path(rel: str) -> Path:
    """Path of an example-robot-data file, e.g. ``ur_description/urdf/ur5_robot.urdf``; skips the
    calling test if the package or the file is not installed."""
    d = robots_dir()
    if d is None or not (d / rel).is_file():
        pytest.skip(f"example-robot-data file {rel} is not installed")
    return d / rel


# --- Pinocchio ------------------------------------------------------------------------------------
def to_pinocchio(robot: Robot):
    """The Pinocchio model of ``robot`` (a chain or a tree): joint i+1 is our joint i
    (RevoluteUnaligned or PrismaticUnaligned about our axis), child of joint parents[i] + 1,
    placed at our joint origin; the body of joint i+1 is our
    link i (its frame is the joint frame moved by the joint); same gravity."""
    import pinocchio as pin

    model = pin.Model()
    model.name = robot.name
    for j, lk, p in zip(robot.joints, robot.links, robot.parents, strict=True):
        axis = np.array(j.axis, dtype=float)
        jm = (pin.JointModelPrismaticUnaligned(axis) if j.is_prismatic
              else pin.JointModelRevoluteUnaligned(axis))
        origin = np.asarray(j.origin)
        # Pinocchio's joint id k + 1 is our joint k; its parent, our parents[k] + 1 (0: universe)
        jid = model.addJoint(p + 1, jm, pin.SE3(origin[:3, :3].copy(), origin[:3, 3].copy()),
                             j.name)
        model.appendBodyToJoint(
            jid,
            pin.Inertia(float(lk.mass), np.array(lk.com, dtype=float),
                        np.array(lk.inertia, dtype=float)),
            pin.SE3.Identity(),
        )
    model.gravity = pin.Motion(np.concatenate([np.asarray(robot.gravity, dtype=float),
                                               np.zeros(3)]))
    return model


def _link_rotation(robot: Robot, q) -> np.ndarray:
    """Orientation of the last link in the base frame (plain 4x4 composition along its path
    from the base, ``robot.parents``; tests/naive.py's joint motion)."""
    from naive import motion

    path, k = [], robot.n - 1
    while k >= 0:
        path.append(k)
        k = robot.parents[k]
    T = np.eye(4)
    for k in reversed(path):
        T = T @ np.asarray(robot.joints[k].origin) @ motion(robot.joints[k], float(q[k]))
    return T[:3, :3]


def pin_fext(robot: Robot, model, q, f_ext, f_ext_point=None) -> list:
    """Our external wrench as Pinocchio's ``fext`` list (one ``pin.Force`` per joint of ``model``).

    Ours: ``f_ext = [f_e; n_e]``, base coordinates, the wrench the last link exerts ON the
    environment, at ``f_ext_point`` (last link's frame). Pinocchio's: the force applied TO each
    body, in its joint's local frame (the frame after the joint motion: our link frame), about
    the joint origin. So the last joint receives ``-[R^T f_e; R^T n_e + p_e x R^T f_e]``.
    ``model`` is needed for the number of joints and the id of our last joint.
    """
    import pinocchio as pin

    out = [pin.Force.Zero() for _ in range(model.njoints)]
    if f_ext is None:
        return out
    fe = np.asarray(f_ext, dtype=float)
    pe = np.zeros(3) if f_ext_point is None else np.asarray(f_ext_point, dtype=float)
    R = _link_rotation(robot, q)
    f_loc, n_loc = R.T @ fe[:3], R.T @ fe[3:]
    out[model.getJointId(robot.joint_names[-1])] = pin.Force(-f_loc, -(n_loc + np.cross(pe, f_loc)))
    return out


class PinChain:
    """A Pinocchio model seen through our joint order and conventions.

    ``model``'s joints must be exactly ours (matched by name; ``nv == robot.n``), possibly in
    another order, continuous joints possibly stored as (cos, sin) (``nq != nv``). Methods take
    and return our quantities, in our joint order: q, qd, qdd, tau (n,), H (n, n).
    """

    def __init__(self, robot: Robot, model) -> None:
        import pinocchio as pin

        self.pin = pin
        self.robot, self.model, self.data = robot, model, model.createData()
        assert model.nv == robot.n, f"Pinocchio nv={model.nv}, robot n={robot.n}"
        self.ids = [model.getJointId(name) for name in robot.joint_names]
        assert all(0 < i < model.njoints for i in self.ids), "joint names differ"
        self.joints = [model.joints[i] for i in self.ids]
        self.iv = np.array([jm.idx_v for jm in self.joints])

    def config(self, q) -> np.ndarray:
        """Pinocchio's configuration vector of our q: (cos, sin) for an unbounded joint."""
        conf = self.pin.neutral(self.model)
        for jm, qi in zip(self.joints, np.asarray(q, dtype=float), strict=True):
            if jm.nq == 2:
                conf[jm.idx_q:jm.idx_q + 2] = (np.cos(qi), np.sin(qi))
            else:
                assert jm.nq == 1
                conf[jm.idx_q] = qi
        return conf

    def vel(self, x) -> np.ndarray:
        """Our (n,) joint-rate-like vector in Pinocchio's velocity order."""
        out = np.zeros(self.model.nv)
        out[self.iv] = x
        return out

    def ours(self, y) -> np.ndarray:
        """Pinocchio's velocity-ordered vector in our joint order."""
        return np.asarray(y)[self.iv].copy()

    def fext(self, q, f_ext, f_ext_point):
        return pin_fext(self.robot, self.model, q, f_ext, f_ext_point)

    def rnea(self, q, qd, qdd, f_ext=None, f_ext_point=None) -> np.ndarray:
        args = [self.model, self.data, self.config(q), self.vel(qd), self.vel(qdd)]
        if f_ext is not None:
            args.append(self.fext(q, f_ext, f_ext_point))
        return self.ours(self.pin.rnea(*args))

    def mass_matrix(self, q) -> np.ndarray:
        """pin.crba (which fills the upper triangle), symmetrized, in our order."""
        M = np.array(self.pin.crba(self.model, self.data, self.config(q)))
        M = np.triu(M) + np.triu(M, 1).T
        return M[np.ix_(self.iv, self.iv)]

    def bias(self, q, qd, f_ext=None, f_ext_point=None) -> np.ndarray:
        """pin.nonLinearEffects without an external wrench, else rnea(q, qd, 0, fext)."""
        if f_ext is None:
            return self.ours(self.pin.nonLinearEffects(self.model, self.data, self.config(q),
                                                       self.vel(qd)))
        return self.rnea(q, qd, np.zeros(self.robot.n), f_ext, f_ext_point)

    def aba(self, q, qd, tau, f_ext=None, f_ext_point=None) -> np.ndarray:
        args = [self.model, self.data, self.config(q), self.vel(qd), self.vel(tau)]
        if f_ext is not None:
            args.append(self.fext(q, f_ext, f_ext_point))
        return self.ours(self.pin.aba(*args))

    def reactions(self, q, qd, qdd, f_ext=None, f_ext_point=None) -> np.ndarray:
        """(n, 6) joint reactions in our convention, from Pinocchio's ``data.f`` after rnea.

        ``data.f[i]`` is the spatial force [f; n] the parent exerts on the subtree of joint i,
        in joint i's local frame (after the joint motion: our link frame), the moment about its
        origin. Ours is in the joint frame before the motion, about that frame's origin:
        revolute: rotate by the joint rotation ``Rot(axis, q)`` (the origins coincide);
        prismatic: same orientation, origin shifted back by ``q axis``, so the moment about our
        origin is ``n + (q axis) x f``.
        """
        from naive import axis_angle

        self.rnea(q, qd, qdd, f_ext, f_ext_point)
        out = np.zeros((self.robot.n, 6))
        for k, (j, jid, qk) in enumerate(zip(self.robot.joints, self.ids,
                                             np.asarray(q, dtype=float), strict=True)):
            F = self.data.f[jid]
            f, m = np.array(F.linear), np.array(F.angular)
            axis = np.asarray(j.axis, dtype=float)
            if j.is_prismatic:
                out[k] = np.concatenate([f, m + np.cross(qk * axis, f)])
            else:
                Rq = axis_angle(axis, qk)
                out[k] = np.concatenate([Rq @ f, Rq @ m])
        return out


def sines_trajectory(robot: Robot) -> tuple[np.ndarray, ...]:
    """t, q, qd, qdd [s, rad, rad/s, rad/s^2] of a 10 s sum of sines about the middle of each
    joint's range (amplitude 0.4 rad, 0.1-0.27 Hz), sampled every 20 ms: the other trajectory an
    identified robot's efforts are predicted on, in closed form."""
    t = np.arange(0.0, 10.0, 0.02)
    w = 2 * np.pi * np.array([0.1, 0.13, 0.17, 0.21, 0.23, 0.27, 0.31])[:robot.n]
    q = (robot.lower + robot.upper) / 2 + 0.4 * np.sin(np.outer(t, w))
    return t, q, 0.4 * w * np.cos(np.outer(t, w)), -0.4 * w ** 2 * np.sin(np.outer(t, w))


def pinocchio_base_condition(pc: PinChain, robot: Robot, q, qd, qdd) -> float:
    """The condition number of the column-scaled base regressor stacked over the rows of (q, qd,
    qdd): Pinocchio's ``computeJointTorqueRegressor`` (link columns in mrnea's order) beside the
    drive columns written out here (G^2 J_m qdd, F_v qd, F+ [qd > 0], -F- [qd < 0], offset),
    the base columns chosen by :func:`mrnea.identify.base.base_parameters` (the independent
    check of what ``mrnea.excitation`` and ``identify`` report)."""
    import pinocchio as pin

    from mrnea.identify.base import base_parameters

    n = robot.n
    blocks = np.concatenate([np.arange(10 * (i - 1), 10 * i) for i in pc.ids])
    rows = []
    for k in range(q.shape[0]):
        Y = np.asarray(pin.computeJointTorqueRegressor(pc.model, pc.data, pc.config(q[k]),
                                                       pc.vel(qd[k]), pc.vel(qdd[k])))
        drive = np.zeros((n, 5 * n))
        for j in range(n):
            v = qd[k, j]
            drive[j, 5 * j:5 * j + 5] = [qdd[k, j], v, float(v > 0), -float(v < 0), 1.0]
        rows.append(np.hstack([Y[pc.iv][:, blocks], drive]))
    W = np.vstack(rows)[:, base_parameters(robot).columns]
    return float(np.linalg.cond(W / np.linalg.norm(W, axis=0)))


def pin_from_urdf(path: Path, robot: Robot):
    """Pinocchio's model of a URDF, reduced to ``robot``'s joints: every other moving joint is
    locked at its neutral position (q = 0), as :func:`mrnea.load_urdf` freezes it."""
    import pinocchio as pin

    full = pin.buildModelFromUrdf(str(path))
    keep = set(robot.joint_names)
    locked = [i for i in range(1, full.njoints) if full.names[i] not in keep]
    model = pin.buildReducedModel(full, locked, pin.neutral(full)) if locked else full
    model.gravity = pin.Motion(np.concatenate([np.asarray(robot.gravity, dtype=float),
                                               np.zeros(3)]))
    return model


# --- a Dask cluster in processes of its own (the sweep's tests) ----------------------------------

def mrnea_cli(*args: str | Path, cwd: Path | None = None,
              timeout: float = 600) -> subprocess.CompletedProcess:
    """``python -m mrnea ARGS`` as a real process in ``cwd``, the environment (PYTHONPATH)
    kept; ``timeout`` [s] is the hang guard."""
    return subprocess.run([sys.executable, "-m", "mrnea", *map(str, args)], cwd=cwd,
                          capture_output=True, text=True, timeout=timeout)


def one_error_line(res: subprocess.CompletedProcess, *words: str) -> str:
    """Exit code 2 and exactly one ``mrnea: error:`` line on stderr, naming ``words``; no
    traceback, no MemoryError. Returns the line."""
    assert res.returncode == 2, (res.returncode, res.stdout, res.stderr)
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("mrnea: error: "), res.stderr
    for w in words:
        assert w in lines[0], (w, lines[0])
    assert "Traceback" not in res.stderr and "MemoryError" not in res.stderr
    return lines[0]

def environment(**extra: str) -> dict[str, str]:
    """The environment of a subprocess that must import the mrnea under test, from any
    folder."""
    src = str(Path(mrnea.__file__).resolve().parents[1])
    return {**os.environ, "PYTHONPATH": os.pathsep.join([src, os.environ.get("PYTHONPATH", "")]),
            **extra}


@pytest.fixture(scope="session")
def demo_run(tmp_path_factory) -> tuple[subprocess.CompletedProcess, Path]:
    """``mrnea demo --out DIR --no-3d`` run once as a real process for the session (the full
    demo: 8401 cycles, every file): (the process, DIR). Tests read its output and must not
    change DIR (copy it first)."""
    out = tmp_path_factory.mktemp("demo_run") / "d"
    return mrnea_cli("demo", "--out", out, "--no-3d"), out


@pytest.fixture(scope="session")
def scheduler_address(tmp_path_factory):
    """A scheduler and one single-threaded worker, each a process of its own (as a real
    cluster's are), started from the command line; the tests reach it through its address."""
    folder = tmp_path_factory.mktemp("dask")
    info = folder / "scheduler.json"
    log = open(folder / "cluster.log", "w")
    common = {"stdout": log, "stderr": subprocess.STDOUT, "cwd": folder, "env": environment()}
    procs = [subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler",
                               "--scheduler-file", str(info), "--host", "127.0.0.1",
                               "--port", "0", "--no-dashboard"], **common)]
    try:
        deadline = time.monotonic() + 120
        while not info.exists() and time.monotonic() < deadline:
            time.sleep(0.1)
        address = json.loads(info.read_text())["address"]
        procs.append(subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker",
                                       "--scheduler-file", str(info), "--nworkers", "1",
                                       "--nthreads", "1", "--no-dashboard"], **common))
        from distributed import Client

        with Client(address, timeout="60s") as c:
            c.wait_for_workers(1, timeout=120)
        yield address
    finally:
        for p in reversed(procs):
            p.terminate()
            p.wait(timeout=60)
        log.close()


# --- pages in headless Chromium (tests/chromium_cdp.py) ------------------------------------------

@contextmanager
def chromium(width: int, height: int = 1000, extra_flags: tuple[str, ...] = ()) -> Iterator:
    """A headless Chromium window of ``width`` x ``height`` CSS px (``extra_flags`` on its
    command line); skips the test, saying why, only where no Chromium can be started."""
    from chromium_cdp import Browser, ChromiumUnavailable

    try:
        b = Browser(width=width, height=height, extra_flags=extra_flags)
    except ChromiumUnavailable as exc:
        pytest.skip(f"no Chromium for the browser tests: {exc}")
    with b:
        yield b


def open_report(browser, url: str):
    """The report at ``url`` opened in ``browser``, its 3D view ready (asserts WebGL) and two
    frames drawn; the page."""
    page = browser.open(url)
    assert page.evaluate("mrneaView3d.ready.then(a => a !== null)"), "no WebGL in Chromium"
    page.next_frames(2)
    return page


def time_marker(page, figure: str) -> tuple[float, float, float]:
    """On the report figure whose id ends in ``-figure``: where the 3D view's time line is
    drawn, where its first time axes (``data-xaxes``) puts the view's time (both CSS px from
    the image's left edge), and that time [s]."""
    return tuple(page.evaluate(f"""(async () => {{
  const fig = document.querySelector("figure[id$='-{figure}']");
  const img = fig.querySelector('img'), line = fig.querySelector('.mv3d-tline');
  const [x0, x1, , , a, b] = JSON.parse(fig.dataset.xaxes)[0];
  const t = await mrneaView3d.time();
  const want = (x0 + (t - a) / (b - a) * (x1 - x0)) * img.clientWidth;
  return [line.getBoundingClientRect().left - img.getBoundingClientRect().left + 1, want, t];
}})()"""))


def figure_scales(page) -> list[float]:
    """Per ``<figure>`` image of the page: its drawn width over its own pixel width (1: drawn
    at its own size; below 0.7 a report figure's text is unreadable)."""
    return page.evaluate("[...document.querySelectorAll('figure img')].map("
                         "i => i.getBoundingClientRect().width / i.naturalWidth)")


# A fresh process's record of what Numba compiles: every compile's (qualified name, argument
# types), from Numba's own "numba:compile" events, printed on one "COMPILED " line. Prefix a
# script with COMPILE_LISTENER and end it with COMPILE_REPORT; CLI_COMPILES runs the command line
# given as the script's arguments (`python -c CLI_COMPILES demo --out X`).
COMPILE_LISTENER = r"""
import json, sys
from numba.core import event
names = []
class Record(event.Listener):
    def on_start(self, ev):
        pass
    def on_end(self, ev):
        d = ev.data or {}
        f = getattr(d.get("dispatcher"), "py_func", None)
        names.append([getattr(f, "__qualname__", "?"), str(d.get("args"))])
"""
COMPILE_REPORT = 'print("COMPILED " + json.dumps(names))\n'
CLI_COMPILES = COMPILE_LISTENER + r"""
event.register("numba:compile", Record())
from mrnea.cli import main
try:
    main(sys.argv[1:], standalone_mode=True)
except SystemExit:
    pass
""" + COMPILE_REPORT


def compiled_kernels(stdout: str) -> list[tuple[str, str]]:
    """The (qualified name, argument types) of every compile a COMPILE_LISTENER script
    printed."""
    line = next(x for x in stdout.splitlines() if x.startswith("COMPILED "))
    return [tuple(k) for k in json.loads(line[len("COMPILED "):])]


def stop_requested_at(monkeypatch, owner: object, name: str, before: bool = False) -> None:
    """Replace ``owner.name`` by a wrapper that requests a stop (what SIGINT or SIGTERM sets:
    ``mrnea.cli.base._request_stop``) just after the call returns, or just before it
    (``before``): a stop request placed at that moment of a command, in process."""
    from mrnea.cli import base

    real = getattr(owner, name)

    def wrapped(*args, **kw):
        if before:
            base._request_stop(15, None)
        out = real(*args, **kw)
        if not before:
            base._request_stop(15, None)
        return out

    monkeypatch.setattr(owner, name, wrapped)
