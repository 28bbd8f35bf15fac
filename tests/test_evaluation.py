from __future__ import annotations

import pytest

from hadim_cli.errors import HadimError
from hadim_cli.evaluation.metric import point_error, task_score
from hadim_cli.evaluation.tasks import load_task, load_task_file, task_names


def test_metric():
    assert point_error((0, 0), (0, 0), (1, 0)) == 1.0  # did nothing
    assert point_error((0, 0), (1, 0), (1, 0)) == 0.0  # reached
    assert point_error((0, 0), (0.5, 0), (1, 0)) == pytest.approx(0.5)
    assert point_error((0, 0), (-3, 0), (1, 0)) == 1.0  # worse is capped
    assert task_score([1.0, 1.0]) == 0.0
    assert task_score([0.0, 0.0]) == 1.0
    with pytest.raises(ValueError):
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
