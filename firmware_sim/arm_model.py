"""Planar serial-chain rigid-body dynamics of an arm, read from its TOML file.

firmware_sim reads the arm file itself (``tomllib``): the other side of the wire never
depends on robodcn. It uses ``[arm] links``, each ``[joints.servo]`` (``id``, ``model``,
``ticks_per_turn``, ``zero_offset``, ``direction``) and an optional ``[dynamics]`` table::

    [dynamics]
    link_masses = [0.10, 0.10, 0.05]   # kg per link (default 0.10 each)
    link_com = [0.10, 0.075, 0.025]    # m from the link's joint along it (default l/2)
    link_inertias = [...]              # kg·m² about the centre of mass (default m·l²/12)
    payload_kg = 0.0                   # point mass at the tool point
    gravity = [0.0, -9.81]             # m/s² in the arm's plane (default 0: plane horizontal)

Joint i rotates by q_i (rad) relative to link i−1; link angles φ = S·q with S the lower
triangular matrix of ones. Body b (a link's centre of mass, or the payload) sits at
p_b = Σ_s L_bs·(cos φ_s, sin φ_s), L_bs = l_s before its link, c_b on it, 0 after.
With H_sr = Σ_b m_b·L_bs·L_br the kinetic energy is T = ½·φ̇ᵀ·D(φ)·φ̇, D_sr = H_sr·cos(φ_s −
φ_r) + δ_sr·I_s, and the Euler–Lagrange equations in joint coordinates are::

    M(q)·q̈ + b(q, q̇) = τ,   M = Sᵀ·D·S,
    b = Sᵀ·(h + g),  h_s = Σ_r H_sr·sin(φ_s − φ_r)·φ̇_r²,  g_s = −(Σ_b m_b L_bs)·(G · e⊥(φ_s))

(e⊥(φ) = (−sin φ, cos φ), G the gravity vector): the centrifugal/Coriolis terms of a planar
chain written in absolute angles (e.g. Spong, Hutchinson & Vidyasagar, *Robot Modeling and
Control*, §7.4, generalised to n links).
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

#: Default mass of a link, kg (a bracket with the next servo's share of a light arm).
DEFAULT_LINK_MASS_KG = 0.10


class ArmConfigError(ValueError):
    """An arm file firmware_sim cannot use; the message names the key and the value."""


@dataclass(frozen=True)
class JointMap:
    """How a joint angle maps to its servo's position: tick = zero + direction·q·ticks/2π."""

    servo_id: int
    model: str = "xm430-w350"
    ticks_per_turn: int = 4096
    zero_offset: int = 2048
    direction: int = 1


