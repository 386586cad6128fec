"""The public names of the robodcn package."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

import robodcn


def test_servo_names_are_the_stream_and_bus_objects():
    from robodcn import bus, stream

    assert robodcn.execute is stream.execute
    assert robodcn.StopSignal is stream.StopSignal
    assert robodcn.ExecutionReport is stream.ExecutionReport
    assert robodcn.ServoBus is bus.ServoBus and robodcn.scan is bus.scan
    assert set(robodcn.__all__) <= set(dir(robodcn)) | set(robodcn._LAZY)


def test_planning_does_not_import_the_serial_stack():
    code = ("import sys, robodcn; robodcn.plan(robodcn.load_arm('configs/arm3r.toml'), "
            "[[0.25, 0.1, 0.0], [0.12, 0.24, 1.0]]); print('dynamixel_sdk' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=Path(__file__).resolve().parent.parent, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "False"


def test_unknown_attribute_raises():
    with pytest.raises(AttributeError, match="no_such_thing"):
        robodcn.no_such_thing  # noqa: B018
