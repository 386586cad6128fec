"""rmw_zenoh's wire rules: key expressions, liveliness tokens, QoS text and attachments.

Source: ros2/rmw_zenoh ``docs/design.md`` and ``liveliness_utils.cpp`` /
``attachment_helpers.cpp`` (Jazzy, rmw_zenoh 0.2.x); gathered in the project's
``ros2-zenoh.md``.

- Data key: ``<domain>/<name without leading/trailing '/'>/<dds type name>/<RIHS01 hash>``.
- Liveliness token: ``@ros2_lv/<domain>/<session zid>/<node id>/<entity id>/<kind>/<enclave>/
  <namespace>/<node name>[/<topic>/<dds type name>/<hash>/<qos>]``, each name with ``/``
  turned into ``%`` and an empty one written ``%``.
- QoS text: ``<reliability>:<durability>:<history>,<depth>:<deadline s>,<ns>:<lifespan s>,
  <ns>:<liveliness>,<lease s>,<ns>``, a part equal to rmw_zenoh's default left empty (the
  defaults: reliable, volatile, keep-last 42, infinite durations, automatic liveliness).
- Attachment of every sample, request and reply (33 bytes): int64 sequence number, int64
  source timestamp (ns since the UNIX epoch), the byte 16, the 16-byte GID, little-endian.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from typing import Literal

from robodcn.errors import InputError
from robodcn.ros2.idl import dds_name
from robodcn.ros2.typehash import type_hash

ADMIN_SPACE = "@ros2_lv"
#: Entity kinds of a liveliness token.
Kind = Literal["NN", "MP", "MS", "SS", "SC"]
GID_SIZE = 16
ATTACHMENT = struct.Struct("<qqB")
ATTACHMENT_SIZE = ATTACHMENT.size + GID_SIZE  # 33

RELIABLE, BEST_EFFORT = 1, 2
TRANSIENT_LOCAL, VOLATILE = 1, 2
KEEP_LAST, KEEP_ALL = 1, 2


@dataclass(frozen=True)
class QoS:
    """The QoS an endpoint advertises (rmw_qos_profile_t's policies that rmw_zenoh writes;
    durations are left at rmw_zenoh's default, infinite)."""

    reliability: int = RELIABLE
    durability: int = VOLATILE
    history: int = KEEP_LAST
    depth: int = 42

    def text(self) -> str:
        """The token's QoS part; defaults empty (``QoS().text() == "::,:,:,:,,"``)."""
        default = QoS()

        def part(value: int, base: int) -> str:
            return "" if value == base else str(value)

        return (f"{part(self.reliability, default.reliability)}:"
                f"{part(self.durability, default.durability)}:"
                f"{part(self.history, default.history)},{part(self.depth, default.depth)}"
                ":,:,:,,")


def strip_slashes(name: str) -> str:
    """A fully qualified name without its leading and trailing ``/``."""
    return name.strip("/")


def mangle(name: str) -> str:
    """A name as a token part: ``/`` → ``%``, empty → ``%``."""
    return name.replace("/", "%") or "%"


def topic_key(domain: int, name: str, type_name: str) -> str:
    """The data key of topic or service ``name`` of ``type_name`` (``pkg/msg/Name``)."""
    if not name.startswith("/"):
        raise InputError(f"a ROS 2 name here is fully qualified (starts with /), got "
                         f"{name!r}", field="name", value=name)
    return f"{domain}/{strip_slashes(name)}/{dds_name(type_name)}/{type_hash(type_name)}"


@dataclass(frozen=True)
class Node:
    """A node as its tokens name it: domain, session zid (hex), node id, namespace, name."""

    domain: int
    zid: str
    node_id: int
    name: str
    namespace: str = "/"
    enclave: str = ""

    def _prefix(self, entity_id: int, kind: Kind) -> str:
        ns = "" if self.namespace == "/" else self.namespace
        return (f"{ADMIN_SPACE}/{self.domain}/{self.zid}/{self.node_id}/{entity_id}/{kind}/"
                f"{mangle(self.enclave)}/{mangle(ns)}/{mangle(self.name)}")

    def node_token(self) -> str:
        """The node's own token (kind NN; entity id = node id)."""
        return self._prefix(self.node_id, "NN")

    def entity_token(self, entity_id: int, kind: Kind, topic: str, type_name: str,
                     qos: QoS = QoS()) -> str:
        """The token of a publisher (MP), subscription (MS), service server (SS) or
        client (SC) of ``topic`` (fully qualified) with ``type_name``."""
        return (f"{self._prefix(entity_id, kind)}/{mangle(topic)}/{dds_name(type_name)}/"
                f"{type_hash(type_name)}/{qos.text()}")


def attachment(sequence: int, timestamp_ns: int, gid: bytes) -> bytes:
    """The 33-byte attachment: sequence number, source timestamp (ns), 16, GID."""
    if len(gid) != GID_SIZE:
        raise InputError(f"a GID has {GID_SIZE} bytes, got {len(gid)}", field="gid",
                         value=len(gid))
    return ATTACHMENT.pack(sequence, timestamp_ns, GID_SIZE) + bytes(gid)


def read_attachment(data: bytes) -> tuple[int, int, bytes]:
    """(sequence number, source timestamp ns, GID) of an attachment; InputError naming
    ``attachment`` if it is not the 33-byte layout."""
    if len(data) != ATTACHMENT_SIZE or data[16] != GID_SIZE:
        raise InputError(f"an rmw_zenoh attachment has {ATTACHMENT_SIZE} bytes with 16 at "
                         f"byte 16, got {len(data)} bytes", field="attachment",
                         value=len(data))
    sequence, timestamp, _ = ATTACHMENT.unpack_from(data)
    return sequence, timestamp, bytes(data[ATTACHMENT.size:])
