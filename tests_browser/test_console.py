"""The web console in headless Chromium against a real ``robodcn serve --sim``.

What a user does — type or drag a target, preview, move, stop — and what they must see: the
arm's live joints, the move's status, the plan drawn, the error of an impossible target. The
server is checked independently (its own JSON API) rather than trusting the page.
"""

from __future__ import annotations

import math
import re
import time
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parent.parent
REACHABLE = (0.12, 0.24, 60.0)   # metres, metres, degrees
UNREACHABLE = (0.5, 0.5, 0.0)
#: A move that ran to its end: "degraded" when a loaded machine made the stream skip samples
#: (the status says so; the arm still reached the goal).
FINISHED = ("done", "degraded")


def el(driver: Any, testid: str) -> Any:
    return driver.find_element("css selector", f'[data-testid="{testid}"]')


def open_console(driver: Any, until: Any, service: Any) -> None:
    driver.get(service.url + "/")
    until(lambda d: re.search(r"-?\d", el(d, "joints").text), message="no live joints")
    until(lambda d: d.execute_script("return window.robodcnConsole.stats.state") > 0)


#: The target inputs of a planar arm (arm3r): x, y (m), θ (deg).
AXES = ("target-x", "target-y", "target-theta")


def type_target(driver: Any, pose: tuple[float, ...], duration: str = "auto",
                axes: tuple[str, ...] = AXES) -> None:
    """Type ``pose`` into the target inputs ``axes`` (one number each) and ``duration``."""
    for testid, value in zip(axes, pose, strict=True):
        box = el(driver, testid)
        box.clear()
        box.send_keys(str(value))
    box = el(driver, "duration")
    box.clear()
    box.send_keys(duration)


def severe_logs(driver: Any) -> list[dict[str, Any]]:
    return [e for e in driver.get_log("browser") if e["level"] == "SEVERE"]


def forget_earlier_pages(driver: Any) -> None:
    """Leave the page an earlier test opened, then drop what it logged: left open, its event
    stream keeps reconnecting to that test's closed server and logs a refused connection
    into the next test's page (seen once in CI)."""
    driver.get("about:blank")
    driver.get_log("browser")


def color_pixels(driver: Any, rgb: tuple[int, int, int]) -> int:
    """Pixels of the arm canvas within 12 of ``rgb`` on every channel."""
    return driver.execute_script("""
        const [r, g, b] = arguments[0];
        const c = document.querySelector('[data-testid="arm-canvas"]');
        const px = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
        let n = 0;
        for (let i = 0; i < px.length; i += 4)
          if (px[i + 3] > 200 && Math.abs(px[i] - r) < 12 && Math.abs(px[i + 1] - g) < 12
              && Math.abs(px[i + 2] - b) < 12) n++;
        return n;""", list(rgb))


def present_degrees(service: Any) -> list[float]:
    status, state = service.call("GET", "/v1/state")
    assert status == 200, state
    return [math.degrees(q) for q in state["joints"]]


def shown_degrees(driver: Any) -> list[float]:
    return [float(v) for v in re.findall(r"-?\d+(?:\.\d+)?", el(driver, "joints").text)]


def far_target(service: Any) -> tuple[float, float, float]:
    """Home or REACHABLE, whichever the arm is not at: a move of some length from here."""
    _, state = service.call("GET", "/v1/state")
    x, y, _ = state["pose"]
    return (0.25, 0.10, 0.0) if math.hypot(x - 0.25, y - 0.10) > 0.05 else REACHABLE


def click_move_and_wait_running(driver: Any, until: Any, service: Any) -> str:
    before = service.move_count()
    el(driver, "move").click()
    from selenium.common.exceptions import TimeoutException
    try:
        until(lambda d: service.move_count() == before + 1)
    except TimeoutException:  # say why: what the page shows and what the service logged
        raise AssertionError(f"no move was started; the page's error: "
                             f"{el(driver, 'error').text!r}, move status: "
                             f"{el(driver, 'move-status').text!r}; the service's log:\n"
                             f"{service.log_tail()}") from None
    move_id = str(before + 1)
    until(lambda d: el(d, "move-status").get_attribute("data-move-id") == move_id)
    return move_id


