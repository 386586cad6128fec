"""Dragging the target moves the arm live: one follow session in pose space per drag.

Headless Chromium drags the target frame on the arm canvas of a real ``robodcn serve
--sim`` (arm3r) with the pointer (selenium's ActionChains); the service is asked on its
own API, mid-drag and after the drop, what the arm and its moves did: one move with status
``following`` for the whole drag, the present joints heading for the dragged target before
the pointer is released, the move ending at the last target after it.
"""

from __future__ import annotations

import itertools
import math
import time
from pathlib import Path
from typing import Any

from test_console import (
    FINISHED,
    click_move_and_wait_running,
    el,
    forget_earlier_pages,
    open_console,
    severe_logs,
    type_target,
)

ROOT = Path(__file__).resolve().parent.parent
HOME = (0.25, 0.10, 0.0)       # m, m, deg: arm3r's home
DRAG_TO = (0.18, 0.18)         # m: in reach at θ = 0
OUT_OF_REACH = (0.45, 0.10)    # m: beyond the 0.40 m the links reach
#: m: how near the target the arm rests: a joint that settles 7 ticks (0.6°) short moves
#: the tool up to ~4 mm at 0.4 m
SETTLED = 0.006


def canvas_px(driver: Any, x: float, y: float, view: str = "arm-canvas") -> tuple[float, float]:
    """Client-pixel offset from the centre of canvas ``view`` (the side view, or "arm-top")
    of its drawing's point (x, y) (metres)."""
    return driver.execute_script("""
        const c = window.robodcnConsole, el = document.getElementById(arguments[2]);
        const to = arguments[2] === 'arm-top' ? c.topToCanvas : c.toCanvas;
        const [px, py] = to(arguments[0], arguments[1]);
        const r = el.getBoundingClientRect();
        return [px * r.width / el.width - r.width / 2, py * r.height / el.height - r.height / 2];
        """, x, y, view)


def press_and_drag(driver: Any, start: tuple[float, float], end: tuple[float, float],
                   steps: int = 12, pause_s: float = 0.06, press: bool = True,
                   view: str = "arm-canvas", path: Any = None) -> None:
    """Press the pointer on canvas ``view`` at drawing point ``start`` and drag it in
    ``steps`` to ``end`` (along ``path(s)``, s in (0, 1], where given; else straight), a
    pause between steps (a hand's pace); the button stays down. ``press=False``: the
    pointer is already down at ``start`` (a drag going on)."""
    from selenium.webdriver.common.action_chains import ActionChains

    canvas = el(driver, view)
    x0, y0 = canvas_px(driver, *start, view)
    if path is None:
        path = lambda s: (start[0] + (end[0] - start[0]) * s,  # noqa: E731
                          start[1] + (end[1] - start[1]) * s)
    chain = ActionChains(driver, duration=20)
    if press:
        chain.move_to_element_with_offset(canvas, round(x0), round(y0)).click_and_hold()
    done = (round(x0), round(y0))
    for k in range(1, steps + 1):
        px, py = canvas_px(driver, *path(k / steps), view)
        at = (round(px), round(py))
        chain.move_by_offset(at[0] - done[0], at[1] - done[1]).pause(pause_s)
        done = at
    chain.perform()


def release(driver: Any) -> None:
    from selenium.webdriver.common.action_chains import ActionChains

    ActionChains(driver).release().perform()


def move_of(service: Any, move_id: int) -> dict[str, Any]:
    status, info = service.call("GET", f"/v1/moves/{move_id}")
    assert status == 200, info
    return info


def present_pose(service: Any) -> list[float]:
    status, state = service.call("GET", "/v1/state")
    assert status == 200, state
    return state["pose"]


def shown_target(driver: Any) -> list[float]:
    return driver.execute_script("return window.robodcnConsole.S.target.slice()")


#: records the page's requests to /v1/follow…: method, body, sent and answered (ms)
RECORD_FOLLOW = """
    const sent = window.followWire = [], fetched = window.fetch;
    window.fetch = async (path, init) => {
      if (!String(path).startsWith('/v1/follow')) return fetched(path, init);
      const row = { method: init.method, body: JSON.parse(init.body),
        type: init.headers['Content-Type'], at: performance.now(), done: null };
      sent.push(row);
      try { return await fetched(path, init); } finally { row.done = performance.now(); }
    };"""


def start_at_home(driver: Any, until: Any, service: Any) -> int:
    """The page open with the arm resting at home (typed and moved there with Move, the
    click-a-button flow) and the target on it; the number of moves recorded so far."""
    forget_earlier_pages(driver)
    open_console(driver, until, service)
    service.wait_idle()
    if math.dist(present_pose(service)[:2], HOME[:2]) > 0.002:
        type_target(driver, HOME)
        home = click_move_and_wait_running(driver, until, service)
        until(lambda d: move_of(service, int(home))["status"] in FINISHED, 20,
              f"the move home never ended: {move_of(service, int(home))}")
        service.wait_idle()
    type_target(driver, HOME)
    until(lambda d: math.dist(shown_target(d)[:2], HOME[:2]) < 1e-6, 5)
    driver.execute_script("document.activeElement.blur()")   # keys go to the page
    return service.move_count()


