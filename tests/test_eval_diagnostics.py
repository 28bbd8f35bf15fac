"""Diagnostics of the controller's levels: its settings in the config, per-point figures,
pose and line tasks, exact levels, and animations of evaluation episodes."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from hadim_cli.app import app
from hadim_cli.errors import HadimError
from hadim_cli.evaluation.metric import heading_error
from hadim_cli.evaluation.tasks import load_task, load_task_file

ITERATIONS = 400
"""Long enough for seed 2 to have a push affordance."""


def invoke(runner, *args: object):
    return runner.invoke(app, [str(a) for a in args])


@pytest.fixture(scope="module")
def store(tmp_path_factory) -> Path:
    from typer.testing import CliRunner

    path = tmp_path_factory.mktemp("diag") / "s.sqlite"
    result = invoke(CliRunner(), "train", "--iterations", ITERATIONS, "--eval-every", 0,
                    "--seed", 2, "--store", path, "--set", "planner.beam=6")
    assert result.exit_code == 0, result.stderr
    return path


def test_planner_settings_reach_the_controller_and_are_stored(runner, store):
    from hadim_cli import runs

    shown = json.loads(invoke(runner, "runs", "show", "run-1", "--json", "--store", store).stdout)
    assert shown["config"]["planner"]["beam"] == 6
    with runs.open_store(str(store), create=False) as st:
        session = runs.restore_session(st, st.get_run("run-1"))
    assert session.learner.controller.pc == session.config.planner
    assert session.config.planner.beam == 6


def test_a_bad_planner_setting_is_one_line(runner, tmp_path):
    result = invoke(runner, "train", "--iterations", 100, "--store", tmp_path / "x.sqlite",
                    "--set", "planner.commands=1")
    assert result.exit_code == 2
    assert result.stderr.strip().startswith("error: ") and "planner.commands" in \
        result.stderr
    assert not (tmp_path / "x.sqlite").exists()


def test_points_report_actions_path_trips_and_line_deviation(runner, store):
    out = invoke(runner, "eval", "run-1", "--task", "push-line", "--json", "--store", store)
    assert out.exit_code == 0, out.stderr
    points = json.loads(out.stdout)["points"]
    assert len(points) == len(load_task("push-line").points)
    for p in points:
        assert {"actions", "robot_path", "trips", "line_deviation"} <= set(p)
        assert p["robot_path"] >= 0 and p["trips"] >= 0 and p["line_deviation"] >= 0
    # A robot that moved drove a path at least as long as its displacement.
    assert any(p["robot_path"] > 0 for p in points)


def test_points_count_their_actions_by_what_the_controller_served(store):
    """`pursuits`: every action of a point counted once, under what the controller served
    when it chose it (what an animation shows, step by step)."""
    from collections import Counter

    from hadim_cli import runs
    from hadim_cli.evaluation.runner import evaluate

    with runs.open_store(str(store), create=False) as st:
        session = runs.restore_session(st, st.get_run("run-1"))
    result = evaluate(session.learner, session.config.world, load_task("push-line"),
                      record=True)
    plain = evaluate(session.learner, session.config.world, load_task("push-line"))
    assert [p.pursuits for p in plain.points] == [p.pursuits for p in result.points]
    for p, rec in zip(result.points, result.recordings, strict=True):
        assert sum(p.pursuits.values()) == p.actions == len(rec.steps)
        seen = Counter(s.labels[0] for s in rec.steps)
        assert p.pursuits == dict(seen)
        assert list(p.pursuits.values()) == sorted(p.pursuits.values(), reverse=True)
    # The robot driving to its place behind the object, and the push itself.
    labels = {k for p in result.points for k in p.pursuits}
    assert any(k.startswith("place robot for A") for k in labels)
    assert any(k.endswith("target.position") and not k.startswith("place") for k in labels)


def test_the_pose_task_scores_heading_and_position():
    task = load_task("reach-pose")
    assert task.prop == "pose" and len(task.headings) == len(task.points)
    assert heading_error(0.0, np.pi / 2, np.pi / 2) == 0.0
    assert heading_error(0.0, 0.0, np.pi / 2) == 1.0
    assert heading_error(0.0, np.pi / 4, np.pi / 2) == pytest.approx(0.5)
    assert heading_error(3.0, -3.0, np.pi) == pytest.approx(
        (2 * np.pi - 6.0) / 2 / (np.pi - 3.0), rel=1e-6)  # across ±π


def test_bad_pose_tasks_are_refused(tmp_path):
    bad = tmp_path / "t.toml"
    bad.write_text('entity = "robot"\nproperty = "pose"\npoints = [[1, 2]]\nbudget = 5\n'
                   '[scene]\n')
    with pytest.raises(HadimError, match="heading in degrees"):
        load_task_file(bad)
    bad.write_text('entity = "target"\ntarget = "obj1"\nproperty = "pose"\n'
                   'points = [[1, 2, 3]]\nbudget = 5\n[scene]\n')
    with pytest.raises(HadimError, match="'pose' for the robot"):
        load_task_file(bad)


def test_an_exact_level_is_a_diagnostic_not_a_stored_score(runner, store):
    from hadim_store import Store

    with Store.open(store, create=False) as st:
        before = len(st.evaluations("run-1"))
    out = invoke(runner, "eval", "run-1", "--task", "move-robot", "--exact", "navigation",
                 "--json", "--store", store)
    assert out.exit_code == 0, out.stderr
    assert 0.0 <= json.loads(out.stdout)["score"] <= 1.0
    with Store.open(store, create=False) as st:
        assert len(st.evaluations("run-1")) == before
    bad = invoke(runner, "eval", "run-1", "--task", "move-robot", "--exact", "physics",
                 "--store", store)
    assert bad.exit_code == 2 and bad.stderr.strip() == \
        "error: --exact: unknown level 'physics' (known: navigation, push, tool)"


def test_the_exact_level_changes_nothing_of_the_learner(store):
    """Within the block the controller imagines the named levels by the room's physics
    (other scores), afterwards as before; the learner is never changed."""
    from hadim_cli import runs
    from hadim_cli.evaluation.exact import exact_levels
    from hadim_cli.evaluation.runner import evaluate

    with runs.open_store(str(store), create=False) as st:
        session = runs.restore_session(st, st.get_run("run-1"))
    task = load_task("push-object")
    digest = session.learner.dataset.sha256()
    before = evaluate(session.learner, session.config.world, task)
    for levels in (("navigation",), ("push",), ("navigation", "push")):
        with exact_levels(session.learner, session.config.world, levels):
            exact = evaluate(session.learner, session.config.world, task)
        assert [p.final for p in exact.points] != [p.final for p in before.points], levels
    after = evaluate(session.learner, session.config.world, task)
    assert after.points == before.points
    assert session.learner.dataset.sha256() == digest


def test_an_animation_is_written_and_the_same_run_draws_the_same_frames(runner, store,
                                                                       tmp_path):
    from PIL import Image, ImageSequence

    from hadim_cli import runs
    from hadim_cli.evaluation.animate import animate
    from hadim_cli.evaluation.runner import evaluate

    task = dataclasses.replace(load_task("push-object"), points=((0.8, 0.45),), budget=6)
    with runs.open_store(str(store), create=False) as st:
        session = runs.restore_session(st, st.get_run("run-1"))
    first = evaluate(session.learner, session.config.world, task, record=True)
    again = evaluate(session.learner, session.config.world, task, record=True)
    rec = first.recordings[0]
    assert rec.observations.shape[0] == first.points[0].actions + 1
    assert len(rec.steps) == first.points[0].actions
    assert all(step.labels for step in rec.steps)  # what the controller served, every action
    a = animate(first.recordings, session.world.layout, tmp_path / "a.gif", hold=2)
    b = animate(again.recordings, session.world.layout, tmp_path / "b.gif", hold=2)
    assert a.read_bytes() == b.read_bytes()
    durations = [f.info["duration"] for f in ImageSequence.Iterator(Image.open(a))]
    assert len(durations) == rec.observations.shape[0]  # one frame per observation
    assert durations[-1] == 2 * durations[0]  # the last one held
    # Through the CLI: one line saying what it wrote.
    out = invoke(runner, "eval", "run-1", "--task", "move-robot", "--animate",
                 tmp_path / "m.gif", "--store", store)
    assert out.exit_code == 0, out.stderr
    assert out.stdout.strip().splitlines()[-1] == f"wrote {tmp_path / 'm.gif'}"
    assert (tmp_path / "m.gif").stat().st_size > 0


def test_an_action_counts_as_robot_only_unless_it_moves_an_object():
    """`robot_only`: the actions that moved no object (turns, drives, blocked pushes); a push
    that moves any object, the task's or not, is not one."""
    from hadim_cli.config import WorldConfig
    from hadim_cli.evaluation.runner import EvalActuator
    from hadim_cli.world.scene import ObjectSpec, Scene
    from hadim_cli.world.world import World

    cfg = WorldConfig()
    green = (0.2, 0.8, 0.2)
    far = [ObjectSpec(-1.5 + 0.4 * i, 1.6, 0.1, 0.2, (0.8, 0.2, 0.2), False)
           for i in range(cfg.n_green + cfg.n_red - 1)]
    world = World(cfg)
    obs = world.reset(scene=Scene((ObjectSpec(0.27, 0.0, 0.1, 0.2, green, True), *far)))
    actuator = EvalActuator(world, obs, 10, None)
    actuator.act(np.array([-1.0, 1.0]))   # a turn on the spot
    actuator.act(np.array([1.0, -1.0]))   # back
    assert (actuator.used, actuator.robot_only) == (2, 2)
    for _ in range(3):                    # into obj1, which moves
        actuator.act(np.array([1.0, 1.0]))
    assert actuator.robot_only == 2
    actuator.act(np.array([-1.0, -1.0]))  # backing off: obj1 at rest (`settle_time`) stays
    assert (actuator.used, actuator.robot_only) == (6, 3)


