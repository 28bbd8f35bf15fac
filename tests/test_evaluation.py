from __future__ import annotations

import numpy as np
import pytest

from hadim_cli.errors import HadimError
from hadim_cli.evaluation.metric import (
    distance_error,
    heading_error,
    point_error,
    remaining_share,
    task_score,
)
from hadim_cli.evaluation.tasks import load_task, load_task_file, task_names


def test_metric():
    assert point_error((0, 0), (0, 0), (1, 0)) == 1.0  # did nothing
    assert point_error((0, 0), (1, 0), (1, 0)) == 0.0  # reached
    assert point_error((0, 0), (0.5, 0), (1, 0)) == pytest.approx(0.5)
    assert point_error((0, 0), (-3, 0), (1, 0)) == 1.0  # worse is capped
    # A goal reached at the start: kept is 0, left is 1 (the one goal score near zero).
    assert distance_error(0.0, 0.0) == 0.0 and distance_error(0.0, 0.1) == 1.0
    assert point_error((1, 0), (1.2, 0), (1, 0)) == 1.0
    assert task_score([1.0, 1.0]) == 0.0
    assert task_score([0.0, 0.0]) == 1.0
    with pytest.raises(ValueError, match="^a task needs at least one point$"):
        task_score([])


def test_shipped_tasks_load():
    assert {"move-robot", "push-object", "push-with-tool"} <= set(task_names())
    for name in ("move-robot", "push-object", "push-with-tool"):
        task = load_task(name)
        assert len(task.scene.objects) == 9 and task.points and task.budget > 0
    assert load_task("push-with-tool").tool == "obj2"


def test_bad_tasks(tmp_path):
    with pytest.raises(HadimError, match="unknown task 'nope'"):
        load_task("nope")
    bad = tmp_path / "t.toml"
    bad.write_text('entity = "robot"\nproperty = "position"\npoints = [[1, 2, 3]]\nbudget = 5\n'
                   '[scene]\n')
    with pytest.raises(HadimError, match="pair"):
        load_task_file(bad)
    bad.write_text('entity = "robot"\nproperty = "position"\npoints = [[1, 2]]\nbudget = 5\n'
                   'colour = 1\n[scene]\n')
    with pytest.raises(HadimError, match="unknown key 'colour'"):
        load_task_file(bad)


def test_a_task_evaluates_the_affordance_it_names():
    """The most competent affordance with the task's input space; the most competent of any
    input when H has none with it; none when nothing drives the property."""
    from dataclasses import replace
    from types import SimpleNamespace

    from hadim_cli.evaluation.runner import choose_affordance
    from hadim_cli.learner.spaces import parse_space

    def aff(aid, inp, competence, tool=False):
        return SimpleNamespace(id=aid, input=parse_space(inp), competence=competence,
                               has_tool=tool)

    h = [aff(3, "robot.position", 0.43), aff(4, "action", 0.44), aff(5, "robot.heading", 0.40),
         aff(6, "tool.position", 0.9, tool=True)]
    learner = SimpleNamespace(hierarchy=SimpleNamespace(with_output=lambda space: h))
    task = load_task("push-object")
    assert task.affordance_input == "robot.position"
    assert choose_affordance(learner, task).id == 3
    assert choose_affordance(learner, replace(task, affordance_input=None)).id == 4
    h.pop(0)
    assert choose_affordance(learner, task).id == 4
    assert choose_affordance(learner, load_task("push-with-tool")).id == 6
    h.clear()
    assert choose_affordance(learner, task) is None


def test_a_task_names_a_real_input_space(tmp_path):
    bad = tmp_path / "t.toml"
    bad.write_text('entity = "robot"\nproperty = "position"\npoints = [[1, 2]]\nbudget = 5\n'
                   'affordance_input = "robot.wheels"\n[scene]\n')
    with pytest.raises(HadimError, match="'affordance_input' must name a space"):
        load_task_file(bad)


