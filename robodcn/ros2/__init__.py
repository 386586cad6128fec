"""ROS 2's wire as rmw_zenoh speaks it, without ROS: interface definitions (Jazzy) shipped
as data, REP 2016 type hashes, a CDR codec, and rmw_zenoh's keys, liveliness tokens and
attachments. Pure Python, no Zenoh import: the Zenoh surface (:mod:`robodcn.zenoh`) puts
these bytes on the network."""

from robodcn.ros2.cdr import CdrError, decode, encode
from robodcn.ros2.idl import dds_name, registry
from robodcn.ros2.typehash import type_hash
from robodcn.ros2.wire import QoS, attachment, read_attachment, topic_key

__all__ = ["CdrError", "QoS", "attachment", "dds_name", "decode", "encode",
           "read_attachment", "registry", "topic_key", "type_hash"]
