"""The viewer and the figures, looked at as a person would: the viewer opens from file:// in
headless Chromium with no request and no error, draws the scene, and shows the robot elsewhere at
another instant; the figures are real images; the commands fail with one line on bad input."""

from __future__ import annotations

import base64
import contextlib
import fcntl
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest
from meshcat.commands import SetObject, SetTransform
from PIL import Image

from hriplan.planner.problem import load_problem
from hriplan.planner.replay import PlannedWorld
from hriplan.planner.session import PlanningSession
from hriplan.planner.trajectory import TrajectoryFile
from hriplan.viewer import write_plots, write_task_viewer, write_viewer
from hriplan.viewer.drawing import Drawing
from hriplan.viewer.page import render_page
from hriplan.viewer.scene import build_drawing

SCENARIO = Path(__file__).parents[2] / "benchmarks" / "scenarios" / "b_madar_handover.json"
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
NODE = shutil.which("node")


@pytest.fixture(scope="module")
def trajectory() -> TrajectoryFile:
    problem = load_problem(SCENARIO)
    session = PlanningSession(problem.robot, problem.scene, problem.hands or None, problem.roles)
    session.set_constraints(problem.constraints)
    result = session.plan(problem.start, problem.goal, problem.options.model_copy(update={"seed": 1}), problem.group)
    assert result.solved, result.message
    return result.trajectory


@pytest.fixture(scope="module")
def viewer_file(trajectory, tmp_path_factory) -> Path:
    return write_viewer(trajectory, tmp_path_factory.mktemp("viewer") / "plan.html")


