"""The report's p_A column reads what `hadim affordances` shows: entities labelled with their
colour (`obj7 (red)`)."""

from __future__ import annotations

from hadim_cli.evaluation.tasks import load_task
from hadim_cli.report.tables import p_a_checks
from hadim_cli.reports import entity_label


def test_p_a_checks_read_the_labelled_entities_p_a_accepts():
    task = load_task("push-object")
    names = [f"obj{i + 1}" for i in range(len(task.scene.objects))]
    green = [n for n, o in zip(names, task.scene.objects, strict=True) if o.pushable]
    red = [n for n, o in zip(names, task.scene.objects, strict=True) if not o.pushable]
    assert green and red

    def labels(entities):
        return [entity_label(e, task.scene) for e in entities]

    assert p_a_checks(labels(green), task) == (True, True, True)
    assert p_a_checks(labels([*green, red[0]]), task) == (True, False, True)
    assert p_a_checks(labels([*green[1:], "robot"]), task) == (False, True, False)
    assert p_a_checks(None, task) is None
