"""A user's first day (issue 15): results that cannot be silently wrong, fast read-only
commands, a damaged store refused in one line, readable output."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from hadim_cli.app import app
from hadim_cli.config import configs_dir
from hadim_store.api import Store

ROOT = Path(__file__).resolve().parents[1]
SMALL = ("--set", "world.episode_length=25", "--set", 'evaluation.tasks=["move-robot"]')


def invoke(*args: object, **kw):
    return CliRunner().invoke(app, [str(a) for a in args], **kw)


def ok(*args: object, **kw):
    result = invoke(*args, **kw)
    assert result.exit_code == 0, (args, result.output, result.exception)
    return result


def one_error_line(result, match: str = "") -> str:
    assert result.exit_code == 2, (result.exit_code, result.output, result.exception)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), result.stderr
    assert match in lines[0], lines[0]
    return lines[0]


@pytest.fixture(scope="module")
def store(tmp_path_factory) -> Path:
    """run-1: 100 iterations in episodes of 25, evaluated on move-robot at 50 and 100."""
    path = tmp_path_factory.mktemp("first-day") / "s.sqlite"
    ok("train", "-n", 100, "--eval-every", 50, *SMALL, "--store", path)
    return path


def task_file(tmp_path: Path, name: str, points: str, source: str = "move-robot") -> Path:
    """A copy of a built-in task with another name and other points."""
    text = (configs_dir() / "tasks" / f"{source}.toml").read_text()
    head, sep, tail = text.partition("points = ")
    path = tmp_path / f"{name}.toml"
    path.write_text(head.replace(f'name = "{source}"', f'name = "{name}"') + sep + points
                    + "\n" + tail.split("\n", 1)[1])
    return path


# --------------------------------------------------------------------------- 1. --points

def test_a_points_file_never_takes_a_built_in_tasks_name(store, tmp_path):
    easy = task_file(tmp_path, "push-with-tool", "[[0.3, 0.0], [0.0, 0.3]]")
    with Store.open(store, create=False) as st:
        before = [(e.iteration, e.score) for e in st.evaluations("run-1", "push-with-tool")]
    out = json.loads(ok("eval", "run-1", "--points", easy, "--json", "--store", store).stdout)
    assert out["task"] == "user:push-with-tool"
    table = ok("eval", "run-1", "--points", easy, "--store", store).stdout
    assert "user:push-with-tool" in table
    with Store.open(store, create=False) as st:
        assert [(e.iteration, e.score) for e in st.evaluations("run-1", "push-with-tool")] \
            == before
        assert len(st.evaluations("run-1", "user:push-with-tool")) == 2


@pytest.mark.parametrize(("points", "source", "match"), [
    ("[[10.0, 10.0]]", "move-robot", "outside the 4 x 4 m room"),
    ("[[1.9, 0.0]]", "move-robot", "outside the 4 x 4 m room"),     # the robot's radius
    ("[[1.55, -1.55]]", "move-robot", "inside the fixed object obj7"),
    ("[[0.0, 1.9]]", "push-object", "outside the 4 x 4 m room"),
])
def test_a_target_the_entity_cannot_reach_is_refused(store, tmp_path, points, source, match):
    path = task_file(tmp_path, "mine", points, source)
    with Store.open(store, create=False) as st:
        before = st.evaluations("run-1")
    one_error_line(invoke("eval", "run-1", "--points", path, "--store", store), match)
    with Store.open(store, create=False) as st:
        assert st.evaluations("run-1") == before


# --------------------------------------------------------------------------- 2. damage

def damaged_copy(store: Path, tmp_path: Path, start: float, stop: float) -> Path:
    """A copy of `store` with bytes [start, stop) of its length (fractions) overwritten."""
    copy = tmp_path / "damaged.sqlite"
    data = bytearray(store.read_bytes())
    a, b = int(len(data) * start), int(len(data) * stop)
    data[a:b] = bytes((7 * i + 3) % 251 for i in range(b - a))
    copy.write_bytes(bytes(data))
    return copy


@pytest.mark.parametrize("args", [
    ("eval", "run-1", "--task", "move-robot"),
    ("eval", "run-1", "--task", "move-robot", "--at", 50),
    ("fork", "run-1", "--at", 50),
    ("resume", "run-1", "-n", 150),
], ids=lambda a: " ".join(map(str, a)))
def test_a_damaged_store_is_never_written_into(store, tmp_path, args):
    copy = damaged_copy(store, tmp_path, 0.5, 0.52)
    before = copy.read_bytes()
    one_error_line(invoke(*args, "--store", copy), "is damaged")
    assert copy.read_bytes() == before
    assert not Path(f"{copy}-wal").exists() and not Path(f"{copy}-shm").exists()


def damaged_table(store: Path, tmp_path: Path, table: str) -> Path:
    """A copy of `store` whose table `table` has its root page overwritten with garbage."""
    import sqlite3

    with sqlite3.connect(f"{store.resolve().as_uri()}?mode=ro", uri=True) as con:
        root, = con.execute("SELECT rootpage FROM sqlite_master WHERE name = ?",
                            (table,)).fetchone()
        page_size, = con.execute("PRAGMA page_size").fetchone()
    copy = tmp_path / "damaged.sqlite"
    data = bytearray(store.read_bytes())
    start = (root - 1) * page_size
    data[start:start + page_size] = bytes((7 * i + 3) % 251 for i in range(page_size))
    copy.write_bytes(bytes(data))
    return copy


@pytest.mark.parametrize(("args", "table"), [
    (("runs", "show", "run-1"), "episodes"),
    (("affordances", "run-1", "--at", 50), "checkpoint_items"),
    (("affordances", "run-1", "--timeline"), "affordance_events"),
    (("plot", "run-1"), "evaluations"),
], ids=lambda a: " ".join(map(str, a)) if isinstance(a, tuple) else a)
def test_a_database_error_is_one_line(store, tmp_path, args, table):
    copy = damaged_table(store, tmp_path, table)
    one_error_line(invoke(*args, "--store", copy), "cannot be read")


def test_a_store_damaged_where_its_schema_is_read_is_refused_as_damaged(store, tmp_path):
    """SQLite's "malformed" while the store's own metadata is read is damage, not a foreign
    file: the same one-line refusal, nothing written, and `store check` names it (exit 1)."""
    copy = damaged_table(store, tmp_path, "meta")
    before = copy.read_bytes()
    one_error_line(invoke("resume", "run-1", "-n", 150, "--store", copy),
                   "run run-1 untouched: the store is damaged")
    assert copy.read_bytes() == before
    result = invoke("store", "check", "--store", copy)
    assert result.exit_code == 1, result.output
    assert "damaged" in result.stdout and "runs not read" in result.stdout


def test_a_database_errors_reason_is_its_first_line_without_the_rows_content():
    """What a damage line quotes of an error: its first line, without the text of the row
    SQLite could not decode, at most 60 characters (the last an ellipsis)."""
    from hadim_cli.runs import short_reason

    undecodable = ValueError("Could not decode to UTF-8 column 'x' with text 'secret row'\nmore")
    assert short_reason(undecodable) == "Could not decode to UTF-8 column 'x'"
    assert short_reason(ValueError("y" * 61)) == "y" * 59 + "…"
    assert short_reason(ValueError("y" * 60)) == "y" * 60


def test_store_check_names_what_is_damaged(store, tmp_path):
    sound = ok("store", "check", "--store", store).stdout
    assert "integrity_check ok" in sound and "run-1: readable (100 iterations" in sound
    copy = damaged_copy(store, tmp_path, 0.5, 0.52)
    result = invoke("store", "check", "--store", copy)
    assert result.exit_code == 1, result.output
    assert "damaged" in result.stdout and "integrity_check ok" not in result.stdout


def test_a_truncated_store_is_refused_without_litter(store, tmp_path):
    cut = tmp_path / "cut.sqlite"
    cut.write_bytes(store.read_bytes()[:20000])
    for args in (("runs", "list"), ("eval", "run-1", "--task", "move-robot")):
        one_error_line(invoke(*args, "--store", cut))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cut.sqlite"]


# --------------------------------------------------------------------------- 3. iterations

def test_every_score_says_the_iteration_it_was_measured_at(store):
    ok("fork", "run-1", "--name", "quiet", "--store", store)
    ok("resume", "quiet", "-n", 150, "--eval-every", 0, "--store", store)
    info = json.loads(ok("runs", "show", "quiet", "--json", "--store", store).stdout)
    assert info["iterations"] == 150
    assert info["scores"]["move-robot"]["iteration"] == 100
    assert 0.0 <= info["scores"]["move-robot"]["score"] <= 1.0
    table = ok("runs", "show", "quiet", "--store", store).stdout
    assert "at iteration 100" in table and "None" not in table and "{'" not in table


# --------------------------------------------------------------------------- 4. no torch

def test_reading_commands_do_not_import_torch(store):
    """`runs list`, `runs show`, the timeline and a misspelt name need no learner: importing
    torch alone takes seconds."""
    commands = [["runs", "list"], ["runs", "show", "run-1", "--json"], ["runs", "show", "nope"],
                ["affordances", "run-1", "--timeline", "--json"]]
    script = (
        "import json, sys\n"
        "from hadim_cli.app import main\n"
        "for args in json.loads(sys.argv[1]):\n"
        "    try:\n"
        f"        main(args + ['--store', {str(store)!r}])\n"
        "    except SystemExit:\n"
        "        pass\n"
        "    print('loaded:', 'torch' in sys.modules,\n"
        "          'hadim_cli.learner.explorer' in sys.modules)\n")
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    out = subprocess.run([sys.executable, "-c", script, json.dumps(commands)],
                         capture_output=True, text=True, env=env, check=True).stdout
    loaded = [line for line in out.splitlines() if line.startswith("loaded:")]
    assert loaded == ["loaded: False False"] * len(commands), out


# --------------------------------------------------------------------------- 7. readable

def test_tables_keep_space_names_whole_at_80_columns(store):
    env = {"COLUMNS": "80"}
    rows = json.loads(ok("affordances", "run-1", "--json", "--store", store).stdout)
    table = ok("affordances", "run-1", "--store", store, env=env).stdout
    events = json.loads(ok("affordances", "run-1", "--timeline", "--json", "--store",
                           store).stdout)
    timeline = ok("affordances", "run-1", "--timeline", "--store", store, env=env).stdout
    assert "…" not in table + timeline
    words = {w for line in table.splitlines() + timeline.splitlines() for w in line.split()}
    for r in rows:
        assert {r["input"], r["output"], *r["context"]} <= words, r
    for e in events:
        assert {e["input"], e["output"], *e["context"]} <= words, e
        assert "added: ," not in timeline and "(added" not in timeline


def test_event_text_reads_as_a_change():
    from hadim_cli.reports import event_text

    assert event_text("context_replaced", {"added": ["tool.position"],
                                           "removed": ["robot.lidar"]}) \
        == "context replaced +tool.position −robot.lidar"
    assert event_text("context_removed", {"added": [], "removed": ["robot.lidar"]}) \
        == "context removed −robot.lidar"
    assert event_text("created", {}) == "created"


def test_p_a_names_objects_with_their_colour():
    from hadim_cli.evaluation.tasks import load_task
    from hadim_cli.reports import entity_label

    scene = load_task("push-object").scene
    labels = [entity_label(f"obj{i + 1}", scene) for i in range(len(scene.objects))]
    assert labels[0] == "obj1 (green)" and "obj7 (red)" in labels
    assert entity_label("robot", scene) == "robot"
    assert sum(label.endswith("(red)") for label in labels) == sum(
        not o.pushable for o in scene.objects)


def test_config_show_gives_every_meaning_whole():
    import dataclasses

    from hadim_cli.config import Config, field_docs, load_config

    resolved = load_config()
    wide = ok("config", "show", env={"COLUMNS": "1000"}).stdout
    tables = [(section.name, getattr(resolved, section.name))
              for section in dataclasses.fields(Config)]
    for name, values in tables:
        for key, doc in field_docs(type(values)).items():
            assert " ".join(doc.split()) in wide, f"{name}.{key}"
            if dataclasses.is_dataclass(getattr(values, key)):
                tables.append((f"{name}.{key}", getattr(values, key)))


def test_outputs_say_what_they_wrote_and_name_the_run(store, tmp_path):
    png = tmp_path / "t.png"
    out = ok("affordances", "run-1", "--timeline", "--out", png, "--store", store).stdout
    assert f"wrote {png}" in out and png.read_bytes().startswith(b"\x89PNG")
    as_json = ok("affordances", "run-1", "--timeline", "--out", png, "--json", "--store", store)
    json.loads(as_json.stdout)
    assert f"wrote {png}" in as_json.stderr


def test_version_and_help_without_type_markers():
    from hadim_cli import __version__

    assert ok("--version").stdout.strip() == f"hadim {__version__}"
    for command in (["train"], ["affordances"], ["eval"], ["runs", "show"], ["config", "show"],
                    ["store", "check"]):
        text = ok(*command, "--help", env={"COLUMNS": "120"}).stdout
        assert "<bool>" not in text and "<list[str]>" not in text and "<int range>" not in text


# --------------------------------------------------------------------------- 9. package

def test_the_wheel_lists_every_package_and_ships_the_configs():
    """pyproject.toml names the packages one by one (configs/ is mapped into the wheel as
    hadim_cli/configs), so a new subpackage must be added there: this test says which."""
    import tomllib

    project = tomllib.loads((ROOT / "pyproject.toml").read_text())
    setup = project["tool"]["setuptools"]
    on_disk = {".".join(p.parent.relative_to(ROOT).parts)
               for top in ("hadim_cli", "store") for p in (ROOT / top).rglob("__init__.py")}
    installed = {"hadim_store" + name[len("store"):] if name.startswith("store") else name
                 for name in on_disk}
    assert installed | {"hadim_cli.configs"} == set(setup["packages"])
    assert setup["package-dir"] == {"hadim_cli.configs": "configs", "hadim_store": "store"}
    data = setup["package-data"]["hadim_cli.configs"]
    shipped = {p.relative_to(ROOT / "configs") for pattern in data
               for p in (ROOT / "configs").glob(pattern)}
    assert shipped == {p.relative_to(ROOT / "configs")
                       for p in (ROOT / "configs").rglob("*.toml")}
    assert not any("scikit" in d for d in project["project"]["dependencies"])


def test_an_installed_package_reads_its_shipped_configs(tmp_path, monkeypatch):
    """Without a checkout's configs/ beside the package, configs come from the package data."""
    import shutil

    from hadim_cli import config

    site = tmp_path / "site" / "hadim_cli"
    (site / "configs").mkdir(parents=True)
    shutil.copytree(ROOT / "configs", site / "configs", dirs_exist_ok=True)
    shutil.copy(config.__file__, site / "config.py")
    monkeypatch.setattr(config, "__file__", str(site / "config.py"))
    monkeypatch.setattr(config.resources, "files", lambda package: site)
    monkeypatch.delenv(config.CONFIG_DIR_ENV, raising=False)
    assert config.configs_dir() == site / "configs"
    assert config.load_config().evaluation.tasks


