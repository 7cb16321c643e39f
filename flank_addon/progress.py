"""Progress reports and cancellation for long planner runs (the Blender Run operator, the CLI).

A planner takes ``progress``: None or a callable ``progress(fraction, message)`` with fraction in
[0, 1].  The callable may return False (or raise :class:`Cancelled` itself) to stop the run; the
planner then raises :class:`Cancelled` at its next report, before it has returned anything, so a
caller that builds results only from a returned value is left exactly as it was.
"""


class Cancelled(Exception):
    """The progress callback asked the planner to stop."""


def reporter(progress, lo=0.0, hi=1.0):
    """A report function for one stage: maps the stage's own fraction in [0, 1] into [lo, hi] of the
    caller's scale and raises :class:`Cancelled` when ``progress`` returns False.  ``progress`` None
    gives a no-op."""
    lo, hi = float(lo), float(hi)

    def report(fraction, message):
        if progress is None:
            return
        f = lo + (hi - lo) * min(max(float(fraction), 0.0), 1.0)
        if progress(f, str(message)) is False:
            raise Cancelled(message)

    report.span = (lo, hi)
    return report


def substage(report, lo, hi):
    """The report function of a sub-range [lo, hi] of ``report``'s own [0, 1] scale."""
    a, b = getattr(report, "span", (0.0, 1.0))

    def sub(fraction, message):
        report((lo + (hi - lo) * min(max(float(fraction), 0.0), 1.0)), message)

    sub.span = (a + (b - a) * lo, a + (b - a) * hi)
    return sub
