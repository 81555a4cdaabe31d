"""Long runs keep their data and their memory in bounds (slow: about a minute or two)."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

SCRIPT = textwrap.dedent("""
    import resource, sys
    import numpy as np
    import mrnea
    from mrnea.robots.sdt_profile import training_profile
    from mrnea.simulate import simulate

    K = int(sys.argv[1])
    robot = mrnea.robots.sdt()
    dt = 0.005
    _, prof = training_profile(dt)  # 8401 cycles, repeated: planetary keeps turning
    reps = -(-K // prof.shape[0])
    q_cmd = np.concatenate([prof + [r * prof[-1, 0], 0, 0, 0] for r in range(reps)])[:K]
    simulate(robot, q_cmd[:10], dt)  # load the compiled kernels before measuring
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    res = simulate(robot, q_cmd, dt)
    after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    arrays = sum(a.nbytes for a in vars(res).values() if isinstance(a, np.ndarray))
    print(res.K, res.completed, arrays, (after - before) * 1024)
""")


@pytest.mark.slow
def test_a_million_cycles_in_bounded_memory():
    """10^6 cycles of the SDT (83 min of training at 5 ms). Streaming the table to disk is
    tested at smaller K in test_simulate.py (a million rows of CSV is about 1 GB)."""
    K = 1_000_000
    proc = subprocess.run([sys.executable, "-c", SCRIPT, str(K)], capture_output=True,
                          text=True, timeout=1200)
    assert proc.returncode == 0, proc.stderr
    k, completed, arrays, growth = proc.stdout.split()
    assert int(k) == K and completed == "True"
    # the peak resident memory grows by the result arrays (and the program and its velocity,
    # and the per-cycle wrench buffers), not by anything per cycle on top
    assert int(growth) < 1.5 * int(arrays) + 200e6, (growth, arrays)
