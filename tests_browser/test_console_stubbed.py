"""The console against a scripted service (stub_service): what ``robodcn serve`` cannot be
made to do on demand — a move that ends ``degraded`` — and what it does not offer yet —
a contract with another β range, a yawed arm (x, y, z, pitch; issue 18 §1), a gripper
route (issue 18 §4). The answers are built from robodcn itself (its OpenAPI document, its
config and kinematics) or taken from a real service, so their shapes are the real ones.
"""

from __future__ import annotations

import copy
import math
import re
import time
from pathlib import Path
from typing import Any

from test_console import el, forget_earlier_pages, severe_logs, type_target

from robodcn.config import load_arm
from robodcn.http.openapi import openapi
from robodcn.kinematics import Chain, fk_yawed
from robodcn.kinematics._yawed import plane_fk

ROOT = Path(__file__).resolve().parent.parent
ARM_RGB = (0x38, 0x40, 0x4A)


def arm_info(arm: Any) -> dict[str, Any]:
    """GET /v1/arm of ``arm`` (robodcn.http.ops.op_arm's fields)."""
    return {"name": arm.name, "dof": arm.dof, "joint_names": list(arm.joint_names),
            "servo_ids": list(arm.servo_ids), "source": str(arm.source),
            "config": arm.to_dict()}


def stub_state(joints: list[float], pose: list[float], names: list[str]) -> dict[str, Any]:
    return {"joints": joints, "pose": pose, "ticks": [2048] * len(joints), "joint_names": names,
            "torque": True, "alerts": {}, "moving": False, "move": None, "source": "bus",
            "paused": False, "speed_scale": None}


def open_stub(driver: Any, until: Any, stub: Any) -> None:
    driver.get(stub.url + "/")
    until(lambda d: d.execute_script(
        "return window.robodcnConsole && window.robodcnConsole.S.model !== null"), 10)
    stub.push("state", {**stub.get["/v1/state"], "move_info": None})
    until(lambda d: re.search(r"-?\d", el(d, "joints").text), 10, message="no joints shown")


def pixel_near(driver: Any, canvas: str, px: float, py: float, rgb: tuple[int, ...],
               radius: int = 2) -> bool:
    """Some pixel within ``radius`` of (px, py) on canvas ``canvas`` is within 12 of rgb."""
    return driver.execute_script("""
        const [cid, x, y, r, rgb] = arguments;
        const c = document.querySelector(`[data-testid="${cid}"]`);
        const d = c.getContext('2d').getImageData(Math.round(x) - r, Math.round(y) - r,
                                                   2 * r + 1, 2 * r + 1).data;
        for (let i = 0; i < d.length; i += 4)
          if (d[i + 3] > 200 && [0, 1, 2].every((k) => Math.abs(d[i + k] - rgb[k]) < 12))
            return true;
        return false;""", canvas, px, py, radius, list(rgb))


def test_a_degraded_move_shows_why(driver: Any, until: Any, service: Any, stub: Any) -> None:
    """The reason comes from the move's report (headline, rate, warnings), as sent on the
    move event, and fetched from GET /v1/moves/{id} when the page only saw the short
    status of a state event."""
    service.wait_idle()
    _, st = service.call("GET", "/v1/state")
    turned = [*st["pose"][:2], st["pose"][2] + 0.2]
    status, info = service.call("POST", "/v1/moves",
                                {"waypoints": [st["pose"], turned], "duration": 0.3})
    assert status == 202, info
    service.wait_idle()
    _, real = service.call("GET", f"/v1/moves/{info['id']}")
    report = real["report"]
    for key in ("headline", "warnings", "rate_hz", "skipped", "samples_total"):
        assert key in report, key                     # the fields the console reads
    total = report["samples_total"]
    degraded = {**real, "id": "9", "status": "degraded",
                "report": {**report, "outcome": "degraded", "skipped": 3, "samples_skipped": 3,
                           "headline": f"completed with 3 of {total} samples skipped",
                           "warnings": [{"code": "rate", "message": "the bus carries 80 Hz"}]}}
    _, doc = service.call("GET", "/openapi.json")
    _, arm = service.call("GET", "/v1/arm")
    _, plan = service.call("GET", f"/v1/moves/{info['id']}/trajectory")
    fake = stub({"/openapi.json": doc, "/v1/arm": arm, "/v1/state": st,
                 "/v1/moves/9": degraded, "/v1/moves/9/trajectory": plan})
    forget_earlier_pages(driver)
    open_stub(driver, until, fake)
    assert not el(driver, "move-reason").is_displayed()
    short = {k: degraded[k] for k in ("id", "progress", "elapsed", "duration", "tracking_error",
                                      "error")}
    fake.push("state", {**st, "move_info": {**short, "status": "running"}})
    fake.push("move", degraded)
    until(lambda d: el(d, "move-status").text == "degraded", 10)
    text = until(lambda d: "skipped" in el(d, "move-reason").text and el(d, "move-reason").text,
                 10)
    assert f"3 of {total} samples skipped" in text and "100 Hz" in text, text
    assert "the bus carries 80 Hz" in text, text
    # A page opened after the move: the state event's short status, the report fetched.
    fake.events.clear()
    open_stub(driver, until, fake)
    fake.push("state", {**st, "move_info": {**short, "status": "degraded"}})
    until(lambda d: f"3 of {total} samples skipped" in el(d, "move-reason").text, 10,
          "the report's reason is not shown after a reload")
    # The gripper control is offered exactly when the (real) contract lists its route.
    assert el(driver, "gripper-row").is_displayed() == ("/v1/gripper" in doc["paths"])
    assert severe_logs(driver) == []


