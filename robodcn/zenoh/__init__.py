"""The Zenoh face of ``robodcn serve`` (``--zenoh``, ``--ros2``) and ``robodcn fleet``.

Many arms on many hosts share one key space, ``robodcn/<arm>/…``
(:mod:`robodcn.zenoh.native`): a liveliness token per arm, its state published, every
operation of the OpenAPI document as a queryable run through the HTTP layer's own operation
table (:mod:`robodcn.zenoh.dispatch`), the follow targets as puts. With ``--ros2`` the
service is also a ROS 2 node on rmw_zenoh's wire (:mod:`robodcn.zenoh.ros2node`, the wire
rules in :mod:`robodcn.ros2`). Options and the loopback rule: :mod:`robodcn.zenoh.options`.

The ``zenoh`` package (``pip install 'robodcn[zenoh]'``) is imported only when a session
opens (:func:`robodcn.zenoh.session.open_session`): ``import robodcn`` and planning never
need it.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
from collections.abc import Iterator
from typing import Any

from robodcn.zenoh.options import ZenohOptions

#: The state rate at rest with ``--ros2`` (Hz): /joint_states rides on it.
ROS_IDLE_HZ = 10.0


@contextlib.contextmanager
def face(server: Any, options: ZenohOptions, *, url: str | None = None) -> Iterator[Any]:
    """The Zenoh face of ``server`` (the HTTP server object: arm, controller, operations)
    while the block runs: the session, the native keys and, with ``options.ros2``, the
    ROS 2 node. Yields the :class:`~robodcn.zenoh.native.NativeFace`."""
    from robodcn.zenoh.native import NativeFace
    from robodcn.zenoh.session import open_session

    if options.ros2 and options.idle_hz < ROS_IDLE_HZ:
        options = dataclasses.replace(options, idle_hz=ROS_IDLE_HZ)
    if getattr(server, "token", None) and options.config_file is None:
        logging.getLogger("robodcn.zenoh").warning(
            "--token gates HTTP only: the Zenoh face answers any peer that reaches it "
            "(loopback here); give --zenoh-config with user/password to gate it too")
    session = open_session(options)
    try:
        with contextlib.ExitStack() as stack:
            native = stack.enter_context(NativeFace(server, session, options, url=url))
            if options.ros2:
                from robodcn.zenoh.ros2node import RosNode

                native.ros = stack.enter_context(RosNode(server, session, options, native))
            yield native
    finally:
        session.close()


__all__ = ["ZenohOptions", "face"]