def test_a_tool_task_fails_every_point_the_robot_touches_the_target_in():
    """Driving straight ahead, the robot pushes the nearest object towards every point:
    scored as a direct push it makes progress, through a tool (the same object the target)
    each point fails on the robot–target contact, and the attempt stops there."""
    from dataclasses import replace

    from hadim_cli.config import load_config
    from hadim_cli.evaluation.runner import evaluate
    from hadim_cli.learner.explorer import Learner
    from hadim_cli.learner.goals import Attempt
    from hadim_cli.learner.spaces import Rows, parse_space
    from hadim_cli.world.world import World

    config = load_config()
    world = World(config.world)
    learner = Learner(config.learner, world.layout, world.action_space)
    for inp in ("robot.position", "tool.position"):
        aff = learner.fitter.new_affordance(learner.hierarchy.allocate_id(), parse_space(inp),
                                            parse_space("target.position"), (), Rows.empty(),
                                            0, np.random.default_rng(0))
        learner.hierarchy.add(aff, 0)
    bindings = []

    def straight_ahead(aff, binding, goal, actuator, budget):
        bindings.append((aff.input.name, binding.target, binding.tool))
        while not actuator.exhausted:
            actuator.act(np.array([1.0, 1.0]))
        return Attempt(1.0, 1.0, actuator.used)

    learner.controller.reach = straight_ahead
    task = load_task("push-with-tool")
    direct = evaluate(learner, config.world, replace(task, target="obj2", tool=None,
                                                      affordance_input="robot.position"))
    assert direct.score > 0.05 and not any(p.contact_failed for p in direct.points)
    through = evaluate(learner, config.world, replace(task, target="obj2", tool="obj1"))
    assert through.score == 0.0
    assert all(p.contact_failed and p.error == 1.0 for p in through.points)
    assert all(p.actions < task.budget for p in through.points)  # stopped at the contact
    assert bindings[0] == ("robot.position", 2, -1) and bindings[-1] == ("tool.position", 2, 1)


def test_the_remaining_share_is_the_error_so_far_unclipped():
    """`remaining_share` (a trip's start in `trip_starts`): the point's error, not capped."""
    assert remaining_share((0, 0), (0, 0), (1, 0)) == 1.0       # not moved
    assert remaining_share((0.5, 0), (0, 0), (1, 0)) == pytest.approx(0.5)
    assert remaining_share((1, 0.25), (0, 0), (1, 0)) == pytest.approx(0.25)
    assert remaining_share((-1, 0), (0, 0), (1, 0)) == pytest.approx(2.0)  # pushed away
    assert remaining_share((1, 1), (1, 3), (1, 0)) == pytest.approx(1 / 3)   # a share of 3 m
    assert remaining_share((0, 0), (0.2, 0), (0.2, 0.1)) == pytest.approx(np.hypot(0.2, 0.1) / 0.1)


def test_each_point_is_scored_by_the_share_of_its_distance_left_and_the_task_by_their_mean():
    """The metric of §5.1 through `evaluate`: a point's error is min(1, final / initial
    distance of the driven entity to the point), from where the task's scene puts it to
    where the attempt leaves it; the task's score is 1 − the mean error. A robot driven
    straight ahead (heading 0) for a few actions gets part of the way to a point ahead of it,
    none of the way to one behind it."""
    from dataclasses import replace

    from hadim_cli.config import load_config
    from hadim_cli.evaluation.runner import evaluate
    from hadim_cli.learner.explorer import Learner
    from hadim_cli.learner.goals import Attempt
    from hadim_cli.learner.spaces import ACTION, Rows, parse_space
    from hadim_cli.world.world import World

    config = load_config()
    world = World(config.world)
    learner = Learner(config.learner, world.layout, world.action_space)
    aff = learner.fitter.new_affordance(learner.hierarchy.allocate_id(), ACTION,
                                        parse_space("robot.position"), (), Rows.empty(), 0,
                                        np.random.default_rng(0))
    learner.hierarchy.add(aff, 0)

    def straight_ahead(aff, binding, goal, actuator, budget):
        while not actuator.exhausted:
            actuator.act(np.array([1.0, 1.0]))
        return Attempt(1.0, 1.0, actuator.used)

    learner.controller.reach = straight_ahead
    task = replace(load_task("move-robot"), points=((1.0, 0.0), (-0.5, 0.0), (0.8, 0.4)),
                   budget=4)
    result = evaluate(learner, config.world, task)
    world = World(config.world)
    world.reset(scene=task.scene)
    for _ in range(task.budget):
        world.step(np.array([1.0, 1.0]))
    final = np.asarray(world.robot_pose()[:2])
    start = np.array([task.scene.robot_x, task.scene.robot_y])
    errors = []
    for point, p in zip(task.points, result.points, strict=True):
        np.testing.assert_allclose(p.start, start, atol=1e-9)
        np.testing.assert_allclose(p.final, final, atol=1e-9)
        expected = min(1.0, np.linalg.norm(np.subtract(point, final))
                       / np.linalg.norm(np.subtract(point, start)))
        assert p.error == pytest.approx(expected, abs=1e-12)
        errors.append(expected)
    assert 0.0 < errors[0] < 0.9 and errors[1] == 1.0 and 0.0 < errors[2] < 1.0
    assert result.score == pytest.approx(1.0 - np.mean(errors), abs=1e-12)


