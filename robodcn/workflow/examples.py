"""The example arms and ``--arm FILE|NAME`` resolution, for the surfaces: the names, paths
and texts live in the config layer (:mod:`robodcn.config._examples`, so that
:func:`robodcn.load_arm` takes an example name too); :func:`resolve_arm` loads one.
"""

from __future__ import annotations

import os

from robodcn.config import Arm, load_arm
from robodcn.config._examples import (
    DEFAULT_EXAMPLE,
    EXAMPLES,
    example_path,
    example_text,
    resolve_arm_path,
)


def resolve_arm(name_or_path: str | os.PathLike[str] | None, *, option: str = "--arm") -> Arm:
    """Load the arm an ``--arm`` value names (see :func:`resolve_arm_path`)."""
    return load_arm(resolve_arm_path(name_or_path, option=option))


__all__ = ["DEFAULT_EXAMPLE", "EXAMPLES", "example_path", "example_text", "resolve_arm",
           "resolve_arm_path"]
