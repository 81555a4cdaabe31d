"""The single-state entries' arguments as the loops' types: one compiled pass for every caller.

The public API's fast path (mrnea.dynamics ``_Entry``) calls an entry (``rnea``, ``mrnea``,
``fd_mrnea``, ``reactions``) with the caller's own arrays, typed layout ``A`` (any 1-D float64
array: checking C-contiguity in Python costs about 60 ns an array, a twentieth of a call), and
``fext = pe = None`` when there is no wrench (two arrays fewer to unbox). The batch kernels and
the simulation loop call the passes below the entries (``rnea_ws``, ``mrnea_ws``,
``reactions_ws``) on rows of C arrays and always with a wrench and its point. Numba compiles a
callee once per signature, so the entries compiled a second copy of every pass under them
(the kinematics, ``link_forces``, ``newton_euler``, the mRNEA pass: about 10 s of a first run,
docs/performance.md section 7). Here the entry hands its callee exactly the loops' types:

* :func:`contiguous` checks, in compiled code, that a state array's one stride is its item
  size (a few instructions); the entry returns the status ``LAYOUT`` otherwise, and the wrapper
  takes its validated path, which makes C-contiguous copies (mrnea.validate.array);
* :func:`loop_args` then retypes the arrays as layout ``C`` (the same memory, the same array
  structure: Numba's layouts share one data model; only the type changes), and gives ``None``
  the zero wrench at the last link's origin, which the loops pass for "no wrench"
  (mrnea.validate ``_ZERO_WRENCH``): two constant arrays compiled into the entry, retyped as
  the loops' writable C rows (the passes never write their inputs).

A zero wrench adds exact zeros to the last link's force and moment: the results are those of
the batch and the loop, bit for bit, for the same state.
Under NUMBA_DISABLE_JIT the Python bodies run: the identity, and NumPy's zero arrays.
"""

from __future__ import annotations

import numpy as np
from numba.core import types
from numba.core.imputils import impl_ret_borrowed
from numba.extending import intrinsic, overload

ZERO_WRENCH = np.zeros(6)  # [f; n] of "no wrench" [N, N m]; read only by the passes
ZERO_POINT = np.zeros(3)  # its point [m], the last link's origin
ZERO_WRENCH.setflags(write=False)
ZERO_POINT.setflags(write=False)


def contiguous(a):
    """Whether the array ``a`` can be read as a C array: a 1-D array whose stride is its item
    size; an array typed ``C`` (the wrappers' own), and None, always."""
    return a is None or a.ndim != 1 or a.strides[0] == a.itemsize


def loop_args(q, qd, qdd, fext, pe):
    """The entry's state arrays and wrench as the loops' types (module docstring): each array
    retyped as a writable C array (compiled code; the caller has checked :func:`contiguous`),
    ``qdd`` None kept (the mRNEA takes none), ``fext = pe = None`` as :data:`ZERO_WRENCH` and
    :data:`ZERO_POINT` (the entries pass both or neither). Returns ``(q, qd, qdd, fext, pe)``:
    a tuple, as a kernel without Numba's runtime may return no new array."""
    if fext is None:
        return q, qd, qdd, ZERO_WRENCH, ZERO_POINT
    return q, qd, qdd, fext, pe


@intrinsic
def _c(typingctx, a):
    """``a`` typed as a writable C array (None stays None): the array structure unchanged."""
    if isinstance(a, types.NoneType):
        return a(a), lambda context, builder, sig, args: context.get_dummy_value()
    to = types.Array(a.dtype, a.ndim, "C")

    def codegen(context, builder, sig, args):
        # one data model for every layout; a new reference where the caller counts them
        return impl_ret_borrowed(context, builder, sig.return_type, args[0])

    return to(a), codegen


@overload(contiguous, inline="always")
def _contiguous(a):
    if isinstance(a, types.NoneType) or (isinstance(a, types.Array)
                                         and (a.layout == "C" or a.ndim != 1)):
        return lambda a: True
    return lambda a: a.strides[0] == a.itemsize


@overload(loop_args, inline="always")
def _loop_args(q, qd, qdd, fext, pe):
    if isinstance(fext, types.NoneType):
        return lambda q, qd, qdd, fext, pe: (_c(q), _c(qd), _c(qdd), _c(ZERO_WRENCH),
                                             _c(ZERO_POINT))
    return lambda q, qd, qdd, fext, pe: (_c(q), _c(qd), _c(qdd), _c(fext), _c(pe))
