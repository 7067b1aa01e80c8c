"""Statistics over independent runs (seeds): confidence intervals of errors and times, and
the time at which a convergence curve reaches an error.

Errors and times are positive and skewed, so intervals are computed on their logarithms
(t distribution with K - 1 degrees of freedom) and reported as a geometric mean with a
multiplicative interval; ratios of two configurations likewise (Welch).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

CONFIDENCE = 0.95


def _t_quantile(dof: float, confidence: float = CONFIDENCE) -> float:
    from scipy import stats  # scipy comes with scikit-image, which the metrics need

    return float(stats.t.ppf(0.5 + confidence / 2, dof))


@dataclass(frozen=True)
class Interval:
    """A geometric mean with its confidence interval (lo == hi == mean for one value)."""
    mean: float
    lo: float
    hi: float
    n: int

    def format(self, spec: str = ".3g", unit: str = "") -> str:
        if self.n < 2 or not math.isfinite(self.mean):
            return f"{self.mean:{spec}}{unit}"
        return f"{self.mean:{spec}}{unit} ({self.lo:{spec}}–{self.hi:{spec}})"


def log_interval(values, confidence: float = CONFIDENCE) -> Interval:
    """Geometric mean of positive values and the confidence interval of it."""
    x = np.asarray([v for v in values], np.float64)
    if x.size == 0:
        return Interval(math.nan, math.nan, math.nan, 0)
    if np.any(~np.isfinite(x)):  # a run that never got there
        return Interval(math.inf, math.inf, math.inf, int(x.size))
    if np.any(x <= 0):
        mean = float(x.mean())
        return Interval(mean, float(x.min()), float(x.max()), int(x.size))
    logs = np.log(x)
    mean = float(logs.mean())
    if x.size < 2:
        return Interval(math.exp(mean), math.exp(mean), math.exp(mean), 1)
    half = _t_quantile(x.size - 1, confidence) * float(logs.std(ddof=1)) / math.sqrt(x.size)
    return Interval(math.exp(mean), math.exp(mean - half), math.exp(mean + half), int(x.size))


def ratio_interval(numerator, denominator, confidence: float = CONFIDENCE) -> Interval:
    """Ratio of the geometric means of two independent samples, with Welch's interval."""
    a = np.log(np.asarray(numerator, np.float64))
    b = np.log(np.asarray(denominator, np.float64))
    mean = float(a.mean() - b.mean())
    if a.size < 2 or b.size < 2:
        return Interval(math.exp(mean), math.exp(mean), math.exp(mean), min(a.size, b.size))
    va, vb = a.var(ddof=1) / a.size, b.var(ddof=1) / b.size
    se = math.sqrt(va + vb)
    if se == 0:
        return Interval(math.exp(mean), math.exp(mean), math.exp(mean), min(a.size, b.size))
    dof = (va + vb) ** 2 / (va ** 2 / (a.size - 1) + vb ** 2 / (b.size - 1))
    half = _t_quantile(dof, confidence) * se
    return Interval(math.exp(mean), math.exp(mean - half), math.exp(mean + half), min(a.size, b.size))


def loglog_interpolate(xs, ys, x: float) -> float:
    """y at x on the piecewise-linear log-log curve through (xs, ys); NaN outside it."""
    xs, ys = np.asarray(xs, np.float64), np.asarray(ys, np.float64)
    if x < xs[0] or x > xs[-1] or np.any(xs <= 0) or np.any(ys <= 0):
        return math.nan
    return float(np.exp(np.interp(np.log(x), np.log(xs), np.log(ys))))


def time_to_reach(times, errors, target: float) -> float:
    """When the curve (times increasing) first reaches `target` error, interpolated on the
    log-log segment that crosses it. The first checkpoint's time if it is already there
    (an upper bound); inf if it never gets there."""
    times, errors = list(times), list(errors)
    if not times:
        return math.inf
    if errors[0] <= target:
        return float(times[0])
    for (t0, e0), (t1, e1) in zip(zip(times, errors), zip(times[1:], errors[1:])):
        if e1 <= target < e0:
            if t0 <= 0 or e1 <= 0:
                return float(t1)
            f = (math.log(e0) - math.log(target)) / (math.log(e0) - math.log(e1))
            return float(math.exp(math.log(t0) + f * (math.log(t1) - math.log(t0))))
    return math.inf