@dataclass(frozen=True)
class ArmModel:
    """A planar arm's mass properties and its joint ↔ servo maps (SI units).

    Attributes
    ----------
    links : tuple of float
        Link lengths l_i, m.
    masses, com, inertias : tuple of float
        Per link: mass (kg), centre of mass from its joint (m), inertia about it (kg·m²).
    payload : float
        Point mass at the tool point, kg.
    gravity : tuple of float
        (gx, gy) in the arm's plane, m/s².
    joints : tuple of JointMap
    """

    links: tuple[float, ...]
    masses: tuple[float, ...]
    com: tuple[float, ...]
    inertias: tuple[float, ...]
    payload: float
    gravity: tuple[float, float]
    joints: tuple[JointMap, ...]

    @property
    def dof(self) -> int:
        return len(self.links)

    def _bodies(self) -> list[tuple[float, list[float]]]:
        """(mass, L_b·) per body: each link's centre of mass, then the payload."""
        n = self.dof
        out = []
        for b in range(n):
            out.append((self.masses[b], [self.links[s] if s < b else (self.com[b] if s == b
                                                                         else 0.0)
                                         for s in range(n)]))
        if self.payload > 0:
            out.append((self.payload, list(self.links)))
        return out

    def __post_init__(self) -> None:
        n = self.dof
        bodies = self._bodies()
        h = [[sum(m * lb[s] * lb[r] for m, lb in bodies) for r in range(n)] for s in range(n)]
        first = [sum(m * lb[s] for m, lb in bodies) for s in range(n)]
        object.__setattr__(self, "_h", h)
        object.__setattr__(self, "_first", first)

    def link_angles(self, q: Sequence[float]) -> list[float]:
        """φ = S·q: each link's angle from the base x axis."""
        out, acc = [], 0.0
        for qi in q:
            acc += qi
            out.append(acc)
        return out

    def dynamics(self, q: Sequence[float], qd: Sequence[float]
                 ) -> tuple[list[list[float]], list[float]]:
        """(M(q), b(q, q̇)): joint-space mass matrix and bias torques (module equations)."""
        n = self.dof
        h: list[list[float]] = self._h          # type: ignore[attr-defined]
        first: list[float] = self._first        # type: ignore[attr-defined]
        phi = self.link_angles(q)
        phid = self.link_angles(qd)
        c = [math.cos(p) for p in phi]
        s = [math.sin(p) for p in phi]
        d = [[h[a][b] * (c[a] * c[b] + s[a] * s[b]) for b in range(n)] for a in range(n)]
        for a in range(n):
            d[a][a] += self.inertias[a]
        gx, gy = self.gravity
        bias_phi = []
        for a in range(n):
            cor = sum(h[a][b] * (s[a] * c[b] - c[a] * s[b]) * phid[b] * phid[b]
                      for b in range(n))
            grav = -first[a] * (gx * -s[a] + gy * c[a])
            bias_phi.append(cor + grav)
        # M = Sᵀ D S: M_ij = Σ_{a ≥ i, b ≥ j} D_ab; b = Sᵀ·bias_phi: b_i = Σ_{a ≥ i}
        suffix = [[0.0] * (n + 1) for _ in range(n + 1)]
        for a in range(n - 1, -1, -1):
            for b in range(n - 1, -1, -1):
                suffix[a][b] = (d[a][b] + suffix[a + 1][b] + suffix[a][b + 1]
                                - suffix[a + 1][b + 1])
        m = [[suffix[i][j] for j in range(n)] for i in range(n)]
        bias, acc = [0.0] * n, 0.0
        for a in range(n - 1, -1, -1):
            acc += bias_phi[a]
            bias[a] = acc
        return m, bias

    def body_positions(self, q: Sequence[float]) -> list[tuple[float, float]]:
        """Centre of each body (links' centres of mass, then the payload), m."""
        phi = self.link_angles(q)
        return [(sum(lb[s] * math.cos(phi[s]) for s in range(self.dof)),
                 sum(lb[s] * math.sin(phi[s]) for s in range(self.dof)))
                for _, lb in self._bodies()]

    def energy(self, q: Sequence[float], qd: Sequence[float]) -> float:
        """Kinetic plus potential energy, J (for conservation checks)."""
        m, _ = self.dynamics(q, [0.0] * self.dof)
        kinetic = 0.5 * sum(qd[i] * m[i][j] * qd[j] for i in range(self.dof)
                            for j in range(self.dof))
        gx, gy = self.gravity
        potential = -sum(mass * (gx * x + gy * y) for (mass, _), (x, y)
                         in zip(self._bodies(), self.body_positions(q), strict=True))
        return kinetic + potential


def _number(table: Mapping[str, Any], key: str, where: str) -> float:
    value = table[key]
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ArmConfigError(f"{where}{key} = {value!r}: expected a finite number")
    return float(value)


def _per_link(table: Mapping[str, Any], key: str, n: int, default: list[float],
              positive: bool) -> tuple[float, ...]:
    if key not in table:
        return tuple(default)
    raw = table[key]
    if not isinstance(raw, list) or len(raw) != n:
        raise ArmConfigError(f"dynamics.{key} = {raw!r}: expected a list of {n} numbers "
                             "(one per link)")
    values = tuple(_number({f"{key}[{i}]": v}, f"{key}[{i}]", "dynamics.")
                   for i, v in enumerate(raw))
    for i, v in enumerate(values):
        if v < 0 or (positive and v == 0):
            raise ArmConfigError(f"dynamics.{key}[{i}] = {v!r}: must be "
                                 f"{'positive' if positive else 'non-negative'}")
    return values


