"""``python -m firmware_sim --arm omx`` as a user starts it, through the real dynamixel-sdk
over the pty: every servo answers the first ping of a client, also one that took a second
to start (the physics is kept up with the clock between packets, so the first packet after
a pause does not integrate the whole pause before it can answer)."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pytest
from dynamixel_sdk import COMM_SUCCESS
from fw_helpers import PH, open_port

ROOT = Path(__file__).resolve().parent.parent
OMX_IDS = (11, 12, 13, 14, 15)


@pytest.fixture
def omx_cli():
    """The CLI's omx bus in its own process; yields its pty path."""
    proc = subprocess.Popen([sys.executable, "-m", "firmware_sim", "--arm", "omx"], cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        path = proc.stdout.readline().strip()
        assert path.startswith("/dev/"), proc.stderr.read() if proc.poll() is not None else path
        yield path
    finally:
        proc.terminate()
        _, err = proc.communicate(timeout=10)
    assert proc.returncode == 0, err


def _first_pings(port) -> dict[int, str]:
    """Each id pinged once: the SDK's result text per id."""
    return {i: PH.getTxRxResult(PH.ping(port, i)[1]) for i in OMX_IDS}


@pytest.mark.parametrize("pause_s", [0.0, 1.5])
def test_every_servo_answers_the_first_ping(omx_cli, pause_s):
    time.sleep(pause_s)                  # a client starting up (robodcn's imports) …
    port = open_port(omx_cli)
    try:
        answers = _first_pings(port)     # … then its first command: one ping each
    finally:
        port.closePort()
    ok = PH.getTxRxResult(COMM_SUCCESS)
    assert answers == dict.fromkeys(OMX_IDS, ok), answers
