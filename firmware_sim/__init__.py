"""firmware_sim: a simulated Dynamixel X-series Protocol 2.0 bus on a pseudo-terminal.

``with SimBus(config=SimBusConfig(ids=(1, 2, 3))) as bus:`` (or ``SimBus([1, 2, 3])``)
gives ``bus.port_path`` for the dynamixel-sdk's PortHandler, live servos
(``bus.servo(1)``), fault injection (``bus.faults``), a packet log (``bus.log``) and
``bus.goal_history(id)``. ``python -m firmware_sim`` serves one from the command line.
"""

from firmware_sim.bus import LogEntry, SimBus
from firmware_sim.bus_config import SimBusConfig
from firmware_sim.faults import Fault, FaultInjector, FaultKind

__all__ = ["Fault", "FaultInjector", "FaultKind", "LogEntry", "SimBus", "SimBusConfig"]