def test_the_beta_slider_follows_a_changed_contract(driver: Any, until: Any, stub: Any) -> None:
    arm = load_arm(ROOT / "configs" / "arm3r.toml")
    doc = copy.deepcopy(openapi(arm))
    beta = doc["components"]["schemas"]["PlanBody"]["properties"]["beta"]
    beta["oneOf"][0].update(minimum=0.25, maximum=4.0)
    fake = stub({"/openapi.json": doc, "/v1/arm": arm_info(arm),
                 "/v1/state": stub_state([0.3, -0.6, 0.2], [0.25, 0.1, 0.0],
                                         list(arm.joint_names))})
    open_stub(driver, until, fake)
    slider = el(driver, "beta")
    assert (slider.get_attribute("min"), slider.get_attribute("max")) == ("0.25", "4")
    assert 0.25 <= float(slider.get_attribute("value")) <= 4.0


def yawed_stub(stub: Any, q: list[float]) -> tuple[Any, Any]:
    arm = load_arm(ROOT / "configs" / "omx.toml")
    pose = fk_yawed(arm.chain, [q])[0].tolist()
    fake = stub({"/openapi.json": openapi(arm), "/v1/arm": arm_info(arm),
                 "/v1/state": stub_state(q, pose, list(arm.joint_names))})
    fake.answers[("POST", "/v1/trajectories")] = (422, {"error": {
        "code": "unreachable", "message": "refused by the stub", "field": "waypoints[1]"}})
    return arm, fake


def test_a_yawed_arm_has_four_pose_numbers_a_side_and_a_top_view(driver: Any, until: Any,
                                                                 stub: Any) -> None:
    q = [0.5, -0.5, 0.4, 0.6]
    arm, fake = yawed_stub(stub, q)
    forget_earlier_pages(driver)
    open_stub(driver, until, fake)
    for testid in ("target-x", "target-y", "target-z", "target-pitch"):
        assert el(driver, testid).is_displayed(), testid
    assert not el(driver, "target-theta").is_displayed()
    assert el(driver, "arm-top").is_displayed()
    pose = fake.get["/v1/state"]["pose"]
    readout = driver.find_element("id", "pose").text
    assert f"z {pose[2]:.3f} m" in readout and f"pitch {math.degrees(pose[3]):.1f}°" in readout
    driver.execute_script("window.robodcnConsole.draw()")
    # Side view: the last link, between robodcn's wrist and tool points in (r, z), is drawn.
    chain = arm.chain
    wrist = plane_fk(Chain(chain.links[:2], chain.shoulder_height), [q[1:3]])[0]
    tool = plane_fk(chain, [q[1:]])[0]
    for share in (0.3, 0.5, 0.7):
        u, v = (1 - share) * wrist[:2] + share * tool[:2]
        px, py = driver.execute_script("return window.robodcnConsole.toCanvas(...arguments)", u, v)
        assert pixel_near(driver, "arm-canvas", px, py, ARM_RGB), (share, u, v)
    # Top view: the arm along its yaw, out to the tool point's (x, y).
    for share in (0.4, 0.7):
        px, py = driver.execute_script("return window.robodcnConsole.topToCanvas(...arguments)",
                                       share * pose[0], share * pose[1])
        assert pixel_near(driver, "arm-top", px, py, ARM_RGB), share
    # The plan request carries [x, y, z, pitch] rows (SI).
    target = (0.15, 0.05, 0.12, -20.0)
    for testid, value in zip(("target-x", "target-y", "target-z", "target-pitch"), target,
                             strict=True):
        box = el(driver, testid)
        box.clear()
        box.send_keys(str(value))
    el(driver, "preview").click()
    until(lambda d: fake.posted("/v1/trajectories"), 10)
    body = fake.posted("/v1/trajectories")[-1]
    assert body["waypoints"][0] == pose
    assert body["waypoints"][1] == [0.15, 0.05, 0.12, math.radians(-20.0)]
    # the stub has the request once it is posted; the console shows its 422 when the reply
    # has come back and been drawn (a moment later on a loaded machine)
    until(lambda d: "refused by the stub" in el(d, "error").text, 10,
          "the console never showed the stub's 422")
    # no script error (the stub's 422 is logged as a network failure, as it should)
    assert [e for e in severe_logs(driver) if e.get("source") != "network"] == []


