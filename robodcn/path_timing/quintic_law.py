"""The uniform quintic law along a path piece: the jerk pass's rest-to-rest fallback.

s(t) = s₀ + L·p(τ), τ = t/T, p(τ) = 10τ³ − 15τ⁴ + 6τ⁵ (the minimum-jerk polynomial of Flash
and Hogan, "The coordination of arm movements", J. Neurosci. 5(7), 1985: rest to rest with
zero acceleration at both ends). ṡ = L p′/T, s̈ = L p″/T², s⃛ = L p‴/T³, so along a fixed path
every joint's velocity, acceleration and jerk (q̇ = q′ṡ, q̈ = q″ṡ² + q′s̈,
q⃛ = q‴ṡ³ + 3q″ṡs̈ + q′s⃛) scale exactly as 1/T, 1/T², 1/T³, and so does a torque row's
A s̈ + B ṡ²: the least T within every limit is one evaluation's ratios away.

The box-filtered optimum (:mod:`robodcn.path_timing.jerk`) pays about one filter window per
piece over the jerk-limited optimum; under a tight jerk limit (of the order of the quintic's
own peak jerk) that overhead made it slower than this uniform law, which meets the same
limits (issue 17 §1: the optimal profile is never slower than quintic). Each rest-to-rest
piece takes the faster of the two.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn.path_timing.law import PathTiming, Samples, _check_stretch
from robodcn.path_timing.torque import TorqueRows

#: the margins of the rounds of "evaluate at the stream rate, rescale T": the ratios scale
#: exactly with T, only the sample instants move (a peak between two samples is read a
#: little differently), so each round asks a little more room than the last
_ROUND_MARGINS = (1e-9, 1e-5, 1e-4, 1e-3)


class QuinticTiming(PathTiming):
    """s(t) = s_start + (s_end − s_start)·p(t/T) on [0, T], at rest before and after.

    Same interface as :class:`PathTiming` (``window`` 0, ``stretch_factor`` 1: a stretch is
    a longer T, exactly the uniform slow-down λ = T′/T).
    """

    def __init__(self, s_start: float, s_end: float, duration: float) -> None:
        self.s_start, self.s_end = float(s_start), float(s_end)
        self._duration = float(duration)
        self.window = 0.0
        self.stretch_factor = 1.0

    @property
    def duration(self) -> float:
        """T, seconds from rest at s_start to rest at s_end."""
        return self._duration

    def at(self, t: ArrayLike) -> Samples:
        """s, ṡ, s̈, s⃛ at times t (at rest before 0 and from T on).

        ṡ = 30 L τ²(1 − τ)²/T, s̈ = 60 L τ(1 − τ)(1 − 2τ)/T², s⃛ = 60 L (1 − 6τ + 6τ²)/T³.
        """
        t = np.asarray(t, dtype=np.float64)
        big_t, length = self._duration, self.s_end - self.s_start
        tau = np.clip(t / big_t, 0.0, 1.0)
        rest = 1.0 - tau
        s = np.minimum(self.s_start + length * tau ** 3 * (10.0 + tau * (-15.0 + 6.0 * tau)),
                       self.s_end)
        sd = (30.0 * length / big_t) * (tau * rest) ** 2
        sdd = (60.0 * length / big_t ** 2) * tau * rest * (rest - tau)
        moving = (t >= 0.0) & (t < big_t)
        sddd = np.where(moving, (60.0 * length / big_t ** 3) * (1.0 - 6.0 * tau * rest), 0.0)
        return Samples(t, s, sd, sdd, sddd)

    def positions(self, t: ArrayLike) -> NDArray[np.float64]:
        """s alone at times t (:meth:`at`'s s)."""
        return self.at(t).s

    def stretch(self, duration: float) -> QuinticTiming:
        """The same law over a longer ``duration`` (velocities 1/λ, accelerations 1/λ², jerks
        1/λ³ of this one's: every limit still holds)."""
        _check_stretch(duration, self._duration)
        return QuinticTiming(self.s_start, self.s_end, max(duration, self._duration))

    def compressed(self, factor: float) -> QuinticTiming:
        """This law run in ``factor`` times its duration, unchecked (PathTiming.compressed)."""
        return QuinticTiming(self.s_start, self.s_end, self._duration * factor)

    def __repr__(self) -> str:
        return f"QuinticTiming(duration={self._duration:.6g} s)"


def torque_ratio(m: Samples, sg: NDArray, rows: TorqueRows) -> float:
    """max over the samples ``m`` of a law of (A s̈ + B ṡ²) / bound: the factor λ² a uniform
    slow-down needs for lo ≤ A s̈ + B ṡ² ≤ hi (rows on the grid ``sg``, read at s(t))."""
    big_a, big_b, lo, hi = (np.stack([np.interp(m.s, sg, r[:, i]) for i in range(r.shape[1])],
                                     axis=1) for r in rows)
    y = big_a * m.sdd[:, None] + big_b * m.sd[:, None] ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        over = np.where(y > 0.0, y / hi, np.where(y < 0.0, y / lo, 0.0))
    over = np.where(np.isfinite(over), over, 0.0)  # ±inf bounds: no limit on that joint
    return float(over.max(initial=0.0))


def fastest_quintic(s_start: float, s_end: float,
                    ratios: Callable[[PathTiming], tuple[float, float, float, float]],
                    guess: float,
                    torque: tuple[NDArray, TorqueRows] | None = None) -> QuinticTiming | None:
    """The shortest :class:`QuinticTiming` from ``s_start`` to ``s_end`` within the limits,
    None if it is not found within a few rounds (then it is no candidate).

    ``ratios(law)`` gives (r_v, r_a, r_j, r_step) of a law at the stream rate (the jerk
    pass's ``joint_ratios``: a step's jerk scales as 1/T², so √r_step); ``guess`` a first T;
    ``torque`` the grid and its rows, or None. T ← T·max(r_v, √r_a, ∛r_j, √r_step, √r_τ),
    then checked: only a law whose every ratio is ≤ 1 is returned.
    """
    def needed(law: QuinticTiming) -> float:
        rv, ra, rj, r_step = ratios(law)
        need = max(rv, math.sqrt(ra), rj ** (1.0 / 3.0), math.sqrt(r_step))
        if torque is not None:
            sg, rows = torque
            need = max(need, math.sqrt(torque_ratio(law.sample(_check_hz(law)), sg, rows)))
        return need

    law = QuinticTiming(s_start, s_end, guess)
    need = needed(law)
    for margin in _ROUND_MARGINS:
        if not (math.isfinite(need) and need > 0.0):
            return None
        law = QuinticTiming(s_start, s_end, law.duration * need * (1.0 + margin))
        need = needed(law)
        if need <= 1.0:
            return law
    return None


def _check_hz(law: PathTiming) -> float:
    """A rate giving about 2000 samples over the law: torque rows are smooth in s."""
    return max(100.0, 2000.0 / max(law.duration, 1e-9))


__all__ = ["QuinticTiming", "fastest_quintic", "torque_ratio"]
