"""One simulated X-series servo: control-table rules, motion model, errors, watchdog.

Behaviour follows the ROBOTIS e-manual (XM430-W350 / XL430-W250 control tables,
Protocol 2.0 instructions) as summarised in /work/shared/dynamixel-notes.md §1.4 to §2.1.
Time comes from a :class:`~firmware_sim.clock.Clock`; motion is evaluated analytically
(:mod:`firmware_sim.profile`) whenever the servo is touched, so nothing ticks.

Position frames: the profile runs in the *present* frame (what Present Position reads).
The motor's own position is ``actual = s·(present - Homing Offset)`` with s = -1 when
Drive Mode bit 0 (reverse) is set. Homing Offset and Drive Mode are EEPROM items, so they
change only with torque off, when the motor is at rest: the actual position is kept and
Present Position jumps.

Error precedence of a write (all-or-nothing, nothing written on any error):
Access (0x07: undefined, read-only, EEPROM while torque on) → Length (0x05: part of an
item) → Range (0x04: outside the item's range; goal items while the Bus Watchdog has
tripped) → Limit (0x06: Goal Position outside Min/Max Position Limit in mode 3, goal
PWM/current/velocity above their limit items).
"""

from __future__ import annotations

import dataclasses
import math
import struct
import threading

from firmware_sim import control_table as ct
from firmware_sim.arm_model import ArmModel
from firmware_sim.clock import Clock, RealClock
from firmware_sim.control_table import (
    ALERT_BIT,
    ERR_ACCESS,
    ERR_DATA_LENGTH,
    ERR_DATA_LIMIT,
    ERR_DATA_RANGE,
    ERR_INSTRUCTION,
    ERR_RESULT_FAIL,
    MODELS,
    TABLE_SIZE,
    ControlTable,
    Item,
    indirect_data_slot,
)
from firmware_sim.drive import PULSES_PER_RAD, Drive, DriveSettings
from firmware_sim.dynamics import Plant
from firmware_sim.motor import CURRENT_UNIT_A, DEFAULT_SUPPLY_V, MOTORS, PWM_FULL
from firmware_sim.profile import (
    ACCELERATION_UNIT,
    VELOCITY_UNIT,
    Profile,
    hold,
    plan_time_based,
    plan_velocity_based,
    plan_velocity_mode,
)

#: Parameters of CLEAR (0x10) for a multi-turn clear: 0x01 'D' 'X' 'L' '"'.
CLEAR_MULTI_TURN = b"\x01DXL\x22"
#: Magic of CONTROL_TABLE_BACKUP (0x20) after the option byte: 'C' 'T' 'R' 'L'.
BACKUP_MAGIC = b"CTRL"
BACKUP_STORE = 0x01
BACKUP_RESTORE = 0x02
#: FACTORY_RESET options: reset all / all but ID / all but ID and Baud Rate.
RESET_ALL, RESET_KEEP_ID, RESET_KEEP_ID_BAUD = 0xFF, 0x01, 0x02
#: Bus Watchdog unit, s (e-manual: 20 ms).
WATCHDOG_UNIT_S = 0.020
#: Pulses per revolution (12-bit absolute encoder).
PULSES_PER_REV = 4096
#: Startup Configuration (60) bits (fw >= 45).
STARTUP_TORQUE_ON = 0x01
STARTUP_RAM_RESTORE = 0x02
#: First firmware with CONTROL_TABLE_BACKUP on the X430 (e-manual: Backup Ready from V45).
BACKUP_MIN_FIRMWARE = 45
#: Default boot delay after REBOOT / FACTORY_RESET / restore, s (the servo ignores the bus).
BOOT_DELAY_S = 0.01

_POSITION_MODES = (ct.MODE_POSITION, ct.MODE_EXTENDED_POSITION, ct.MODE_CURRENT_POSITION)
_GOALS = (ct.GOAL_PWM, ct.GOAL_CURRENT, ct.GOAL_VELOCITY, ct.GOAL_POSITION)


# Realtime Tick, Moving, Moving Status at 120; Present Velocity, Present Position,
# Velocity Trajectory, Position Trajectory at 128
_TICK_MOVING = struct.Struct("<HBB")
_VEL_POS_TRAJ = struct.Struct("<iiii")
_S8 = struct.Struct("<b")
_S32 = struct.Struct("<i")
_S16 = struct.Struct("<h")
_U16 = struct.Struct("<H")
_U32 = struct.Struct("<I")


def couple_arm(arm: ArmModel, servos: list[Servo]) -> Plant:
    """Put ``servos`` (in the arm's joint order, physics model, one shared lock) on one
    plant carrying the arm's rigid bodies; returns it."""
    t0 = servos[0].clock.now()
    drives = []
    for s in servos:
        if s._drive is None:
            raise ValueError(f"servo {s.id}: an arm needs the physics model (dynamics=True)")
        drives.append(s._drive)
    plant = Plant(drives, [s._plant.theta[0] for s in servos], t0, arm=arm)  # type: ignore[union-attr]
    plant.owners = list(servos)
    for j, s in enumerate(servos):
        s._plant = plant
        s._joint = j
    return plant


def _round(x: float) -> int:
    return math.floor(x + 0.5)


def _touches_indirect_data(address: int, length: int) -> bool:
    return any(address < data_base + count and data_base < address + length
               for _, data_base, count in ct.INDIRECT_BANKS)


