"""Fixtures of the browser tests: a real ``robodcn serve --sim`` and headless Chromium.

Chromium and its driver are the Debian packages (``chromium``, ``chromium-driver``);
selenium is the ``browser`` extra. ``make test-browser`` installs whatever is missing. These
tests are not part of ``make test`` (pytest's testpaths there is tests/).
"""

from __future__ import annotations

import json
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parent.parent


@dataclass
class Service:
    """A running ``robodcn serve --sim``: its URL and token."""

    url: str
    token: str | None
    proc: subprocess.Popen[str]
    #: the service's stderr (its log, one INFO line a request), as a file: a pipe nobody
    #: reads fills after some 64 KiB and then blocks the service in its next log write
    log: Path | None = None

    def log_tail(self, lines: int = 40) -> str:
        """The last ``lines`` of the service's log but its GET request lines (the page's and
        the tests' polling), for a failing test to say why."""
        if self.log is None or not self.log.exists():
            return ""
        kept = [line for line in self.log.read_text(errors="replace").splitlines()
                if " GET /" not in line]
        return "\n".join(kept[-lines:])

    def call(self, method: str, path: str, body: Any = None) -> tuple[int, Any]:
        if body is None and method != "GET":
            body = {}  # every POST/PUT carries a JSON body
        headers = {"Content-Type": "application/json"} if body is not None else {}
        if self.token:
            headers["Authorization"] = f"Bearer {self.token}"
        data = None if body is None else json.dumps(body).encode()
        req = urllib.request.Request(self.url + path, method=method, data=data, headers=headers)
        try:
            with urllib.request.urlopen(req, timeout=20) as resp:
                return resp.status, json.loads(resp.read())
        except urllib.error.HTTPError as exc:
            return exc.code, json.loads(exc.read())

    def move_count(self) -> int:
        """How many moves the service has recorded (ids count up from 1)."""
        n = 0
        while self.call("GET", f"/v1/moves/{n + 1}")[0] == 200:
            n += 1
        return n

    def wait_idle(self, timeout: float = 20.0) -> None:
        deadline = time.monotonic() + timeout
        while self.call("GET", "/healthz")[1]["moving"]:
            assert time.monotonic() < deadline, "the arm is still moving"
            time.sleep(0.05)


def _serve(token: str | None, target: tuple[str, ...] = ("--sim",),
           port: int = 0, arm: str = str(ROOT / "configs" / "arm3r.toml")) -> Iterator[Service]:
    args = [sys.executable, "-m", "robodcn", "serve", *target, "--port", str(port),
            "--arm", arm]
    if token:
        args += ["--token", token]
    with tempfile.TemporaryDirectory(prefix="robodcn-serve-") as tmp:
        log = Path(tmp) / "serve.log"
        with log.open("w") as err:
            proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=err, text=True,
                                    cwd=ROOT)
        try:
            found = re.search(r"http://[\d.]+:\d+", proc.stdout.readline())
            assert found, log.read_text(errors="replace")
            yield Service(found.group(0), token, proc, log)
        finally:
            _terminate(proc)


def _terminate(proc: subprocess.Popen) -> None:
    """SIGTERM (the service holds and closes its bus), then kill after 15 s."""
    proc.send_signal(signal.SIGTERM)
    try:
        proc.wait(timeout=15)
    except subprocess.TimeoutExpired:
        proc.kill()


@pytest.fixture(scope="module")
def service() -> Iterator[Service]:
    yield from _serve(None)


@pytest.fixture(scope="module")
def omx_service() -> Iterator[Service]:
    """``robodcn serve --sim --arm omx``: the packaged OpenMANIPULATOR-X (a base yaw, a
    chain under gravity, a gripper), named as a new user names it."""
    yield from _serve(None, arm="omx")


@pytest.fixture(scope="module")
def token_service() -> Iterator[Service]:
    yield from _serve("s3cret-token")


@pytest.fixture
def restartable() -> Iterator[tuple[int, Callable[[], Any]]]:
    """(port, start): ``start()`` is a context running ``serve --sim`` on that fixed port, to
    stop and start again under an open page."""
    import contextlib
    import socket

    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    yield port, contextlib.contextmanager(lambda: _serve(None, port=port))


@pytest.fixture(scope="module")
def device_service() -> Iterator[Service]:
    """``robodcn serve --device`` on a firmware_sim bus in its own process (servos at 0°)."""
    sim = subprocess.Popen([sys.executable, "-m", "firmware_sim", "--ids", "1,2,3"],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)
    try:
        device = sim.stdout.readline().strip()
        assert device.startswith("/dev/"), sim.stderr.read()
        yield from _serve(None, ("--device", device))
    finally:
        _terminate(sim)


@pytest.fixture(scope="session")
def driver() -> Iterator[Any]:
    webdriver = pytest.importorskip("selenium.webdriver", reason="pip install -e '.[browser]'")
    from selenium.webdriver.chrome.service import Service as DriverService

    browser = shutil.which("chromium") or shutil.which("chromium-browser")
    chromedriver = shutil.which("chromedriver")
    if not (browser and chromedriver):
        pytest.fail("chromium and chromium-driver are needed (apt-get install -y chromium "
                    "chromium-driver, or make test-browser as root)")
    options = webdriver.ChromeOptions()
    options.binary_location = browser
    for arg in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", "--disable-gpu",
                "--window-size=1380,1060", "--force-device-scale-factor=1"):
        options.add_argument(arg)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    # An explicit driver path: selenium then never tries to download one.
    drv = webdriver.Chrome(service=DriverService(chromedriver), options=options)
    drv.set_script_timeout(30)
    try:
        yield drv
    finally:
        drv.quit()


@pytest.fixture
def until(driver: Any) -> Callable[..., Any]:
    """``until(predicate, timeout)``: poll ``predicate(driver)`` until truthy, return it."""
    from selenium.webdriver.support.ui import WebDriverWait

    def wait(predicate: Callable[[Any], Any], timeout: float = 20.0, message: str = "") -> Any:
        return WebDriverWait(driver, timeout, poll_frequency=0.05).until(predicate, message)

    return wait


@pytest.fixture
def stub() -> Iterator[Callable[..., Any]]:
    """``stub(get)``: a started :class:`StubService` answering GET ``path`` with
    ``get[path]`` (and the console's own files); stopped after the test."""
    from stub_service import StubService

    made: list[StubService] = []

    def make(get: dict[str, Any]) -> StubService:
        made.append(StubService(get).start())
        return made[-1]

    yield make
    for service in made:
        service.stop()