def test_a_drag_follows_live_as_one_move_and_rests_at_the_drop(driver: Any, until: Any,
                                                               service: Any) -> None:
    before = start_at_home(driver, until, service)
    start = present_pose(service)
    driver.execute_script(RECORD_FOLLOW)
    press_and_drag(driver, HOME[:2], DRAG_TO)
    # Mid-drag, the button still down: one move, following, and the arm on its way.
    session = before + 1
    until(lambda d: service.move_count() == session, 10, "no follow session was opened")
    info = move_of(service, session)
    assert info["status"] == "following", (info, service.log_tail())
    dragged = shown_target(driver)
    assert math.dist(dragged[:2], DRAG_TO) < 0.01, dragged
    until(lambda d: math.dist(present_pose(service)[:2], dragged[:2])
          < 0.25 * math.dist(start[:2], dragged[:2]), 10,
          "the arm did not head for the dragged target before the drop")
    info = move_of(service, session)
    assert info["status"] == "following", (info, service.log_tail())
    assert service.move_count() == session
    assert el(driver, "move-status").text == "following"
    release(driver)
    # After the drop: the session ends at rest at the last target, the only move.
    until(lambda d: move_of(service, session)["status"] not in ("following",), 20,
          "the session never ended")
    info = move_of(service, session)
    assert info["status"] in FINISHED, (info, service.log_tail())
    service.wait_idle()
    rest = present_pose(service)
    # within SETTLED: the servos' own position loop stops a few ticks short (the move's
    # report names them "out of position")
    assert math.dist(rest[:2], dragged[:2]) < SETTLED, (rest, dragged)
    assert abs(rest[2] - dragged[2]) < math.radians(1.5), (rest, dragged)
    assert service.move_count() == session
    until(lambda d: el(d, "move-status").text in FINISHED, 10)
    assert el(driver, "error").text == ""
    assert severe_logs(driver) == []
    # On the wire: open, targets at most one in flight and ~30 ms apart, the last target
    # the dropped pose, then the end; all JSON.
    wire = driver.execute_script("return window.followWire")
    assert [r["method"] for r in (wire[0], wire[-1])] == ["POST", "DELETE"], wire
    assert wire[0]["body"] == {"space": "pose"} and wire[-1]["body"] == {}
    assert all(r["type"] == "application/json" for r in wire)
    puts = wire[1:-1]
    assert puts and all(r["method"] == "PUT" for r in puts), wire
    assert len(puts) <= 12 + 1       # one pose a pointer step at most (12 steps)
    for a, b in itertools.pairwise(wire):
        assert b["at"] >= a["done"], (a, b)              # one request in flight
    for a, b in itertools.pairwise(puts):
        assert b["at"] - a["at"] >= 29, (a, b)           # at most every 30 ms
    assert math.dist(puts[-1]["body"]["pose"], dragged) < 1e-9, (puts[-1], dragged)


def test_an_unreachable_drag_says_pose_and_the_arm_rests_at_the_last_valid_target(
        driver: Any, until: Any, service: Any) -> None:
    before = start_at_home(driver, until, service)
    press_and_drag(driver, HOME[:2], OUT_OF_REACH, steps=14)
    until(lambda d: "pose" in el(d, "error").text, 10,
          "the page shows no refusal of the out-of-reach target: it shows "
          f"{el(driver, 'error').text!r}, target {shown_target(driver)}, "
          f"move {move_of(service, before + 1) if service.move_count() > before else None}; "
          f"the service's log:\n{service.log_tail()}")
    assert "reach" in el(driver, "error").text
    release(driver)
    session = before + 1
    until(lambda d: move_of(service, session)["status"] != "following", 20)
    assert move_of(service, session)["status"] in FINISHED
    service.wait_idle()
    # The arm went on to the last target the service took, short of the refused ones.
    taken = driver.execute_script("const S = window.robodcnConsole.S;"
                                  "return S.sent && S.sent.id == arguments[0] && S.sent.pose",
                                  str(session))
    assert taken, "the page kept no taken target"
    rest = present_pose(service)
    # (at the edge of reach, the elbow near straight, the servos' few ticks short move the
    # tool further: up to ~1 cm, still far from the refused poses)
    assert math.dist(rest[:2], taken[:2]) < 0.01, (rest, taken, move_of(service, session))
    assert math.hypot(*rest[:2]) < 0.401
    assert math.dist(rest[:2], OUT_OF_REACH) > 0.04
    assert service.move_count() == session


