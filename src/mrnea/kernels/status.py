"""Kernel status codes: what every kernel returns (plain integers; this module imports nothing, so
that :mod:`mrnea.validate` can translate them without loading Numba).

A status >= 0 is the index of the joint whose pivot of H (or articulated inertia D_i) is not
positive: H is singular or not positive definite there.
"""

OK = -1  # the outputs hold the result
NONFINITE = -2  # an input holds NaN or inf
OVERFLOW = -3  # finite inputs gave a result that is not finite: values too large for float64
SIZE = -4  # a state array's length is not the model's n (checked by the single-state entries)
CYCLE_LIMIT = -5  # the exact cycle solve reached its exact-arithmetic step bound (rounding)
LAYOUT = -6  # a state array a single-state entry cannot read as C (kernels/entry.py): the wrapper
# then takes its validated path, whose arrays are C-contiguous, so no caller ever sees it