# --------------------------------------------------------------------------- 5. progress

def test_resume_without_a_terminal_reports_progress_and_a_summary(store):
    ok("fork", "run-1", "--name", "told", "--store", store)
    result = ok("resume", "told", "-n", 150, "--eval-every", 50, "--store", store)
    lines = result.stderr.splitlines()
    progress = [line for line in lines if line.startswith("told: ") and "/150 iterations" in line]
    assert progress and progress[-1].startswith("told: 150/150 iterations")
    assert "ETA" in progress[0]
    text = result.stderr
    assert "told: finished at iteration 150 (50 trained in" in text
    assert "move-robot" in text and "at 150" in text and "affordances:" in text
    assert f"store: {store}" in text and "hadim runs show told --store" in text


def test_the_progress_bar_shows_an_eta():
    import io

    from rich.console import Console

    from hadim_cli.progress import Reporter
    from hadim_cli.runs import Progress

    reporter = Reporter("run-9", 0, 400)
    reporter.console = Console(file=io.StringIO(), force_terminal=True, width=160)
    reporter.terminal = True
    with reporter:
        reporter.update(Progress(200, 400, 3, {"move-robot": 0.5}, 200))
    out = reporter.console.file.getvalue()
    assert "ETA" in out and "200/400" in out and "move-robot=0.50 (at 200)" in out


