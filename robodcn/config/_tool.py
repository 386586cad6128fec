"""The optional ``[tool]`` table: the tool point's default and largest speeds (SI inside).

``speed`` (m/s), ``angular_speed`` | ``angular_speed_deg_s`` and ``acceleration`` (m/s²)
are the defaults a plan request without ``tool_speed`` / ``tool_angular_speed`` /
``tool_acceleration`` takes (absent: no tool limit, today's plans); ``max_speed``,
``max_angular_speed`` | ``max_angular_speed_deg_s`` and ``max_acceleration`` are the largest
values a request may ask for (absent: no ceiling). A default above its ceiling is refused.
"""

from __future__ import annotations

import math

from robodcn.config._reader import Reader
from robodcn.config._specs import ToolSpec

#: (SI key, degree key or None, unit) of each quantity, default then ceiling.
_QUANTITIES = (("speed", None, "m/s"), ("angular_speed", "angular_speed_deg_s", "rad/s"),
               ("acceleration", None, "m/s²"))


def tool(r: Reader) -> ToolSpec:
    """The ``[tool]`` table as a :class:`ToolSpec` (every value positive and finite)."""
    keys = set()
    for key, deg, _ in _QUANTITIES:
        keys |= {key, f"max_{key}"} | ({deg, f"max_{deg}"} if deg else set())
    r.only(keys)
    out: dict[str, float | None] = {}
    for key, deg, unit in _QUANTITIES:
        for name, deg_name in ((key, deg), (f"max_{key}", deg and f"max_{deg}")):
            given = r.has(name) or (deg_name is not None and r.has(deg_name))
            if not given:
                out[name] = None
                continue
            value = (r.angle(name, deg_name) if deg_name is not None else r.number(name))
            shown = deg_name if deg_name is not None and r.has(deg_name) else name
            if not value > 0.0:
                raise r.fail(shown, f"must be positive ({unit})", r.table[shown])
            out[name] = value
        top, default = out[f"max_{key}"], out[key]
        if top is not None and default is not None and default > top:
            shown = deg if deg is not None and r.has(deg) else key
            raise r.fail(shown, f"is above max_{key} ({top:g} {unit})", r.table[shown])
    assert all(v is None or math.isfinite(v) for v in out.values())
    return ToolSpec(**out)


__all__ = ["tool"]
