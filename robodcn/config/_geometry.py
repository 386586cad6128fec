"""Parsing of the ``[arm]`` table: the chain's links, an optional base yaw, home and rest."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from robodcn.config._reader import Reader
from robodcn.config._specs import ELBOWS, LINK_RANGE, PLANES


@dataclass(frozen=True)
class Geometry:
    """What ``[arm]`` says, checked: the fields :class:`robodcn.config.Arm` takes."""

    name: str
    base_yaw: bool
    plane: str
    shoulder_height: float
    lengths: tuple[float, ...]
    vectors: tuple[tuple[float, float], ...] | None
    elbow: str
    home: tuple[float, ...]
    rest: tuple[float, ...] | None


def _links(a: Reader, base_yaw: bool) -> tuple[tuple[float, ...],
                                                tuple[tuple[float, float], ...] | None]:
    """Planar arm: 2 or 3 lengths. Yawed arm: 2 or 3 links, each an (r, z) vector or a
    length (the vector (l, 0))."""
    raw = a.table.get("links")
    if raw is None:
        raise a.missing("links")
    what = ("link vectors [r, z] (or lengths) in metres" if base_yaw
            else "link lengths in metres")
    if not isinstance(raw, list) or len(raw) not in (2, 3):
        raise a.fail("links", f"must be a list of 2 or 3 {what}", raw)
    items = Reader(a.source, {f"links[{i}]": v for i, v in enumerate(raw)}, a.prefix)
    vectors: list[tuple[float, float]] = []
    for i, value in enumerate(raw):
        key = f"links[{i}]"
        if isinstance(value, list):
            if not base_yaw:
                raise a.fail(key, "a link vector [r, z] needs base_yaw = true (a planar "
                             "arm's links are lengths)", value)
            vectors.append(items.pair(key, value, "[r, z] in metres"))
            if not LINK_RANGE[0] <= math.hypot(*vectors[-1]) <= LINK_RANGE[1]:
                raise a.fail(key, f"a link vector must be {LINK_RANGE[0]:g}.."
                             f"{LINK_RANGE[1]:g} m long", value)
        else:
            vectors.append((items.number(key), 0.0))
            if not LINK_RANGE[0] <= vectors[-1][0] <= LINK_RANGE[1]:
                raise a.fail(key, f"a link length must be within {LINK_RANGE[0]:g}.."
                             f"{LINK_RANGE[1]:g} m", value)
    lengths = tuple(math.hypot(*v) for v in vectors)
    return lengths, (tuple(vectors) if base_yaw else None)


def _pose(r: Reader, base_yaw: bool) -> tuple[float, ...]:
    """A pose table: x, y, theta | theta_deg (planar) or x, y, z, pitch | pitch_deg."""
    if base_yaw:
        r.only({"x", "y", "z", "pitch", "pitch_deg"})
        return (r.number("x"), r.number("y"), r.number("z"),
                r.angle("pitch", "pitch_deg", default=0.0))
    r.only({"x", "y", "theta", "theta_deg"})
    return r.number("x"), r.number("y"), r.angle("theta", "theta_deg", default=0.0)


def geometry(a: Reader) -> Geometry:
    """The ``[arm]`` table (see :mod:`robodcn.config` for its keys)."""
    a.only({"name", "links", "elbow", "home", "rest", "base_yaw", "plane", "shoulder_height"})
    name = a.string("name")
    base_yaw: Any = a.table.get("base_yaw", False)
    if not isinstance(base_yaw, bool):
        raise a.fail("base_yaw", "must be true or false", base_yaw)
    plane = a.string("plane", "vertical" if base_yaw else "horizontal", choices=PLANES)
    if base_yaw and plane != "vertical":
        raise a.fail("plane", "a base yaw turns a chain moving in a vertical plane", plane)
    if base_yaw:
        height = a.number("shoulder_height")
        if not 0.0 <= height <= LINK_RANGE[1]:
            raise a.fail("shoulder_height", f"must be within 0..{LINK_RANGE[1]:g} m", height)
    elif a.has("shoulder_height"):
        raise a.fail("shoulder_height", "needs base_yaw = true", a.table["shoulder_height"])
    else:
        height = 0.0
    lengths, vectors = _links(a, base_yaw)
    elbow = a.string("elbow", "up", choices=ELBOWS)
    home = _pose(a.sub("home"), base_yaw)
    rest = _pose(a.sub("rest"), base_yaw) if a.has("rest") else None
    return Geometry(name, base_yaw, plane, height, lengths, vectors, elbow, home, rest)