# --------------------------------------------------------------------------- 6. Ctrl-C | tee

def test_ctrl_c_with_a_dead_pipe_still_tells_how_to_resume(tmp_path):
    """`hadim train 2>&1 | tee log`, Ctrl-C: tee dies of the same signal. The run pauses, the
    resume command reaches the terminal, and the exit status is the documented 130."""
    import pty
    import signal
    import time

    path = tmp_path / "s.sqlite"
    read_end, write_end = os.pipe()
    pid, terminal = pty.fork()
    if pid == 0:  # the child: stdout and stderr into the pipe, the pty as its terminal
        os.dup2(write_end, 1)
        os.dup2(write_end, 2)
        os.environ["PYTHONPATH"] = str(ROOT)
        os.execv(sys.executable, [sys.executable, "-m", "hadim_cli.app", "train", "-n",
                                  "100000", "--eval-every", "0", *SMALL, "--store", str(path)])
    os.close(write_end)
    seen = b""
    while b"training from" not in seen:  # the loop has started
        chunk = os.read(read_end, 4096)
        assert chunk, seen
        seen += chunk
    os.close(read_end)  # tee is gone
    time.sleep(0.2)
    os.kill(pid, signal.SIGINT)
    said = b""
    while True:
        try:
            chunk = os.read(terminal, 4096)
        except OSError:  # EIO: the child closed the terminal
            break
        if not chunk:
            break
        said += chunk
    _, status = os.waitpid(pid, 0)
    assert os.WEXITSTATUS(status) == 130, (status, said)
    text = said.decode()
    assert "paused at iteration" in text and f"hadim resume run-1 --store {path}" in text
    assert "run-1: paused at iteration" in text  # the summary follows it
    with Store.open(path, create=False) as st:
        assert st.get_run("run-1").status.value == "paused"