def shown_plan(driver: Any, until: Any, service: Any, move_id: str) -> tuple[Any, Any]:
    """The plan the page draws once it tracks move ``move_id``, and that move's own plan
    (GET /v1/moves/{id}/trajectory, 200): (shown, own)."""
    shown = until(lambda d: d.execute_script(
        "const S = window.robodcnConsole.S;"
        "return S.trackedMove === arguments[0] && S.movePlan", move_id), 10,
        f"the page shows no plan of move {move_id}")
    status, own = service.call("GET", f"/v1/moves/{move_id}/trajectory")
    assert status == 200, own
    return shown, own


def move_with_screenshot(driver: Any, until: Any, service: Any, shot: Path, after_s: float,
                         timeout: float) -> str:
    """Click Move; once it runs, ``after_s`` later, save a screenshot to ``shot`` (a PNG);
    wait up to ``timeout`` for the move to finish, on the page and in the service (done or
    degraded). The move's id."""
    move_id = click_move_and_wait_running(driver, until, service)
    until(lambda d: el(d, "move-status").text == "running", 10)
    time.sleep(after_s)
    driver.save_screenshot(str(shot))
    assert shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    until(lambda d: el(d, "move-status").text in FINISHED, timeout)
    status, info = service.call("GET", f"/v1/moves/{move_id}")
    assert status == 200 and info["status"] in FINISHED, info
    return move_id


def start_slow_move(driver: Any, until: Any, service: Any, target: Any = None) -> str:
    """Type a far target (or ``target``) with a 6 s duration, so that what the test does
    next lands mid-move, click Move and wait until it runs; its move id."""
    type_target(driver, far_target(service) if target is None else target, duration="6")
    move_id = click_move_and_wait_running(driver, until, service)
    until(lambda d: el(d, "move-status").text == "running", 10)
    return move_id


def test_page_loads_without_console_errors(driver: Any, until: Any, service: Any) -> None:
    forget_earlier_pages(driver)
    open_console(driver, until, service)
    until(lambda d: el(d, "move-status").text != "")
    time.sleep(1.0)  # a few state events, drawing
    assert severe_logs(driver) == []
    assert el(driver, "arm-canvas").size["width"] > 300
    # Controls the service does not offer stay hidden; the token field only when needed.
    _, doc = service.call("GET", "/openapi.json")
    for testid, path in (("pause", "/v1/pause"), ("resume", "/v1/resume"),
                         ("speed", "/v1/speed")):
        assert el(driver, testid).is_displayed() == (path in doc["paths"]), testid
    assert not el(driver, "token").is_displayed()
    # The readout shows the arm's present joints, in degrees.
    shown, present = shown_degrees(driver), present_degrees(service)
    assert len(shown) == len(present)
    assert all(abs(a - b) < 0.2 for a, b in zip(shown, present, strict=True)), (shown, present)


def test_preview_draws_the_planned_path(driver: Any, until: Any, service: Any) -> None:
    open_console(driver, until, service)
    type_target(driver, REACHABLE)
    el(driver, "method").send_keys("ScLERP")
    time.sleep(0.6)  # let the typed target's own debounced preview land
    sclerp = (0x24, 0x57, 0xC5)
    driver.execute_script("""const c = window.robodcnConsole;
        c.S.plans = {}; c.S.planOrder = []; c.draw();
        document.querySelector('#plans tbody').replaceChildren();""")
    before = color_pixels(driver, sclerp)
    el(driver, "preview").click()
    until(lambda d: "feasible" in d.find_element("css selector", "#plans tbody").text)
    driver.execute_script("window.robodcnConsole.draw()")
    after = color_pixels(driver, sclerp)
    assert after > before + 50, (before, after)
    assert el(driver, "error").text == ""