def _wrap32(x: int) -> int:
    """Two's-complement wrap to int32, as the firmware's 4-byte items do."""
    return (x + (1 << 31)) % (1 << 32) - (1 << 31)


class Servo:
    """A simulated X-series servo.

    Parameters
    ----------
    servo_id : int
        Initial ID (0..252).
    model : str
        Key of :data:`firmware_sim.control_table.MODELS`.
    firmware : int
        Firmware Version item (6); below 45 the bus gives no fast-read replies.
    baud_index : int
        Initial Baud Rate item (8), 0..7 (see ``BAUD_RATES``).
    clock : Clock, optional
        Time source; :class:`RealClock` by default.
    position : int
        Initial Present Position, pulse (actual position with Homing Offset 0).
    boot_delay_s : float
        How long :meth:`booting` stays true after a reboot.
    dynamics : bool
        False: the kinematic model (Present Position is the profile position). True: the
        physics model: the firmware's controller drives a DC motor, gearbox and load
        (:mod:`firmware_sim.drive`, :mod:`firmware_sim.dynamics`), and Present Velocity,
        Current, PWM, Load, Input Voltage and Temperature follow it.
    supply_voltage : float
        Supply, V (physics model; Present Input Voltage reads it).
    lock : threading.RLock, optional
        Shared with the other servos of one arm (their shafts are coupled).

    Notes
    -----
    :meth:`read` and :meth:`write` bring motion and watchdog up to ``clock.now()`` first.
    Thread-safe (one internal re-entrant lock).
    """

    def __init__(self, servo_id: int, model: str = "xm430-w350", *, firmware: int = 46,
                 baud_index: int = 3, clock: Clock | None = None, position: int = 2048,
                 boot_delay_s: float = BOOT_DELAY_S, dynamics: bool = False,
                 supply_voltage: float = DEFAULT_SUPPLY_V,
                 lock: threading.RLock | None = None) -> None:
        if model not in MODELS:
            raise ValueError(f"model {model!r} unknown; known: {sorted(MODELS)}")
        spec = MODELS[model]
        if not 0 <= int(servo_id) <= 252:
            raise ValueError(f"servo_id must be 0..252, got {servo_id!r}")
        if int(baud_index) not in ct.BAUD_RATES:
            raise ValueError(f"baud_index must be one of {sorted(ct.BAUD_RATES)}, got "
                             f"{baud_index!r}")
        if not 0 <= int(firmware) <= 255:
            raise ValueError(f"firmware must be 0..255, got {firmware!r}")
        if not boot_delay_s >= 0:
            raise ValueError(f"boot_delay_s must be >= 0, got {boot_delay_s!r}")
        if not -(1 << 31) <= int(position) < (1 << 31):
            raise ValueError(f"position must fit Present Position (int32), got {position!r}")
        self.model = model
        self.spec = spec
        self.clock: Clock = clock if clock is not None else RealClock()
        self.boot_delay_s = float(boot_delay_s)
        self.table = ControlTable(spec)
        self._lock = lock if lock is not None else threading.RLock()
        if not (math.isfinite(supply_voltage) and 0 < supply_voltage <= 30):
            raise ValueError(f"supply_voltage must be in (0, 30] V, got {supply_voltage!r}")
        self._firmware = int(firmware)
        self.table.set(ct.FIRMWARE_VERSION, self._firmware)
        self.table.set(ct.ID, int(servo_id))
        self.table.set(ct.BAUD_RATE, int(baud_index))
        now = self.clock.now()
        self._boot_time = now
        self._boot_until = now        # constructed servos are up at once
        self._profile: Profile = hold(now, float(position))
        self._drive: Drive | None = None
        self._plant: Plant | None = None
        self._joint = 0
        if dynamics:
            self._drive = Drive(MOTORS[model], self._physical_fault, supply_voltage)
            self._plant = Plant([self._drive], [float(position) / PULSES_PER_RAD], now)
            self._plant.owners = [self]
        self._last_instruction = now
        self._watchdog_tripped = False
        self._watchdog_armed_at = now
        self._registered: tuple[int, bytes] | None = None
        self._backup: dict[int, bytes] | None = None
        self._reset_goals()

    # ---- live properties ----------------------------------------------------------
    @property
    def id(self) -> int:
        return self.table.get(ct.ID)

    @property
    def model_number(self) -> int:
        return self.table.get(ct.MODEL_NUMBER)

    @property
    def firmware_version(self) -> int:
        return self.table.get(ct.FIRMWARE_VERSION)

    @firmware_version.setter
    def firmware_version(self, value: int) -> None:
        if not 0 <= int(value) <= 255:
            raise ValueError(f"firmware_version must be 0..255, got {value!r}")
        with self._lock:
            self._firmware = int(value)
            self.table.set(ct.FIRMWARE_VERSION, self._firmware)

    @property
    def secondary_id(self) -> int | None:
        """Secondary (Shadow) ID (12): the servo also executes packets for it, never
        replying to them; None when 255 (off)."""
        value = self.table.get(ct.SECONDARY_ID)
        return None if value == 255 else value

    @property
    def protocol_type(self) -> int:
        return self.table.get(ct.PROTOCOL_TYPE)

    @property
    def baud_index(self) -> int:
        return self.table.get(ct.BAUD_RATE)

    @property
    def return_delay_us(self) -> float:
        """Return Delay Time (9) in µs (2 µs a unit)."""
        return 2.0 * self.table.get(ct.RETURN_DELAY_TIME)

    @property
    def status_return_level(self) -> int:
        return self.table.get(ct.STATUS_RETURN_LEVEL)

    @property
    def hardware_error(self) -> int:
        return self.table.get(ct.HARDWARE_ERROR_STATUS)

    @property
    def torque_enabled(self) -> bool:
        with self._lock:
            self.update()
            return bool(self.table.get(ct.TORQUE_ENABLE))

    @property
    def operating_mode(self) -> int:
        return self.table.get(ct.OPERATING_MODE)

    @property
    def goal_position(self) -> int:
        return self.table.get(ct.GOAL_POSITION)

    @property
    def present_position(self) -> int:
        with self._lock:
            self.update()
            return self.table.get(ct.PRESENT_POSITION)

    @property
    def present_velocity(self) -> int:
        with self._lock:
            self.update()
            return self.table.get(ct.PRESENT_VELOCITY)

    @property
    def moving(self) -> bool:
        with self._lock:
            self.update()
            return bool(self.table.get(ct.MOVING))

    @property
    def watchdog_tripped(self) -> bool:
        with self._lock:
            self.update()
            return self._watchdog_tripped

    @property
    def profile(self) -> Profile:
        """The motion plan in force (present-position frame, pulses and seconds)."""
        return self._profile

    def get(self, address: int) -> int:
        """Typed value of the item at ``address`` after :meth:`update` (test convenience)."""
        with self._lock:
            self.update()
            return self.table.get(address)

    # ---- time -----------------------------------------------------------------------
    def booting(self) -> bool:
        """True while the servo is rebooting (it ignores the bus then)."""
        return self.clock.now() < self._boot_until

    def note_instruction(self) -> None:
        """An instruction addressed to this servo arrived: feed the Bus Watchdog."""
        with self._lock:
            self.update()
            self._last_instruction = self.clock.now()

    def update(self) -> None:
        """Advance the watchdog and the live items (Present *, Moving, tick...) to now."""
        with self._lock:
            now = self.clock.now()
            plant = self._plant
            if plant is not None:
                deadline = self._watchdog_deadline()
                if deadline is not None and deadline <= now:
                    plant.advance(deadline)      # the stop happens at the deadline
                self._check_watchdog(now)
                plant.advance(now)
                self._refresh_physics(now)
                return
            self._check_watchdog(now)
            self._refresh(now)

    def _watchdog_deadline(self) -> float | None:
        data = self.table.data
        wd = _S8.unpack_from(data, ct.BUS_WATCHDOG)[0]
        if self._watchdog_tripped or wd <= 0 or not data[ct.TORQUE_ENABLE]:
            return None
        return max(self._last_instruction, self._watchdog_armed_at) + wd * WATCHDOG_UNIT_S

    def _check_watchdog(self, now: float) -> None:
        data = self.table.data
        wd = _S8.unpack_from(data, ct.BUS_WATCHDOG)[0]
        if self._watchdog_tripped or wd <= 0 or not data[ct.TORQUE_ENABLE]:
            return
        deadline = max(self._last_instruction, self._watchdog_armed_at) + wd * WATCHDOG_UNIT_S
        if deadline <= now:
            # stop at once where the profile was at the deadline (profile treated as 0/0)
            p, _ = self._profile.state(deadline)
            self._profile = hold(deadline, p)
            self._watchdog_tripped = True
            self.table.set(ct.BUS_WATCHDOG, -1)
            # e-manual Bus Watchdog example: on the stop both profile items become 0
            self.table.set(ct.PROFILE_VELOCITY, 0)
            self.table.set(ct.PROFILE_ACCELERATION, 0)

    def _refresh(self, now: float) -> None:
        # hot path (every read): struct on the byte image rather than typed item access
        data = self.table.data
        prof = self._profile
        p, v = prof.state(now)
        vel = _wrap32(_round(v / VELOCITY_UNIT))
        pos = _wrap32(_round(p))
        ongoing = prof.ongoing(now)
        moving = ongoing or abs(vel) > _U32.unpack_from(data, ct.MOVING_THRESHOLD)[0]
        status = prof.kind
        if ongoing:
            status |= ct.MS_PROFILE_ONGOING
        elif (data[ct.TORQUE_ENABLE] and data[ct.OPERATING_MODE] in _POSITION_MODES
              and pos == _S32.unpack_from(data, ct.GOAL_POSITION)[0]):
            status |= ct.MS_IN_POSITION
        # the epsilon keeps 1.234 s from reading 1233 ms through float rounding
        tick = math.floor((now - self._boot_time) * 1000.0 + 1e-6) % 32768
        _TICK_MOVING.pack_into(data, ct.REALTIME_TICK, tick, int(moving), status)
        _VEL_POS_TRAJ.pack_into(data, ct.PRESENT_VELOCITY, vel, pos, vel, pos)
        data[ct.REGISTERED_INSTRUCTION] = int(self._registered is not None)
        data[ct.BACKUP_READY] = int(self._backup is not None)

    def _refresh_physics(self, now: float) -> None:
        """Live items from the plant (position, velocity) and the drive (PWM, current,
        voltage, temperature); the trajectory items from the profile."""
        data = self.table.data
        drive = self._drive
        plant = self._plant
        assert drive is not None and plant is not None
        j = self._joint
        sign = -1 if data[ct.DRIVE_MODE] & ct.DRIVE_REVERSE else 1
        homing = _S32.unpack_from(data, ct.HOMING_OFFSET)[0]
        actual = plant.theta[j] * PULSES_PER_RAD - drive.turns
        pos = _wrap32(_round(sign * actual + homing))
        vel = _wrap32(_round(sign * plant.omega[j] * PULSES_PER_RAD / VELOCITY_UNIT))
        prof = self._profile
        p_d, v_d = prof.state(now)
        ongoing = prof.ongoing(now)
        threshold = _U32.unpack_from(data, ct.MOVING_THRESHOLD)[0]
        moving = ongoing or abs(vel) > threshold
        status = prof.kind
        if ongoing:
            status |= ct.MS_PROFILE_ONGOING
        elif (data[ct.TORQUE_ENABLE] and data[ct.OPERATING_MODE] in _POSITION_MODES
              and abs(pos - _S32.unpack_from(data, ct.GOAL_POSITION)[0]) <= threshold):
            # inference: "in position" within the Moving Threshold of the goal
            status |= ct.MS_IN_POSITION
        tick = math.floor((now - self._boot_time) * 1000.0 + 1e-6) % 32768
        _TICK_MOVING.pack_into(data, ct.REALTIME_TICK, tick, int(moving), status)
        _VEL_POS_TRAJ.pack_into(data, ct.PRESENT_VELOCITY, vel, pos,
                                _wrap32(_round(v_d / VELOCITY_UNIT)), _wrap32(_round(p_d)))
        _S16.pack_into(data, ct.PRESENT_PWM, max(-PWM_FULL, min(PWM_FULL, _round(
            sign * drive.duty * PWM_FULL))))
        if self.spec.has_current:
            present_current = _round(sign * drive.current / CURRENT_UNIT_A)
        else:          # Present Load: 0.1 % of the rated stall current
            present_current = _round(sign * 1000.0 * drive.current / drive.motor.stall_current)
        _S16.pack_into(data, ct.PRESENT_CURRENT, max(-32768, min(32767, present_current)))
        volts = _round(drive.supply_voltage / 0.1)
        _U16.pack_into(data, ct.PRESENT_INPUT_VOLTAGE, volts)
        data[ct.PRESENT_TEMPERATURE] = max(0, min(255, _round(drive.thermal.temperature)))
        data[ct.REGISTERED_INSTRUCTION] = int(self._registered is not None)
        data[ct.BACKUP_READY] = int(self._backup is not None)
        lo = _U16.unpack_from(data, ct.MIN_VOLTAGE_LIMIT)[0]
        hi = _U16.unpack_from(data, ct.MAX_VOLTAGE_LIMIT)[0]
        if not lo <= volts <= hi and not data[ct.HARDWARE_ERROR_STATUS] & ct.HW_INPUT_VOLTAGE:
            self._physical_fault(ct.HW_INPUT_VOLTAGE, now)

    def _configure_drive(self) -> None:
        """Snapshot what the drive reads from the control table (before plant steps)."""
        drive = self._drive
        assert drive is not None
        t = self.table
        xm = self.spec.has_current
        stall = drive.supply_voltage / drive.motor.resistance
        drive.settings = DriveSettings(
            torque_on=bool(t.data[ct.TORQUE_ENABLE]),
            mode=t.get(ct.OPERATING_MODE),
            sign=self._sign(),
            homing=t.get(ct.HOMING_OFFSET),
            kpp=t.get(ct.POSITION_P_GAIN) / 128.0,
            kpi=t.get(ct.POSITION_I_GAIN) / 65536.0,
            kpd=t.get(ct.POSITION_D_GAIN) / 16.0,
            kff1=t.get(ct.FEEDFORWARD_1ST_GAIN) / 4.0,
            kff2=t.get(ct.FEEDFORWARD_2ND_GAIN) / 4.0,
            kvp=t.get(ct.VELOCITY_P_GAIN) / 128.0,
            kvi=t.get(ct.VELOCITY_I_GAIN) / 65536.0,
            pwm_limit=float(abs(t.get(ct.GOAL_PWM))),
            goal_pwm=float(t.get(ct.GOAL_PWM)),
            goal_current=(t.get(ct.GOAL_CURRENT) * CURRENT_UNIT_A if xm else stall),
            current_limit=(t.get(ct.CURRENT_LIMIT) * CURRENT_UNIT_A if xm else stall),
            profile=self._profile,
            temperature_limit=float(t.get(ct.TEMPERATURE_LIMIT)),
            voltage_ok=True,
        )

    def _physical_fault(self, bits: int, t: float) -> None:
        """A fault with a physical cause (overload, overheating, voltage) at time ``t``:
        Hardware Error Status gets ``bits``; Shutdown (63) bits turn the torque off."""
        table = self.table
        old = table.get(ct.HARDWARE_ERROR_STATUS)
        if old & bits == bits and not table.data[ct.TORQUE_ENABLE]:
            return
        table.set(ct.HARDWARE_ERROR_STATUS, old | bits)
        if bits & table.get(ct.SHUTDOWN) and table.data[ct.TORQUE_ENABLE]:
            table.set(ct.TORQUE_ENABLE, 0)
            self._hold_here(t)
            if self._drive is not None:       # the bridge opens at once
                self._drive.current = self._drive.duty = 0.0
        if self._drive is not None:
            self._configure_drive()

    # ---- frames ---------------------------------------------------------------------
    def _actual_now(self, now: float) -> float:
        """The motor's multi-turn position counter (actual frame), pulses."""
        if self._plant is None:
            return self._actual(self._profile.state(now)[0])
        assert self._drive is not None
        return self._plant.theta[self._joint] * PULSES_PER_RAD - self._drive.turns

    def _present_now(self, now: float) -> float:
        """Present Position as a float (present frame), pulses."""
        if self._plant is None:
            return self._profile.state(now)[0]
        return self._present(self._actual_now(now))

    def _set_actual(self, now: float, actual: float) -> None:
        """Make the counter read ``actual`` (the shaft stays put); the profile holds there."""
        if self._plant is not None:
            assert self._drive is not None
            self._drive.turns = self._plant.theta[self._joint] * PULSES_PER_RAD - actual
            self._drive.reset_controllers()
        self._profile = hold(now, self._present(actual))

    def _hold_here(self, now: float) -> float:
        """The profile stops where the servo is (kinematic: the profile's own position);
        returns that position."""
        p = self._present_now(now)
        self._profile = hold(now, p)
        if self._drive is not None:
            self._drive.reset_controllers()
        return p

    def _sign(self) -> int:
        return -1 if self.table.get(ct.DRIVE_MODE) & ct.DRIVE_REVERSE else 1

    def _actual(self, present: float) -> float:
        return self._sign() * (present - self.table.get(ct.HOMING_OFFSET))

    def _present(self, actual: float) -> float:
        return self._sign() * actual + self.table.get(ct.HOMING_OFFSET)

    # ---- read -----------------------------------------------------------------------
    def read(self, address: int, length: int) -> tuple[int, bytes]:
        """READ: (error code, data); data is b"" on error.

        A read must start on a defined item and stay inside the table, else it is an
        Access Error; undefined gaps inside a longer block read 0 (block reads of the
        table work on the firmware). Indirect Data bytes read the
        byte their Indirect Address names (unless that is itself an Indirect Data byte:
        then the stored byte, so the factory self-mapping behaves as plain RAM).
        """
        with self._lock:
            self.update()
            if length <= 0:
                return ERR_DATA_LENGTH, b""
            if address < 0 or address + length > TABLE_SIZE or self.spec.owner(address) is None:
                return ERR_ACCESS, b""
            out = bytearray(self.table.raw(address, length))
            if not _touches_indirect_data(address, length):
                return 0, bytes(out)
            for i in range(length):
                slot = indirect_data_slot(address + i)
                if slot is not None:
                    target = self.table.get(slot)
                    if indirect_data_slot(target) is None:
                        out[i] = self.table.data[target]
            return 0, bytes(out)

    # ---- write ----------------------------------------------------------------------
    def write(self, address: int, data: bytes) -> int:
        """WRITE: error code (0 = ok). All-or-nothing; see the module notes for codes."""
        with self._lock:
            self.update()
            code, items = self._validate(address, bytes(data))
            if code:
                return code
            return self._commit(items)

    def _resolve(self, address: int, data: bytes) -> tuple[int, dict[Item, dict[int, int]]]:
        """Map written bytes to target items (through indirect data); error on bad access."""
        if not data:
            return ERR_DATA_LENGTH, {}
        if address < 0 or address + len(data) > TABLE_SIZE:
            return ERR_ACCESS, {}
        items: dict[Item, dict[int, int]] = {}
        for i, byte in enumerate(data):
            a = address + i
            slot = indirect_data_slot(a)
            if slot is not None:
                target = self.table.get(slot)
                # an Indirect Data target (the factory mapping points each at itself) is
                # not followed: the data byte is then plain storage
                if indirect_data_slot(target) is None:
                    a = target
            owner = self.spec.owner(a)
            if owner is None or not owner.writable:
                return ERR_ACCESS, {}
            items.setdefault(owner, {})[a - owner.address] = byte
        return 0, items

    def _validate(self, address: int, data: bytes) -> tuple[int, dict[Item, int]]:
        code, raw = self._resolve(address, data)
        if code:
            return code, {}
        t = self.table
        torque = t.get(ct.TORQUE_ENABLE)
        if torque and any(it.eeprom for it in raw):
            return ERR_ACCESS, {}
        if any(len(parts) != it.size for it, parts in raw.items()):
            return ERR_DATA_LENGTH, {}
        values = {it: it.decode(bytes(parts[k] for k in range(it.size)))
                  for it, parts in raw.items()}
        for it, value in values.items():
            if not it.in_range(value):
                return ERR_DATA_RANGE, {}
            if self._watchdog_tripped and (it.address in _GOALS
                                           or (it.address == ct.BUS_WATCHDOG and value)):
                return ERR_DATA_RANGE, {}
        for it, value in values.items():
            if it.limit and not self._within_limit(it.limit, value):
                return ERR_DATA_LIMIT, {}
        if values.get(self.spec.items[ct.TORQUE_ENABLE]) == 1 and not torque and \
                t.get(ct.HARDWARE_ERROR_STATUS) & t.get(ct.SHUTDOWN):
            return ERR_RESULT_FAIL, {}     # shut down: only a reboot re-enables torque
        return 0, values

    def _within_limit(self, kind: str, value: int) -> bool:
        t = self.table
        if kind == "pwm":
            return abs(value) <= t.get(ct.PWM_LIMIT)
        if kind == "current":
            return abs(value) <= t.get(ct.CURRENT_LIMIT)
        if kind == "velocity":
            return abs(value) <= t.get(ct.VELOCITY_LIMIT)
        if t.get(ct.OPERATING_MODE) == ct.MODE_POSITION:
            return t.get(ct.MIN_POSITION_LIMIT) <= value <= t.get(ct.MAX_POSITION_LIMIT)
        return True

    def _commit(self, values: dict[Item, int]) -> int:
        t = self.table
        now = self.clock.now()
        written = {it.address for it in values}
        old_torque = t.get(ct.TORQUE_ENABLE)
        actual = self._actual_now(now)
        old_mode = t.get(ct.OPERATING_MODE)
        for it in sorted(values, key=lambda it: it.address):
            t.set(it.address, values[it])
        if written & {ct.HOMING_OFFSET, ct.DRIVE_MODE}:
            self._set_actual(now, actual)
        if ct.OPERATING_MODE in written and t.get(ct.OPERATING_MODE) != old_mode:
            # e-manual: a mode change resets the profile and the goal PWM/current; entering
            # (extended) position control re-reads the absolute encoder (one turn)
            if t.get(ct.OPERATING_MODE) in (ct.MODE_POSITION, ct.MODE_EXTENDED_POSITION):
                self._single_turn(now)
            for a in (ct.PROFILE_VELOCITY, ct.PROFILE_ACCELERATION):
                if a not in written:
                    t.set(a, 0)
            self._reset_goals(keep=written)
        if ct.TORQUE_ENABLE in written:
            new_torque = t.get(ct.TORQUE_ENABLE)
            if new_torque and not old_torque:
                self._torque_on(now, keep_goal=ct.GOAL_POSITION in written)
            elif old_torque and not new_torque:
                self._hold_here(now)
        if ct.BUS_WATCHDOG in written:
            if t.get(ct.BUS_WATCHDOG) == 0:
                self._watchdog_tripped = False
            self._watchdog_armed_at = now
        if ct.GOAL_POSITION in written or ct.GOAL_VELOCITY in written:
            self._goal_changed(now, ct.GOAL_POSITION in written)
        self._refresh(now)
        return 0

    def _single_turn(self, now: float) -> None:
        """Present Position back to the absolute encoder's one-turn value (plus offset)."""
        self._set_actual(now, self._actual_now(now) % PULSES_PER_REV)

    def _torque_on(self, now: float, keep_goal: bool) -> None:
        # the servo holds where it is; the goal follows the present position. In
        # position control mode torque-on re-reads the absolute encoder (e-manual note)
        if self.table.get(ct.OPERATING_MODE) == ct.MODE_POSITION:
            self._single_turn(now)
        p = self._hold_here(now)
        if not keep_goal:
            self.table.set(ct.GOAL_POSITION, _round(p))
        self._watchdog_armed_at = now

    def _goal_changed(self, now: float, position: bool) -> None:
        t = self.table
        mode = t.get(ct.OPERATING_MODE)
        if not t.get(ct.TORQUE_ENABLE):
            if not (t.get(ct.DRIVE_MODE) & ct.DRIVE_TORQUE_ON_BY_GOAL) or \
                    t.get(ct.HARDWARE_ERROR_STATUS) & t.get(ct.SHUTDOWN):
                return
            t.set(ct.TORQUE_ENABLE, 1)
            self._torque_on(now, keep_goal=True)
        p, v = self._profile.state(now)
        if mode in _POSITION_MODES and position:
            self._profile = self._plan_position(now, p, v, t.get(ct.GOAL_POSITION))
        elif mode == ct.MODE_VELOCITY and not position:
            accel = t.get(ct.PROFILE_ACCELERATION) * ACCELERATION_UNIT
            self._profile = plan_velocity_mode(now, p, v,
                                               t.get(ct.GOAL_VELOCITY) * VELOCITY_UNIT, accel)

    def _plan_position(self, now: float, p: float, v: float, goal: int) -> Profile:
        t = self.table
        pv, pa = t.get(ct.PROFILE_VELOCITY), t.get(ct.PROFILE_ACCELERATION)
        if t.get(ct.DRIVE_MODE) & ct.DRIVE_TIME_BASED:
            return plan_time_based(now, p, v, goal, pv / 1000.0, pa / 1000.0)
        if pv > 0:
            pv = min(pv, t.get(ct.VELOCITY_LIMIT))
        key = ("velocity-based", goal, pv, pa)
        if self._profile.key == key:
            # the same goal again (streaming): the plan in force (running or finished)
            # already answers it; re-planning would only add float noise
            return self._profile
        plan = plan_velocity_based(now, p, v, goal, pv * VELOCITY_UNIT, pa * ACCELERATION_UNIT)
        return dataclasses.replace(plan, key=key)

    def _reset_goals(self, keep: set[int] | frozenset[int] = frozenset()) -> None:
        t = self.table
        if ct.GOAL_PWM not in keep:
            t.set(ct.GOAL_PWM, t.get(ct.PWM_LIMIT))
        if self.spec.has_current and ct.GOAL_CURRENT not in keep:
            t.set(ct.GOAL_CURRENT, t.get(ct.CURRENT_LIMIT))
        if ct.GOAL_POSITION not in keep:
            t.set(ct.GOAL_POSITION, _round(self._present_now(self.clock.now())))

    # ---- registered write -------------------------------------------------------------
    def reg_write(self, address: int, data: bytes) -> int:
        """REG_WRITE: validate now, store; :meth:`action` applies it. Registered Instruction = 1."""
        with self._lock:
            self.update()
            code, _ = self._validate(address, bytes(data))
            if code:
                return code
            self._registered = (int(address), bytes(data))
            self._refresh(self.clock.now())
            return 0

    def action(self) -> int:
        """ACTION: apply the registered write (re-validated now); ERR_INSTRUCTION if none."""
        with self._lock:
            self.update()
            if self._registered is None:
                return ERR_INSTRUCTION
            address, data = self._registered
            self._registered = None
            code = self.write(address, data)
            self._refresh(self.clock.now())
            return code

    # ---- errors ---------------------------------------------------------------------
    def status_error(self, code: int) -> int:
        """ERR byte for a status packet: ``code`` plus the alert bit while Hardware Error
        Status is non-zero."""
        return code | ALERT_BIT if self.table.get(ct.HARDWARE_ERROR_STATUS) else code

    def trip(self, bits: int) -> None:
        """Inject hardware error ``bits`` (Shutdown bits: 0x01 voltage, 0x04 overheat,
        0x08 encoder, 0x10 electrical shock, 0x20 overload). Torque goes off if any bit is
        set in Shutdown (63); only a reboot clears the status."""
        if not 0 < int(bits) <= 0xFF:
            raise ValueError(f"hardware error bits must be 1..255, got {bits!r}")
        with self._lock:
            self.update()
            t = self.table
            t.set(ct.HARDWARE_ERROR_STATUS, t.get(ct.HARDWARE_ERROR_STATUS) | int(bits))
            if int(bits) & t.get(ct.SHUTDOWN) and t.get(ct.TORQUE_ENABLE):
                now = self.clock.now()
                t.set(ct.TORQUE_ENABLE, 0)
                self._hold_here(now)
            self._refresh(self.clock.now())

    # ---- reboot, reset, clear, backup -------------------------------------------------
    def reboot(self) -> None:
        """REBOOT: torque off, RAM (64+) to defaults, hardware error cleared, multi-turn
        lost (the absolute encoder reports one revolution), boot delay starts."""
        with self._lock:
            self.update()
            self._reboot(self.clock.now())

    def _reboot(self, now: float) -> None:
        actual = self._actual_now(now) % PULSES_PER_REV
        self.table.reset(lambda it: not it.eeprom)
        self._registered = None
        self._watchdog_tripped = False
        self._set_actual(now, actual)
        self._reset_goals()
        self._boot_time = now
        self._boot_until = now + self.boot_delay_s
        self._last_instruction = self._watchdog_armed_at = now
        startup = self.table.get(ct.STARTUP_CONFIGURATION)
        if startup & STARTUP_RAM_RESTORE and self._backup is not None:
            self.table.restore(self._ram_part(self._backup))
            self.table.set(ct.GOAL_POSITION, _round(self._profile.state(now)[0]))
        if startup & STARTUP_TORQUE_ON:
            self.table.set(ct.TORQUE_ENABLE, 1)
            self._torque_on(now, keep_goal=False)
        self._refresh(now)

    @staticmethod
    def _ram_part(saved: dict[int, bytes]) -> dict[int, bytes]:
        return {a: raw for a, raw in saved.items() if a >= ct.EEPROM_END}

    def factory_reset(self, option: int) -> int:
        """FACTORY_RESET: 0xFF all items, 0x01 all but ID, 0x02 all but ID and Baud Rate;
        then reboot. Another option is a Data Range Error and changes nothing."""
        with self._lock:
            self.update()
            if option not in (RESET_ALL, RESET_KEEP_ID, RESET_KEEP_ID_BAUD):
                return ERR_DATA_RANGE
            now = self.clock.now()
            actual = self._actual_now(now)
            keep = {ct.MODEL_NUMBER, ct.FIRMWARE_VERSION}
            if option in (RESET_KEEP_ID, RESET_KEEP_ID_BAUD):
                keep.add(ct.ID)
            if option == RESET_KEEP_ID_BAUD:
                keep.add(ct.BAUD_RATE)
            self.table.reset(lambda it: it.address not in keep)
            self.table.set(ct.FIRMWARE_VERSION, self._firmware)
            self._set_actual(now, actual)
            self._reboot(now)
            return 0

    def clear(self, params: bytes) -> int:
        """CLEAR multi-turn (params 0x01 'D' 'X' 'L' '"'): Present Position back into one
        revolution of the actual position. Result Fail while moving."""
        with self._lock:
            self.update()
            params = bytes(params)
            if len(params) != len(CLEAR_MULTI_TURN):
                return ERR_DATA_LENGTH
            if params != CLEAR_MULTI_TURN:
                return ERR_DATA_RANGE
            now = self.clock.now()
            if self.table.get(ct.MOVING) or self._profile.ongoing(now):
                return ERR_RESULT_FAIL
            actual = self._actual_now(now) % PULSES_PER_REV
            self._set_actual(now, actual)
            if self.table.get(ct.TORQUE_ENABLE):
                self.table.set(ct.GOAL_POSITION, _round(self._present(actual)))
            self._refresh(now)
            return 0

    def backup(self, params: bytes) -> int:
        """CONTROL_TABLE_BACKUP: 0x01 'C' 'T' 'R' 'L' stores every writable item, 0x02 ...
        restores them after a reboot. Result Fail while torque is on or with no backup;
        Instruction Error below firmware 45 (no such instruction there)."""
        with self._lock:
            self.update()
            if self._firmware < BACKUP_MIN_FIRMWARE:
                return ERR_INSTRUCTION
            params = bytes(params)
            if len(params) != 1 + len(BACKUP_MAGIC):
                return ERR_DATA_LENGTH
            if params[1:] != BACKUP_MAGIC or params[0] not in (BACKUP_STORE, BACKUP_RESTORE):
                return ERR_DATA_RANGE
            if self.table.get(ct.TORQUE_ENABLE):
                return ERR_RESULT_FAIL
            now = self.clock.now()
            saved_items = [it for it in self.spec.items.values()
                           if it.writable and it.address != ct.TORQUE_ENABLE]
            if params[0] == BACKUP_STORE:
                self._backup = self.table.snapshot(saved_items)
                self._refresh(now)
                return 0
            if self._backup is None:
                return ERR_RESULT_FAIL
            actual = self._actual_now(now)
            self.table.restore(self._backup)
            self._set_actual(now, actual)
            self._reboot(now)
            self.table.restore(self._ram_part(self._backup))
            self._refresh(now)
            return 0

    # ---- the outside world (physics) -----------------------------------------------------
    @property
    def dynamics(self) -> bool:
        """True when the physics model drives this servo."""
        return self._plant is not None

    @property
    def supply_voltage(self) -> float:
        """Supply voltage, V (physics model)."""
        return self._drive.supply_voltage if self._drive is not None else DEFAULT_SUPPLY_V

    @supply_voltage.setter
    def supply_voltage(self, volts: float) -> None:
        if not (math.isfinite(volts) and 0 < volts <= 30):
            raise ValueError(f"supply_voltage must be in (0, 30] V, got {volts!r}")
        with self._lock:
            self.update()
            if self._drive is None:
                raise RuntimeError("supply_voltage needs the physics model (dynamics=True)")
            self._drive.supply_voltage = float(volts)

    @property
    def temperature(self) -> float:
        """Winding temperature, °C (physics model; the kinematic model reads the table)."""
        with self._lock:
            self.update()
            if self._drive is None:
                return float(self.table.get(ct.PRESENT_TEMPERATURE))
            return self._drive.thermal.temperature

    @property
    def current_a(self) -> float:
        """Motor current, A, in the present frame's sign (0 in the kinematic model)."""
        with self._lock:
            self.update()
            return 0.0 if self._drive is None else self._sign() * self._drive.current

    def backdrive(self, ticks: int) -> None:
        """Move the output shaft by hand so Present Position reads ``ticks`` (torque off).

        Raises
        ------
        RuntimeError
            While torque is on (the servo would fight the hand).
        """
        with self._lock:
            self.update()
            if self.table.data[ct.TORQUE_ENABLE]:
                raise RuntimeError(f"servo {self.id}: torque is on; turn it off before "
                                   "moving the shaft by hand")
            if not -(1 << 31) <= int(ticks) < (1 << 31):
                raise ValueError(f"ticks must fit Present Position (int32), got {ticks!r}")
            now = self.clock.now()
            if self._plant is not None:
                assert self._drive is not None
                actual = self._actual(int(ticks))
                self._plant.theta[self._joint] = (actual + self._drive.turns) / PULSES_PER_RAD
                self._plant.omega[self._joint] = 0.0
            self._profile = hold(now, float(int(ticks)))
            self.update()

    def push(self, torque_nm: float) -> None:
        """Apply an external torque to the output shaft, N·m (0 releases it). It acts with
        torque on or off, in the present frame's positive direction."""
        if not math.isfinite(torque_nm):
            raise ValueError(f"torque_nm must be finite, got {torque_nm!r}")
        with self._lock:
            self.update()
            if self._drive is None:
                raise RuntimeError("push needs the physics model (dynamics=True)")
            self._drive.external_torque = self._sign() * float(torque_nm)

    def set_obstacle(self, degrees: float | None) -> None:
        """Block the joint beyond ``degrees`` (joint angle: tick 2048 = 0° unless an arm
        file maps it), on the far side from where it is now; None removes the obstacle."""
        if degrees is not None and not math.isfinite(degrees):
            raise ValueError(f"obstacle angle must be finite degrees, got {degrees!r}")
        with self._lock:
            self.update()
            if self._plant is None:
                raise RuntimeError("obstacles need the physics model (dynamics=True)")
            self._plant.set_obstacle(self._joint, degrees)

    def __repr__(self) -> str:
        return (f"Servo(id={self.id}, model={self.model!r}, firmware={self.firmware_version}, "
                f"baud_index={self.baud_index})")