# --------------------------------------------------------------------------- 8. docs

def test_docs_cite_only_what_the_repository_holds():
    """A page cites files the checkout holds; what left docs/ for the repository's history
    (docs/notes.md, the experiment notes) is named only in the `git log` that shows it."""
    import re

    pages = [ROOT / "README.md", *(ROOT / "docs").rglob("*.md")]
    texts = {str(p.relative_to(ROOT)): p.read_text() for p in pages}
    for name, text in texts.items():
        assert not re.search(r"\bissue #?\d+", text), name
        text = re.sub(r"git log [^`)\n]*", "", text)
        for path in re.findall(r"\b(?:docs|scripts|configs|tests|hadim_cli|store)/"
                               r"[A-Za-z0-9_./-]+\.(?:md|py|toml|png|json)", text):
            assert (ROOT / path).exists(), (name, path)


def test_the_docs_say_where_the_project_stands_not_how_it_got_there():
    """docs/ is user documentation: a start page; results and performance without dated
    history or one machine's paths."""
    import re

    index = (ROOT / "docs" / "index.md").read_text()
    for page in ("cli.md", "results.md", "performance.md", "algorithm.md", "store.md"):
        assert f"]({page})" in index, page
    assert not (ROOT / "docs" / "notes.md").exists()
    for page in ("results.md", "performance.md", "index.md", "cli.md"):
        text = (ROOT / "docs" / page).read_text()
        assert not re.search(r"\b20\d\d-\d\d-\d\d\b", text), page
        assert not re.search(r"\b(?:\w+-)?\w+(?:st|nd|rd|th) (?:tool-use |perf )?session\b",
                             text.split("\n## ", 1)[-1][:3000]), page  # "where we stand"
        assert not re.search(r"(?<![\w.])/(?:work|tmp|home)/", text), page
    # Where results and performance stand, not the sittings they were measured in.
    history = re.compile(r"\b\w+(?:st|nd|rd|th) (?:tool-use |perf )?session|\bthis (?:session|"
                         r"branch)\b|\btoday\b|\bsitting|\b\d\d?:\d\d\b|\bUTC\b", re.I)
    for page in ("results.md", "performance.md"):
        found = history.findall((ROOT / "docs" / page).read_text())
        assert not found, (page, found)