def test_a_heading_is_scored_by_the_share_of_its_angle_left_the_short_way_round():
    """`heading_error` (pose tasks): min(1, final / initial angle to the wanted heading),
    each angle the short way round (turning past ±π is no detour); a heading wanted from the
    start scores 0 while kept within 0.05 rad, 1 once left further."""
    assert heading_error(0.0, 0.0, np.pi / 2) == 1.0                      # did not turn
    assert heading_error(0.0, np.pi / 2, np.pi / 2) == 0.0                # turned all the way
    assert heading_error(0.0, np.pi / 4, np.pi / 2) == pytest.approx(0.5)
    assert heading_error(0.0, -np.pi / 2, np.pi / 2) == 1.0               # worse is capped
    # Across ±π: from 3 rad to −3 rad is 0.28 rad, not 6.
    assert heading_error(3.0, -3.1, -3.0) == pytest.approx(0.1 / (2 * np.pi - 6.0))
    assert heading_error(-3.0, 3.0 + 2 * np.pi, 3.0) == 0.0
    assert heading_error(1.0, 1.5, 1.0 + 4 * np.pi) == pytest.approx(1.0)
    # Wanted from the start: kept within 0.05 rad, else lost.
    assert heading_error(0.3, 0.33, 0.3) == 0.0
    assert heading_error(0.3, 0.3 - 0.0499, 0.3) == 0.0
    assert heading_error(0.3, 0.3 + 0.051, 0.3) == 1.0
    assert heading_error(0.3, 0.3 - 0.2, 0.3) == 1.0
    assert heading_error(0.3, 0.3 + 2.0, 0.3) == 1.0


def test_each_action_is_counted_and_recorded_under_what_the_controller_served():
    """A stand-in controller drives the robot straight ahead into obj1, towards push-line's
    first point (ahead of obj1, on its line), telling the observer what each action serves:
    two actions to its place, two pushes, one to its place again, one push. The point counts
    its actions by label, most first; its trips (stretches of `place …` actions) with obj1's
    remaining share when each began; how its first push was lined up (straight behind obj1,
    along its way); no contact failed. The recording keeps each label with the observation
    after its action."""
    from dataclasses import replace

    from hadim_cli.config import load_config
    from hadim_cli.evaluation.runner import evaluate
    from hadim_cli.learner.controller import Decision
    from hadim_cli.learner.explorer import Learner
    from hadim_cli.learner.goals import Attempt
    from hadim_cli.learner.spaces import Rows, parse_space
    from hadim_cli.world.world import World

    config = load_config()
    world = World(config.world)
    learner = Learner(config.learner, world.layout, world.action_space)
    aff = learner.fitter.new_affordance(learner.hierarchy.allocate_id(),
                                        parse_space("robot.position"),
                                        parse_space("target.position"), (), Rows.empty(), 0,
                                        np.random.default_rng(0))
    learner.hierarchy.add(aff, 0)
    place, push = f"place robot for A{aff.id}", f"A{aff.id} target.position"
    labels = [place, place, push, push, place, push]
    ahead = np.array([1.0, 1.0])

    def straight_ahead(aff, binding, goal, actuator, budget):
        for label in labels:
            learner.controller.observer(Decision(ahead, 0.0, 0.0, label))
            actuator.act(ahead)
        return Attempt(1.0, 1.0, actuator.used)

    learner.controller.reach = straight_ahead
    task = replace(load_task("push-line"), points=((1.25, 0.0),), budget=len(labels))
    result = evaluate(learner, config.world, task, record=True)
    (p,), (rec,) = result.points, result.recordings
    assert p.actions == len(labels) and p.contact_failed is False
    assert p.pursuits == {place: 3, push: 3} and list(p.pursuits) == sorted(p.pursuits)
    assert p.trips == 2 and p.trip_starts[0] == 1.0 and 0.0 < p.trip_starts[1] < 1.0
    assert p.first_push.pusher_off == pytest.approx(0.0, abs=1.0)
    assert p.first_push.move_off == pytest.approx(0.0, abs=1.0)
    assert [s.labels for s in rec.steps] == [(label,) for label in labels]
    assert rec.observations.shape[0] == len(labels) + 1
    np.testing.assert_array_equal(learner.reader.entity_position(rec.observations[-1], 1),
                                  p.final)