def test_move_runs_to_done(driver: Any, until: Any, service: Any, tmp_path: Path) -> None:
    service.wait_idle()
    open_console(driver, until, service)
    start = present_degrees(service)
    type_target(driver, far_target(service), duration="2.5")
    # Overlay all four methods: each gets a row with its duration and feasibility.
    for box in driver.find_elements("css selector", ".overlay-method"):
        if not box.is_selected():
            box.click()
    el(driver, "preview").click()
    rows_js = "return [...document.querySelectorAll('#plans tbody tr')].map(r => r.innerText)"

    def every_method_feasible(d: Any) -> bool:
        rows = d.execute_script(rows_js)
        return len(rows) == 4 and all(
            any(name in r and "2.50 s" in r and "feasible" in r for r in rows)
            for name in ("ScLERP", "KenLERP", "SEP-LERP", "DLB"))

    until(every_method_feasible, 10, "not every method's row says feasible in 2.50 s")
    move_with_screenshot(driver, until, service, tmp_path / "console.png", 1.0, 20)
    # The arm moved, and the page shows where it is now.
    end = present_degrees(service)
    assert max(abs(a - b) for a, b in zip(start, end, strict=True)) > 5
    until(lambda d: all(abs(a - b) < 0.2 for a, b in zip(shown_degrees(d), end, strict=True)),
          5, "the joints readout does not show the final joints")
    measured = driver.execute_script("return window.robodcnConsole.S.measured.length")
    assert measured > 20


def test_stop_during_a_move_stops_it(driver: Any, until: Any, service: Any) -> None:
    service.wait_idle()
    open_console(driver, until, service)
    move_id = start_slow_move(driver, until, service)  # the stop lands mid-move
    time.sleep(0.5)
    el(driver, "stop").click()
    until(lambda d: el(d, "move-status").text == "stopped", 10)
    status, info = service.call("GET", f"/v1/moves/{move_id}")
    assert status == 200 and info["status"] == "stopped" and info["progress"] < 0.9, info


def test_unreachable_target_shows_the_error_and_sends_no_move(driver: Any, until: Any,
                                                              service: Any) -> None:
    service.wait_idle()
    open_console(driver, until, service)
    before = service.move_count()
    type_target(driver, UNREACHABLE)
    el(driver, "move").click()
    text = until(lambda d: el(d, "error").text, 10)
    # The field names the target in the body sent: its only waypoint where the contract
    # takes a one-waypoint move (from the present state), else the second.
    one = driver.execute_script("return window.robodcnConsole.S.features.oneWaypoint")
    assert "out of reach" in text and f"waypoints[{0 if one else 1}]" in text, text
    # The refused move is marked at the target, not at the present pose.
    mark = until(lambda d: d.execute_script(
        "const p = window.robodcnConsole.S.plans.sclerp; return p && p.mark"), 10)
    assert math.dist(mark[:2], UNREACHABLE[:2]) < 1e-9, mark
    time.sleep(0.5)
    assert service.move_count() == before
    assert not service.call("GET", "/healthz")[1]["moving"]
    # The preview marks the failing waypoint on the canvas.
    el(driver, "preview").click()
    until(lambda d: d.execute_script(
        "const p = window.robodcnConsole.S.plans.sclerp; return p && p.mark"), 10)


def test_four_overlays_of_an_unreachable_target_say_it_once(driver: Any, until: Any,
                                                            service: Any) -> None:
    """Issue 27 §7: four methods refused at one target showed the error four times, the
    field twice in each row, and four labels on top of each other, cut at the edge."""
    service.wait_idle()
    open_console(driver, until, service)
    type_target(driver, UNREACHABLE)
    for box in driver.find_elements("css selector", ".overlay-method"):
        if not box.is_selected():
            box.click()
    el(driver, "preview").click()
    rows_js = "return [...document.querySelectorAll('#plans tbody tr')].map(r => r.innerText)"
    rows = until(lambda d: (r := d.execute_script(rows_js)) and len(r) == 4
                 and all("–" in x for x in r) and r, 15, "no four refused rows")
    first, *others = rows
    assert "out of reach" in first and first.count("waypoints[1]") == 1, first
    assert all("as ScLERP" in r and "out of reach" not in r for r in others), others
    error = el(driver, "error").text
    assert error.count("out of reach") == 1, error
    assert error.startswith("ScLERP, KenLERP, SEP-LERP, DLB: "), error
    labels = until(lambda d: d.execute_script(
        "return window.robodcnConsole.S.markLabels"), 10, "no mark label drawn")
    width = driver.execute_script("return document.querySelector('canvas').width")
    assert len(labels) == 1 and len(labels[0]["methods"]) == 4, labels
    assert 0 <= labels[0]["x"] and labels[0]["x"] + labels[0]["w"] <= width, (labels, width)


