"""Per-call forward dynamics with and without external wrenches (issue 25: wrenches on any link).

``mrnea.forward_dynamics`` by the mRNEA, one state, ns of thread CPU time (best of 9 rounds of
timeit's autorange; CPU time keeps the figures meaningful on a loaded machine):

* ``chain_free``: the Puma 560 (built in), no wrench: the fast path, which a wrench on a named
  link must not slow;
* ``chain_tip``: the same with a wrench on the last link (``f_ext`` (6,), ``f_ext_point`` (3,));
* ``tree_free`` / ``tree_links``: ``examples/waist_two_arms.urdf`` without a wrench and with a
  wrench on each hand (``f_ext`` a dict by link name), where this version of mrnea has it.

Run it side by side on two checkouts (the same machine, one after the other)::

    PYTHONPATH=$PWD/src python benchmarks/wrench_fd.py

(docs/performance.md, "Wrenches on named links").
"""

from __future__ import annotations

import json
import time
import timeit
from pathlib import Path

import numpy as np

import mrnea
import mrnea.robots


def per_call(f) -> float:
    """ns per call of f: best of 9 rounds of timeit's autorange, thread CPU time."""
    t = timeit.Timer(f, timer=time.thread_time)
    num, _ = t.autorange()
    return min(t.repeat(9, num)) / num * 1e9


def main() -> None:
    rng = np.random.default_rng(0)
    out = {}
    puma = mrnea.robots.puma560()
    q, qd, tau = (rng.uniform(-1, 1, puma.n) for _ in range(3))
    fe, pe = rng.uniform(-5, 5, 6), np.array([0.0, 0.0, 0.1])
    out["chain_free"] = per_call(lambda: mrnea.forward_dynamics(puma, q, qd, tau))
    out["chain_tip"] = per_call(lambda: mrnea.forward_dynamics(puma, q, qd, tau, fe, pe))
    tree = mrnea.load_robot(str(Path(__file__).parents[1] / "examples" / "waist_two_arms.urdf"))
    q, qd, tau = (rng.uniform(-1, 1, tree.n) for _ in range(3))
    out["tree_free"] = per_call(lambda: mrnea.forward_dynamics(tree, q, qd, tau))
    links = {"hand_l": fe, "hand_r": -fe}
    points = {"hand_l": pe, "hand_r": pe}
    try:
        mrnea.forward_dynamics(tree, q, qd, tau, links, points)
    except (TypeError, ValueError):
        pass  # a version without wrenches on named links
    else:
        out["tree_links"] = per_call(
            lambda: mrnea.forward_dynamics(tree, q, qd, tau, links, points))
    print(json.dumps({k: round(v) for k, v in out.items()}, indent=1))


if __name__ == "__main__":
    main()