def arm_from_dict(data: Mapping[str, Any]) -> ArmModel:
    """An :class:`ArmModel` from a parsed arm TOML document (keys in the module notes)."""
    try:
        links_raw = data["arm"]["links"]
        joints_raw = data["joints"]
    except (KeyError, TypeError):
        raise ArmConfigError("arm file needs [arm] links and [[joints]] tables") from None
    if not isinstance(links_raw, list) or not 2 <= len(links_raw) <= 6:
        raise ArmConfigError(f"arm.links = {links_raw!r}: expected 2 to 6 lengths in metres")
    links = tuple(_number({f"links[{i}]": v}, f"links[{i}]", "arm.")
                  for i, v in enumerate(links_raw))
    if any(v <= 0 for v in links):
        raise ArmConfigError(f"arm.links = {list(links)}: lengths must be positive")
    n = len(links)
    if not isinstance(joints_raw, list) or len(joints_raw) != n:
        raise ArmConfigError(f"joints: expected {n} [[joints]] tables, one per link")
    joints = []
    for i, j in enumerate(joints_raw):
        servo = j.get("servo") if isinstance(j, Mapping) else None
        if not isinstance(servo, Mapping) or "id" not in servo:
            raise ArmConfigError(f"joints[{i}].servo.id is missing")
        jm = JointMap(int(servo["id"]), str(servo.get("model", "xm430-w350")),
                      int(servo.get("ticks_per_turn", 4096)),
                      int(servo.get("zero_offset", int(servo.get("ticks_per_turn", 4096)) // 2)),
                      int(servo.get("direction", 1)))
        if jm.direction not in (1, -1) or jm.ticks_per_turn <= 0:
            raise ArmConfigError(f"joints[{i}].servo: direction must be ±1 and ticks_per_turn "
                                 f"positive, got {jm.direction}, {jm.ticks_per_turn}")
        joints.append(jm)
    ids = [jm.servo_id for jm in joints]
    if len(set(ids)) != len(ids):
        raise ArmConfigError(f"joints[].servo.id = {ids}: ids must be unique")
    dyn = data.get("dynamics", {})
    if not isinstance(dyn, Mapping):
        raise ArmConfigError(f"dynamics = {dyn!r}: expected a table")
    known = {"link_masses", "link_com", "link_inertias", "payload_kg", "gravity"}
    unknown = sorted(set(dyn) - known)
    if unknown:
        raise ArmConfigError(f"dynamics: unknown key(s) {', '.join(unknown)}; known: "
                             f"{', '.join(sorted(known))}")
    masses = _per_link(dyn, "link_masses", n, [DEFAULT_LINK_MASS_KG] * n, positive=True)
    com = _per_link(dyn, "link_com", n, [length / 2 for length in links], positive=False)
    inertias = _per_link(dyn, "link_inertias", n,
                         [m * length ** 2 / 12 for m, length in zip(masses, links, strict=True)],
                         positive=False)
    payload = _number(dyn, "payload_kg", "dynamics.") if "payload_kg" in dyn else 0.0
    if payload < 0:
        raise ArmConfigError(f"dynamics.payload_kg = {payload!r}: must be non-negative")
    gravity_raw = dyn.get("gravity", [0.0, 0.0])
    if gravity_raw is True:
        gravity_raw = [0.0, -9.81]
    elif gravity_raw is False:
        gravity_raw = [0.0, 0.0]
    if not isinstance(gravity_raw, list) or len(gravity_raw) != 2:
        raise ArmConfigError(f"dynamics.gravity = {gravity_raw!r}: expected [gx, gy] in m/s² "
                             "(or true for [0, -9.81])")
    gravity = (_number({"g": gravity_raw[0]}, "g", "dynamics.gravity "),
               _number({"g": gravity_raw[1]}, "g", "dynamics.gravity "))
    return ArmModel(links, masses, com, inertias, payload, gravity, tuple(joints))


def load_arm(source: str | Path | Mapping[str, Any]) -> ArmModel:
    """An :class:`ArmModel` from a TOML path or an already parsed document."""
    if isinstance(source, Mapping):
        return arm_from_dict(source)
    path = Path(source)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise ArmConfigError(f"cannot read arm file {str(path)!r}: {exc.strerror}") from None
    except tomllib.TOMLDecodeError as exc:
        raise ArmConfigError(f"arm file {str(path)!r} is not valid TOML: {exc}") from None
    return arm_from_dict(data)