def test_a_too_fast_plan_marks_its_failing_sample(driver: Any, until: Any,
                                                 service: Any) -> None:
    service.wait_idle()
    open_console(driver, until, service)
    target = far_target(service)
    type_target(driver, target, duration="0.3")
    el(driver, "preview").click()
    text = until(lambda d: el(d, "error").text, 10)
    assert re.search(r"sample \d+", text) and "limit" in text, text
    mark = until(lambda d: d.execute_script(
        "const p = window.robodcnConsole.S.plans.sclerp; return p && p.error && p.mark"), 10)
    # The mark lies on the path: between the start and the target, inside the reach.
    _, state = service.call("GET", "/v1/state")
    assert math.hypot(mark[0], mark[1]) <= sum(service.call("GET", "/v1/arm")[1]["config"][
        "arm"]["links"])
    span = math.hypot(target[0] - state["pose"][0], target[1] - state["pose"][1])
    assert math.hypot(mark[0] - state["pose"][0], mark[1] - state["pose"][1]) <= span + 0.01


def test_dragging_the_target_changes_the_inputs(driver: Any, until: Any, service: Any) -> None:
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.actions.wheel_input import ScrollOrigin

    open_console(driver, until, service)
    type_target(driver, (0.2, 0.0, 0.0))
    canvas = el(driver, "arm-canvas")
    px, py = driver.execute_script(
        "const c = window.robodcnConsole; return c.toCanvas(c.S.target[0], c.S.target[1]);")
    w, h = canvas.size["width"], canvas.size["height"]
    (ActionChains(driver).move_to_element_with_offset(canvas, int(px - w / 2), int(py - h / 2))
     .click_and_hold().move_by_offset(30, -40).move_by_offset(10, -10).release().perform())
    x, y = float(el(driver, "target-x").get_attribute("value")), \
        float(el(driver, "target-y").get_attribute("value"))
    assert x > 0.2 + 0.01 and y > 0.01, (x, y)
    # The mouse wheel turns it, 5° a notch.
    ActionChains(driver).scroll_from_origin(ScrollOrigin.from_element(canvas), 0, -100).perform()
    until(lambda d: float(el(d, "target-theta").get_attribute("value")) == 5.0, 5)


def test_events_arrive_at_20_hz_while_moving(driver: Any, until: Any, service: Any) -> None:
    service.wait_idle()
    open_console(driver, until, service)
    type_target(driver, far_target(service), duration="3")
    click_move_and_wait_running(driver, until, service)
    until(lambda d: el(d, "move-status").text == "running", 10)
    t0 = driver.execute_script("return performance.now()")
    time.sleep(1.5)
    stamps = driver.execute_script("return window.robodcnConsole.stats.stamps")
    window = [t for t in stamps if t0 + 250 <= t < t0 + 1250]
    assert len(window) >= 20, len(window)
    until(lambda d: el(d, "move-status").text in FINISHED, 20)


def test_the_page_works_with_a_token(driver: Any, until: Any, token_service: Any) -> None:
    if driver.current_url.startswith("http"):
        driver.execute_script("sessionStorage.clear()")
    open_console(driver, until, token_service)
    assert el(driver, "token").is_displayed()
    type_target(driver, REACHABLE)
    el(driver, "move").click()
    assert "token" in until(lambda d: el(d, "error").text, 10)
    assert token_service.move_count() == 0
    el(driver, "token").send_keys(token_service.token + "\n")
    el(driver, "move").click()
    until(lambda d: token_service.move_count() == 1, 10, "the move with the token was refused")
    until(lambda d: el(d, "move-status").text in FINISHED, 20)
    # Kept for this tab's session only.
    assert driver.execute_script("return sessionStorage.getItem('robodcn-token')") == \
        token_service.token
    assert driver.execute_script("return localStorage.length") == 0


