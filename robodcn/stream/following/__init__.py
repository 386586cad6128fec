"""Follow a stream of targets: :func:`follow` opens a session, :class:`Follower` runs it.

Modules: ``targets`` (checking a target, pose → joints, its velocity), ``source`` (the
loop's sample source made by the online generator), ``session`` (:class:`Follower`,
:func:`follow`).
"""

from robodcn.stream.following.session import STOP_MODES, Follower, follow, rest_trajectory
from robodcn.stream.following.targets import SPACES, STALE_S, Target, Targets

__all__ = ["SPACES", "STALE_S", "STOP_MODES", "Follower", "Target", "Targets", "follow",
           "rest_trajectory"]
