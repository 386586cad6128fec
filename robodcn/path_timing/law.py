"""The time law s(t) of a timed path: piecewise constant s̈, optionally box-filtered.

The jerk-free law s₀(t) has constant s̈ on each stage. A jerk-limited law is the causal moving
average of s₀ over a window w, s(t) = (1/w) ∫_{t-w}^{t} s₀(τ) dτ, so that
ṡ = (s₀(t) - s₀(t-w))/w, s̈ = (ṡ₀(t) - ṡ₀(t-w))/w and s⃛ = (s̈₀(t) - s̈₀(t-w))/w: every
acceleration switch of s₀ becomes a linear ramp of duration w (a bounded jerk), exactly as
in the jerk-limited double integrator. A uniform time stretch by λ ≥ 1 maps s(t) to s(t/λ).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn.errors import InputError


class Samples(NamedTuple):
    """A sampled time law: t (N,) seconds, s, ṡ (1/s), s̈ (1/s²), s⃛ (1/s³)."""

    t: NDArray[np.float64]
    s: NDArray[np.float64]
    sd: NDArray[np.float64]
    sdd: NDArray[np.float64]
    sddd: NDArray[np.float64]


class PathTiming:
    """A time law s(t) along a fixed path, from its start state to rest at s_end.

    Attributes
    ----------
    duration : float, seconds
    s_start, s_end : path parameter at t = 0 and at the end
    window : box-filter width w of the jerk pass (0 when jerk is unlimited), seconds
    stretch_factor : λ ≥ 1 applied on top of the optimal law (1 when optimal)

    Use :meth:`sample` for the stream, :meth:`at` for any times, :meth:`stretch` for a
    longer fixed duration.
    """

    def __init__(self, t_breaks: NDArray[np.float64], s_breaks: NDArray[np.float64],
                 sd_breaks: NDArray[np.float64], u: NDArray[np.float64], *,
                 window: float = 0.0, stretch_factor: float = 1.0,
                 s_start: float | None = None) -> None:
        self._tb = np.asarray(t_breaks, dtype=np.float64)
        self._sb = np.asarray(s_breaks, dtype=np.float64)
        self._vb = np.asarray(sd_breaks, dtype=np.float64)
        self._u = np.asarray(u, dtype=np.float64)
        # the antiderivative S of s₀ at the breaks: built on first use (:attr:`_Sb`), as
        # only the filtered law (window > 0) reads it
        self._big_sb: NDArray[np.float64] | None = None
        self.window = float(window)
        self.stretch_factor = float(stretch_factor)
        self.s_end = float(self._sb[-1])
        self.s_start = float(self._sb[0] if s_start is None else s_start)
        self._t_end = float(self._tb[-1])

    # -- the jerk-free law s₀ and its antiderivative ---------------------------------------
    @property
    def _Sb(self) -> NDArray[np.float64]:
        """S at the breaks: S_0 = 0, S_{i+1} = S_i + s_i Δt + ṡ_i Δt²/2 + u_i Δt³/6."""
        if self._big_sb is None:
            dt = self._tb[1:] - self._tb[:-1]  # np.diff
            pieces = (self._sb[:-1] * dt + self._vb[:-1] * dt ** 2 / 2
                      + self._u * dt ** 3 / 6)
            big = self._big_sb = np.empty(pieces.shape[0] + 1)
            big[0] = 0.0
            np.cumsum(pieces, out=big[1:])  # np.concatenate([[0.0], np.cumsum(pieces)])
        return self._big_sb

    def _at0(self, t: NDArray[np.float64]) -> tuple[NDArray, NDArray, NDArray]:
        """Each time's break index i, whether it is past the end, τ = t − t_i (0 after)."""
        # clip(searchsorted(t_0..t_N, t, "right") − 1, 0, N − 1) is the count of inner
        # breaks t_1..t_{N−1} at or below t (t_0 counts for every t that is not clipped up
        # to 0, t_N for none that is not clipped down to N − 1): one search, no clipping
        i = self._tb[1:-1].searchsorted(t, side="right")  # (np.searchsorted's wrapper skipped)
        after = t >= self._t_end
        return i, after, np.where(after, 0.0, t - self._tb[i])

    def _s0(self, t: NDArray[np.float64]) -> NDArray:
        """s of :meth:`_law0` alone (the same operations)."""
        i, after, tau = self._at0(t)
        s = self._sb[i] + self._vb[i] * tau + self._u[i] * tau ** 2 / 2
        return np.where(after, self.s_end, s)

    def _big_s0(self, t: NDArray[np.float64]) -> NDArray:
        """The antiderivative S of :meth:`_law0` alone (the same operations)."""
        i, after, tau = self._at0(t)
        v0, u = self._vb[i], self._u[i]
        big_s = self._Sb[i] + self._sb[i] * tau + v0 * tau ** 2 / 2 + u * tau ** 3 / 6
        return np.where(after, self._Sb[-1] + self.s_end * (t - self._t_end), big_s)

    def _law0(self, t: NDArray[np.float64], big: bool = True
              ) -> tuple[NDArray, NDArray, NDArray, NDArray | None]:
        """s₀, ṡ₀, s̈₀ and (``big``, else None: the jerk-free law does not read it) S at t."""
        i, after, tau = self._at0(t)
        v0, u = self._vb[i], self._u[i]
        s = self._sb[i] + v0 * tau + u * tau ** 2 / 2
        sd = v0 + u * tau
        s = np.where(after, self.s_end, s)
        sd = np.where(after, 0.0, sd)
        sdd = np.where(after, 0.0, u)
        if not big:
            return s, sd, sdd, None
        big_s = self._Sb[i] + self._sb[i] * tau + v0 * tau ** 2 / 2 + u * tau ** 3 / 6
        rest = t - self._t_end
        big_s = np.where(after, self._Sb[-1] + self.s_end * rest, big_s)
        return s, sd, sdd, big_s

    @property
    def _base_duration(self) -> float:
        # the filtered law reaches rest a window after s₀ does
        return self._t_end + (self.window if self.window > 0 else -float(self._tb[0]))

    @property
    def duration(self) -> float:
        """Seconds from the start state to rest at s_end."""
        return self.stretch_factor * self._base_duration

    def at(self, t: ArrayLike) -> Samples:
        """s, ṡ, s̈, s⃛ at times t (seconds from the start; held at rest after the end)."""
        t = np.asarray(t, dtype=np.float64)
        lam = self.stretch_factor
        tl = np.maximum(t / lam if lam != 1.0 else t, 0.0)  # t / 1.0 is t
        w = self.window
        if w > 0:
            # the jerk-free law starts at -w (its history); tl is filtered over [tl - w, tl]
            s1, v1, a1, big1 = self._law0(tl)
            s0, v0, a0, big0 = self._law0(tl - w)
            assert big1 is not None and big0 is not None
            s, sd, sdd, sddd = (big1 - big0) / w, (s1 - s0) / w, (v1 - v0) / w, (a1 - a0) / w
        else:
            tl = tl + float(self._tb[0])
            s, sd, sdd, _ = self._law0(tl, big=False)
            sddd = np.zeros_like(s)
        # the filter's sums round: never past the end of the path
        s = np.minimum(s, self.s_end)
        if lam == 1.0:  # x / 1.0 is x: the divisions below would only copy
            return Samples(t, s, sd, sdd, sddd)
        return Samples(t, s, sd / lam, sdd / lam ** 2, sddd / lam ** 3)

    def positions(self, t: ArrayLike) -> NDArray[np.float64]:
        """s alone at times t: :meth:`at`'s s (the same operations), without ṡ, s̈, s⃛."""
        t = np.asarray(t, dtype=np.float64)
        lam = self.stretch_factor
        tl = np.maximum(t / lam if lam != 1.0 else t, 0.0)  # t / 1.0 is t
        w = self.window
        if w > 0:
            s = (self._big_s0(tl) - self._big_s0(tl - w)) / w
        else:
            s = self._s0(tl + float(self._tb[0]))
        return np.minimum(s, self.s_end)

    def sample_times(self, rate_hz: float) -> NDArray[np.float64]:
        """The times of :meth:`sample`: every 1/rate_hz s from t = 0 to the first sample at
        or after the end."""
        if not (isinstance(rate_hz, int | float) and math.isfinite(rate_hz) and rate_hz > 0):
            raise InputError(f"rate_hz must be a positive number, got {rate_hz!r}",
                             field="rate_hz", value=rate_hz)
        n = max(1, math.ceil(self.duration * rate_hz - 1e-9))
        return np.arange(n + 1) / rate_hz

    def sample(self, rate_hz: float) -> Samples:
        """The law every 1/rate_hz s from t = 0 to the first sample at or after the end."""
        return self.at(self.sample_times(rate_hz))

    def stretch(self, duration: float) -> PathTiming:
        """This law slowed uniformly to a fixed, longer ``duration`` (seconds).

        Velocities scale by 1/λ, accelerations 1/λ², jerks 1/λ³ (λ = duration / optimal),
        so every limit still holds.

        Raises
        ------
        InputError
            ``duration`` shorter than this law's (the optimum under the limits cannot be
            beaten), or a moving start (a stretch would change the start velocity).
        """
        _check_stretch(duration, self.duration)
        start = self.at(np.array([0.0]))
        # a rest start may begin with an acceleration step (jerk-free law): it scales by
        # 1/λ² and stays a start from rest; a moving start would change its velocity
        if abs(start.sd[0]) > 1e-12 or (self.window > 0 and abs(start.sdd[0]) > 1e-12):
            raise InputError("a law from a moving start cannot be stretched uniformly: the "
                             "start velocity would change", field="duration", value=duration)
        out = PathTiming(self._tb, self._sb, self._vb, self._u, window=self.window,
                         s_start=self.s_start,
                         stretch_factor=max(1.0, duration / self._base_duration))
        return out

    def compressed(self, factor: float) -> PathTiming:
        """This law run in ``factor`` < 1 times its duration: s(t / factor), unchecked.

        The inverse of :meth:`stretch` without its checks: velocities scale by 1/factor,
        accelerations by 1/factor², jerks by 1/factor³, so limits may be exceeded (a fixed
        duration shorter than the optimum: validation names the first sample past one).
        """
        return PathTiming(self._tb, self._sb, self._vb, self._u, window=self.window,
                          s_start=self.s_start, stretch_factor=self.stretch_factor * factor)

    def __repr__(self) -> str:
        return (f"PathTiming(duration={self.duration:.6g} s, window={self.window:.4g} s, "
                f"stretch_factor={self.stretch_factor:.6g})")