def test_keyboard_jog_moves_the_tool(driver: Any, until: Any, service: Any) -> None:
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.keys import Keys

    service.wait_idle()
    open_console(driver, until, service)
    _, state = service.call("GET", "/v1/state")
    before = service.move_count()
    driver.execute_script("document.activeElement && document.activeElement.blur()")
    ActionChains(driver).send_keys(Keys.ARROW_RIGHT).perform()  # +x by the 1 cm step
    until(lambda d: service.move_count() == before + 1, 10, "the key started no move")
    until(lambda d: el(d, "move-status").get_attribute("data-move-id") == str(before + 1))
    until(lambda d: el(d, "move-status").text in FINISHED, 20)
    _, after = service.call("GET", "/v1/state")
    assert abs(after["pose"][0] - state["pose"][0] - 0.01) < 0.002, (state["pose"], after["pose"])
    assert abs(after["pose"][1] - state["pose"][1]) < 0.002


def test_the_page_drives_serve_device_on_firmware_sim(driver: Any, until: Any,
                                                      device_service: Any) -> None:
    forget_earlier_pages(driver)
    open_console(driver, until, device_service)
    start = present_degrees(device_service)
    type_target(driver, REACHABLE)
    move_id = click_move_and_wait_running(driver, until, device_service)
    until(lambda d: el(d, "move-status").text in FINISHED, 30)
    assert device_service.call("GET", f"/v1/moves/{move_id}")[1]["status"] in FINISHED
    _, state = device_service.call("GET", "/v1/state")
    assert math.hypot(state["pose"][0] - REACHABLE[0], state["pose"][1] - REACHABLE[1]) < 0.005
    end = present_degrees(device_service)
    assert max(abs(a - b) for a, b in zip(start, end, strict=True)) > 5
    # The servos may still settle after the last sample: compare with the present joints
    # read at the same time as the readout.
    until(lambda d: all(abs(a - b) < 0.2 for a, b in zip(
        shown_degrees(d), present_degrees(device_service), strict=True)),
          5, "the joints readout does not show the final joints")
    assert severe_logs(driver) == []


def test_the_page_reconnects_after_the_service_restarts(driver: Any, until: Any,
                                                        restartable: Any) -> None:
    _, start = restartable
    with start() as first:
        open_console(driver, until, first)
        until(lambda d: el(d, "link").text == "live")
    until(lambda d: el(d, "link").text != "live", 10, "the page did not see the stream drop")
    with start() as second:
        seen = driver.execute_script("return window.robodcnConsole.stats.state")
        until(lambda d: el(d, "link").text == "live", 20, "the page did not reconnect")
        until(lambda d: d.execute_script("return window.robodcnConsole.stats.state") > seen,
              10, "no state events after reconnecting")
        assert second.call("GET", "/healthz")[0] == 200


@pytest.mark.parametrize("path", ["/static/app.js", "/static/style.css"])
def test_assets_are_served(driver: Any, service: Any, path: str) -> None:
    status, _ = service.call("GET", "/healthz")
    assert status == 200
    driver.get(service.url + path)
    assert len(driver.find_element("tag name", "body").text) > 100


def test_torque_buttons_switch_the_servos(driver: Any, until: Any, service: Any) -> None:
    """The console offers torque once the service documents POST /v1/torque, and its
    buttons switch the servos (the pill follows the state events)."""
    service.wait_idle()
    open_console(driver, until, service)
    assert el(driver, "torque-off").is_displayed()
    try:
        el(driver, "torque-off").click()
        until(lambda d: service.call("GET", "/v1/state")[1]["torque"] is False, 10,
              "torque did not go off")
        until(lambda d: d.find_element("id", "torque-state").text == "torque off", 10)
        el(driver, "torque-on").click()
        until(lambda d: service.call("GET", "/v1/state")[1]["torque"] is True, 10,
              "torque did not come back on")
        until(lambda d: d.find_element("id", "torque-state").text == "torque on", 10)
    finally:
        service.call("POST", "/v1/torque", {"on": True})


