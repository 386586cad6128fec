"""One simulated X-series servo: the face the bus and the tests talk to.

Behaviour follows the ROBOTIS e-manual (XM430-W350 / XL430-W250 control tables, Protocol
2.0 instructions) as summarised in /work/shared/dynamixel-notes.md §1.4 to §2.1. Time
comes from a :class:`~firmware_sim.clock.Clock`; motion is evaluated analytically
(:mod:`firmware_sim.profile`) or by the physics plant whenever the servo is touched, so
nothing ticks. The rules live by concept beside this module: table access
(:mod:`.access`), write effects (:mod:`.effects`), live items (:mod:`.live`), the Bus
Watchdog (:mod:`.watchdog`), hardware errors (:mod:`.alerts`), reboot/reset/clear/backup
(:mod:`.maintenance`), the outside world (:mod:`.environment`) and the frames
(:mod:`.motion`).
"""

from __future__ import annotations

import math
import threading

from firmware_sim import control_table as ct
from firmware_sim.clock import Clock, RealClock
from firmware_sim.control_table import ERR_INSTRUCTION, MODELS, ControlTable
from firmware_sim.drive import PULSES_PER_RAD, Drive
from firmware_sim.dynamics import Plant
from firmware_sim.motor import DEFAULT_SUPPLY_V, MOTORS
from firmware_sim.profile import Profile, hold
from firmware_sim.servo import access, alerts, effects, environment, maintenance
from firmware_sim.servo.indirect import UNRESOLVED, accepted, indirect_mode
from firmware_sim.servo.live import configure_drive, refresh
from firmware_sim.servo.motion import Motion
from firmware_sim.servo.state import ServoState
from firmware_sim.servo.watchdog import BusWatchdog

