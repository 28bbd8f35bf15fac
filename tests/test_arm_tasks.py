"""The arm's evaluation tasks (`reach`, `arm-push`, `arm-push-with-tool`): an arm run is
evaluated on them (by `hadim eval`, its `--animate`, and beside training), a task belongs to
one body and a run of the other refuses it in one line with nothing stored, and an arm task's
points must lie where the arm can bring its entity."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from test_cli import PNG, SMALL, ok, refused, snapshot

from hadim_cli.config import Body, WorldConfig, configs_dir, load_config
from hadim_cli.evaluation.runner import EvalActuator
from hadim_cli.evaluation.tasks import body_tasks, load_task
from hadim_cli.world.environment import make_world

ARM = ("--config", str(configs_dir() / "arm.toml"), "--set", "world.episode_length=50")
ARM_TASKS = ("arm-push", "arm-push-with-tool", "reach")


@pytest.fixture(scope="module")
def arm_store(tmp_path_factory) -> Path:
    """run-1: an arm run of 100 iterations evaluated beside its training at 50 and 100 on the
    tasks configs/arm.toml names; run-2: a rover run of 50 iterations."""
    from typer.testing import CliRunner

    runner = CliRunner()
    store = tmp_path_factory.mktemp("arm-tasks") / "s.sqlite"
    ok(runner, "train", *ARM, "--iterations", 100, "--seed", 1, "--eval-every", 50,
       "--store", store)
    ok(runner, "train", *SMALL, "--iterations", 50, "--eval-every", 0, "--store", store)
    return store


def test_the_arm_has_its_tasks_and_its_config_evaluates_them():
    assert sorted(body_tasks(Body.ARM)) == list(ARM_TASKS)
    assert not set(ARM_TASKS) & set(body_tasks(Body.ROVER))
    config = load_config(configs_dir() / "arm.toml", [])
    assert sorted(config.evaluation.tasks) == list(ARM_TASKS)
    assert load_task("reach").entity == "effector"
    assert load_task("arm-push-with-tool").tool == "obj2"


def test_an_arm_run_is_evaluated_on_its_tasks_beside_training(runner, arm_store):
    shown = json.loads(ok(runner, "runs", "show", "run-1", "--json", "--store", arm_store).stdout)
    assert shown["config"]["world"]["body"] == "arm"
    from hadim_store import Store

    with Store.open(arm_store) as st:
        stored = sorted((e.iteration, e.task) for e in st.evaluations("run-1"))
    assert stored == sorted((it, task) for it in (50, 100) for task in ARM_TASKS)


@pytest.mark.parametrize("task", ARM_TASKS)
def test_hadim_eval_runs_each_arm_task_on_an_arm_run(runner, arm_store, task):
    result = json.loads(ok(runner, "eval", "run-1", "--task", task, "--json",
                           "--store", arm_store).stdout)
    assert result["task"] == task and result["iteration"] == 100
    assert result["actor"] == "effector"
    assert len(result["points"]) == len(load_task(task).points)
    assert 0.0 <= result["score"] <= 1.0
    assert all(p["actions"] <= load_task(task).budget for p in result["points"])
    # The attempt starts from the task's scene: the driven entity where the scene puts it.
    start = np.array(result["points"][0]["start"])
    scene = load_task(task).scene
    if task == "reach":
        from hadim_cli.world.kinematics import effector_position

        expected = effector_position((0.6, 0.5, 0.4), np.array(scene.joints))
    else:
        expected = np.array([scene.objects[0].x, scene.objects[0].y])
    assert np.allclose(start, expected, atol=2e-3)


def test_eval_animates_and_plots_an_arm_run(runner, arm_store, tmp_path):
    gif = tmp_path / "reach.gif"  # one point of a few actions: drawing frames is slow
    ok(runner, "eval", "run-1", "--points", _task_file(tmp_path, "[[1.0, 0.0]]"),
       "--animate", gif, "--store", arm_store)
    assert gif.read_bytes()[:6] == b"GIF89a"
    png = tmp_path / "curves.png"
    ok(runner, "plot", "run-1", "--out", png, "--store", arm_store)
    assert png.read_bytes()[:8] == PNG
    table = ok(runner, "eval", "run-1", "--task", "arm-push", "--store", arm_store).stdout
    assert "effector" in table and "robot" not in table  # the world's name for its actor


def test_an_arm_run_s_affordances_are_shown_with_its_effector_and_stored_by_role(
        runner, arm_store, tmp_path):
    """`affordances` and its `--timeline` (table and figure) name the actor as the arm's world
    does; `--json` prints the stored role names, and showing writes nothing."""
    from hadim_cli.learner.spaces import parse_space

    before = snapshot(arm_store)
    table = ok(runner, "affordances", "run-1", "--store", arm_store).stdout
    timeline = ok(runner, "affordances", "run-1", "--timeline", "--out", tmp_path / "t.png",
                  "--store", arm_store).stdout
    for shown in (table, timeline):
        assert "effector.position" in shown and "robot" not in shown
    stored = json.loads(ok(runner, "affordances", "run-1", "--json", "--store",
                           arm_store).stdout)
    names = {n for r in stored for n in (r["input"], r["output"], *r["context"])}
    assert "robot.position" in names and not any("effector" in n for n in names)
    assert all(parse_space(n).name == n for n in names)
    assert snapshot(arm_store) == before


def test_a_space_is_shown_with_the_world_s_name_for_its_actor_the_rover_s_unchanged():
    from hadim_cli.learner.spaces import (
        OPEN_OUTPUT_SPACES,
        Role,
        actor_contexts,
        context_candidates,
        shown_as,
    )
    from hadim_cli.world.layout import actor_of

    arm = make_world(load_config(configs_dir() / "arm.toml", []).world)
    every = frozenset({Role.ROBOT, Role.TARGET, Role.TOOL})
    names = [s.name for world in (arm, make_world(load_config(None, []).world))
             for s in (*OPEN_OUTPUT_SPACES,
                       *context_candidates(every, actor_contexts(world.layout)))]
    assert all(shown_as(n, "robot") == n for n in names)
    for body in Body:  # the name a stored run's tables use is the one its world declares
        assert actor_of(body) == make_world(WorldConfig(body=body)).layout.actor
    assert shown_as("target-robot", "effector") == "target-effector"
    assert shown_as("robot.joints", "effector") == "effector.joints"
    assert shown_as("A2 robot.position", "effector") == "A2 effector.position"
    assert shown_as("place robot for A3", "effector") == "place effector for A3"
    assert shown_as("target-tool", "effector") == "target-tool"
    # an affordance as `describe()` writes it (`affordances --pa`)
    assert (shown_as("A1(robot.position → target.position | target-robot, robot.orientation)",
                     "effector")
            == "A1(effector.position → target.position | target-effector, effector.orientation)")
    assert shown_as("A0(action → robot.position | ∅)", "effector") == \
        "A0(action → effector.position | ∅)"


def test_a_task_of_one_body_on_a_run_of_the_other_is_refused_with_nothing_stored(
        runner, arm_store):
    before = snapshot(arm_store)
    line = refused(runner, "eval", "run-1", "--task", "push-object", "--store", arm_store,
                   match="task push-object is a task of the rover")
    assert "this run's body is the arm" in line and "reach" in line
    line = refused(runner, "eval", "run-2", "--task", "reach", "--store", arm_store,
                   match="task reach is a task of the arm")
    assert "this run's body is the rover" in line
    assert snapshot(arm_store) == before


def test_training_refuses_evaluation_tasks_of_another_body(runner, tmp_path):
    store = tmp_path / "s.sqlite"
    refused(runner, "train", *ARM, "--set", 'evaluation.tasks=["move-robot"]',
            "--iterations", 100, "--eval-every", 50, "--store", store,
            match="task move-robot is a task of the rover")
    refused(runner, "train", "--set", 'evaluation.tasks=["reach"]', "--iterations", 200,
            "--eval-every", 100, "--store", store, match="task reach is a task of the arm")
    assert not store.exists()


def _task_file(tmp_path: Path, points: str, scene: str = "joints = [0.0, 1.0, 1.0]",
               entity: str = "effector") -> Path:
    objects = "".join(
        f"[[scene.objects]]\nx = {x}\ny = 1.8\nradius = 0.1\nheight = 0.2\n"
        f"color = [0.2, 0.8, 0.2]\npushable = {'true' if i < 6 else 'false'}\n"
        for i, x in enumerate(np.linspace(-1.6, 1.6, 9).round(2)))
    path = tmp_path / "mine.toml"
    path.write_text(f'body = "arm"\nentity = "{entity}"\nproperty = "position"\n'
                    f"budget = 5\npoints = {points}\n[scene]\n{scene}\n{objects}")
    return path


def test_an_arm_task_refuses_what_the_arm_cannot_do(runner, arm_store, tmp_path):
    before = snapshot(arm_store)

    def eval_points(path: Path, match: str) -> None:
        refused(runner, "eval", "run-1", "--points", path, "--store", arm_store, match=match)

    eval_points(_task_file(tmp_path, "[[1.0, 0.0], [0.1, 0.0]]"),
                "target point (0.1, 0) is 0.1 m from the arm's base")
    eval_points(_task_file(tmp_path, "[[1.6, 0.0]]"), "only 0.2-1.5 m from it")
    eval_points(_task_file(tmp_path, "[[1.0, 0.0]]", "robot = [0.0, 0.0, 0.0]"),
                "scene.robot places another body than the arm")
    eval_points(_task_file(tmp_path, "[[1.0, 0.0]]", "joints = [0.0, 1.0]"),
                "places 2 joints in its scene; this run's arm has 3")
    eval_points(_task_file(tmp_path, "[[1.0, 0.0]]", "joints = [0.0, 1.0, 2.5]"),
                "turns joint 3 to 2.5 rad")
    eval_points(_task_file(tmp_path, "[[1.0, 0.0]]", entity="robot"),
                "entity must be 'effector' (the arm's actor) or 'target'")
    assert snapshot(arm_store) == before
    # A point the arm reaches is attempted (and stored, under the user's name).
    ok(runner, "eval", "run-1", "--points", _task_file(tmp_path, "[[1.0, 0.0]]"),
       "--store", arm_store)


def test_an_effector_touching_the_target_of_a_tool_task_fails_it():
    """The contact rule of the tool tasks holds on the arm: its effector, not a 'robot'."""
    config = load_config(configs_dir() / "arm.toml", [])
    world = make_world(config.world)
    task = load_task("arm-push")  # the target just beyond the effector, nothing between
    obs = world.reset(scene=task.scene)
    actuator = EvalActuator(world, obs, budget=40, watch="obj1")
    straighten = np.array([0.0, -1.0, -1.0])  # the effector swings out into obj1
    while not actuator.exhausted:
        actuator.act(straighten)
    assert actuator.touched and actuator.used < 40


def test_exact_navigation_imagines_the_arm_by_its_kinematics(runner, arm_store):
    """`--exact navigation` on an arm run: the effector's motion imagined by the arm's forward
    kinematics, whatever A0 learned in 100 iterations — a diagnostic, not stored."""
    before = snapshot(arm_store)
    out = ok(runner, "eval", "run-1", "--task", "reach", "--exact", "navigation", "--json",
             "--store", arm_store).stdout
    assert json.loads(out)["score"] >= 0.9
    assert snapshot(arm_store) == before


def test_p_a_is_asked_about_the_arm_s_own_scene_and_objects_it_never_drew():
    """`affordances --pa` on an arm run: p_A is asked about the effector and the objects of
    the arm's scene of seed 0, and about the unseen objects, each read from an observation of
    the arm's world (p_A's features as the arm's learner sees them)."""
    from types import SimpleNamespace

    from hadim_cli.learner.explorer import Learner
    from hadim_cli.learner.spaces import Role, RoleSpace, Rows
    from hadim_cli.pa_probes import UNSEEN, verdicts
    from hadim_cli.world.layout import Property

    config = load_config(configs_dir() / "arm.toml")
    world = make_world(config.world)
    learner = Learner(config.learner, world.layout, world.action_space)
    rng = np.random.default_rng(0)
    obs = world.reset(seed=0)
    for _ in range(20):
        after = world.step(world.action_space.sample(rng, 1)[0])
        learner.dataset.append(np.zeros(world.action_space.dim), obs, after)
        obs = after
    t = np.arange(20)
    push = learner.fitter.new_affordance(
        0, RoleSpace(Role.ROBOT, Property.POSITION), RoleSpace(Role.TARGET, Property.POSITION),
        (), Rows(t, np.ones(20, dtype=np.int64), np.full(20, -1)), 20, rng)
    learner.hierarchy.add(push, 20)
    (found,) = verdicts(SimpleNamespace(learner=learner, config=config))
    scene = world.draw_scene(np.random.default_rng(0))
    colours = ["green" if o.pushable else "red" for o in scene.objects]
    assert list(found.scene) == ["effector"] + [f"obj{i + 1} ({c})"
                                                 for i, c in enumerate(colours)]
    assert list(found.unseen) == [u.name for u in UNSEEN]
    probe = np.stack([learner.reader.visual_features(world.reset(scene=scene), i)
                      for i in range(len(world.layout.entities))])
    p = push.classifier.predict_proba(probe)
    assert list(found.scene.values()) == [round(float(v), 4) for v in p]