def test_pause_resume_and_the_speed_slider_drive_the_move(driver: Any, until: Any,
                                                          service: Any) -> None:
    """The service documents pause, resume and speed: the console shows them and they act
    on the running move (checked on the service's own move status and state)."""
    service.wait_idle()
    open_console(driver, until, service)
    for testid in ("pause", "resume", "speed"):
        assert el(driver, testid).is_displayed(), testid
    assert not el(driver, "resume").is_enabled(), "Resume offered with nothing paused"
    move_id = start_slow_move(driver, until, service)
    assert not el(driver, "resume").is_enabled(), "Resume offered on a running move"
    driver.execute_script("""
        const s = arguments[0];
        s.value = '0.5';
        s.dispatchEvent(new Event('input'));
        s.dispatchEvent(new Event('change'));""", el(driver, "speed"))
    until(lambda d: service.call("GET", f"/v1/moves/{move_id}")[1]["speed_scale"] == 0.5, 10,
          "the speed slider did not set the speed scale")
    el(driver, "pause").click()
    until(lambda d: service.call("GET", f"/v1/moves/{move_id}")[1]["paused"] is True, 10,
          "Pause did not pause the move")
    time.sleep(0.8)   # the brake to rest is over well within this
    before = present_degrees(service)
    time.sleep(0.5)
    after = present_degrees(service)
    assert max(abs(a - b) for a, b in zip(before, after, strict=True)) < 0.2, "paused arm moved"
    _, info = service.call("GET", f"/v1/moves/{move_id}")
    assert info["status"] == "running" and info["progress"] < 0.9, info
    until(lambda d: el(d, "resume").is_enabled(), 10, "Resume not offered on a paused move")
    el(driver, "resume").click()
    until(lambda d: service.call("GET", f"/v1/moves/{move_id}")[1]["paused"] is False, 10,
          "Resume did not resume the move")
    until(lambda d: el(d, "move-status").text in FINISHED, 30)
    _, info = service.call("GET", f"/v1/moves/{move_id}")
    assert info["status"] in FINISHED, info


def test_hold_holds_at_once_and_stop_stops_smoothly(driver: Any, until: Any,
                                                    service: Any) -> None:
    """Stop sends {"mode": "smooth"} (the report says it decelerated along the path), Hold
    {"mode": "hold"} (held where the arm was)."""
    for button, smooth in (("stop", True), ("hold", False)):
        service.wait_idle()
        open_console(driver, until, service)
        move_id = start_slow_move(driver, until, service)
        time.sleep(0.5)
        el(driver, button).click()
        until(lambda d: el(d, "move-status").text == "stopped", 10)
        _, info = service.call("GET", f"/v1/moves/{move_id}")
        assert info["status"] == "stopped", info
        assert ("smoothly" in info["report"]["message"]) is smooth, (button, info["report"])


def test_move_while_moving_replaces_the_running_move(driver: Any, until: Any,
                                                     service: Any) -> None:
    """The move body has two forms (waypoints with replace, or a given trajectory): the page
    still finds replace, keeps Move enabled while moving, and a second Move retargets."""
    service.wait_idle()
    open_console(driver, until, service)
    assert driver.execute_script("return window.robodcnConsole.S.features.replace") is True
    target = far_target(service)
    first = start_slow_move(driver, until, service, target)
    time.sleep(0.5)
    assert el(driver, "move").is_enabled()
    type_target(driver, (0.2, 0.15, 30.0))
    second = click_move_and_wait_running(driver, until, service)
    until(lambda d: service.call("GET", f"/v1/moves/{first}")[1]["status"] == "replaced", 10)
    until(lambda d: el(d, "move-status").text in FINISHED, 30)
    _, info = service.call("GET", f"/v1/moves/{second}")
    assert info["status"] in FINISHED, info
    _, state = service.call("GET", "/v1/state")
    assert math.hypot(state["pose"][0] - 0.2, state["pose"][1] - 0.15) < 0.01, state["pose"]