#: Default boot delay after REBOOT / FACTORY_RESET / restore, s (the servo ignores the bus).
BOOT_DELAY_S = 0.01


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
    load_inertia : float
        Inertia of what the lone shaft carries, kg·m² at the output (physics model, a
        servo that is not a joint of an arm, e.g. a gripper's jaws).
    indirect : bool or {"on", "off", "unresolved"}
        How the firmware treats the Indirect Address map (:mod:`.indirect`): True/"on"
        as the e-manual; False/"off" a WRITE to an Indirect Address answers OK and stores
        nothing (an older firmware, a clone); "unresolved" the map stores but Indirect
        Data does not follow it.

    Notes
    -----
    :meth:`read` and :meth:`write` bring motion and watchdog up to ``clock.now()`` first.
    Thread-safe (one internal re-entrant lock).
    """

    def __init__(self, servo_id: int, model: str = "xm430-w350", *, firmware: int = 46,
                 baud_index: int = 3, clock: Clock | None = None, position: int = 2048,
                 boot_delay_s: float = BOOT_DELAY_S, dynamics: bool = False,
                 supply_voltage: float = DEFAULT_SUPPLY_V,
                 lock: threading.RLock | None = None, load_inertia: float = 0.0,
                 indirect: bool | str = True) -> None:
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
        supply_voltage = environment.check_supply(supply_voltage)
        if not (math.isfinite(load_inertia) and load_inertia >= 0):
            raise ValueError(f"load_inertia must be >= 0 kg·m², got {load_inertia!r}")
        self.model = model
        self.spec = spec
        self.clock: Clock = clock if clock is not None else RealClock()
        table = ControlTable(spec)
        self.table = table
        self._lock = lock if lock is not None else threading.RLock()
        table.set(ct.FIRMWARE_VERSION, int(firmware))
        table.set(ct.ID, int(servo_id))
        table.set(ct.BAUD_RATE, int(baud_index))
        now = self.clock.now()
        motion = Motion(table, hold(now, float(position)))
        # constructed servos are up at once
        self._st = ServoState(table, spec, self.clock, motion, BusWatchdog(now),
                              int(firmware), float(boot_delay_s), now, now)
        if dynamics:
            motion.drive = Drive(MOTORS[model], self._physical_fault, supply_voltage)
            motion.plant = Plant([motion.drive], [float(position) / PULSES_PER_RAD], now,
                                 load_inertia=[float(load_inertia)])
            motion.plant.owners = [self]
        self._st.indirect = indirect_mode(indirect)
        effects.reset_goals(self._st)

    # ---- identity and settings ----------------------------------------------------------
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
            self._st.firmware = int(value)
            self.table.set(ct.FIRMWARE_VERSION, int(value))

    @property
    def boot_delay_s(self) -> float:
        """How long the servo ignores the bus after a reboot, s."""
        return self._st.boot_delay_s

    @boot_delay_s.setter
    def boot_delay_s(self, value: float) -> None:
        if not value >= 0:
            raise ValueError(f"boot_delay_s must be >= 0, got {value!r}")
        self._st.boot_delay_s = float(value)

    @property
    def indirect(self) -> str:
        """``"on"``, ``"off"`` or ``"unresolved"``: how this firmware treats the Indirect
        Address map (:mod:`.indirect`); settable (True/False for on/off)."""
        return self._st.indirect

    @indirect.setter
    def indirect(self, value: bool | str) -> None:
        mode = indirect_mode(value)
        with self._lock:
            self._st.indirect = mode

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
    def operating_mode(self) -> int:
        return self.table.get(ct.OPERATING_MODE)

    @property
    def goal_position(self) -> int:
        return self.table.get(ct.GOAL_POSITION)

    # ---- live state -----------------------------------------------------------------------
    def get(self, address: int) -> int:
        """Typed value of the item at ``address`` after :meth:`update` (test convenience)."""
        with self._lock:
            self.update()
            return self.table.get(address)

    @property
    def torque_enabled(self) -> bool:
        return bool(self.get(ct.TORQUE_ENABLE))

    @property
    def present_position(self) -> int:
        return self.get(ct.PRESENT_POSITION)

    @property
    def present_velocity(self) -> int:
        return self.get(ct.PRESENT_VELOCITY)

    @property
    def moving(self) -> bool:
        return bool(self.get(ct.MOVING))

    @property
    def watchdog_tripped(self) -> bool:
        with self._lock:
            self.update()
            return self._st.watchdog.tripped

    @property
    def profile(self) -> Profile:
        """The motion plan in force (present-position frame, pulses and seconds)."""
        return self._st.motion.profile

    @property
    def motion(self) -> Motion:
        """Profile, drive and plant shaft of this servo (physics: ``motion.plant``)."""
        return self._st.motion

    # ---- time -----------------------------------------------------------------------
    def booting(self) -> bool:
        """True while the servo is rebooting (it ignores the bus then)."""
        return self.clock.now() < self._st.boot_until

    def note_instruction(self) -> None:
        """An instruction addressed to this servo arrived: feed the Bus Watchdog."""
        with self._lock:
            self.update()
            self._st.watchdog.feed(self.clock.now())

    def update(self) -> None:
        """Advance the plant, the watchdog and the live items (Present *, Moving, tick…)
        to now."""
        with self._lock:
            now = self.advance()
            st = self._st
            if refresh(st, now):
                alerts.physical_fault(st, ct.HW_INPUT_VOLTAGE, now)

    def advance(self) -> float:
        """Advance the plant and the watchdog to now, leaving the live items to the next
        read (:meth:`update` refreshes them): what the bus's keep-up between packets needs,
        without rewriting every Present item of every servo each time. Returns now."""
        with self._lock:
            st = self._st
            now = self.clock.now()
            plant = st.motion.plant
            if plant is not None:
                deadline = st.watchdog.deadline(st.table)
                if deadline is not None and deadline <= now:
                    plant.advance(deadline)      # the stop happens at the deadline
            st.watchdog.expire(st.table, st.motion, now)
            if plant is not None:
                plant.advance(now)
            return now

    def configure_drive(self) -> None:
        """Snapshot the control table for the drive (the plant calls it before steps)."""
        configure_drive(self._st)

    def _physical_fault(self, bits: int, t: float) -> None:
        alerts.physical_fault(self._st, bits, t)

    # ---- instructions ---------------------------------------------------------------------
    def read(self, address: int, length: int) -> tuple[int, bytes]:
        """READ: (error code, data); data is b"" on error (:func:`.access.read`)."""
        with self._lock:
            self.update()
            return access.read(self.table, self.spec, address, length,
                               follow=self._st.indirect != UNRESOLVED)

    def write(self, address: int, data: bytes) -> int:
        """WRITE: error code (0 = ok). All-or-nothing (:mod:`.access` for the codes)."""
        with self._lock:
            self.update()
            code, items = access.validate(self.table, self.spec, address, bytes(data),
                                          watchdog_tripped=self._st.watchdog.tripped,
                                          follow=self._st.indirect != UNRESOLVED)
            if code:
                return code
            return effects.commit(self._st, accepted(self._st.indirect, items))

    def reg_write(self, address: int, data: bytes) -> int:
        """REG_WRITE: validate now, store; :meth:`action` applies it. Registered Instruction = 1."""
        with self._lock:
            self.update()
            code, _ = access.validate(self.table, self.spec, address, bytes(data),
                                      watchdog_tripped=self._st.watchdog.tripped,
                                      follow=self._st.indirect != UNRESOLVED)
            if code:
                return code
            self._st.registered = (int(address), bytes(data))
            refresh(self._st, self.clock.now())
            return 0

    def action(self) -> int:
        """ACTION: apply the registered write (re-validated now); ERR_INSTRUCTION if none."""
        with self._lock:
            self.update()
            if self._st.registered is None:
                return ERR_INSTRUCTION
            address, data = self._st.registered
            self._st.registered = None
            code = self.write(address, data)
            refresh(self._st, self.clock.now())
            return code

    def status_error(self, code: int) -> int:
        """ERR byte for a status packet: ``code`` plus the alert bit while Hardware Error
        Status is non-zero."""
        return alerts.status_error(self._st, code)

    def trip(self, bits: int) -> None:
        """Inject hardware error ``bits`` (Shutdown bits: 0x01 voltage, 0x04 overheat,
        0x08 encoder, 0x10 electrical shock, 0x20 overload). Torque goes off if any bit is
        set in Shutdown (63); only a reboot clears the status."""
        if not 0 < int(bits) <= 0xFF:
            raise ValueError(f"hardware error bits must be 1..255, got {bits!r}")
        with self._lock:
            self.update()
            alerts.trip(self._st, int(bits))

    def reboot(self) -> None:
        """REBOOT (:func:`.maintenance.reboot`)."""
        with self._lock:
            self.update()
            maintenance.reboot(self._st, self.clock.now())

    def factory_reset(self, option: int) -> int:
        """FACTORY_RESET (:func:`.maintenance.factory_reset`)."""
        with self._lock:
            self.update()
            return maintenance.factory_reset(self._st, option)

    def clear(self, params: bytes) -> int:
        """CLEAR multi-turn (:func:`.maintenance.clear`)."""
        with self._lock:
            self.update()
            return maintenance.clear(self._st, bytes(params))

    def backup(self, params: bytes) -> int:
        """CONTROL_TABLE_BACKUP (:func:`.maintenance.backup`)."""
        with self._lock:
            self.update()
            return maintenance.backup(self._st, bytes(params))

    # ---- the outside world (physics) -----------------------------------------------------
    @property
    def dynamics(self) -> bool:
        """True when the physics model drives this servo."""
        return self._st.motion.plant is not None

    @property
    def supply_voltage(self) -> float:
        """Supply voltage, V (physics model)."""
        drive = self._st.motion.drive
        return drive.supply_voltage if drive is not None else DEFAULT_SUPPLY_V

    @supply_voltage.setter
    def supply_voltage(self, volts: float) -> None:
        with self._lock:
            self.update()
            environment.set_supply(self._st, volts)

    @property
    def temperature(self) -> float:
        """Winding temperature, °C (physics model; the kinematic model reads the table)."""
        with self._lock:
            self.update()
            drive = self._st.motion.drive
            if drive is None:
                return float(self.table.get(ct.PRESENT_TEMPERATURE))
            return drive.thermal.temperature

    @property
    def current_a(self) -> float:
        """Motor current, A, in the present frame's sign (0 in the kinematic model)."""
        with self._lock:
            self.update()
            drive = self._st.motion.drive
            return 0.0 if drive is None else self._st.motion.sign() * drive.current

    def backdrive(self, ticks: int) -> None:
        """Move the output shaft by hand so Present Position reads ``ticks`` (torque off;
        RuntimeError while torque is on)."""
        with self._lock:
            self.update()
            environment.backdrive(self._st, self.id, ticks)
            self.update()

    def push(self, torque_nm: float) -> None:
        """Apply an external torque to the output shaft, N·m (0 releases it). It acts with
        torque on or off, in the present frame's positive direction."""
        with self._lock:
            self.update()
            environment.push(self._st, torque_nm)

    def set_obstacle(self, degrees: float | None) -> None:
        """Block the joint beyond ``degrees`` (joint angle: tick 2048 = 0° unless an arm
        file maps it), on the far side from where it is now; None removes the obstacle."""
        with self._lock:
            self.update()
            environment.set_obstacle(self._st, degrees)

    def __repr__(self) -> str:
        return (f"Servo(id={self.id}, model={self.model!r}, firmware={self.firmware_version}, "
                f"baud_index={self.baud_index})")