def test_the_top_view_turns_the_yaw(driver: Any, until: Any, stub: Any) -> None:
    from selenium.webdriver.common.action_chains import ActionChains

    _, fake = yawed_stub(stub, [0.0, -0.5, 0.4, 0.6])
    open_stub(driver, until, fake)
    before = [float(el(driver, t).get_attribute("value"))
              for t in ("target-x", "target-y", "target-z", "target-pitch")]
    canvas = el(driver, "arm-top")
    w, h = canvas.size["width"], canvas.size["height"]
    # A click 45° round from x (canvas y points down).
    (ActionChains(driver).move_to_element_with_offset(canvas, 60, -60).click().perform())
    x, y, z, pitch = [float(el(driver, t).get_attribute("value"))
                      for t in ("target-x", "target-y", "target-z", "target-pitch")]
    assert abs(math.degrees(math.atan2(y, x)) - 45.0) < 1.5, (x, y)
    assert abs(math.hypot(x, y) - math.hypot(before[0], before[1])) < 0.002   # r kept
    assert (z, pitch) == (before[2], before[3])
    assert w > 100 and h > 100


def test_the_gripper_control_posts_the_contracts_body(driver: Any, until: Any,
                                                      stub: Any) -> None:
    _, fake = yawed_stub(stub, [0.0, -0.5, 0.4, 0.6])
    doc = copy.deepcopy(fake.get["/openapi.json"])
    doc["paths"]["/v1/gripper"] = {"post": {"requestBody": {"content": {"application/json": {
        "schema": {"type": "object", "properties": {
            "command": {"type": "string", "enum": ["open", "close"]},
            "width_m": {"type": "number", "minimum": 0.02, "maximum": 0.075}}}}}}}}
    fake.get["/openapi.json"] = doc
    open_stub(driver, until, fake)
    assert el(driver, "gripper-row").is_displayed()
    el(driver, "gripper-close").click()
    el(driver, "gripper-open").click()
    box = el(driver, "gripper-width")
    assert (box.get_attribute("min"), box.get_attribute("max")) == ("20", "75")
    box.clear()
    box.send_keys("30")
    el(driver, "gripper-width-set").click()
    until(lambda d: len(fake.posted("/v1/gripper")) == 3, 10)
    sent = fake.posted("/v1/gripper")
    assert sent[:2] == [{"command": "close"}, {"command": "open"}]
    assert abs(sent[2]["width_m"] - 0.03) < 1e-12 and list(sent[2]) == ["width_m"]
    time.sleep(0.2)
    assert el(driver, "error").text == ""


def test_a_refused_move_keeps_its_error_through_the_preview_after_it(
        driver: Any, until: Any, service: Any, stub: Any) -> None:
    """A Move the service refuses (422) says why, and the preview that the typed target
    schedules — answered after the refusal, planning fine — does not wipe it (it did: the
    omx console showed no reason for a refused retarget); the user's next edit does."""
    service.wait_idle()
    _, st = service.call("GET", "/v1/state")
    _, doc = service.call("GET", "/openapi.json")
    _, arm = service.call("GET", "/v1/arm")
    goal = [st["pose"][0] - 0.02, st["pose"][1] + 0.02, st["pose"][2]]
    status, plan = service.call("POST", "/v1/trajectories",
                                {"waypoints": [st["pose"], goal]})
    assert status == 200, plan
    fake = stub({"/openapi.json": doc, "/v1/arm": arm, "/v1/state": st})
    refusal = {"error": {"code": "invalid_input", "field": "duration",
                         "message": "the replacement cannot be timed to duration 3"}}
    fake.answers[("POST", "/v1/moves")] = (422, refusal)
    fake.answers[("POST", "/v1/trajectories")] = (200, plan)
    open_stub(driver, until, fake)
    type_target(driver, (goal[0], goal[1], math.degrees(goal[2])))
    el(driver, "move").click()   # within the preview's 250 ms debounce: it answers after
    until(lambda d: "cannot be timed to duration 3" in el(d, "error").text, 10,
          "the refusal is not shown")

    def previews_after_the_move() -> int:
        paths = [p for m, p, _ in fake.requests if m == "POST"]
        return paths[paths.index("/v1/moves"):].count("/v1/trajectories")

    until(lambda d: previews_after_the_move() >= 1, 5, "no preview after the Move")
    time.sleep(0.4)   # the preview's answer is drawn
    assert "cannot be timed to duration 3" in el(driver, "error").text
    box = el(driver, "target-x")
    box.send_keys("1")
    until(lambda d: el(d, "error").text == "", 5, "an edit did not clear the old refusal")