def test_escape_mid_drag_stops_the_session_and_the_drop_starts_nothing(
        driver: Any, until: Any, service: Any) -> None:
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.keys import Keys

    before = start_at_home(driver, until, service)
    press_and_drag(driver, HOME[:2], DRAG_TO, steps=6)
    session = before + 1
    until(lambda d: service.move_count() == session, 10)
    ActionChains(driver).send_keys(Keys.ESCAPE).perform()   # the page's smooth Stop
    until(lambda d: move_of(service, session)["status"] == "stopped", 10,
          "Escape did not stop the follow session: "
          f"{move_of(service, session)}, the page's error {el(driver, 'error').text!r}, "
          f"focus on {driver.execute_script('return document.activeElement.tagName')}; "
          f"the service's log:\n{service.log_tail()}")
    # Dragging on and dropping: the targets find no session; nothing new starts.
    press_and_drag(driver, DRAG_TO, (0.2, 0.05), steps=4, press=False)
    release(driver)
    time.sleep(0.5)
    assert service.move_count() == session
    assert move_of(service, session)["status"] == "stopped"
    assert el(driver, "error").text == ""


def test_a_yaw_drag_on_the_omx_top_view_turns_the_arm_live(driver: Any, until: Any,
                                                           omx_service: Any) -> None:
    from test_console_omx import open_omx

    forget_earlier_pages(driver)
    omx_service.wait_idle()
    open_omx(driver, until, omx_service)
    driver.execute_script("document.activeElement.blur()")
    before = omx_service.move_count()
    start = omx_service.call("GET", "/v1/state")[1]
    target = shown_target(driver)
    radius, yaw0 = math.hypot(*target[:2]), math.atan2(target[1], target[0])
    turn = math.radians(35)

    def arc(s: float) -> tuple[float, float]:
        return radius * math.cos(yaw0 + turn * s), radius * math.sin(yaw0 + turn * s)

    press_and_drag(driver, arc(0), arc(1), steps=10, view="arm-top", path=arc)
    session = before + 1
    until(lambda d: omx_service.move_count() == session, 10, "no follow session was opened")
    dragged = shown_target(driver)
    want = math.atan2(dragged[1], dragged[0])
    assert abs(want - (yaw0 + turn)) < math.radians(3), (want, yaw0 + turn)
    # Mid-drag: following, the yaw well on its way (the base joint is the yaw).
    until(lambda d: abs(omx_service.call("GET", "/v1/state")[1]["joints"][0] - want)
          < 0.3 * abs(start["joints"][0] - want), 10, "the yaw did not follow the drag")
    info = move_of(omx_service, session)
    assert info["status"] == "following", (info, omx_service.log_tail())
    release(driver)
    until(lambda d: move_of(omx_service, session)["status"] != "following", 20)
    info = move_of(omx_service, session)
    assert info["status"] in FINISHED, (info, omx_service.log_tail())
    omx_service.wait_idle()
    rest = omx_service.call("GET", "/v1/state")[1]
    assert abs(rest["joints"][0] - want) < math.radians(1.5), (rest["joints"], want)
    assert math.dist(rest["pose"][:3], dragged[:3]) < SETTLED, (rest["pose"], dragged)
    assert omx_service.move_count() == session


def test_leaving_the_page_mid_drag_ends_the_session(driver: Any, until: Any,
                                                    service: Any) -> None:
    before = start_at_home(driver, until, service)
    press_and_drag(driver, HOME[:2], DRAG_TO, steps=6)
    session = before + 1
    until(lambda d: service.move_count() == session, 10)
    until(lambda d: move_of(service, session)["status"] == "following", 10)
    driver.get("about:blank")               # the tab goes elsewhere, the button still down
    release(driver)
    until(lambda d: move_of(service, session)["status"] != "following", 10,
          "the session outlived the page")
    assert move_of(service, session)["status"] in FINISHED
    service.wait_idle()
    status, info = service.call("POST", "/v1/follow", {"space": "pose"})   # the arm is free
    assert status == 201, info
    assert service.call("DELETE", "/v1/follow", {})[0] == 200


def test_without_follow_in_the_contract_a_drag_only_previews(driver: Any, until: Any,
                                                             stub: Any) -> None:
    """A service whose OpenAPI document lists no follow_open (an older one): the drag moves
    the target only, and the drop previews the plan to it (POST /v1/trajectories)."""
    import copy

    from test_console_stubbed import arm_info, open_stub, stub_state

    from robodcn.config import load_arm
    from robodcn.http.openapi import openapi

    arm = load_arm(ROOT / "configs" / "arm3r.toml")
    doc = copy.deepcopy(openapi(arm))
    for path in ("/v1/follow", "/v1/follow/target"):
        del doc["paths"][path]
    forget_earlier_pages(driver)
    fake = stub({"/openapi.json": doc, "/v1/arm": arm_info(arm),
                 "/v1/state": stub_state([0.3, -0.6, 0.2], [*HOME[:2], 0.0],
                                         list(arm.joint_names))})
    open_stub(driver, until, fake)
    until(lambda d: math.dist(shown_target(d)[:2], HOME[:2]) < 1e-6, 5)
    press_and_drag(driver, HOME[:2], DRAG_TO, steps=6)
    release(driver)
    until(lambda d: fake.posted("/v1/trajectories"), 10, "the drop previewed nothing")
    assert math.dist(fake.posted("/v1/trajectories")[-1]["waypoints"][-1][:2], DRAG_TO) < 0.01
    assert not [r for r in fake.requests if r[1].startswith("/v1/follow")], fake.requests
