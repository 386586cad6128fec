"""How a :class:`~firmware_sim.bus.SimBus` is set up: one frozen :class:`SimBusConfig`,
and the servo layout it resolves to (:func:`layout`)."""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

from firmware_sim.arm_model import GRIPPER_INERTIA_KG_M2, ArmModel, load_arm
from firmware_sim.clock import Clock
from firmware_sim.control_table import BAUD_RATES, MODELS
from firmware_sim.motor import DEFAULT_SUPPLY_V
from firmware_sim.protocol import MAX_ID
from firmware_sim.servo.indirect import indirect_mode

TIMINGS = ("fast", "realistic")


def _frozen(value: Mapping[int, Any] | Any) -> Any:
    return MappingProxyType(dict(value)) if isinstance(value, Mapping) else value


@dataclass(frozen=True)
class SimBusConfig:
    """Everything a SimBus is built from (validated on construction; ValueError).

    Attributes
    ----------
    ids : tuple of int, optional
        Servo IDs (0..252, unique); default the arm's servos, else (1,).
    model : str or mapping id -> str
        ``"xm430-w350"`` or ``"xl430-w250"``, for all servos or per ID.
    baud : int
        Bits/s; the servos' Baud Rate item is set to match (a value of BAUD_RATES).
    timing : {"fast", "realistic"}
        ``fast``: reply as soon as possible (unit tests); ``realistic``: wire timing.
    firmware : int or mapping id -> int
        Firmware version per servo (< 45: no Fast Sync/Bulk Read).
    clock : Clock, optional
        Time base of the servos' motion (a VirtualClock lets tests jump time).
    link : str, optional
        Path of a symlink to the pty slave, created on start and removed on close.
    log : bool
        Keep a packet log.
    log_file : str, optional
        Also append every log entry to this text file.
    turnaround_s : float
        Firmware turnaround before a reply in realistic timing, s.
    fault_seed : int, optional
        Seed for probabilistic faults.
    log_limit : int
        Oldest log entries are discarded beyond this many.
    goal_limit : int
        Goal history kept per servo; older goals are dropped, so a long-running
        ``serve --sim`` does not grow without bound.
    fast_chain_stops : bool
        What later servos of a Fast Sync/Bulk Read do when an earlier one stays silent
        (undocumented): False, they append their blocks anyway; True, the chain ends.
        Either way the packet is shorter than its LEN and the SDK reports RX_CORRUPT.
    switch_interval : float or None
        While any bus runs, the interpreter's GIL switch interval is lowered to this
        (restored when the last bus closes). The SDK client spins on the port holding
        the GIL; with the default 5 ms interval the server thread can wait that long for
        it, and under CPU load long enough to miss the SDK's 34 ms timeout. None leaves
        the interpreter alone.
    dynamics : bool
        False: the kinematic model, Present Position = the profile. True: the physics
        model (:mod:`firmware_sim.drive`, :mod:`firmware_sim.dynamics`).
    arm : path or mapping, optional
        An arm TOML file (or its parsed dict): its servos drive the arm's rigid-body
        dynamics (:mod:`firmware_sim.arm_model`); needs ``dynamics=True``. Each arm servo
        (and the file's gripper servo) starts at its zero_offset, except that an arm under
        gravity with an ``[arm.rest]`` pose starts resting there when ``positions`` is not
        given (:func:`rest_ticks`).
    positions : mapping id -> int, optional
        Initial Present Position per servo (default 2048).
    supply_voltage : float
        Supply of every servo, V (physics model).
    indirect : bool or str, or mapping id -> bool or str
        How each servo's firmware treats the Indirect Address map
        (:mod:`firmware_sim.servo.indirect`): True/"on" (default) as the e-manual;
        False/"off" a WRITE to an Indirect Address answers OK and stores nothing (an older
        firmware, a clone); "unresolved" the map stores but Indirect Data does not follow
        it. Servos a mapping leaves out are "on".
    """

    ids: tuple[int, ...] | None = None
    model: str | Mapping[int, str] = "xm430-w350"
    baud: int = 1_000_000
    timing: str = "fast"
    firmware: int | Mapping[int, int] = 46
    clock: Clock | None = None
    link: str | None = None
    log: bool = True
    log_file: str | None = None
    turnaround_s: float = 30e-6
    fault_seed: int | None = None
    log_limit: int = 100_000
    goal_limit: int = 1_000_000
    fast_chain_stops: bool = False
    switch_interval: float | None = 1e-4
    dynamics: bool = False
    arm: str | os.PathLike[str] | Mapping[str, object] | None = None
    positions: Mapping[int, int] | None = None
    supply_voltage: float = DEFAULT_SUPPLY_V
    indirect: bool | str | Mapping[int, bool | str] = True

    def __post_init__(self) -> None:
        if self.ids is not None:
            object.__setattr__(self, "ids", tuple(int(i) for i in self.ids))
        for name in ("model", "firmware", "positions"):
            object.__setattr__(self, name, _frozen(getattr(self, name)))
        ind = self.indirect
        object.__setattr__(self, "indirect", _frozen(
            {int(k): indirect_mode(v) for k, v in ind.items()} if isinstance(ind, Mapping)
            else indirect_mode(ind)))
        if self.timing not in TIMINGS:
            raise ValueError(f"timing must be 'fast' or 'realistic', got {self.timing!r}")
        if int(self.baud) not in BAUD_RATES.values():
            raise ValueError(f"baud {self.baud} is not an X-series rate; choose from "
                             f"{sorted(BAUD_RATES.values())}")
        if self.turnaround_s < 0:
            raise ValueError(f"turnaround_s must be >= 0, got {self.turnaround_s}")
        if self.switch_interval is not None and not self.switch_interval > 0:
            raise ValueError(f"switch_interval must be > 0 or None, got "
                             f"{self.switch_interval}")
        if self.arm is not None and not self.dynamics:
            raise ValueError("an arm load needs the physics model: pass dynamics=True")

    @property
    def baud_index(self) -> int:
        """The Baud Rate item value of :attr:`baud`."""
        return {bps: k for k, bps in BAUD_RATES.items()}[int(self.baud)]

    def replace(self, **changes: Any) -> SimBusConfig:
        """A copy with ``changes`` (validated again)."""
        return dataclasses.replace(self, **changes)


