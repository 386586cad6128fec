"""``robodcn serve --zenoh`` options as one validated object, and the loopback rule.

Zenoh has no authentication by default, so the Zenoh face listens on loopback only
(``tcp/127.0.0.1:0``, an ephemeral port: peers on this host find it through a router or
``--zenoh-connect``) unless told otherwise; a listen endpoint on another address needs a
``--zenoh-config`` that sets user/password (``transport/auth/usrpwd``) or TLS (a ``tls/`` or
``quic/`` endpoint with ``transport/link/tls`` certificate and key), as ``--token`` gates
HTTP off loopback. Multicast scouting is off unless ``scout`` (as rmw_zenoh does: robots on
one LAN do not find each other by accident).
"""

from __future__ import annotations

import ipaddress
import os
import re
from dataclasses import dataclass

from robodcn.errors import InputError

#: Where the face listens when no endpoint is given: loopback, any free port.
DEFAULT_LISTEN = ("tcp/127.0.0.1:0",)
#: Where the command line connects when no endpoint or configuration is given: this host's
#: router (``zenohd``, or rmw_zenoh's ``rmw_zenohd``), as rmw_zenoh's sessions do.
DEFAULT_ROUTER = "tcp/127.0.0.1:7447"
#: ``<protocol>/<host>:<port>`` (IPv6 hosts in brackets), optional ``#…`` / ``?…`` tail.
_ENDPOINT = re.compile(r"^(?P<proto>[a-z0-9]+)/(?P<host>\[[^\]]+\]|[^:/\[\]#?]+):"
                       r"(?P<port>\d{1,5})(?:[#?].*)?$")
_LOOPBACK_NAMES = {"localhost", "ip6-localhost"}
#: A name a Zenoh key segment takes for an arm: no wildcards, no separators.
_NAME = re.compile(r"^[A-Za-z0-9_\-.]{1,64}$")


def split_endpoint(endpoint: str, option: str) -> tuple[str, str, int]:
    """(protocol, host, port) of ``tcp/127.0.0.1:7447``; InputError naming ``option``."""
    found = _ENDPOINT.match(endpoint)
    if found is None or int(found["port"]) > 65535:
        raise InputError(f"{option} {endpoint!r} is not a Zenoh endpoint "
                         "<protocol>/<host>:<port>, e.g. tcp/192.168.1.7:7447",
                         field=option, value=endpoint)
    return found["proto"], found["host"].strip("[]"), int(found["port"])


def is_loopback(host: str) -> bool:
    """Whether ``host`` (an address or name) is this machine only."""
    if host.lower() in _LOOPBACK_NAMES:
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


@dataclass(frozen=True)
class ZenohOptions:
    """The Zenoh face of ``robodcn serve``.

    connect, listen : endpoints (``tcp/host:port``) to connect to and listen on; listen
        defaults to :data:`DEFAULT_LISTEN`.
    config_file : a Zenoh JSON5 configuration (TLS, user/password, routers) under the rest.
    scout : multicast scouting on (off by default).
    name : the arm's name in the key space (default: the config's ``[arm] name``).
    ros2 : also be a ROS 2 node on rmw_zenoh's wire; ``ros_domain`` (default
        ``$ROS_DOMAIN_ID``, else 0) and ``ros_controller`` (the controller name MoveIt calls).
    state_hz, idle_hz : the state publication's rate while moving (100 Hz: a 100 Hz
        stream's feedback rate, ≥ the 50 Hz asked) and at rest (≥ 2 Hz).
    """

    connect: tuple[str, ...] = ()
    listen: tuple[str, ...] = ()
    config_file: str | None = None
    scout: bool = False
    name: str | None = None
    ros2: bool = False
    ros_domain: int | None = None
    ros_controller: str = "arm_controller"
    state_hz: float = 100.0
    idle_hz: float = 2.0

    def __post_init__(self) -> None:
        for endpoint in self.connect:
            split_endpoint(endpoint, "--zenoh-connect")
        for endpoint in self.listen:
            split_endpoint(endpoint, "--zenoh-listen")
        if self.name is not None and not _NAME.match(self.name):
            raise InputError(f"--name {self.name!r} must be 1-64 letters, digits, '_', '-' "
                             "or '.' (it is a Zenoh key segment and part of a ROS node name)",
                             field="--name", value=self.name)
        if self.config_file is not None and not os.path.isfile(self.config_file):
            raise InputError(f"--zenoh-config {self.config_file!r}: no such file",
                             field="--zenoh-config", value=self.config_file)
        if self.ros_domain is not None and not 0 <= self.ros_domain <= 232:
            raise InputError(f"--ros-domain-id must be 0..232, got {self.ros_domain}",
                             field="--ros-domain-id", value=self.ros_domain)
        if not re.match(r"^[A-Za-z_][A-Za-z0-9_]*$", self.ros_controller):
            raise InputError(f"--ros-controller {self.ros_controller!r} is not a ROS name "
                             "(letters, digits, '_')", field="--ros-controller",
                             value=self.ros_controller)

    @property
    def domain(self) -> int:
        """The ROS domain id: ``ros_domain``, else ``$ROS_DOMAIN_ID``, else 0."""
        if self.ros_domain is not None:
            return self.ros_domain
        env = os.environ.get("ROS_DOMAIN_ID", "").strip()
        return int(env) if env.isdigit() and int(env) <= 232 else 0


def check_listen(endpoints: tuple[str, ...], *, usrpwd: bool, tls: bool) -> None:
    """Refuse a listen endpoint off loopback unless the configuration authenticates
    (user/password) or encrypts (TLS, on a ``tls/`` or ``quic/`` endpoint)."""
    for endpoint in endpoints:
        proto, host, _ = split_endpoint(endpoint, "--zenoh-listen")
        if is_loopback(host) or usrpwd or (tls and proto in ("tls", "quic")):
            continue
        raise InputError(f"--zenoh-listen {endpoint!r} is reachable from other hosts and "
                         "Zenoh has no authentication by default: give --zenoh-config with "
                         "transport/auth/usrpwd (user/password) or TLS on a tls/ endpoint "
                         "(transport/link/tls certificate and key), or listen on 127.0.0.1",
                         field="--zenoh-listen", value=endpoint)
