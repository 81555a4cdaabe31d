"""Session 38's changes (issue 22: a first ``mrnea excite`` in seconds).

The excitation search runs its small SVDs with the BLAS libraries on one thread (threadpoolctl's
own report, read inside the search through its checkpoint), and the limit ends with the call.
"""

from __future__ import annotations

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
