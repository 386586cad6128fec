"""Calibrate an arm by hand: zero offsets, directions and tick ranges from present positions.

The procedure (issue 12 §1), one :class:`Calibrator` method per step so that a surface
(``robodcn calibrate``: a terminal, a script on stdin, a test) drives the dialogue:

1. torque off on every servo (the arm can be moved by hand) — on an arm under gravity only
   when confirmed, after lowering it to its rest pose (:meth:`Calibrator.start`, the
   gravity guard), and however the calibration ends the arm then holds where it is;
2. the user puts the arm in the reference pose — every joint angle 0 as the config defines
   it — and confirms: each servo's Present Position becomes its ``zero_offset``;
3. per joint, the user turns it a little in its positive direction and confirms: the sign
   of the tick change is its ``direction`` (angle = direction·(tick − zero_offset)·2π/4096,
   robodcn.servo_units);
4. optionally, per joint, the user moves it through its whole range while Present Position
   is sampled: ``min_tick``/``max_tick`` become the extremes seen, moved inward by a margin,
   and the joint limits become the angles of those ticks (so they lie inside the tick range).
   A range whose ticks leave 0..ticks_per_turn−1 (or jump by more than three quarters of a
   turn between two samples, 20 ms apart: no hand turns a joint that fast) crosses the
   encoder's wrap: it needs Extended Position Mode (Operating Mode 4),
   which robodcn configs do not describe, so that joint's range is left as it was and noted.

:func:`updated_toml` writes the result into the input's TOML text with tomlkit, keeping its
comments and layout; the new text is validated by :func:`robodcn.config.arm_from_dict`.
"""

from __future__ import annotations

import difflib
import logging
import math
import threading
import tomllib
from collections.abc import Callable
from dataclasses import dataclass, field
from types import TracebackType
from typing import Self

import numpy as np
from numpy.typing import NDArray

from robodcn import servo_units
from robodcn._checks import is_finite_real
from robodcn.bus import ServoBus
from robodcn.config import Arm, arm_from_dict
from robodcn.errors import InputError
from robodcn.workflow.float_teach import has_gravity
from robodcn.workflow.release import ReleaseResult, hold, release, released

log = logging.getLogger(__name__)

@dataclass(frozen=True)
class JointCalibration:
    """What calibration found for one joint (ticks; angles in radians)."""

    name: str
    zero_offset: int
    direction: int
    min_tick: int | None = None
    max_tick: int | None = None
    min_angle: float | None = None
    max_angle: float | None = None
    extended_position: bool = False
    note: str = ""


@dataclass(frozen=True)
class Calibration:
    """One :class:`JointCalibration` per joint, in joint order, plus notes for the user."""

    joints: tuple[JointCalibration, ...]
    notes: tuple[str, ...] = field(default=())
    #: The gripper servo's angles (rad, tick ``zero_offset`` = 0) at open and closed, when
    #: the gripper step measured them (None: skipped, or the arm has no gripper).
    gripper: tuple[float, float] | None = None


class _Sampler:
    """Reads Present Position in a background thread while the main thread waits for input.

    The bus belongs to one thread at a time (ServoBus.claim); the main thread does not touch
    it until :meth:`stop` has joined the sampler.
    """

    def __init__(self, bus: ServoBus, period_s: float) -> None:
        self.bus = bus
        self.period_s = period_s
        self.rows: list[NDArray[np.int64]] = []
        self.error: BaseException | None = None
        self._done = threading.Event()
        self._thread = threading.Thread(target=self._run, name="calibrate sampler", daemon=True)

    def _run(self) -> None:
        try:
            while not self._done.is_set():
                self.rows.append(self.bus.read_positions())
                self._done.wait(self.period_s)
        except BaseException as exc:  # re-raised in the main thread by stop()
            self.error = exc

    def __enter__(self) -> _Sampler:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._done.set()
        self._thread.join()

    def result(self) -> NDArray[np.int64]:
        if self.error is not None:
            raise self.error
        return np.array(self.rows, dtype=np.int64)


