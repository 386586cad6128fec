"""robodcn: smooth planar rigid-motion trajectories with dual complex numbers, streamed to
Dynamixel servos."""

from robodcn import errors

__all__ = ["errors"]
__version__ = "0.1.0"