# -- a tiny Chrome DevTools Protocol client (standard library: no Playwright here) -------------
class Browser:
    """Headless Chromium on `--remote-debugging-pipe` (fd 3 in, fd 4 out); keeps every event."""

    FLAGS = (
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--enable-unsafe-swiftshader",  # WebGL on the CPU, without a deprecation message
    )

    def __init__(self, width: int = 1280, height: int = 800) -> None:
        self.profile = tempfile.TemporaryDirectory(prefix="hriplan-chromium-")
        to_chrome, self._out = os.pipe()
        self._in, from_chrome = os.pipe()
        # Chromium's ends above 9, so that bash's `3<&` and `4>&` cannot overwrite one another.
        to_chrome, from_chrome = (_above_nine(fd) for fd in (to_chrome, from_chrome))
        self.process = subprocess.Popen(
            [
                "bash",
                "-c",
                f'exec "$0" "$@" 3<&{to_chrome} 4>&{from_chrome}',
                CHROMIUM,
                *self.FLAGS,
                f"--user-data-dir={self.profile.name}",
                "--remote-debugging-pipe",
                "about:blank",
            ],
            pass_fds=(to_chrome, from_chrome),
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        os.close(to_chrome)
        os.close(from_chrome)
        self._buffer, self._id, self.events = b"", 0, []
        target = self.call("Target.createTarget", url="about:blank")["targetId"]
        self.session = self.call("Target.attachToTarget", targetId=target, flatten=True)["sessionId"]
        for domain in ("Page", "Runtime", "Log", "Network"):
            self.page(f"{domain}.enable")
        self.page("Emulation.setDeviceMetricsOverride", width=width, height=height, deviceScaleFactor=1, mobile=False)

    def call(self, method: str, session: str | None = None, **params: object) -> dict:
        self._id += 1
        message = {"id": self._id, "method": method, "params": params} | ({"sessionId": session} if session else {})
        os.write(self._out, json.dumps(message).encode() + b"\0")
        deadline = time.monotonic() + 60
        while True:
            while b"\0" not in self._buffer:
                assert time.monotonic() < deadline, f"Chromium did not answer {method}"
                chunk = os.read(self._in, 1 << 16)
                assert chunk, "Chromium closed the DevTools pipe"
                self._buffer += chunk
            raw, self._buffer = self._buffer.split(b"\0", 1)
            reply = json.loads(raw)
            if reply.get("id") == self._id:
                assert "error" not in reply, f"{method}: {reply['error']}"
                return reply["result"]
            self.events.append(reply)

    def page(self, method: str, **params: object) -> dict:
        return self.call(method, session=self.session, **params)

    def evaluate(self, expression: str) -> object:
        result = self.page("Runtime.evaluate", expression=expression, returnByValue=True, awaitPromise=True)
        assert "exceptionDetails" not in result, result["exceptionDetails"]
        return result["result"].get("value")

    def wait_for(self, expression: str, timeout: float = 30.0) -> object:
        deadline = time.monotonic() + timeout
        while not (value := self.evaluate(expression)):
            assert time.monotonic() < deadline, f"waited {timeout} s for {expression}"
            time.sleep(0.05)
        return value

    def screenshot(self, path: Path) -> np.ndarray:
        path.write_bytes(base64.b64decode(self.page("Page.captureScreenshot", format="png")["data"]))
        return np.asarray(Image.open(path).convert("RGB")).astype(int)

    def problems(self) -> list[str]:
        """Console errors, uncaught exceptions, browser log errors and failed requests."""
        found = []
        for event in self.events:
            method, params = event.get("method"), event.get("params", {})
            if method == "Runtime.consoleAPICalled" and params["type"] in ("error", "assert"):
                found.append(
                    f"console.{params['type']}: {[a.get('value', a.get('description')) for a in params['args']]}"
                )
            elif method == "Runtime.exceptionThrown":
                found.append(f"exception: {params['exceptionDetails']}")
            elif method == "Log.entryAdded" and params["entry"]["level"] == "error":
                found.append(f"log: {params['entry']['text']}")
            elif method == "Network.loadingFailed":
                found.append(f"failed request: {params}")
        return found

    def requests(self) -> list[str]:
        return [e["params"]["request"]["url"] for e in self.events if e.get("method") == "Network.requestWillBeSent"]

    def close(self) -> None:
        with contextlib.suppress(AssertionError, OSError):  # Chromium may go before it answers
            self.call("Browser.close")
        try:
            self.process.wait(timeout=20)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
        os.close(self._out)
        os.close(self._in)
        self.profile.cleanup()


def _above_nine(fd: int) -> int:
    moved = fcntl.fcntl(fd, fcntl.F_DUPFD, 10)
    os.close(fd)
    return moved


@pytest.fixture(scope="module")
def browser():
    if CHROMIUM is None:
        pytest.skip("chromium is not installed (.ci/run installs Debian's chromium package)")
    browser = Browser()
    yield browser
    browser.close()


PROJECT_RIGHT_ARM = """(() => {  // screen positions of the right arm's parts, and the GUI's box
  const T = MeshCat.THREE, robot = viewer.scene_tree.find(["robot"]);
  const points = Object.keys(robot.children).filter(n => n.startsWith("right_")).map(n => {
    const p = robot.children[n].object.getWorldPosition(new T.Vector3()).project(viewer.camera);
    return [(p.x + 1) / 2 * innerWidth, (1 - p.y) / 2 * innerHeight];
  });
  const gui = viewer.gui.domElement.getBoundingClientRect();
  return {points, gui: [gui.left, gui.top, gui.right, gui.bottom]};
})()"""


def show(browser: Browser, url: str, time_s: float) -> None:
    """Navigate (the first time) or change the address's #t= (then the page seeks), and wait
    until the page has drawn that instant."""
    browser.page("Page.navigate", url=f"{url}#t={time_s}")
    browser.wait_for(f"document.body && Number(document.body.dataset.shownTime) === {time_s}")


def test_viewer_opens_offline_draws_the_scene_and_animates(browser, viewer_file, trajectory, tmp_path):
    url = viewer_file.resolve().as_uri()
    end = trajectory.report.duration  # the very end: the arm at the receiver's hand
    browser.page("Page.navigate", url=url)  # opened as is, the plan plays
    browser.wait_for("document.body && document.body.dataset.shownTime === 'playing'")
    browser.wait_for("viewer.animator.time > 0.1")  # (it was reset to 0 when the page said 'playing')
    show(browser, url, 0.0)
    first = browser.screenshot(tmp_path / "t0.png")
    arm_first = browser.evaluate(PROJECT_RIGHT_ARM)
    show(browser, url, end)
    last = browser.screenshot(tmp_path / "t_end.png")
    arm_last = browser.evaluate(PROJECT_RIGHT_ARM)

    assert browser.problems() == []
    assert all(u == url or u.startswith("data:") for u in browser.requests()), browser.requests()  # nothing fetched
    assert browser.evaluate("viewer.animator.time") == pytest.approx(end)  # the time slider shows the instant

    # The scene is drawn: many colours, and much of the picture changes when the plan's content is hidden.
    colours = np.unique((first // 8).reshape(-1, 3), axis=0)
    assert len(colours) > 300
    browser.evaluate(
        "['robot', 'people', 'scene', 'constraints', 'tool_paths'].forEach(p => "
        "{ viewer.scene_tree.find([p]).object.visible = false; }); viewer.set_dirty();"
        "new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)))"
    )
    empty = browser.screenshot(tmp_path / "empty.png")
    assert (np.abs(first - empty).sum(axis=2) > 40).mean() > 0.05

    # The two instants differ, and where they differ is where the right arm moved.
    left, top, right, bottom = (int(v) for v in arm_first["gui"])
    changed = np.abs(first - last).sum(axis=2) > 40
    changed[top:bottom, left:right] = False  # the time display in the controls
    assert changed.mean() > 0.002
    arm = np.array(arm_first["points"] + arm_last["points"])
    (x0, y0), (x1, y1) = arm.min(axis=0) - 60, arm.max(axis=0) + 60
    ys, xs = np.nonzero(changed)
    inside = (xs >= x0) & (xs <= x1) & (ys >= y0) & (ys <= y1)
    assert inside.mean() > 0.9, f"{inside.mean():.2f} of the changed pixels are near the right arm"


def test_viewer_shows_every_constraint_with_its_geometry(trajectory, viewer_file):
    html = viewer_file.read_text()
    assert viewer_file.stat().st_size < 6e6
    assert "<script src" not in html and '<link rel="stylesheet"' not in html  # one self-contained file
    for c in trajectory.constraints:
        assert f"<b>{c.spec.id}</b>" in html
    # without a reason from the rules, a constraint is worded as `hriplan derive` words it (constraints/words.py)
    cone = (
        "right_tool stays inside a cone of radius 0.3 m and height 0.55 m with its apex at receiver/right_hand (offset)"
    )
    assert cone in html
    assert "right_tool stays within 0.1 rad of its target orientation in world, free to spin about its y axis" in html

    # The cone's apex is at its frame's origin and it opens along the frame's +z (spec.py), although
    # three.js cylinders run along y and are centred.
    drawing = build_drawing(PlannedWorld.load(trajectory))
    local = next(
        c.matrix
        for c in drawing.commands
        if isinstance(c, SetTransform) and c.path.lower() == "/constraints/approach_cone/0"
    )
    cone = next(
        c.object.lower()["geometries"][0]
        for c in drawing.commands
        if isinstance(c, SetObject) and c.path.lower() == "/constraints/approach_cone/0"
    )
    assert cone["radiusBottom"] == 0.0 and cone["radiusTop"] == pytest.approx(0.3)
    half = cone["height"] / 2
    assert np.allclose(local @ [0, -half, 0, 1], [0, 0, 0, 1]) and np.allclose(local @ [0, half, 0, 1], [0, 0, 0.55, 1])
    assert len(drawing.clones) > 10  # the second arm's and the fingers' meshes are not sent twice


def _is_real_png(path: Path) -> bool:
    image = Image.open(path)
    image.verify()
    pixels = np.asarray(Image.open(path).convert("RGB"))
    return image.format == "PNG" and min(pixels.shape[:2]) > 300 and len(np.unique(pixels.reshape(-1, 3), axis=0)) > 20


def test_plots_one_real_figure_each(trajectory, tmp_path):
    paths = write_plots(trajectory, tmp_path / "figures")
    assert sorted(p.name for p in paths) == [
        "human_distance.png",
        "joint_accelerations.png",
        "joint_positions.png",
        "joint_velocities.png",
        "margins.png",
        "separation.png",  # timed to ISO/TS 15066 near the receiver (the session's default)
    ]
    assert all(_is_real_png(p) for p in paths)

    alone = trajectory.model_copy(
        update={
            "scene": trajectory.scene.model_copy(update={"humans": []}),
            "constraints": [c for c in trajectory.constraints if "/" not in c.spec.frame.entity],
            "report": trajectory.report.model_copy(update={"separation": []}),
        }
    )
    assert [p.name for p in write_plots(alone, tmp_path / "alone")] == [
        "joint_positions.png",
        "joint_velocities.png",
        "joint_accelerations.png",
        "margins.png",
    ]


def test_margins_are_the_validators(trajectory):
    margins = PlannedWorld.load(trajectory).margins()
    ids = [c.spec.id for c in trajectory.constraints]
    worst = dict(zip(ids, margins.max(axis=0)))
    for name, reported in trajectory.report.max_violation.items():
        assert worst[name] <= reported + 1e-9 and worst[name] == pytest.approx(reported, abs=0.01)


def run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "hriplan.cli", *args], capture_output=True, text=True, timeout=300)


def test_commands_write_files_and_reject_bad_input_in_one_line(trajectory, tmp_path):
    saved = tmp_path / "trajectory.json"
    trajectory.save(saved)
    made = run("plot", str(saved), "-o", str(tmp_path / "figures"))
    assert made.returncode == 0, made.stderr
    assert made.stdout.count("figure written to") == 6
    missing = run("view", str(tmp_path / "nope.json"), "-o", str(tmp_path / "plan.html"))
    assert missing.returncode == 2 and missing.stderr == f"error: {tmp_path / 'nope.json'}: no such file\n"
    wrong = run("view", str(SCENARIO), "-o", str(tmp_path / "plan.html"))  # a planning problem, not a trajectory
    assert wrong.returncode == 2 and wrong.stderr.startswith(f"error: {SCENARIO}: ") and wrong.stderr.count("\n") == 1
    unwritable = run("view", str(saved), "-o", "/proc/plan.html")
    assert unwritable.returncode == 2 and unwritable.stderr.startswith("error: cannot write /proc/plan.html")
    assert not (tmp_path / "plan.html").exists()


def test_joint_plots_are_scaled_to_each_joints_motion(trajectory):
    """A joint that moves 0.1 rad gets axes about that tall, not its whole +-2 pi range."""
    from hriplan.viewer.plots import _joints

    world = PlannedWorld.load(trajectory)
    for field in ("positions", "velocities", "accelerations"):
        figure = _joints(world, field)
        values = np.array([getattr(p, field) for p in trajectory.points])
        for ax, column in zip(figure.axes, values.T):
            low, high = ax.get_ylim()
            span = column.max() - column.min()
            assert low <= column.min() and high >= column.max()
            assert high - low <= max(3.0 * span, 0.2) + 0.5, (field, ax.get_title(), low, high, span)


def test_one_volume_per_place_however_many_constraints_share_it(trajectory):
    """A keep-out bound for each arm is the same volume: drawn once, listed twice."""
    keep_out = next(c for c in trajectory.constraints if c.spec.type != "orientation")
    twin = keep_out.model_copy(
        update={"spec": keep_out.spec.model_copy(update={"id": "twin", "target_link": "right_wrist_3_link"})}
    )
    doubled = trajectory.model_copy(update={"constraints": [*trajectory.constraints, twin]})
    drawing = build_drawing(PlannedWorld.load(doubled))
    drawn = {
        c.path.lower().split("/")[2]
        for c in drawing.commands
        if isinstance(c, SetObject) and "/constraints/" in c.path.lower()
    }
    assert keep_out.spec.id.lower() in drawn and "twin" not in drawn


def _two_steps(trajectory: TrajectoryFile) -> list[TrajectoryFile]:
    return [trajectory.model_copy(update={"task": "demo", "step": name}) for name in ("reach", "back")]


def test_a_task_is_one_page_with_a_step_selector(browser, trajectory, tmp_path):
    page = write_task_viewer(_two_steps(trajectory), tmp_path / "task.html")
    html = page.read_text()
    assert [p.name for p in tmp_path.iterdir()] == ["task.html"]
    assert '<option value="1">step 1: reach</option><option value="2">step 2: back</option>' in html
    assert "worst margin" in html and " m</span>" in html and "0 or below (negative) means kept" in html
    url = page.resolve().as_uri()
    browser.page("Page.navigate", url=f"{url}#step=2&t=0")
    browser.wait_for("document.body && document.body.dataset.shownTime === '0'")
    shown = browser.evaluate(
        "[document.getElementById('hriplan-step').value, "
        "[...document.querySelectorAll('.hriplan-step-legend')].map(l => l.hidden)]"
    )
    assert shown == ["2", [True, False]]
    assert browser.problems() == []


def test_the_address_counts_steps_from_1_as_the_selector_does(tmp_path):
    """`#step=K` opens the step the selector calls "step K" (it opened step K + 1): the page's
    own step function, run in node, on addresses a person would type."""
    html = render_page([("reach", Drawing(), 1.0, "first"), ("back", Drawing(), 1.0, "second")], "two steps")
    assert '<option value="1">step 1: reach</option><option value="2">step 2: back</option>' in html
    assert '<div class="hriplan-step-legend" data-step="2">second</div>' in html and 'id="hriplan-commands-2"' in html
    if NODE is None:
        pytest.skip("no node to run the page's script")
    source = re.search(r"^function hriplanStep\(.*?^}$", html, re.S | re.M).group(0)
    asked = {"#step=1": 1, "#step=2&t=0.5": 2, "#t=0.5&step=2": 2, "": 1, "#t=3": 1, "#step=0": 1, "#step=9": 2}
    script = f"{source}\nconsole.log(JSON.stringify({json.dumps(list(asked))}.map(hash => hriplanStep(hash, 2))))"
    ran = subprocess.run([NODE, "-e", script], capture_output=True, text=True, timeout=60)
    assert ran.returncode == 0, ran.stderr
    assert json.loads(ran.stdout) == list(asked.values())


PROJECT_ROBOT = """(() => {  // screen positions of every robot part and scene object, and the legend's box
  const T = MeshCat.THREE;
  const project = o => { const p = o.getWorldPosition(new T.Vector3()).project(viewer.camera);
                         return [(p.x + 1) / 2 * innerWidth, (1 - p.y) / 2 * innerHeight]; };
  const under = name => Object.values(viewer.scene_tree.find([name]).children).map(c => project(c.object));
  const box = document.querySelector('.hriplan-step-legend:not([hidden]) details').getBoundingClientRect();
  return {robot: under("robot"), scene: under("scene"), legend: [box.left, box.top, box.right, box.bottom]};
})()"""


def test_at_1024x700_the_legend_leaves_the_robot_and_the_objects_in_view(trajectory, tmp_path):
    if CHROMIUM is None:
        pytest.skip("chromium is not installed")
    page = write_viewer(trajectory, tmp_path / "plan.html")
    small = Browser(1024, 700)
    try:
        small.page("Page.navigate", url=f"{page.resolve().as_uri()}#t=0")
        small.wait_for("document.body && document.body.dataset.shownTime === '0'")
        seen = small.evaluate(PROJECT_ROBOT)
    finally:
        small.close()
    left, top, right, bottom = seen["legend"]
    covered = [p for p in seen["robot"] if left <= p[0] <= right and top <= p[1] <= bottom]
    assert not covered, f"{len(covered)} of {len(seen['robot'])} robot parts under the legend"
    assert all(0 <= x <= 1024 and 0 <= y <= 700 for x, y in seen["robot"] + seen["scene"])


def test_the_tool_of_each_moving_arm_is_traced_whatever_its_joints_are_named(arms_named_apart):
    """An arm moves if the trajectory moves one of its joints (its group), not if a joint's name
    starts with the arm's: arm `a`'s joints are `right_*`, as TALOS's `right` arm's are `arm_right_*`."""
    from types import SimpleNamespace

    from hriplan.viewer.scene import _traced_links

    robot = arms_named_apart
    a_joints = robot.group_joints(robot.arm_group("a"))
    world = SimpleNamespace(robot=robot, trajectory=SimpleNamespace(joint_names=a_joints[:2], constraints=[]))
    assert _traced_links(world) == [robot.tool_frame("a")]
