"""The RL comparison as a sweep: `hadim sweep --algo …` plans the grid (combinations an
algorithm refuses are left out), runs it on Ray into one store with the same D as runs made one
by one, and `hadim report` writes the Fig. 5-like table and figure."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from hadim_cli.app import app
from hadim_cli.errors import HadimError
from hadim_cli.report.baselines import comparison_table, first_at, group_label, zone_share
from hadim_cli.sweep.plan import BaselineGrid, RunKind, build_plan
from hadim_store.api import Store
from hadim_store.records import Evaluation

PNG = b"\x89PNG\r\n\x1a\n"


def _plan(grid: BaselineGrid, **kw):
    args = {"configs": [], "grid": [], "sets": [], "seeds": "0-1", "iterations": 300,
            "eval_every": None, **kw}
    return build_plan("g", baselines=grid, **args)


def test_the_grid_is_every_combination_an_algorithm_takes():
    plan = _plan(BaselineGrid(("q-learning", "curious", "a2c"), ("push-with-tool",),
                              ("sparse", "guided"), ("discrete", "continuous")))
    labels = list(dict.fromkeys(e.label for e in plan.entries))
    assert labels == ["q-learning-sparse-push-with-tool", "q-learning-guided-push-with-tool",
                      "curious-sparse-push-with-tool", "a2c-sparse-push-with-tool",
                      "a2c-sparse-push-with-tool-continuous", "a2c-guided-push-with-tool",
                      "a2c-guided-push-with-tool-continuous"]
    assert len(plan.entries) == 2 * len(labels)
    assert [e.run for e in plan.entries[:2]] == ["g-q-learning-sparse-push-with-tool-s0",
                                                 "g-q-learning-sparse-push-with-tool-s1"]
    assert {e.kind for e in plan.entries} == {RunKind.BASELINE}
    assert {e.eval_every for e in plan.entries} == {1000}  # the paper's grid's period
    curious = next(e for e in plan.entries if e.label.startswith("curious"))
    assert curious.config["baseline"]["horizon"] == 300
    assert curious.config["baseline"]["params"]["her"]["n_sampled_goal"] == 4
    assert len(plan.left_out) == 5  # q-learning continuous × 2; curious continuous or guided × 3
    assert any(line.startswith("curious-guided-push-with-tool:") for line in plan.left_out)


def test_the_grid_with_the_learner_and_its_refusals(tmp_path):
    plan = _plan(BaselineGrid(("dqn",), ("move-robot",), ("sparse",)), configs=[None],
                 eval_every=1000)
    assert [e.kind for e in plan.entries] == [RunKind.TRAIN] * 2 + [RunKind.BASELINE] * 2
    for grid, match in ((BaselineGrid(("ppo",), ("move-robot",), ("sparse",)), "'ppo'"),
                        (BaselineGrid(("dqn",), ("fly",), ("sparse",)), "'fly'"),
                        (BaselineGrid(("curious",), ("move-robot",), ("guided",)), "curious")):
        with pytest.raises(HadimError, match=match):
            _plan(grid)
    with pytest.raises(HadimError, match="multiple of 20"):
        _plan(BaselineGrid(("dqn",), ("move-robot",), ("sparse",)), iterations=310)
    with pytest.raises(HadimError, match="--grid and --set"):
        _plan(BaselineGrid(("dqn",), ("move-robot",), ("sparse",)),
              sets=["learner.sigma=0"])
    store = tmp_path / "s.sqlite"
    result = CliRunner().invoke(app, ["sweep", "g", "--algo", "dqn,sac", "--task", "move-robot",
                                      "--store", str(store)])
    assert result.exit_code == 2
    assert result.stderr.strip().splitlines() == [
        "error: unknown algorithm 'sac' (known: q-learning, dqn, a2c, curious)"]
    assert not store.exists()


def _evaluation(it: int, score: float, finals: list[list[float]]) -> Evaluation:
    points = [{"target": [0.0, 0.0], "final": f, "contact_failed": False} for f in finals]
    return Evaluation(it, "move-robot", score, points, None)


def test_runs_are_grouped_as_the_paper_s_legend():
    def baseline(actions: str) -> dict:
        return {"kind": "baseline", "baseline": {"algorithm": "a2c", "reward": "guided",
                                                 "actions": actions}}

    assert group_label(baseline("discrete"), "rl-a2c-guided-push-object") == "a2c (guided)"
    assert group_label(baseline("continuous"), "x") == "a2c (guided, continuous)"
    assert group_label({"world": {}}, "default") == "hadim (default)"


def test_the_table_reads_when_each_group_learned():
    a = [_evaluation(1000, 0.5, [[0.5, 0], [0.05, 0]]), _evaluation(2000, 0.92, [[0.05, 0]] * 2)]
    b = [_evaluation(1000, 0.7, [[0.5, 0], [0.5, 0]]), _evaluation(2000, 0.86, [[0.09, 0]] * 2)]
    assert zone_share(a[0].points, 0.1) == 0.5
    assert first_at([1000, 2000], [[0.5, 0.7], [0.92, 0.86]], 0.9) is None  # mean 0.89
    assert first_at([1000, 2000], [[0.5, 0.7], [0.92, 0.92]], 0.9) == 2000
    table = comparison_table({"dqn (guided)": [a, b]}, 0.1).splitlines()
    assert table[2] == ("| dqn (guided) | move-robot | 2 | not reached | 1/2 | 2000 | "
                        "0.89 ± 0.03 (2000, n=2) | learned in 10k–20k (every algorithm) |")
    behind = [_evaluation(1000, 0.95, [[0.05, 0]] * 2)]  # a run of a sweep still running
    table = comparison_table({"dqn (guided)": [a, b, behind]}, 0.1).splitlines()
    assert table[2].startswith("| dqn (guided) | move-robot | 3 | not reached | 2/3 | "
                               "not reached | 0.72 ± 0.18 (1000, n=3) |")


@pytest.mark.filterwarnings("ignore::DeprecationWarning")
def test_sweep_runs_the_grid_like_one_by_one_and_reports_it(tmp_path):
    pytest.importorskip("ray")
    store = tmp_path / "s.sqlite"
    runner = CliRunner()
    result = runner.invoke(app, [
        "sweep", "rl", "--algo", "q-learning", "--task", "move-robot", "--reward", "sparse,guided",
        "--seeds", "0", "-n", "300", "--eval-every", "100", "--num-cpus", "2",
        "--store", str(store)])
    assert result.exit_code == 0, (result.output, result.exception)
    assert result.stdout.splitlines() == [
        "rl-q-learning-sparse-move-robot-s0\tfinished\t300/300",
        "rl-q-learning-guided-move-robot-s0\tfinished\t300/300"]
    one = runner.invoke(app, ["baseline", "train", "--algo", "q-learning", "--task", "move-robot",
                              "--reward", "guided", "-n", "300", "--eval-every", "100",
                              "--name", "ref", "--store", str(store)])
    assert one.exit_code == 0, one.output
    with Store.open(store, create=False) as st:
        run = "rl-q-learning-guided-move-robot-s0"
        assert st.dataset_sha256(run) == st.dataset_sha256("ref")
        assert st.dataset_sha256(run) != st.dataset_sha256("rl-q-learning-sparse-move-robot-s0")
        assert [(e.iteration, e.task) for e in st.evaluations(run)] == [
            (it, task) for it in (100, 200, 300) for task in ("move-robot", "move-robot@1000")]
    out = tmp_path / "report"
    report = runner.invoke(app, ["report", "rl", "--out", str(out), "--store", str(store)])
    assert report.exit_code == 0, (report.output, report.exception)
    assert sorted(p.name for p in out.iterdir()) == ["fig5.png", "summary.json", "tables.md"]
    assert (out / "fig5.png").read_bytes().startswith(PNG)
    tables = (out / "tables.md").read_text()
    assert "| q-learning (sparse) | move-robot | 1 |" in tables
    assert "| q-learning (guided) | move-robot | 1 |" in tables
    summary = json.loads((out / "summary.json").read_text())
    assert (summary["comparison"]["q-learning (guided)"]["move-robot"]["iterations"]
            == [100, 200, 300])
    assert summary["runs"][run]["baseline"]["reward"] == "guided"
    assert "both measures (score / episode success)" in tables  # issue 46
    assert summary["claims"]["move-robot"]["q-learning (guided)"][0]["iterations"] == [100, 200,
                                                                                    300]