def test_robot_only_actions_after_the_pushed_object_first_moved_are_counted_apart():
    """`robot_only_after`: of the actions that moved no object, those after the push task's
    object first moved (corrections once it is on its way); turns before its first push
    are not among them, and a robot task counts none."""
    from hadim_cli.config import WorldConfig
    from hadim_cli.evaluation.runner import EvalActuator
    from hadim_cli.world.scene import ObjectSpec, Scene
    from hadim_cli.world.world import World

    cfg = WorldConfig()
    green = (0.2, 0.8, 0.2)
    far = [ObjectSpec(-1.5 + 0.4 * i, 1.6, 0.1, 0.2, (0.8, 0.2, 0.2), False)
           for i in range(cfg.n_green + cfg.n_red - 1)]
    scene = Scene((ObjectSpec(0.27, 0.0, 0.1, 0.2, green, True), *far))
    for pushed, after in ((True, 2), (False, 0)):
        world = World(cfg)
        obs = world.reset(scene=scene)
        actuator = EvalActuator(world, obs, 20, None)
        if pushed:
            actuator.watch_push(1, -1, np.array([1.0, 0.0]))
        actuator.act(np.array([-1.0, 1.0]))   # a turn on the spot, before any push
        actuator.act(np.array([1.0, -1.0]))   # back
        for _ in range(3):                    # into obj1, which moves
            actuator.act(np.array([1.0, 1.0]))
        actuator.act(np.array([-1.0, 1.0]))   # turns after it moved
        actuator.act(np.array([1.0, -1.0]))
        assert actuator.robot_only == 4
        assert actuator.robot_only_after == after


