"""The online motion generator: one law toward the newest input, one period at a time.

Between the planner (which plans whole moves from poses) and the stream (which executes
samples): :class:`Generator` holds the commanded state (q, q̇, q̈) and, given an
:class:`Input` (a joint target with a velocity to pass it with, a speed scale, a stop),
returns the :class:`Sample` to stream next, within every joint's velocity, acceleration,
jerk and (:meth:`Generator.check`) torque limits; an input it cannot meet is an
:class:`Infeasible` value. Modules: ``state`` (the input, the sample, the infeasible
result), ``generator`` (the law: Ruckig's).
"""

from robodcn.online.generator import TORQUE_SAMPLES, TORQUE_SCALES, Generator
from robodcn.online.state import MODES, Infeasible, Input, Sample

__all__ = ["MODES", "TORQUE_SAMPLES", "TORQUE_SCALES", "Generator", "Infeasible", "Input",
           "Sample"]
