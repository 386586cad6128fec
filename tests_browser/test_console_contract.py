"""What the console takes from the service, against a real ``robodcn serve --sim``
(issue 17 §2 and §4): the β slider's range from the contract, the speed slider following
the running move's actual speed scale, the service's words (message and field) for a
refused plan, and a replacement's own plan drawn from its move's trajectory.
"""

from __future__ import annotations

import math
import time
from typing import Any

from test_console import (
    click_move_and_wait_running,
    el,
    far_target,
    open_console,
    shown_plan,
    start_slow_move,
    type_target,
)


def number_range(schema: dict[str, Any]) -> tuple[float, float]:
    """(minimum, maximum) of a number schema or of the number form of its oneOf."""
    for form in schema.get("oneOf", [schema]):
        if form.get("type") == "number":
            return form["minimum"], form["maximum"]
    raise AssertionError(f"no number form in {schema}")


def plan_body_schema(doc: dict[str, Any]) -> dict[str, Any]:
    ref = doc["paths"]["/v1/trajectories"]["post"]["requestBody"]["content"][
        "application/json"]["schema"]["$ref"]
    return doc["components"]["schemas"][ref.split("/")[-1]]


def test_the_beta_slider_spans_the_contracts_range(driver: Any, until: Any,
                                                   service: Any) -> None:
    open_console(driver, until, service)
    _, doc = service.call("GET", "/openapi.json")
    lo, hi = number_range(plan_body_schema(doc)["properties"]["beta"])
    beta = el(driver, "beta")
    assert (float(beta.get_attribute("min")), float(beta.get_attribute("max"))) == (lo, hi)
    # Its ends are values the service takes: a KenLERP preview at either is not refused
    # for β (it may be infeasible for the path, never for the field).
    el(driver, "method").send_keys("KenLERP")
    for end in (lo, hi):
        driver.execute_script("""const s = arguments[0]; s.value = arguments[1];
            s.dispatchEvent(new Event('input'));""", beta, str(end))
        assert float(beta.get_attribute("value")) == end
        driver.execute_script("window.robodcnConsole.S.plans = {}")
        el(driver, "preview").click()
        plan = until(lambda d: d.execute_script(
            "return window.robodcnConsole.S.plans.kenlerp"), 10)
        assert plan["body"]["beta"] == end
        assert "traj" in plan or plan["error"]["field"] != "beta", plan["error"]


def test_a_refused_plan_shows_the_message_and_field_not_the_code(driver: Any, until: Any,
                                                                 service: Any) -> None:
    open_console(driver, until, service)
    _, state = service.call("GET", "/v1/state")
    cases = (((0.5, 0.5, 0.0), "auto"),          # out of reach
             (far_target(service), "soon"))      # a duration that is not one
    for pose, duration in cases:
        type_target(driver, pose, duration)
        el(driver, "method").send_keys("ScLERP")
        body = {"waypoints": [state["pose"], [pose[0], pose[1], math.radians(pose[2])]],
                "method": "sclerp", "duration": duration, "start_joints": state["joints"]}
        status, answer = service.call("POST", "/v1/trajectories", body)
        assert status == 422, answer
        error = answer["error"]
        driver.execute_script("document.querySelector('#plans tbody').replaceChildren()")
        el(driver, "preview").click()
        row = until(lambda d: d.execute_script(
            "const r = document.querySelector('#plans tbody tr[data-method=sclerp]');"
            "return r && r.innerText"), 10)
        assert error["message"] in row and error["field"] in row, (row, error)
        assert error["code"] not in row, (row, error)
        assert error["field"] in el(driver, "error").text


def test_the_speed_slider_shows_the_running_moves_speed(driver: Any, until: Any,
                                                        service: Any) -> None:
    """Set to 30 % during one move, the slider shows 100 % once that move ended and while
    the next runs at 100 %: it follows speed_scale in the state, not what was last set."""
    service.wait_idle()
    open_console(driver, until, service)
    speed = el(driver, "speed")
    first = start_slow_move(driver, until, service)
    driver.execute_script("""const s = arguments[0]; s.value = '0.3';
        s.dispatchEvent(new Event('input')); s.dispatchEvent(new Event('change'));""", speed)
    until(lambda d: service.call("GET", f"/v1/moves/{first}")[1]["speed_scale"] == 0.3, 10)
    until(lambda d: el(d, "speed").get_attribute("value") == "0.3", 5)
    assert el(driver, "speed").is_enabled()
    el(driver, "stop").click()
    until(lambda d: el(d, "move-status").text == "stopped", 10)
    service.wait_idle()
    until(lambda d: float(el(d, "speed").get_attribute("value")) == 1.0, 5,
          "the slider kept the ended move's speed")
    assert "100 %" in driver.find_element("id", "speed-value").text
    assert not el(driver, "speed").is_enabled()          # nothing runs to scale
    second = start_slow_move(driver, until, service)
    time.sleep(0.3)
    assert service.call("GET", f"/v1/moves/{second}")[1]["speed_scale"] == 1.0
    assert service.call("GET", "/v1/state")[1]["speed_scale"] == 1.0
    assert float(el(driver, "speed").get_attribute("value")) == 1.0
    el(driver, "stop").click()
    until(lambda d: el(d, "move-status").text == "stopped", 10)


def test_a_replacement_draws_its_own_plan(driver: Any, until: Any, service: Any) -> None:
    """After a retarget the dashed plan is the new move's own trajectory (GET
    /v1/moves/{id}/trajectory: from the moving state), not a plan from the old start."""
    service.wait_idle()
    open_console(driver, until, service)
    first = start_slow_move(driver, until, service)
    time.sleep(1.0)
    type_target(driver, (0.2, 0.15, 30.0), duration="3")
    second = click_move_and_wait_running(driver, until, service)
    until(lambda d: service.call("GET", f"/v1/moves/{first}")[1]["status"] == "replaced", 10)
    shown, own = shown_plan(driver, until, service, second)
    assert shown["t"] == own["t"]
    assert shown["poses"] == own["poses"] and shown["joints"] == own["joints"]
    # It starts where the arm was when the switch came, not at the first move's start.
    _, record = service.call("GET", f"/v1/moves/{first}/trajectory")
    assert math.dist(shown["poses"][0][:2], record["poses"][0][:2]) > 0.005
    until(lambda d: el(d, "move-status").text in ("done", "degraded"), 30)