@dataclass(frozen=True)
class ServoSpec:
    """One servo of the bus as :func:`layout` resolves it."""

    servo_id: int
    model: str
    firmware: int
    position: int
    on_arm: bool
    load_inertia: float = 0.0
    indirect: str = "on"


@dataclass(frozen=True)
class BusLayout:
    """The servos (in bus order) and the arm they drive, if any."""

    servos: tuple[ServoSpec, ...]
    arm: ArmModel | None

    @property
    def arm_ids(self) -> list[int]:
        return [jm.servo_id for jm in self.arm.joints] if self.arm is not None else []


def rest_ticks(arm: ArmModel) -> dict[int, int]:
    """Servo id → Present Position of the arm's rest pose: tick = zero_offset +
    direction·q·ticks_per_turn/2π (rounded); empty for an arm without one."""
    if arm.rest is None:
        return {}
    return {jm.servo_id: round(jm.zero_offset + jm.direction * q * jm.ticks_per_turn
                               / (2 * math.pi)) for jm, q in zip(arm.joints, arm.rest,
                                                                 strict=True)}


def _check_ids(ids: Iterable[int]) -> list[int]:
    id_list = [int(i) for i in ids]
    if not id_list:
        raise ValueError("SimBus needs at least one servo id")
    for i in id_list:
        if not 0 <= i <= MAX_ID:
            raise ValueError(f"servo id must be 0..{MAX_ID}, got {i}")
    if len(set(id_list)) != len(id_list):
        raise ValueError(f"servo ids must be unique, got {id_list}")
    return id_list


def layout(config: SimBusConfig) -> BusLayout:
    """The servos ``config`` describes: ids, models, firmware and start positions, with
    the arm file's servos (ArmConfigError, a ValueError, for a bad arm file). An arm
    file's ``[gripper]`` servo is on the bus by default (a lone shaft carrying the jaws'
    :data:`~firmware_sim.arm_model.GRIPPER_INERTIA_KG_M2`)."""
    arm = load_arm(config.arm) if config.arm is not None else None
    arm_ids = [jm.servo_id for jm in arm.joints] if arm is not None else []
    gripper = arm.gripper if arm is not None else None
    own_ids = arm_ids + ([gripper.servo_id] if gripper is not None else [])
    id_list = _check_ids(config.ids if config.ids is not None else (own_ids or (1,)))
    model = config.model
    models = dict(model) if isinstance(model, Mapping) else dict.fromkeys(id_list, model)
    start = dict(config.positions or {})
    for i in start:
        if i not in id_list:
            raise ValueError(f"positions: no servo {i} on the bus (ids {id_list})")
    if arm is not None:
        missing = [i for i in arm_ids if i not in id_list]
        if missing:
            raise ValueError(f"arm servo ids {missing} are not among the bus ids {id_list}")
        maps = [*arm.joints, *([gripper] if gripper is not None and gripper.servo_id in id_list
                               else [])]
        if not isinstance(model, Mapping):      # the arm file names its servos' models
            models.update({jm.servo_id: jm.model for jm in maps})
        if arm.rest is not None and not config.positions:
            start.update(rest_ticks(arm))        # an arm under gravity starts resting
        for jm in maps:
            start.setdefault(jm.servo_id, jm.zero_offset)
    fw = config.firmware
    firmwares = dict(fw) if isinstance(fw, Mapping) else dict.fromkeys(id_list, fw)
    for i in id_list:
        if i not in models:
            raise ValueError(f"no model given for servo id {i}")
        if models[i] not in MODELS:
            raise ValueError(f"model {models[i]!r} for servo {i} unknown; known: "
                             f"{sorted(MODELS)}")
    ind = config.indirect
    modes = dict(ind) if isinstance(ind, Mapping) else dict.fromkeys(id_list, ind)
    for i in modes:
        if i not in id_list:
            raise ValueError(f"indirect: no servo {i} on the bus (ids {id_list})")
    jaws = gripper.servo_id if gripper is not None else None
    specs = tuple(ServoSpec(i, models[i], int(firmwares.get(i, 46)), int(start.get(i, 2048)),
                            i in arm_ids, GRIPPER_INERTIA_KG_M2 if i == jaws else 0.0,
                            str(modes.get(i, "on")))
                  for i in id_list)
    return BusLayout(specs, arm)
