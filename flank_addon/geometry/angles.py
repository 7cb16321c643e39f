"""Angles that come out the same bit for bit from run to run.

numpy's arctan2, sin, cos, arccos, exp, log and the like have two implementations on processors with AVX-512:
a vectorised one (SVML) and the C library's, which differ in the last bit on about a quarter of the arguments.
numpy takes the vectorised one unless an input may share memory with the output, and it tests that on the byte
range ``stride * length`` from the first element.  For a column of a 2-D array (stride larger than the item) that
range runs past the array's end, so whether the result is vectorised depends on where the allocator happened to
put the output: right behind the input, and the same call on the same numbers gives other bits.  A planner that
optimises on such numbers ends a few units in the last place apart, and a derived figure (a junction's kink)
by up to 1e-7 degrees.  A contiguous input has an exact range and always takes the vectorised code, so these
functions hand numpy contiguous arrays: the results are those of the vectorised code, every time.
"""
import numpy as np


def contiguous(a):
    """``a`` as a C-contiguous float array (no copy when it already is one)."""
    return np.ascontiguousarray(a, dtype=float)


def atan2(y, x):
    """``np.arctan2(y, x)`` of contiguous copies of y and x (columns of larger arrays may be passed)."""
    return np.arctan2(contiguous(y), contiguous(x))


def wrapped(angle):
    """``np.angle(np.exp(1j * angle))``: angles wrapped into (-pi, pi], through the same complex exponential,
    its parts taken apart into contiguous arrays before the arctan2."""
    z = np.exp(1j * np.asarray(angle, float))
    return atan2(z.imag, z.real)
