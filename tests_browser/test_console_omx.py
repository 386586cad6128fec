"""The web console against a real ``robodcn serve --sim --arm omx`` (issue 18, "Done when"):
the OpenMANIPULATOR-X as a new user first meets it in the browser — four pose numbers
(x, y, z, pitch), the side view of its vertical plane and the top view of its yaw, moves,
a retarget mid-move, the z keys, the gripper, torque off under gravity.

What is drawn is checked against robodcn's own kinematics (``fk_yawed``, ``plane_fk``) and
the service's GET /v1/state, not against the page's numbers.
"""

from __future__ import annotations

import itertools
import math
import os
import shutil
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from test_console import (
    FINISHED,
    click_move_and_wait_running,
    el,
    forget_earlier_pages,
    move_with_screenshot,
    severe_logs,
    shown_plan,
    type_target,
)
from test_console_stubbed import ARM_RGB, pixel_near

from robodcn.kinematics import Chain, fk_yawed, plane_fk

AXES = ("target-x", "target-y", "target-z", "target-pitch")
TARGET = (0.18, 0.08, 0.12, -20.0)      # m, m, m, degrees: in reach, yaw 24°
OTHER = (0.15, -0.10, 0.18, 0.0)        # yaw −34°
LEFT = (0.02, 0.14, 0.26, 20.0)         # yaw 82°, high up: far in both views


def open_omx(driver: Any, until: Any, service: Any) -> None:
    driver.get(service.url + "/")
    until(lambda d: d.execute_script(
        "const c = window.robodcnConsole; return c && c.S.model && c.stats.state > 0"), 20,
        "the page got no state")
    until(lambda d: el(d, "target-x").get_attribute("value") != "", 10)


def chain_of(service: Any) -> Chain:
    _, arm = service.call("GET", "/v1/arm")
    cfg = arm["config"]["arm"]
    return Chain(tuple(tuple(v) for v in cfg["links"]), cfg["shoulder_height"])


def joint_points(chain: Chain, q: list[float]) -> list[tuple[float, float]]:
    """(r, z) of the shoulder, elbow, wrist and tool point at joints q (yaw first). The
    wrist and the tool are robodcn's plane_fk; the elbow, one link out, is the same law
    (ψ_1 = α_1 − q_1) for the first link alone."""
    shoulder = (0.0, chain.shoulder_height)
    psi = chain.angles[0] - q[1]
    elbow = (chain.lengths[0] * math.cos(psi), chain.shoulder_height
             + chain.lengths[0] * math.sin(psi))
    wrist = plane_fk(Chain(chain.links[:2], chain.shoulder_height), [q[1:3]])[0][:2]
    tool = plane_fk(chain, [q[1:]])[0][:2]
    return [shoulder, elbow, (wrist[0], wrist[1]), (tool[0], tool[1])]


def side_px(driver: Any, u: float, v: float) -> tuple[float, float]:
    return driver.execute_script("return window.robodcnConsole.toCanvas(...arguments)", u, v)


def top_px(driver: Any, x: float, y: float) -> tuple[float, float]:
    return driver.execute_script("return window.robodcnConsole.topToCanvas(...arguments)", x, y)


