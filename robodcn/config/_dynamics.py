"""Parsing of the optional ``[dynamics]`` table: masses, centres of mass, inertias, gravity,
payload and the servos' reflected rotor inertia (SI, every value checked)."""

from __future__ import annotations

from typing import Any

from robodcn.config._reader import Reader
from robodcn.config._specs import MassProperties

_PER_LINK = ("link_masses", "link_com", "link_inertias")
#: Gravity a planar arm's ``gravity = true`` means: −y in its plane (m/s²).
STANDARD_GRAVITY = 9.81


def _per_link(r: Reader, key: str, n: int, vectors: bool) -> list[Any]:
    raw = r.table[key]
    if vectors and key == "link_com":
        if not isinstance(raw, list) or len(raw) != n:
            raise r.fail(key, f"must be a list of {n} [r, z] vectors in metres (one per "
                         "link, from its joint at zero)", raw)
        return [list(r.pair(f"{key}[{i}]", v, "[r, z] in metres")) for i, v in enumerate(raw)]
    values = r.numbers(key, n, "one per link")
    if any(v < 0 or (key == "link_masses" and v == 0) for v in values):
        raise r.fail(key, "must be positive" if key == "link_masses"
                     else "must be non-negative", raw)
    return values


def _non_negative(r: Reader, key: str, unit: str, positive: bool = False) -> float:
    value = r.number(key)
    if value < 0 or (positive and value == 0):
        raise r.fail(key, f"must be {'positive' if positive else 'non-negative'} ({unit})",
                     value)
    return value


def dynamics(r: Reader, n: int, dof: int, base_yaw: bool) -> tuple[dict[str, Any],
                                                                     MassProperties]:
    """The ``[dynamics]`` table of an arm with ``n`` chain links and ``dof`` joints, as the
    SI dict it was written as and as :class:`MassProperties`.

    Every arm: ``link_masses`` (kg > 0), ``link_inertias`` (kg·m² ≥ 0), ``payload_kg`` ≥ 0,
    ``rotor_inertia_kg_m2`` ≥ 0 (one number for every servo, or one per joint). A planar
    arm: ``link_com`` (m along each link), ``gravity`` [gx, gy] m/s² or true/false. A yawed
    arm: ``link_com`` [[r, z], …] m, ``gravity_m_s2`` (along −z), ``yaw_body_mass`` kg,
    ``yaw_body_com`` [r, z] m, ``yaw_body_inertia`` kg·m².
    """
    common = {*_PER_LINK, "payload_kg", "rotor_inertia_kg_m2"}
    yawed_keys = {"gravity_m_s2", "yaw_body_mass", "yaw_body_com", "yaw_body_inertia"}
    r.only(common | (yawed_keys if base_yaw else {"gravity"}))
    out: dict[str, Any] = {}
    for key in _PER_LINK:
        if r.has(key):
            out[key] = _per_link(r, key, n, base_yaw)
    if r.has("payload_kg"):
        out["payload_kg"] = _non_negative(r, "payload_kg", "kg")
    rotor: tuple[float, ...] | None = None
    if r.has("rotor_inertia_kg_m2"):
        raw = r.table["rotor_inertia_kg_m2"]
        if isinstance(raw, list):
            values = r.numbers("rotor_inertia_kg_m2", dof, "kg·m², one per joint")
            if any(v < 0 for v in values):
                raise r.fail("rotor_inertia_kg_m2", "must be non-negative (kg·m²)", raw)
            out["rotor_inertia_kg_m2"] = values
            rotor = tuple(values)
        else:
            value = _non_negative(r, "rotor_inertia_kg_m2", "kg·m²")
            out["rotor_inertia_kg_m2"] = value
            rotor = (value,) * dof
    gravity = (0.0, 0.0)
    if r.has("gravity"):
        raw = r.table["gravity"]
        if isinstance(raw, bool):
            out["gravity"] = [0.0, -STANDARD_GRAVITY] if raw else [0.0, 0.0]
        elif isinstance(raw, list) and len(raw) == 2:
            out["gravity"] = [Reader(r.source, {"gravity": v}, r.prefix).number("gravity")
                              for v in raw]
        else:
            raise r.fail("gravity", "must be [gx, gy] in m/s² (or true for [0, -9.81])", raw)
        gravity = (out["gravity"][0], out["gravity"][1])
    if r.has("gravity_m_s2"):
        out["gravity_m_s2"] = _non_negative(r, "gravity_m_s2", "m/s² along −z")
        gravity = (0.0, -out["gravity_m_s2"])
    for key, unit in (("yaw_body_mass", "kg"), ("yaw_body_inertia", "kg·m²")):
        if r.has(key):
            out[key] = _non_negative(r, key, unit, positive=key == "yaw_body_mass")
    if r.has("yaw_body_com"):
        out["yaw_body_com"] = list(r.pair("yaw_body_com", r.table["yaw_body_com"]))
    com = out.get("link_com")
    props = MassProperties(
        gravity=gravity,
        link_masses=None if "link_masses" not in out else tuple(out["link_masses"]),
        link_com=None if com is None else tuple(
            (float(c[0]), float(c[1])) if base_yaw else (float(c), 0.0) for c in com),
        link_inertias=None if "link_inertias" not in out else tuple(out["link_inertias"]),
        yaw_body_mass=out.get("yaw_body_mass"),
        yaw_body_com=None if "yaw_body_com" not in out else tuple(out["yaw_body_com"]),
        yaw_body_inertia=out.get("yaw_body_inertia"),
        payload_kg=out.get("payload_kg", 0.0),
        rotor_inertia=rotor)
    return out, props