def test_a_push_length_is_the_driven_object_s_travel_per_action_that_moved_it():
    """`driven_moves` / `driven_path`: the actions that moved the followed object and how far
    it went over them. A turn on the spot and a backing off move it not; each push does, and
    its travel is the object's displacement (three straight pushes: their sum is the net)."""
    from hadim_cli.evaluation.runner import EvalActuator
    from hadim_cli.world.layout import Property
    from hadim_cli.world.scene import ObjectSpec

    world, obs = _pushing_world([ObjectSpec(0.27, 0.0, 0.1, 0.2, (0.2, 0.8, 0.2), True)])
    where = world.layout.space("obj1", Property.POSITION).slice
    start = obs[where].copy()
    actuator = EvalActuator(world, obs, 10, None)
    actuator.follow(1, start, np.array([1.0, 0.0]))
    actuator.act(np.array([-1.0, 1.0]))   # a turn on the spot
    actuator.act(np.array([1.0, -1.0]))   # back
    assert (actuator.driven_moves, actuator.driven_path) == (0, 0.0)
    for _ in range(3):                    # into obj1, which moves
        actuator.act(np.array([1.0, 1.0]))
    actuator.act(np.array([-1.0, -1.0]))  # backing off: obj1 stays
    assert actuator.driven_moves == 3
    travel = float(np.linalg.norm(actuator.obs[where] - start))
    assert travel > 0.1
    assert abs(actuator.driven_path - travel) < 0.005