def link_probes(points: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """Points at 30, 50 and 70 % along every link between consecutive joint points."""
    return [((1 - s) * a[0] + s * b[0], (1 - s) * a[1] + s * b[1])
            for a, b in itertools.pairwise(points) for s in (0.3, 0.5, 0.7)]


def arm_drawn_at(driver: Any, chain: Chain, q: list[float]) -> list[str]:
    """What of the arm at joints q is not drawn: side-view link points (r, z) and top-view
    points along the yaw out to the tool point's radius ([] when all are)."""
    driver.execute_script("window.robodcnConsole.draw()")
    missing = []
    points = joint_points(chain, q)
    for u, v in link_probes(points):
        if not pixel_near(driver, "arm-canvas", *side_px(driver, u, v), ARM_RGB):
            missing.append(f"side ({u:.3f}, {v:.3f})")
    reach = points[-1][0]
    for share in (0.3, 0.6, 0.9):
        x, y = share * reach * math.cos(q[0]), share * reach * math.sin(q[0])
        if not pixel_near(driver, "arm-top", *top_px(driver, x, y), ARM_RGB):
            missing.append(f"top ({x:.3f}, {y:.3f})")
    return missing


def type_pose(driver: Any, pose: tuple[float, ...], duration: str = "auto") -> None:
    """:func:`test_console.type_target` on the four omx axes."""
    type_target(driver, pose, duration, AXES)


def state(service: Any) -> dict[str, Any]:
    status, st = service.call("GET", "/v1/state")
    assert status == 200, st
    return st


def pose_error(pose: list[float], want: tuple[float, ...]) -> tuple[float, float]:
    """(position error m, pitch error deg) of a state pose against a typed pose."""
    return (math.dist(pose[:3], want[:3]), abs(math.degrees(pose[3]) - want[3]))


def test_the_omx_page_shows_four_pose_numbers_and_its_home_in_both_views(
        driver: Any, until: Any, omx_service: Any) -> None:
    forget_earlier_pages(driver)
    omx_service.wait_idle()
    open_omx(driver, until, omx_service)
    time.sleep(0.5)
    assert severe_logs(driver) == []
    for testid in AXES:
        assert el(driver, testid).is_displayed(), testid
    assert not el(driver, "target-theta").is_displayed()
    assert el(driver, "arm-top").is_displayed() and el(driver, "gripper-row").is_displayed()
    # The service starts at the arm's home; the page's inputs and readout show that pose.
    st = state(omx_service)
    chain = chain_of(omx_service)
    _, arm = omx_service.call("GET", "/v1/arm")
    home = arm["config"]["arm"]["home"]
    assert math.dist(st["pose"][:3], [home["x"], home["y"], home["z"]]) < 0.002, st["pose"]
    assert np.allclose(fk_yawed(chain, [st["joints"]])[0], st["pose"], atol=1e-9)
    shown = [float(el(driver, t).get_attribute("value")) for t in AXES]
    assert np.allclose(shown[:3], st["pose"][:3], atol=6e-4), shown
    assert abs(shown[3] - math.degrees(st["pose"][3])) < 0.06, shown
    readout = driver.find_element("id", "pose").text
    assert f"z {st['pose'][2]:.3f} m" in readout, readout
    # Side view (r, z) and top view (x, y): the arm at its home joints.
    assert arm_drawn_at(driver, chain, st["joints"]) == []
    # … and not at another pose: the elbow bent 40° further down moves the middle and the
    # end of the link after it off the drawn arm.
    bent = [*st["joints"][:2], st["joints"][2] + 0.7, st["joints"][3]]
    for u, v in link_probes(joint_points(chain, bent))[4:6]:
        assert not pixel_near(driver, "arm-canvas", *side_px(driver, u, v), ARM_RGB, 1), (u, v)


def test_the_gripper_control_closes_and_opens_the_gripper(driver: Any, until: Any,
                                                         omx_service: Any) -> None:
    open_omx(driver, until, omx_service)
    _, arm = omx_service.call("GET", "/v1/arm")
    grip = arm["config"]["gripper"]

    def width_after(testid: str) -> float:
        driver.execute_script("document.querySelector('[data-testid=gripper-state]')"
                              ".dataset.widthM = ''")
        el(driver, testid).click()
        return float(until(lambda d: el(d, "gripper-state").get_attribute("data-width-m"), 15,
                           f"{testid}: no gripper result shown"))

    assert abs(width_after("gripper-close") - grip["closed_width_m"]) < 0.001
    assert el(driver, "gripper-state").text.startswith("closed")
    assert abs(width_after("gripper-open") - grip["open_width_m"]) < 0.001
    assert el(driver, "gripper-state").text.startswith("open")
    box = el(driver, "gripper-width")
    box.clear()
    box.send_keys("40")
    assert abs(width_after("gripper-width-set") - 0.040) < 0.001
    assert el(driver, "error").text == ""
    # The service agrees: opening again finds the jaws at 40 mm and opens them.
    status, result = omx_service.call("POST", "/v1/gripper", {"command": "open"})
    assert status == 200 and abs(result["final_width_m"] - grip["open_width_m"]) < 0.001


def test_a_typed_pose_moves_the_omx_there(driver: Any, until: Any, omx_service: Any,
                                          tmp_path: Path) -> None:
    omx_service.wait_idle()
    open_omx(driver, until, omx_service)
    chain = chain_of(omx_service)
    start = state(omx_service)
    type_pose(driver, TARGET, duration="3")
    for box in driver.find_elements("css selector", ".overlay-method"):
        if not box.is_selected():
            box.click()
    el(driver, "preview").click()
    rows_js = "return [...document.querySelectorAll('#plans tbody tr')].map(r => r.innerText)"
    until(lambda d: len(d.execute_script(rows_js)) == 4 and all(
        "feasible" in r and "infeasible" not in r for r in d.execute_script(rows_js)), 15,
        "not every method's plan is feasible")
    # The request carries the 4-number target, SI.
    body = driver.execute_script("return window.robodcnConsole.S.plans.sclerp.body")
    assert np.allclose(body["waypoints"][-1], [*TARGET[:3], math.radians(TARGET[3])])
    shot = tmp_path / "console.png"
    move_with_screenshot(driver, until, omx_service, shot, 1.2, 30)
    if os.environ.get("ROBODCN_SCREENSHOT"):  # docs/console.png is made this way
        shutil.copy(shot, os.environ["ROBODCN_SCREENSHOT"])
    end = state(omx_service)
    dist, dpitch = pose_error(end["pose"], TARGET)
    assert dist < 0.002 and dpitch < 1.0, (end["pose"], TARGET)
    # The page shows where it is now: readout and both views at the final joints, and no
    # longer at the start's (its yaw was 0, the target's is 24°).
    until(lambda d: f"z {end['pose'][2]:.3f} m" in d.find_element("id", "pose").text, 5)
    until(lambda d: arm_drawn_at(d, chain, end["joints"]) == [], 5,
          "the views do not draw the arm at its final joints")
    r = joint_points(chain, start["joints"])[-1][0]
    assert not pixel_near(driver, "arm-top", *top_px(driver, 0.8 * r, 0.0), ARM_RGB, 1)
    assert severe_logs(driver) == []


def test_page_up_and_down_move_the_tool_in_z(driver: Any, until: Any,
                                             omx_service: Any) -> None:
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.keys import Keys

    omx_service.wait_idle()
    open_omx(driver, until, omx_service)
    for key, dz in ((Keys.PAGE_UP, 0.01), (Keys.PAGE_DOWN, -0.01)):
        before, count = state(omx_service)["pose"], omx_service.move_count()
        driver.execute_script("document.activeElement && document.activeElement.blur()")
        ActionChains(driver).send_keys(key).perform()   # the 1 cm jog step
        until(lambda d, n=count: omx_service.move_count() == n + 1, 10, "the key started no move")
        until(lambda d, n=count: el(d, "move-status").get_attribute("data-move-id") == str(n + 1))
        until(lambda d: el(d, "move-status").text in FINISHED, 20)
        after = state(omx_service)["pose"]
        assert abs(after[2] - before[2] - dz) < 0.002, (before, after)
        assert math.dist(after[:2], before[:2]) < 0.002 and abs(after[3] - before[3]) < 0.01


def test_a_replacement_mid_move_draws_its_own_plan(driver: Any, until: Any,
                                                   omx_service: Any) -> None:
    """Retargeted mid-move, the dashed plan on both views is the new move's own trajectory
    (GET /v1/moves/{id}/trajectory, from the moving state), and the arm ends at the new
    target."""
    omx_service.wait_idle()
    open_omx(driver, until, omx_service)
    # Towards one side, then retargeted to the other: a long new plan in both views.
    far = OTHER if math.dist(state(omx_service)["pose"][:3], OTHER[:3]) > 0.03 else TARGET
    type_pose(driver, far, duration="6")
    first = click_move_and_wait_running(driver, until, omx_service)
    until(lambda d: el(d, "move-status").text == "running", 10)
    time.sleep(1.0)
    type_pose(driver, LEFT, duration="3")
    # The service refuses a retarget whose planning overran its budget (409, "nothing changed,
    # try again"): on a host busy with the browser, the service and the simulator that is
    # the service's answer, and a user tries again while the first move still runs.
    for attempt in range(3):
        try:
            second = click_move_and_wait_running(driver, until, omx_service)
            break
        except AssertionError as refused:
            running = omx_service.call("GET", f"/v1/moves/{first}")[1]["status"] == "running"
            if "try again" not in str(refused) or not running or attempt == 2:
                raise
    from selenium.common.exceptions import TimeoutException
    try:
        until(lambda d: omx_service.call("GET", f"/v1/moves/{first}")[1]["status"]
              == "replaced", 10)
    except TimeoutException:   # say why: the service's answer as the page shows it
        raise AssertionError((el(driver, "error").text,
                              omx_service.call("GET", f"/v1/moves/{first}")[1])) from None
    shown, own = shown_plan(driver, until, omx_service, second)
    assert shown["t"] == own["t"] and shown["poses"] == own["poses"]
    _, old = omx_service.call("GET", f"/v1/moves/{first}/trajectory")
    assert math.dist(own["poses"][0][:3], old["poses"][0][:3]) > 0.005   # a moving start
    # What the plan adds to each view lies on the new plan's path and covers it.
    changed = driver.execute_script("""
        const c = window.robodcnConsole, S = c.S;
        const grab = (id) => { const k = document.querySelector(`[data-testid="${id}"]`);
          return k.getContext('2d').getImageData(0, 0, k.width, k.height).data; };
        const plan = S.movePlan, out = {};
        S.movePlan = null; c.draw();
        const without = { side: grab('arm-canvas'), top: grab('arm-top') };
        S.movePlan = plan; c.draw();
        for (const [view, id] of [['side', 'arm-canvas'], ['top', 'arm-top']]) {
          const k = document.querySelector(`[data-testid="${id}"]`), d = grab(id), px = [];
          for (let i = 0; i < d.length; i += 4)
            if (Math.abs(d[i] - without[view][i]) + Math.abs(d[i + 1] - without[view][i + 1])
                + Math.abs(d[i + 2] - without[view][i + 2]) > 60)
              px.push([(i / 4) % k.width, Math.floor(i / 4 / k.width)]);
          out[view] = px;
        }
        return out;""")
    poses = np.asarray(own["poses"])
    side = np.array([side_px(driver, math.hypot(x, y), z) for x, y, z, _ in poses])
    top = np.array([top_px(driver, x, y) for x, y, _, _ in poses])
    for view, path, near_px in (("side", side, 16.0), ("top", top, 4.0)):
        px = np.asarray(changed[view], dtype=float)
        assert len(px) > 40, (view, len(px))
        dense = np.concatenate([np.linspace(a, b, 8) for a, b in itertools.pairwise(path)])
        gap = np.min(np.linalg.norm(px[:, None, :] - dense[None, :, :], axis=2), axis=1)
        assert gap.max() <= near_px, (view, gap.max())      # nothing off the new plan
        covered = np.min(np.linalg.norm(dense[::8, None, :] - px[None, :, :], axis=2), axis=1)
        assert np.mean(covered < 6.0) > 0.7, (view, covered)  # the dashes follow it
    until(lambda d: el(d, "move-status").text in FINISHED, 30)
    assert omx_service.call("GET", f"/v1/moves/{second}")[1]["status"] in FINISHED
    dist, dpitch = pose_error(state(omx_service)["pose"], LEFT)
    assert dist < 0.002 and dpitch < 1.0


def test_torque_off_on_the_omx_asks_first(driver: Any, until: Any, omx_service: Any) -> None:
    """The omx is under gravity: torque off is refused unless confirmed (409
    gravity_release). The page asks with the service's words; declined, torque stays on;
    confirmed, it goes off; on brings it back."""
    from selenium.webdriver.support import expected_conditions
    from selenium.webdriver.support.ui import WebDriverWait

    omx_service.wait_idle()
    open_omx(driver, until, omx_service)
    status, refused = omx_service.call("POST", "/v1/torque", {"on": False})
    assert status == 409 and refused["error"]["code"] == "gravity_release", refused
    assert state(omx_service)["torque"] is True
    try:
        for accept in (False, True):
            el(driver, "torque-off").click()
            alert = WebDriverWait(driver, 10).until(expected_conditions.alert_is_present())
            assert refused["error"]["message"] in alert.text, alert.text
            if accept:
                alert.accept()
            else:
                alert.dismiss()
                time.sleep(0.5)
                assert state(omx_service)["torque"] is True
                assert "not confirmed" in el(driver, "error").text
        until(lambda d: state(omx_service)["torque"] is False, 10, "torque did not go off")
        until(lambda d: d.find_element("id", "torque-state").text == "torque off", 10)
        el(driver, "torque-on").click()
        until(lambda d: state(omx_service)["torque"] is True, 10, "torque did not come back")
        until(lambda d: d.find_element("id", "torque-state").text == "torque on", 10)
    finally:
        omx_service.call("POST", "/v1/torque", {"on": True})


@pytest.mark.parametrize("testid", ["target-z", "target-pitch"])
def test_a_bad_number_names_the_omx_axes(driver: Any, until: Any, omx_service: Any,
                                         testid: str) -> None:
    open_omx(driver, until, omx_service)
    count = omx_service.move_count()
    el(driver, testid).clear()
    el(driver, "move").click()
    assert "x, y, z and pitch must be numbers" in until(lambda d: el(d, "error").text, 5)
    assert omx_service.move_count() == count


def test_an_unreachable_omx_target_is_refused_and_marked(driver: Any, until: Any,
                                                         omx_service: Any) -> None:
    omx_service.wait_idle()
    open_omx(driver, until, omx_service)
    count = omx_service.move_count()
    far = (0.45, 0.0, 0.10, 0.0)                     # past the reach (0.38 m)
    type_pose(driver, far)
    el(driver, "move").click()
    text = until(lambda d: el(d, "error").text, 10)
    status, answer = omx_service.call("POST", "/v1/moves", {"waypoints": [
        [*far[:3], math.radians(far[3])]]})
    assert status == 422, answer
    assert answer["error"]["message"] in text and answer["error"]["field"] in text, text
    assert omx_service.move_count() == count
    # The refused target is marked where it is, in the side view's plane.
    mark = until(lambda d: d.execute_script(
        "const p = window.robodcnConsole.S.plans.sclerp; return p && p.mark"), 10)
    assert np.allclose(mark, [*far[:3], math.radians(far[3])]), mark
    driver.execute_script("window.robodcnConsole.draw()")
    assert pixel_near(driver, "arm-canvas", *side_px(driver, far[0], far[2]), (0xB3, 0x26, 0x1E), 3)