def _check_stretch(duration: float, optimal: float) -> None:
    """A stretch target: a finite number of seconds, not shorter than the optimal law's."""
    if not (isinstance(duration, int | float) and math.isfinite(duration)):
        raise InputError(f"duration must be a number of seconds, got {duration!r}",
                         field="duration", value=duration)
    if duration < optimal * (1.0 - 1e-12):
        raise InputError(f"duration {duration:g} s is shorter than the time-optimal "
                         f"{optimal:.6g} s under the joint limits: at least one "
                         "joint limit would be exceeded", field="duration", value=duration)


class ChainTiming(PathTiming):
    """Time laws of consecutive path pieces, each ending at rest (the stops), run in turn.

    Same interface as :class:`PathTiming`; ``window`` is the widest of the pieces'.
    """

    def __init__(self, pieces: list[PathTiming]) -> None:
        self.pieces = list(pieces)
        self.offsets = np.concatenate([[0.0], np.cumsum([p.duration for p in self.pieces])])
        self.window = max(p.window for p in self.pieces)
        self.stretch_factor = min(p.stretch_factor for p in self.pieces)
        self.s_start = self.pieces[0].s_start
        self.s_end = self.pieces[-1].s_end

    @property
    def duration(self) -> float:
        """Seconds from the start to rest at s_end."""
        return float(self.offsets[-1])

    def at(self, t: ArrayLike) -> Samples:
        """s, ṡ, s̈, s⃛ at times t: each piece's law from its start time on."""
        t = np.asarray(t, dtype=np.float64)
        which = np.clip(np.searchsorted(self.offsets, t, side="right") - 1, 0,
                        len(self.pieces) - 1)
        out = [np.empty_like(t) for _ in range(4)]
        for k, piece in enumerate(self.pieces):
            mask = which == k
            if mask.any():
                m = piece.at(t[mask] - self.offsets[k])
                for dst, src in zip(out, m[1:], strict=True):
                    dst[mask] = src
        return Samples(t, *out)

    def positions(self, t: ArrayLike) -> NDArray[np.float64]:
        """s alone at times t (:meth:`at`'s s)."""
        t = np.asarray(t, dtype=np.float64)
        which = np.clip(np.searchsorted(self.offsets, t, side="right") - 1, 0,
                        len(self.pieces) - 1)
        out = np.empty_like(t)
        for k, piece in enumerate(self.pieces):
            mask = which == k
            if mask.any():
                out[mask] = piece.positions(t[mask] - self.offsets[k])
        return out

    def stretch(self, duration: float) -> ChainTiming:
        """Every piece slowed by the same factor to a total ``duration`` (PathTiming.stretch)."""
        _check_stretch(duration, self.duration)
        lam = duration / self.duration
        return ChainTiming([p.stretch(p.duration * lam) for p in self.pieces])

    def compressed(self, factor: float) -> ChainTiming:
        """Every piece run in ``factor`` times its duration (PathTiming.compressed)."""
        return ChainTiming([p.compressed(factor) for p in self.pieces])

    def __repr__(self) -> str:
        return f"ChainTiming(duration={self.duration:.6g} s, pieces={len(self.pieces)})"
