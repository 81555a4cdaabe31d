"""Regenerate the simulated identification logs of the Puma 560 shipped in examples/ (issue 28).

A known robot, the truth, is simulated by mrnea (``mrnea.simulate``: the drive law with friction
and rotor inertia, cycle by cycle) along Fourier trajectories, and its log is written as a real
robot's would be: positions quantised by the encoder, efforts with Gaussian noise.

* The truth (``puma_identify_truth.toml``, a native robot file): the built-in Puma 560 with its
  links changed (masses x 1.1, centres of mass moved by (10, -5, 8) mm, inertias about the centre
  of mass x 1.2, plus the smallest isotropic term that makes each a rigid body with the triangle
  inequality, plus 1e-4 kg m^2) and its drives changed (viscous friction x 1.3, Coulomb friction
  asymmetric: x 1.2 moving up, x 0.8 moving down, rotor inertia x 0.9). The prior that
  ``mrnea identify`` starts from is the unchanged ``puma560``.
* The motion: a finite Fourier series per joint (5 harmonics of 0.1 Hz, at rest at the start,
  random coefficients of a fixed seed, about the middle of the joint's range), commanded to the
  truth and simulated at a 1 ms cycle: ``puma_identify_log.csv`` (20 s, two periods) and, on
  another trajectory, ``puma_identify_validate.csv`` (10 s).
* The log, at 100 Hz (every 10th cycle): ``time [s]``, the positions the simulation made,
  rounded to 1e-5 rad (the encoder), and the joint-side efforts the drives applied plus Gaussian
  noise of 0.5 % of each joint's largest effort (``tau_<joint> [N m]``, read_log's columns).
  Why a 1 ms cycle: a cycle's effort goes with the velocity held over the cycle before it, half a
  cycle behind the central difference of the positions; that delay d biases the identified
  reflected rotor inertia by -F_v d (docs/identification.md). At 1 ms it is a tenth of a
  standard error.

Run: ``python examples/puma_identify.py [--out DIR] [--force]`` (a few seconds once the kernels
are compiled), then

    mrnea identify puma560 examples/puma_identify_log.csv --validate \
        examples/puma_identify_validate.csv --out puma-identified
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import mrnea
from mrnea.identify.fourier import coefficients, evaluate
from mrnea.identify.log import log_columns
from mrnea.io.writer import check_new, create
from mrnea.model import Link, Robot
from mrnea.simulate import SimulationResult

HERE = Path(__file__).resolve().parent
RATE = 100.0  # [Hz] the log's sample rate
CYCLE = 0.001  # [s] the simulation's (the controller's) cycle: the log keeps every 10th
BASE_FREQUENCY, HARMONICS = 0.1, 5  # [Hz], of the Fourier trajectories
QUANTUM = 1e-5  # [rad] the encoder's resolution
NOISE = 0.005  # the efforts' noise, a fraction of each joint's largest effort
COM_SHIFT = np.array([0.010, -0.005, 0.008])  # [m]
FILES = ("puma_identify_truth.toml", "puma_identify_log.csv", "puma_identify_validate.csv")


def changed_links(prior: Robot) -> tuple[Link, ...]:
    """The prior's links changed as the truth's are (module docstring): masses x 1.1, centres of
    mass moved by COM_SHIFT, inertias about the centre of mass x 1.2 plus the smallest
    isotropic term that makes each a rigid body, plus 1e-4 kg m^2."""
    links = []
    for lk in prior.links:
        inertia = 1.2 * np.asarray(lk.inertia)
        e = np.linalg.eigvalsh(inertia)
        inertia = inertia + (max(0.0, e[2] - e[0] - e[1]) + 1e-4) * np.eye(3)
        links.append(Link(lk.name, 1.1 * lk.mass, np.asarray(lk.com) + COM_SHIFT, inertia,
                          lk.visuals))
    return tuple(links)


def truth_robot(prior: Robot) -> Robot:
    """The known robot the logs are simulated from (module docstring)."""
    return prior._replace(links=changed_links(prior), name="puma560_truth").with_actuators(
        viscous_friction=1.3 * prior.viscous_friction,
        coulomb_friction=[(1.2 * p, 0.8 * m) for p, m in prior.coulomb_friction],
        rotor_inertia=0.9 * prior.rotor_inertia)


def fourier_motion(robot: Robot, seed: int, duration: float) -> np.ndarray:
    """q_cmd (K, n) [rad] every CYCLE for ``duration`` [s]: the Fourier trajectory of ``seed``."""
    rng = np.random.default_rng(seed)
    free = rng.normal(0.0, 0.03, size=(robot.n, 1 + 2 * (HARMONICS - 1)))
    free[:, 0] = (robot.lower + robot.upper) / 2 + rng.uniform(-0.3, 0.3, robot.n)
    c, a, b = coefficients(free, robot.n, HARMONICS)
    t = np.arange(round(duration / CYCLE)) * CYCLE
    return evaluate(c, a, b, BASE_FREQUENCY, t)[0]


def logged(res: SimulationResult, rng: np.random.Generator) -> tuple[np.ndarray, ...]:
    """What the log of a run at CYCLE keeps (module docstring): t [s], q [rad] rounded to
    QUANTUM, tau [N m] plus Gaussian noise, every RATE-th of a second; and that noise's standard
    deviation per joint (NOISE x the joint's largest effort) [N m]."""
    every = round(1.0 / (RATE * CYCLE))
    t, q, tau = res.t[::every], res.q[::every], res.tau[::every]
    noise = NOISE * np.abs(tau).max(axis=0)
    return (t, np.round(q / QUANTUM) * QUANTUM, tau + rng.normal(size=tau.shape) * noise,
            noise)


def write_log(path: Path, truth: Robot, seed: int, duration: float, force: bool) -> None:
    """Simulate the truth along the trajectory of ``seed`` and write its noisy log."""
    res = mrnea.simulate(truth, fourier_motion(truth, seed, duration), CYCLE, reactions=False)
    if not res.achievable:
        raise SystemExit(f"{path.name}: the truth cannot follow its trajectory: {res.verdict()}")
    t, q, tau, _ = logged(res, np.random.default_rng(1000 + seed))
    with create(path, force) as fh:
        fh.write(",".join(log_columns(truth)) + "\n")
        for k in range(t.size):
            fh.write(f"{t[k]:.2f}," + ",".join(f"{x:.5f}" for x in q[k]) + ","
                     + ",".join(f"{x:.6g}" for x in tau[k]) + "\n")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=HERE, help="where to write (default: examples/)")
    ap.add_argument("--force", action="store_true", help="replace the files")
    args = ap.parse_args()
    check_new([args.out / f for f in FILES], args.force)
    truth = truth_robot(mrnea.robots.puma560())
    truth.to_toml(args.out / FILES[0], overwrite=args.force)
    write_log(args.out / FILES[1], truth, 1, 20.0, args.force)
    write_log(args.out / FILES[2], truth, 2, 10.0, args.force)
    print("wrote " + ", ".join(str(args.out / f) for f in FILES))


if __name__ == "__main__":
    main()