def test_reproducing_the_paper_is_described_by_sweep_and_report():
    """The README says how to reproduce the paper's figures, with the commands that do it, and
    their --help describes every option."""
    from typer.testing import CliRunner

    from hadim_cli.app import app

    for command in ("sweep", "report"):
        out = CliRunner().invoke(app, [command, "--help"], terminal_width=200).stdout
        options = [line for line in out.splitlines() if line.strip().lstrip("│ ").startswith("--")]
        assert options, out
        for line in options:  # each option's row carries a description after its name
            assert len(line.strip("│ ").split()) >= 2, f"{command}: {line.strip()}"
    readme = (ROOT / "README.md").read_text()
    assert "hadim sweep paper" in readme and "hadim report paper" in readme
    assert "docs/figures" in readme


def test_figures_name_the_run_and_tell_input_from_context(store, tmp_path):
    from hadim_cli.plots import competence_figure, timeline_figure

    with Store.open(store, create=False) as st:
        evaluations, events = st.evaluations("run-1"), st.events("run-1")
    curves = competence_figure({"run-1": evaluations}, tmp_path / "c.png", title="run run-1")
    assert "run-1" in curves.axes[0].get_title()
    timeline = timeline_figure(events, 100, tmp_path / "t.png", title="run run-1: timeline")
    ax = timeline.axes[0]
    assert "run-1" in ax.get_title()
    inputs = [p for p in ax.patches if not p.get_hatch()]
    contexts = [p for p in ax.patches if p.get_hatch()]
    assert inputs and contexts  # run-1 has affordances with contexts by iteration 100
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert {e.input_space for e in events} | {c for e in events for c in e.context} \
        <= set(legend)


def test_no_module_imports_the_store_by_its_folder_name():
    """The store installs as `hadim_store` (pyproject.toml's package-dir): an import of a bare
    `store` works in the checkout only, and would fail (or find another distribution's
    `store`) once installed."""
    import ast

    wrong = []
    for top in ("hadim_cli", "store", "tests", "scripts"):
        for path in (ROOT / top).rglob("*.py"):
            for node in ast.walk(ast.parse(path.read_text())):
                names = ([a.name for a in node.names] if isinstance(node, ast.Import)
                         else [node.module or ""] if isinstance(node, ast.ImportFrom)
                         and node.level == 0 else [])
                wrong += [f"{path.relative_to(ROOT)}: {n}" for n in names
                          if n == "store" or n.startswith("store.")]
    assert not wrong, wrong