def _range(arm: Arm, j: int, zero: int, direction: int, seen: NDArray[np.int64],
           margin_ticks: int) -> JointCalibration:
    """Tick range and joint limits of joint ``j`` from the ticks ``seen`` while it moved."""
    spec = arm.joints[j]
    ticks = spec.servo.ticks_per_turn
    name = spec.name
    jumps = np.abs(np.diff(seen)) if seen.size > 1 else np.zeros(0)
    if seen.min() < 0 or seen.max() > ticks - 1 or (jumps.size and jumps.max() > 3 * ticks // 4):
        note = (f"joint {name!r}: its range crosses the encoder wrap (ticks "
                f"{int(seen.min())}..{int(seen.max())}): that needs Extended Position Mode "
                "(Operating Mode 4); min_tick/max_tick and the joint limits were left as they "
                "were")
        return JointCalibration(name, zero, direction, extended_position=True, note=note)
    lo, hi = int(seen.min()) + margin_ticks, int(seen.max()) - margin_ticks
    if not lo < zero < hi:
        raise InputError(f"joint {name!r}: the reference pose (tick {zero}) is not inside the "
                         f"range moved through ({int(seen.min())}..{int(seen.max())} ticks, "
                         f"{margin_ticks} ticks margin): move it through its whole range",
                         field=f"joints[{j}]", value=[int(seen.min()), int(seen.max())])
    per_tick = 2.0 * math.pi / ticks
    a, b = sorted(direction * (t - zero) * per_tick for t in (lo, hi))
    # Limits in whole tenths of a degree, rounded inward so they stay inside the ticks.
    a = math.radians(math.ceil(math.degrees(a) * 10.0 - 1e-9) / 10.0)
    b = math.radians(math.floor(math.degrees(b) * 10.0 + 1e-9) / 10.0)
    return JointCalibration(name, zero, direction, lo, hi, a, b)


@dataclass(frozen=True)
class Motion:
    """What the direction step saw of one joint: ticks moved since the reference pose and
    the direction that gives (None: less than the least motion, ask again)."""

    joint: int
    moved_ticks: int
    moved_deg: float
    direction: int | None


class Calibrator:
    """The calibration procedure (module docstring) on an open ``bus`` for ``arm``, step by
    step: :meth:`read_reference`, then per joint :meth:`motion` (direction) and, optionally,
    :meth:`sampling` + :meth:`joint_range` (whole range), then :meth:`result`.

    Parameters
    ----------
    bus : open ServoBus whose servos are the arm's (in joint order)
    margin_deg : the tick range is the range seen, this much inside at each end
    min_motion_deg : least motion that counts as "moved in the positive direction"
    sample_period_s : Present Position sampling period during a range step

    A context manager. :meth:`start` switches torque off so a hand moves the arm, through
    the gravity guard (:func:`robodcn.workflow.release.release`): on an arm under gravity
    only when confirmed, after lowering it to its rest pose. Leaving, an arm under gravity
    holds where it is (:func:`robodcn.workflow.release.hold`: torque on, position mode,
    Goal Position = Present Position) however the calibration ended — finished, aborted
    (Ctrl-C, end of input) or failed — and any arm does after an abort or a failure.
    Nothing else is written to the servos.
    """

    def __init__(self, bus: ServoBus, arm: Arm, *, margin_deg: float = 2.0,
                 min_motion_deg: float = 5.0, sample_period_s: float = 0.02) -> None:
        for name, value in (("margin_deg", margin_deg), ("min_motion_deg", min_motion_deg),
                            ("sample_period_s", sample_period_s)):
            if not (is_finite_real(value) and value > 0):
                raise InputError(f"{name} must be a positive number, got {value!r}",
                                 field=name, value=value)
        self.bus = bus
        self.arm = arm
        self.margin_deg = float(margin_deg)
        self.min_motion_deg = float(min_motion_deg)
        self.sample_period_s = float(sample_period_s)
        self.zero: NDArray[np.int64] | None = None
        self._joints: dict[int, JointCalibration] = {}
        self._notes: list[str] = []
        self._skipped: set[int] = set()
        self._gripper: dict[str, float] = {}
        self._gripper_skipped = False
        #: What :meth:`start`'s release did (None before it); whether leaving held the arm.
        self.released: ReleaseResult | None = None
        self.held = False

    def start(self, *, confirm: bool = False, warn: Callable[[str], None] | None = None
              ) -> ReleaseResult:
        """Torque off so a hand moves the arm (class docstring): GravityReleaseError without
        ``confirm`` when that drops it (nothing changed); StoppedError/BusError when the
        lowering first stopped short (torque stays on); ``warn`` is told what happens."""
        self.released = released(release(self.bus, self.arm, confirm=confirm,
                                         what="calibration", warn=warn), "calibration")
        return self.released

    def __enter__(self) -> Self:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close(failed=exc is not None)

    def close(self, *, failed: bool = False) -> None:
        """The end (class docstring): hold the arm where it is if :meth:`start` let it go
        and it is under gravity or the calibration ``failed``; idempotent. A failure to hold
        is raised, or logged when the calibration failed already."""
        if self.held or self.released is None or not self.released.released:
            return
        if not failed and not has_gravity(self.arm):
            return                                  # a horizontal arm stays free
        try:
            hold(self.bus)
        except Exception as error:
            if not failed:
                raise
            log.warning("calibration: the arm could not be held: %s", error)
            return
        self.held = True

    def read_reference(self) -> NDArray[np.int64]:
        """Present Position of every servo at the reference pose: the zero offsets.

        InputError when a servo reads outside 0..ticks_per_turn−1 (a multi-turn reading).
        """
        zero = self.bus.read_positions()
        for j, spec in enumerate(self.arm.joints):
            if not 0 <= zero[j] <= spec.servo.ticks_per_turn - 1:
                raise InputError(f"joint {spec.name!r}: servo {spec.servo.id} reads tick "
                                 f"{int(zero[j])} at the reference pose, outside 0.."
                                 f"{spec.servo.ticks_per_turn - 1}: reboot it (robodcn reboot) "
                                 "so it reports a single turn, then calibrate again",
                                 field=f"joints[{j}].servo.zero_offset", value=int(zero[j]))
        self.zero = zero
        return zero

    def _zero(self, j: int) -> int:
        if self.zero is None:
            raise RuntimeError("read_reference() first")
        return int(self.zero[j])

    def motion(self, j: int) -> Motion:
        """How far joint ``j`` has turned from the reference pose, and its direction when
        that is at least ``min_motion_deg`` (recorded for :meth:`result`)."""
        ticks = self.arm.joints[j].servo.ticks_per_turn
        moved = int(self.bus.read_positions()[j]) - self._zero(j)
        direction = None
        if abs(moved) >= self.min_motion_deg / 360.0 * ticks:
            direction = 1 if moved > 0 else -1
            self._joints[j] = JointCalibration(self.arm.joints[j].name, self._zero(j), direction)
        return Motion(j, moved, moved * 360.0 / ticks, direction)

    def skip(self, j: int) -> None:
        """Leave joint ``j``'s direction and range as configured (its zero offset is the
        reference pose's); noted in the result."""
        spec = self.arm.joints[j]
        note = (f"joint {spec.name!r}: skipped; its direction ({spec.servo.direction:+d}) and "
                "range are the config's")
        self._joints[j] = JointCalibration(spec.name, self._zero(j), spec.servo.direction,
                                           note=note)
        self._skipped.add(j)
        self._notes.append(note)

    def gripper_end(self, end: str) -> float:
        """The gripper servo's angle (rad) where a hand left the jaws, as its ``end``
        ("open" | "closed"); its torque is switched off first (a gripper drops nothing)."""
        gripper = self.arm.gripper
        if gripper is None or end not in ("open", "closed"):
            raise InputError(f"no gripper end {end!r} on arm {self.arm.name!r}",
                             field="gripper", value=end)
        if not self._gripper:
            self.bus.write_torque_enabled(gripper.servo, False)
        tick = self.bus.read_position(gripper.servo)
        angle = float(servo_units.ticks_to_radians([tick], [gripper.servo])[0])
        self._gripper[end] = angle
        return angle

    def skip_gripper(self) -> None:
        """Leave the gripper's open and closed angles as configured; noted in the result."""
        self._gripper.clear()
        self._gripper_skipped = True
        self._notes.append("gripper: skipped; its open and closed angles are the config's")

    def _gripper_result(self) -> tuple[float, float] | None:
        """(open, closed) when both were measured and differ by at least min_motion_deg;
        else None (a note says why when they did not)."""
        if self._gripper_skipped or set(self._gripper) != {"open", "closed"}:
            return None
        opened, closed = self._gripper["open"], self._gripper["closed"]
        if abs(math.degrees(opened - closed)) < self.min_motion_deg:
            self._notes.append(f"gripper: open and closed are only "
                               f"{abs(math.degrees(opened - closed)):.1f}° apart; its angles "
                               "are the config's")
            return None
        return opened, closed

    def sampling(self) -> _Sampler:
        """A context that samples Present Position while the user moves a joint; the bus is
        the sampler's until the context ends."""
        return _Sampler(self.bus, self.sample_period_s)

    def joint_range(self, j: int, sampler: _Sampler) -> JointCalibration:
        """Tick range and joint limits of joint ``j`` from what ``sampler`` saw and one read
        at the end (after :meth:`motion` gave its direction); recorded for :meth:`result`."""
        done = self._joints.get(j)
        if done is None or j in self._skipped:
            raise RuntimeError(f"joint {j}: no direction measured")
        seen = sampler.result()
        end = self.bus.read_positions()
        column = np.concatenate([seen[:, j] if seen.size else [], [end[j]]])
        ticks = self.arm.joints[j].servo.ticks_per_turn
        margin = math.ceil(self.margin_deg / 360.0 * ticks)
        result = _range(self.arm, j, self._zero(j), done.direction, column.astype(np.int64),
                        margin)
        if result.note:
            self._notes.append(result.note)
        self._joints[j] = result
        log.info("calibrated %s: %s", result.name, result)
        return result

    def result(self) -> Calibration:
        """Every joint's calibration, in joint order (each joint calibrated or skipped)."""
        missing = [self.arm.joints[j].name for j in range(self.arm.dof) if j not in self._joints]
        if missing:
            raise RuntimeError(f"joints not calibrated yet: {missing}")
        gripper = self._gripper_result()
        return Calibration(tuple(self._joints[j] for j in range(self.arm.dof)),
                           tuple(self._notes), gripper)


def _set_angle(table, key: str, value: float) -> None:
    """Write an angle under ``key_deg`` (degrees, one decimal) or ``key`` (radians)."""
    if f"{key}_deg" in table or key not in table:
        table[f"{key}_deg"] = round(math.degrees(value), 1)
    else:
        table[key] = round(value, 6)


def updated_toml(text: str, calibration: Calibration, *, source: str = "<calibrated>") -> str:
    """``text`` (an arm TOML) with the calibration written in, comments and layout kept.

    Validates the result as an arm config (ConfigError naming ``source`` otherwise).
    """
    import tomlkit

    doc = tomlkit.parse(text)
    joints = doc["joints"]
    for i, cal in enumerate(calibration.joints):
        table = joints[i]
        servo = table["servo"]
        servo["zero_offset"] = cal.zero_offset
        servo["direction"] = cal.direction
        if cal.min_tick is not None and cal.max_tick is not None:
            servo["min_tick"] = cal.min_tick
            servo["max_tick"] = cal.max_tick
        if cal.min_angle is not None and cal.max_angle is not None:
            _set_angle(table, "min", cal.min_angle)
            _set_angle(table, "max", cal.max_angle)
    if calibration.gripper is not None and "gripper" in doc:
        opened, closed = calibration.gripper
        _set_angle(doc["gripper"], "open", opened)
        _set_angle(doc["gripper"], "closed", closed)
    new = tomlkit.dumps(doc)
    arm_from_dict(tomllib.loads(new), source=source)
    return new


def diff(old: str, new: str, old_name: str, new_name: str) -> str:
    """A unified diff of the two texts ('' when equal)."""
    return "".join(difflib.unified_diff(old.splitlines(keepends=True),
                                        new.splitlines(keepends=True),
                                        fromfile=old_name, tofile=new_name))
