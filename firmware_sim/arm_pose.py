"""An arm file's ``[arm.rest]`` pose as joint angles, and its joints' limits.

firmware_sim reads the arm file itself, so it solves the rest pose itself: a yawed arm's
``x, y, z, pitch_deg`` (base frame; pitch the tool axis's elevation) turns the chain's plane
to yaw ψ = atan2(y, x) and asks the tool point at (r, z) = (√(x² + y²), z) in it; a planar
arm's ``x, y`` with ``theta_deg`` (or ``pitch_deg``) is that point in its plane; either
angle may be given in radians instead, without ``_deg`` (``pitch``, ``theta``: how robodcn
writes an arm back). For a chain of three links (tool axis given) the wrist is
W = P − v₃·e^{iφ₃} with φ₃ = pitch − arg v₃; for two links W = P. The first two links
reach W by the law of cosines (Spong, Hutchinson & Vidyasagar, *Robot Modeling and
Control* §3.3), on the branch ``[arm] elbow`` names ("up", the default: the elbow left of
the line from the chain's origin to W, above it for an arm reaching forward; "down" the
other). Link angles φ relate to joints by φ = σ·S·q (:mod:`firmware_sim.chain`).

Limits: ``[[joints]] min, max`` (rad) or ``min_deg, max_deg``.
"""

from __future__ import annotations

import cmath
import math
from collections.abc import Mapping, Sequence
from typing import Any

Vec = tuple[float, float]


def joint_limits(joints_raw: Sequence[Any]) -> tuple[tuple[float, float] | None, ...]:
    """Per ``[[joints]]`` table its (min, max) in rad, or None when it gives none."""
    out: list[tuple[float, float] | None] = []
    for j in joints_raw:
        if not isinstance(j, Mapping):
            out.append(None)
        elif "min" in j and "max" in j:
            out.append((float(j["min"]), float(j["max"])))
        elif "min_deg" in j and "max_deg" in j:
            out.append((math.radians(j["min_deg"]), math.radians(j["max_deg"])))
        else:
            out.append(None)
    return tuple(out)


def rest_joints(rest: Mapping[str, Any], links: Sequence[Vec], base_yaw: bool,
                origin: Vec, elbow: str = "up") -> tuple[float, ...] | None:
    """The joint angles (rad, the yaw first with ``base_yaw``) of the ``[arm.rest]`` pose
    (module notes), or None when it is out of reach or the chain is not of 2 or 3 links."""
    n = len(links)
    if n not in (2, 3):
        return None
    if base_yaw:
        x, y, z = (float(rest[k]) for k in ("x", "y", "z"))
        yaw, point = math.atan2(y, x) if (x or y) else 0.0, complex(math.hypot(x, y), z)
    else:
        yaw, point = 0.0, complex(float(rest["x"]), float(rest["y"]))
    sign = -1.0 if base_yaw else 1.0
    v = [complex(*link) for link in links]
    phi_last = None
    if n == 3:
        pitch = _angle(rest, "pitch", _angle(rest, "theta", 0.0))
        phi_last = pitch - cmath.phase(v[2])
        point -= v[2] * cmath.exp(1j * phi_last)
    d = point - complex(*origin)
    a, b = abs(v[0]), abs(v[1])
    cos_g = (abs(d) ** 2 - a * a - b * b) / (2 * a * b)
    if not -1.0 <= cos_g <= 1.0:
        return None
    best = None
    for gamma in (math.acos(cos_g), -math.acos(cos_g)):
        alpha = cmath.phase(d) - math.atan2(b * math.sin(gamma), a + b * math.cos(gamma))
        e = a * cmath.exp(1j * alpha)
        left = (d.conjugate() * e).imag > 0          # the elbow left of origin → W
        if left == (elbow != "down"):
            best = (alpha, alpha + gamma)
    if best is None:
        return None
    phis = [best[0] - cmath.phase(v[0]), best[1] - cmath.phase(v[1])]
    if phi_last is not None:
        phis.append(phi_last)
    q = [sign * _wrap(phis[0])] + [sign * _wrap(phis[k] - phis[k - 1]) for k in range(1, n)]
    return ((yaw,) if base_yaw else ()) + tuple(q)


def _angle(table: Mapping[str, Any], key: str, default: float) -> float:
    """``table``'s angle ``key`` (rad) or ``key_deg`` (degrees), else ``default`` (rad)."""
    if f"{key}_deg" in table:
        return math.radians(float(table[f"{key}_deg"]))
    return float(table[key]) if key in table else default


def _wrap(angle: float) -> float:
    """``angle`` in (−π, π]."""
    return math.atan2(math.sin(angle), math.cos(angle))