def _pushing_world(objects):
    """A world with `objects` (ObjectSpecs) first and fixed red discs along the far wall."""
    from hadim_cli.config import WorldConfig
    from hadim_cli.world.scene import ObjectSpec, Scene
    from hadim_cli.world.world import World

    cfg = WorldConfig()
    far = [ObjectSpec(-1.5 + 0.4 * i, 1.6, 0.1, 0.2, (0.8, 0.2, 0.2), False)
           for i in range(cfg.n_green + cfg.n_red - len(objects))]
    world = World(cfg)
    return world, world.reset(scene=Scene((*objects, *far)))


def test_the_first_push_says_how_it_was_lined_up():
    """`first_push`: unset while nothing moves the object; then the pusher's line off the
    object's way to its point and the object's move off it, from the action that moved it."""
    from hadim_cli.evaluation.runner import EvalActuator
    from hadim_cli.world.scene import ObjectSpec

    green = (0.2, 0.8, 0.2)
    for bearing in (0.0, 60.0):
        world, obs = _pushing_world([ObjectSpec(0.27, 0.0, 0.1, 0.2, green, True)])
        point = np.array([0.27, 0.0]) + 0.4 * np.array([np.cos(np.radians(bearing)),
                                                         np.sin(np.radians(bearing))])
        actuator = EvalActuator(world, obs, 10, None)
        actuator.watch_push(1, -1, point)
        actuator.act(np.array([-1.0, -1.0]))   # backing away moves nothing
        assert actuator.first_push is None
        for _ in range(3):
            actuator.act(np.array([1.0, 1.0]))  # straight into the object, along +x
        push = actuator.first_push
        assert push is not None and push.robot_off is None
        assert push.pusher_off == pytest.approx(bearing, abs=1.0)
        assert push.move_off == pytest.approx(bearing, abs=5.0)


def test_the_first_push_through_a_tool_measures_the_chain_s_bend():
    """With a tool, the pusher is the tool, and `robot_off` is the robot→tool line off the
    tool→target line, read before the action that moved the target."""
    from hadim_cli.evaluation.runner import EvalActuator
    from hadim_cli.world.scene import ObjectSpec

    green = (0.2, 0.8, 0.2)
    bend = np.radians(20.0)
    tool = np.array([0.255, 0.0])               # the robot at the origin, 5 mm behind it
    target = tool + 0.205 * np.array([np.cos(bend), np.sin(bend)])
    world, obs = _pushing_world([ObjectSpec(*target, 0.1, 0.2, green, True),
                                 ObjectSpec(*tool, 0.1, 0.2, green, True)])
    actuator = EvalActuator(world, obs, 10, "obj1")
    actuator.watch_push(1, 2, target + np.array([0.4, 0.0]))   # the target's way: +x
    actuator.act(np.array([1.0, 0.5]))          # an arc: the robot ends off the +x axis
    push = actuator.first_push
    assert push is not None
    # Read off the scene before the action that moved the target.
    assert push.robot_off == pytest.approx(20.0, abs=0.01)
    assert push.pusher_off == pytest.approx(20.0, abs=0.01)


def test_trip_starts_are_the_goal_s_remaining_share_when_each_trip_began(store):
    """`trips`: the stretches of actions serving a place (labels "place …"); `trip_starts`:
    one share per trip, read off the observation before its first action: 1.0 before the
    object moved, less once it was on its way."""
    from hadim_cli import runs
    from hadim_cli.evaluation.metric import remaining_share
    from hadim_cli.evaluation.runner import evaluate

    with runs.open_store(str(store), create=False) as st:
        session = runs.restore_session(st, st.get_run("run-1"))
    task = load_task("push-object")
    result = evaluate(session.learner, session.config.world, task, record=True)
    target = session.world.layout.entities.index(task.target)
    total = 0
    for p, rec in zip(result.points, result.recordings, strict=True):
        placing = [s.labels[0].startswith("place ") for s in rec.steps]
        begins = [i for i, on in enumerate(placing) if on and (i == 0 or not placing[i - 1])]
        assert p.trips == len(begins)
        want = [remaining_share(session.learner.reader.entity_position(rec.observations[i],
                                                                       target),
                                p.start, p.target) for i in begins]
        assert list(p.trip_starts) == pytest.approx(want)
        total += p.trips
    assert total > 0
    assert any(s == pytest.approx(1.0) for p in result.points for s in p.trip_starts)
