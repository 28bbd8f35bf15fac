"""A newcomer's first hour: the design card's commands as written, output that fits 80
columns, refusals before restoring, damage found wherever it is read, one-line messages.

These run the installed `hadim` command in a process of its own, as a user does.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import sqlite3
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from hadim_store.api import Store
from hadim_store.reader import quick_check

ROOT = Path(__file__).resolve().parents[1]
HADIM = shutil.which("hadim", path=str(Path(sys.executable).parent)) or "hadim"
SMALL = ("--set", "world.episode_length=25", "--set", 'evaluation.tasks=["move-robot"]')


def hadim(*args: object, store: Path | None = None, cwd: Path | None = None,
          env: dict | None = None) -> subprocess.CompletedProcess:
    """The installed command; with `store`, named by HADIM_STORE (the usages as written)."""
    environ = {k: v for k, v in os.environ.items() if k not in ("HADIM_STORE", "COLUMNS")}
    if store is not None:
        environ["HADIM_STORE"] = str(store)
    environ.update(env or {})
    return subprocess.run([HADIM, *map(str, args)], capture_output=True, text=True,
                          cwd=cwd, env=environ, timeout=600)


def ok(*args: object, **kw) -> subprocess.CompletedProcess:
    result = hadim(*args, **kw)
    assert result.returncode == 0, (args, result.stdout, result.stderr)
    return result


def one_error(result: subprocess.CompletedProcess, match: str = "", code: int = 2) -> str:
    assert result.returncode == code, (result.returncode, result.stdout, result.stderr)
    lines = result.stderr.strip().splitlines()
    errors = [line for line in lines if line.startswith("error: ")]
    assert len(errors) == 1 and "Traceback" not in result.stderr, result.stderr
    assert match in errors[0], errors[0]
    return errors[0]


@pytest.fixture(scope="module")
def store(tmp_path_factory) -> Path:
    """run-1: 100 iterations in episodes of 25, evaluated on move-robot at 50 and 100."""
    path = tmp_path_factory.mktemp("newcomer") / "s.sqlite"
    ok("train", "-n", 100, "--eval-every", 50, *SMALL, "--store", path)
    return path


# --------------------------------------------------------------------------- 1. the card

def test_the_design_cards_usages_work_as_written(store, tmp_path):
    """`hadim affordances --timeline`, `hadim eval --task push-with-tool`: no run named, the
    store's most recent is used and named on stderr."""
    ok("fork", "run-1", "--at", 50, "--name", "newer", store=store)  # the most recent now
    for args in (("affordances", "--timeline"), ("affordances",), ("runs", "show"),
                 ("eval", "--task", "move-robot"), ("plot", "--out", tmp_path / "c.png")):
        result = ok(*args, store=store)
        assert "run newer (the store's most recent" in result.stderr, (args, result.stderr)
    table = ok("eval", "--task", "push-with-tool", store=store).stdout
    assert "push-with-tool at iteration 50: score" in table


def test_an_empty_store_says_there_is_no_run_and_how_to_make_one(tmp_path):
    empty = tmp_path / "empty.sqlite"
    Store.open(empty).close()
    for args in (("affordances", "--timeline"), ("eval", "--task", "push-with-tool"),
                 ("plot",), ("runs", "show")):
        line = one_error(hadim(*args, store=empty), "no run in")
        assert "hadim train" in line
    one_error(hadim("affordances", store=tmp_path / "none.sqlite"), "hadim train")


def test_resume_continues_to_the_iterations_the_run_was_started_for(store):
    ok("fork", "run-1", "--at", 50, "--name", "half", store=store)
    ok("resume", "half", "--eval-every", 0, store=store)
    info = json.loads(ok("runs", "show", "half", "--json", store=store).stdout)
    assert info["iterations"] == 100 and info["status"] == "finished"


def test_resume_of_a_finished_run_says_so_and_how_to_go_further(store):
    line = one_error(hadim("resume", "run-1", store=store), "run-1 is finished at 100")
    assert "hadim resume run-1 --iterations 200" in line
    line = one_error(hadim("resume", "run-1", "-n", 60, store=store), "already has 100")
    assert "--iterations 200" in line


# --------------------------------------------------------------------------- 2. fast refusals

HEAVY = ("torch", "pymunk", "sklearn", "scipy", "matplotlib", "hadim_cli.learner.models",
         "sqlalchemy")
"""What a command that needs no learner must not import: the learner and its libraries take
seconds, SQLAlchemy half of one (a sound store file is read with sqlite3, hadim_store.reader)."""


def _imports(store: Path, commands: list[list[str]], held: str | None = None
             ) -> tuple[list[str], str]:
    """Each command run in turn by one process, against `store` with run `held` locked by
    a live process: per command, its exit status and which of HEAVY it had imported by its
    end (a line `loaded: CODE [...]`); and all that was said on stderr."""
    script = (
        "import json, sys\n"
        "from hadim_cli.app import main\n"
        "for args in json.loads(sys.argv[1]):\n"
        "    try:\n"
        f"        main(args + ['--store', {str(store)!r}])\n"
        "    except SystemExit as exit:\n"
        "        code = exit.code\n"
        f"    print('loaded:', code, [m for m in {HEAVY!r} if m in sys.modules])\n")
    owner = f"{os.uname().nodename}:{os.getpid()}"
    if held is not None:
        with Store.open(store, create=False) as st:
            st.acquire_lock(held, owner)  # held by this live process
    try:
        out = subprocess.run([sys.executable, "-c", script, json.dumps(commands)],
                             capture_output=True, text=True, check=True)
    finally:
        if held is not None:
            with Store.open(store, create=False) as st:
                st.release_lock(held, owner)
    return [line for line in out.stdout.splitlines() if line.startswith("loaded:")], \
        out.stdout + out.stderr


def test_refusals_and_h_need_no_learner(store, tmp_path):
    """What does not need the learner never imports it, nor SQLAlchemy: H's table, the runs, and
    the refusals of an unknown run, a finished run, a run in use, a target outside the room,
    a task file that does not parse. docs/performance.md measures their times."""
    bad = tmp_path / "bad.toml"
    text = (ROOT / "configs" / "tasks" / "move-robot.toml").read_text()
    bad.write_text(re.sub(r"points = \[.*?\]\]", "points = [[9.0, 9.0]]", text, flags=re.S))
    broken = tmp_path / "broken.toml"
    broken.write_text("points = [[")
    ok("fork", "run-1", "--at", 50, "--name", "held", store=store)
    commands = [["affordances", "run-1"], ["affordances", "run-1", "--json"],
                ["affordances", "run-1", "--at", "50"], ["runs", "list"], ["affordances", "rnu-1"],
                ["resume", "run-1"], ["resume", "rnu-1"], ["resume", "held", "-n", "200"],
                ["eval", "run-1", "--points", str(bad)], ["eval", "run-1", "--points", str(broken)],
                ["eval", "rnu-1", "--points", str(bad)]]
    loaded, said = _imports(store, commands, "held")
    assert loaded == [f"loaded: {0 if i < 4 else 2} []" for i in range(len(commands))], said
    for words in ("is outside the", "is finished at", "is in use", "not valid TOML",
                  "did you mean run-1"):
        assert words in said, said


def test_reading_a_run_needs_no_sqlalchemy(store, tmp_path):
    """`runs show`, the timeline, `plot` and the refusals of `bench eval` read a sound store
    file with sqlite3 alone: none imports SQLAlchemy or the learner (the figures are drawn
    with matplotlib, last here)."""
    commands = [["runs", "show", "run-1"], ["runs", "show", "--json"],
                ["affordances", "run-1", "--timeline"],
                ["affordances", "run-1", "--timeline", "--at", "50", "--json"],
                ["bench", "eval", "run-1", "--at", "1000"],
                ["affordances", "--timeline", "--out", str(tmp_path / "t.png")],
                ["plot", "run-1", "--out", str(tmp_path / "c.png")]]
    loaded, said = _imports(store, commands)
    assert loaded == ["loaded: 0 []"] * 4 + ["loaded: 2 []"] + \
        ["loaded: 0 ['matplotlib']"] * 2, said


@pytest.mark.parametrize("args", [
    ("runs", "show", "run-1"), ("runs", "show", "run-1", "--json"), ("runs", "list", "--json"),
    ("affordances", "run-1", "--timeline"), ("affordances", "run-1", "--timeline", "--json"),
    ("affordances", "run-1", "--json"), ("affordances", "run-1", "--timeline", "--out", "{png}"),
    ("plot", "run-1", "--out", "{png}")])
def test_the_light_reader_and_the_store_answer_alike(store, tmp_path, monkeypatch, args):
    """What a read command prints (and draws) is the same whether the file was read with
    sqlite3 alone or through the full store (as an older schema or a server is)."""
    from typer.testing import CliRunner

    from hadim_cli import runs
    from hadim_cli.app import app

    answers = []
    for light in (True, False):
        png = tmp_path / f"{light}.png"
        if not light:
            monkeypatch.setattr(runs, "light_reader", lambda option: None)
        result = CliRunner().invoke(app, [a.format(png=png) for a in args] +
                                    ["--store", str(store)])
        assert result.exit_code == 0, (result.stderr, result.exception)
        answers.append((result.stdout.replace(str(png), "PNG"),
                        png.read_bytes() if png.exists() else None))
    assert answers[0] == answers[1], args


def test_a_baseline_runs_refusals_need_no_agent(store, tmp_path):
    """A baseline run's refusals are read with sqlite3 alone, before its agent (torch,
    stable-baselines3) or the world's physics is imported: resume of a finished run, of a
    total or period its steps do not divide, of a run in use; eval on a task of another
    kind, a target outside the room or a learner's diagnostic; fork; diagnose of a learner's
    run or an unknown one."""
    outside = tmp_path / "outside.toml"
    text = (ROOT / "configs" / "tasks" / "move-robot.toml").read_text()
    outside.write_text(re.sub(r"points = \[.*?\]\]", "points = [[1.0, 9.0]]", text, flags=re.S))
    both = tmp_path / "both.sqlite"
    shutil.copy(store, both)
    ok("baseline", "train", "--algo", "q-learning", "--task", "move-robot", "-n", 40,
       "--eval-every", 0, "--name", "base", "--store", both)
    commands = [["resume", "base"], ["resume", "base", "-n", "20"], ["resume", "base", "-n", "50"],
                ["resume", "base", "-n", "80", "--eval-every", "30"],
                ["resume", "base", "-n", "80"], ["eval", "base", "--task", "push-object"],
                ["eval", "base", "--task", "reach-pose"],
                ["eval", "base", "--points", str(outside)],
                ["eval", "base", "--task", "move-robot", "--animate", str(tmp_path / "a.gif")],
                ["fork", "base"], ["baseline", "diagnose", "run-1"],
                ["baseline", "diagnose", "bsae"]]
    loaded, said = _imports(both, commands, "base")
    assert loaded == ["loaded: 2 []"] * len(commands), said
    for words in ("is finished at 40", "already has 40", "of 20 for this baseline run, got 50",
                  "--eval-every must be a multiple of 20", "is in use", "this run learned",
                  "asks for headings", "point (1, 9) is outside", "--animate and --exact",
                  "fork is for the learner", "run-1 is a learner run", "did you mean base"):
        assert words in said, (words, said)


def test_a_new_runs_refusals_need_no_learner_nor_agent(store, tmp_path):
    """`train`, `fork` and `baseline train` refuse, before importing the learner, an agent or
    SQLAlchemy: a name taken or malformed, a directory for a store, an unknown config key,
    an evaluation period episodes do not divide, an algorithm, task or combination the
    comparison lacks, a total or period a baseline's steps do not divide."""
    q = ["baseline", "train", "--algo", "q-learning", "--task", "move-robot"]
    commands = [["train", "--name", "run-1"], ["train", "--name", "a b"],
                ["train", "--set", "nope.x=1"], ["train", "--eval-every", "30"],
                ["fork", "run-1", "--name", "run-1"], [*q, "--name", "run-1"],
                ["baseline", "train", "--algo", "nope", "--task", "move-robot"],
                ["baseline", "train", "--algo", "q-learning", "--task", "nope"],
                [*q, "--actions", "continuous"], [*q, "-n", "1010"],
                ["baseline", "train", "--algo", "dqn", "--task", "move-robot", "--eval-every",
                 "30"]]
    loaded, said = _imports(store, commands)
    assert loaded == ["loaded: 2 []"] * len(commands), said
    for words in ("'run-1' already exists", "invalid run name 'a b'", "unknown config key",
                  "multiple of the episode length", "unknown algorithm 'nope'",
                  "unknown task 'nope'", "needs --actions discrete", "got 1010",
                  "--eval-every must be a multiple of 20"):
        assert words in said, (words, said)
    loaded, said = _imports(tmp_path, [["train"], q])
    assert loaded == ["loaded: 2 []"] * 2 and said.count("is a directory") == 2, said


# --------------------------------------------------------------------------- 3. 80 columns

def _assert_fits(text: str, width: int = 80) -> None:
    lines = text.splitlines()
    assert lines and max(map(len, lines)) <= width, "\n".join(lines)
    assert "…" not in text, text


def test_tables_fit_80_columns_in_a_pipe_without_cutting_what_matters(store):
    ok("fork", "run-1", "--name", "paper-goal-babbling-only-s4", store=store)
    listing = ok("runs", "list", store=store).stdout  # a pipe: 80 columns
    _assert_fits(listing)
    with Store.open(store, create=False) as st:
        records = st.list_runs()
    for r in records:
        row = next(line for line in listing.splitlines() if f" {r.name} " in line)
        assert r.status.value in row and f" {r.iterations} " in row, row
    wide = ok("runs", "list", "--wide", store=store).stdout
    assert "run-1@100" in wide and "seed" in wide
    timeline = ok("affordances", "run-1", "--timeline", store=store).stdout
    _assert_fits(timeline)
    table = [line for line in timeline.splitlines() if line[:1] in "┃│┏┡└"]
    assert table and all(line[-1] in "┃│┓┩┘" for line in table), timeline  # borders kept
    h = ok("affordances", "run-1", store=store).stdout
    _assert_fits(h)
    accepts = h.split("p_A on the push-object scene's objects", 1)[1].splitlines()[1:]
    for line in accepts:  # a wrapped list of objects is indented under the first
        assert line.startswith("  A") or line.startswith(" " * 12), accepts
    _assert_fits(ok("eval", "run-1", "--task", "move-robot", store=store).stdout)
    _assert_fits(ok("runs", "show", "run-1", store=store).stdout)


# --------------------------------------------------------------------------- 4. damage

READS = [("runs", "list"), ("runs", "show", "run-1"), ("affordances", "run-1"),
         ("affordances", "run-1", "--timeline"), ("plot", "run-1", "--out", "{png}"),
         ("eval", "run-1", "--task", "move-robot")]


@pytest.mark.parametrize("offset", [0.15, 0.3, 0.45, 0.6, 0.75, 0.9])
def test_damage_is_found_wherever_it_is_read(store, tmp_path, offset):
    """8 KB of garbage at one offset of the file: on a run that `hadim store check` calls
    damaged, every read is one short line naming it and a non-zero exit, never a silent 0."""
    copy = tmp_path / "d.sqlite"
    data = bytearray(store.read_bytes())
    a = int(len(data) * offset)
    data[a:a + 8192] = bytes((37 * i + 11) % 256 for i in range(len(data[a:a + 8192])))
    copy.write_bytes(bytes(data))
    check = hadim("store", "check", "--store", copy)
    damaged = check.returncode != 0 and "run-1: readable" not in check.stdout
    for args in READS:
        args = tuple(str(a).format(png=tmp_path / "c.png") for a in args)
        result = hadim(*args, "--store", copy)
        assert "Traceback" not in result.stderr, (args, result.stderr)
        if damaged:
            line = one_error(result, code=result.returncode)
            assert result.returncode != 0, (args, result.stdout, result.stderr)
            # `runs list` names no run when the file is damaged where the runs are listed
            named = "run-1" in line or (args[0] == "runs" and "store is damaged" in line)
            assert named and len(line) <= 200, (args, line)
            assert "{" not in line and "with text" not in line, line  # no row content
        else:
            assert result.returncode == 0 or len(result.stderr.strip().splitlines()) == 1, \
                (args, result.stderr)


def _craft(store: Path, copy: Path, column: str, damage: str) -> None:
    """A copy of `store` whose run-1 has one value of `column` replaced, in a row that is
    otherwise valid: random bytes, the value cut short, or (H) a table that is not H's.
    `model`: the largest array of its latest checkpoint (a model's weights); `state`: that
    checkpoint's JSON of the learner; `h`: its last episode's record, where H's table is
    kept."""
    shutil.copy(store, copy)
    con = sqlite3.connect(copy)
    latest = ("SELECT c.id FROM checkpoints c JOIN runs r ON r.id = c.run_id "
              "WHERE r.name = 'run-1' ORDER BY c.iteration DESC LIMIT 1")
    where, field, value = {
        "model": lambda: ("checkpoint_items", "data", con.execute(
            f"SELECT id, data FROM checkpoint_items WHERE checkpoint_id = ({latest}) AND "
            "data IS NOT NULL ORDER BY length(data) DESC LIMIT 1").fetchone()),
        "state": lambda: ("checkpoint_items", "text", con.execute(
            f"SELECT id, text FROM checkpoint_items WHERE checkpoint_id = ({latest}) AND "
            "key = 'learner'").fetchone()),
        "h": lambda: ("episodes", "extra_json", con.execute(
            "SELECT e.id, e.extra_json FROM episodes e JOIN runs r ON r.id = e.run_id WHERE "
            "r.name = 'run-1' ORDER BY e.episode_index DESC LIMIT 1").fetchone()),
    }[column]()
    row, old = value
    old = old.encode() if isinstance(old, str) else old
    new = {"random bytes": lambda: np.random.default_rng(7).bytes(len(old)),
           "cut short": lambda: old[:len(old) - max(3, len(old) // 3)],
           "another table": lambda: json.dumps({"hierarchy": [{"id": 0}]}).encode()}[damage]()
    con.execute(f"UPDATE {where} SET {field} = ? WHERE id = ?",
                (new if damage == "random bytes" or field == "data" else new.decode(), row))
    con.commit()
    con.close()


@pytest.mark.parametrize(("column", "damage"), [
    (column, damage) for column in ("model", "state", "h")
    for damage in ("random bytes", "cut short")] + [("h", "another table")])
def test_a_crafted_value_is_one_line_wherever_affordances_reads_it(store, tmp_path, column,
                                                                 damage):
    """A row SQLite finds sound (the file passes its checks) whose value does not decode:
    `affordances RUN` reads H's table and the checkpoint it stands for, and says in one line
    that the run cannot be read, never exit 0 over a run that resume and eval would refuse."""
    copy = tmp_path / "crafted.sqlite"
    _craft(store, copy, column, damage)
    assert quick_check(copy) == []  # a sound file: only the value is wrong
    for args in (("affordances", "run-1"), ("affordances", "run-1", "--json")):
        result = hadim(*args, "--store", copy)
        line = one_error(result)
        assert "run run-1 cannot be read" in line and len(line) <= 200, line
        assert "{" not in line and "with text" not in line, line  # no row content
        assert not result.stdout, result.stdout


# --------------------------------------------------------------------------- 5. the figure

def test_the_timeline_figure_stays_legible_with_many_affordances(tmp_path):
    from hadim_cli.plots import timeline_figure
    from hadim_store.records import AffordanceEvent

    spaces = ["robot.position", "robot.heading", "target.position", "target-robot",
              "tool.position", "target-tool", "target.radius", "target.height", "action"]
    events = []
    for aid in range(24):
        for k in range(6):  # a context change every 30 iterations
            context = tuple(spaces[(aid + k + j) % len(spaces)] for j in range(1 + k % 3))
            events.append(AffordanceEvent(400 + 30 * k + aid, aid, "created" if k == 0 else
                                          "context_replaced", spaces[aid % len(spaces)],
                                          "target.position", context, 0.5, {}))
    fig = timeline_figure(events, 4000, tmp_path / "t.png", title="run x: timeline")
    assert (tmp_path / "t.png").read_bytes().startswith(b"\x89PNG")
    ax = fig.axes[0]
    assert ax.get_xlabel() and ax.get_ylabel() and ax.get_title()
    legend = ax.get_legend()
    assert legend is not None and set(spaces) <= {t.get_text() for t in legend.get_texts()}
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    renderer = FigureCanvasAgg(fig).get_renderer()
    fig.draw(renderer)
    texts = [t for t in [*ax.get_yticklabels(), *ax.get_xticklabels(), *ax.texts,
                         *legend.get_texts(), ax.title, ax.xaxis.label, ax.yaxis.label]
             if t.get_text() and t.get_visible()]
    boxes = [t.get_window_extent(renderer) for t in texts]
    for i, a in enumerate(boxes):
        for j in range(i + 1, len(boxes)):
            assert not a.overlaps(boxes[j]), (texts[i].get_text(), texts[j].get_text())


# --------------------------------------------------------------------------- 6. messages

def test_unknown_options_and_commands_are_one_line():
    for args in (("runs", "list", "--bogus"), ("bogus",), ("runs", "bogus"),
                 ("train", "--iterations", "x")):
        result = hadim(*args)
        one_error(result)
        assert "╭" not in result.stderr and "Usage:" not in result.stderr, result.stderr


def test_eval_help_lists_every_exact_level():
    from hadim_cli.evaluation.exact import LEVELS

    text = " ".join(ok("eval", "--help", env={"COLUMNS": "200"}).stdout.split())
    exact = text.split("--exact", 1)[1]
    assert all(level in exact[:400] for level in LEVELS), exact[:400]


def test_messages_name_things_as_the_other_commands_do(store, tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("points = [[")
    assert "task file" in one_error(hadim("eval", "run-1", "--points", bad, store=store))
    for args in (("store", "check"), ("runs", "list")):
        one_error(hadim(*args, "--store", tmp_path), "is a directory")


def test_the_printed_store_size_is_the_files(tmp_path):
    path = tmp_path / "s.sqlite"
    result = ok("train", "-n", 50, "--eval-every", 0, *SMALL, "--store", path)
    printed = float(re.search(r"store: .* \(([\d.]+) MB\)", result.stderr).group(1))
    assert not Path(f"{path}-wal").exists() or Path(f"{path}-wal").stat().st_size == 0
    assert printed == round(path.stat().st_size / 1e6, 1), (printed, path.stat().st_size)


# --------------------------------------------------------------------------- 7. the code

def test_the_commands_do_not_import_each_other_in_a_circle():
    import ast

    folder = ROOT / "hadim_cli" / "commands"
    graph = {}
    for path in folder.glob("*.py"):
        names = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith(
                    "hadim_cli.commands"):
                names |= {node.module.rsplit(".", 1)[-1]} if node.module != \
                    "hadim_cli.commands" else {a.name for a in node.names}
        graph[path.stem] = names - {path.stem}

    def reaches(start: str, goal: str, seen: set) -> bool:
        return any(n == goal or (n not in seen and reaches(n, goal, seen | {n}))
                   for n in graph.get(start, ()))

    assert not [m for m in graph if reaches(m, m, {m})], graph


def test_a_timeline_too_wide_for_80_columns_keeps_its_borders_and_its_words():
    """The long events of a 4000-iteration run (`context replaced +target-robot
    −target.position`) do not fit beside an id column at 80: the id moves into the event."""
    import io

    from rich.console import Console

    from hadim_cli.reports import render_timeline
    from hadim_store.records import AffordanceEvent

    events = [AffordanceEvent(8, 0, "created", "action", "robot.heading", (), 0.348, {}),
              AffordanceEvent(480, 3, "context_replaced", "robot.position", "target.position",
                              ("target.position", "target-robot"), 0.507,
                              {"added": ["target-robot"], "removed": ["target.height"]}),
              AffordanceEvent(829, 5, "context_replaced", "action", "target.position",
                              ("target-robot", "robot.heading"), 0.611,
                              {"added": ["robot.heading"], "removed": ["target.position"]})]
    console = Console(width=80, file=io.StringIO())
    render_timeline(console, events)
    text = console.file.getvalue()
    _assert_fits(text)
    table = [line for line in text.splitlines() if line[:1] in "┃│┏┡└"]
    assert table and all(line[-1] in "┃│┓┩┘" for line in table), text
    words = set(text.split())
    assert {"target-robot", "−target.position", "+robot.heading", "A5"} <= words, text


def test_help_into_a_pipe_closed_early_is_no_traceback():
    """`hadim --help | head -3`: the reader goes away after a few lines; hadim stops without
    a traceback (click's abort, raised on a broken pipe, is caught where typer keeps it)."""
    shell = subprocess.run(f"'{HADIM}' --help | head -3", shell=True, capture_output=True,
                           text=True, timeout=60)
    assert "Usage" in shell.stdout
    assert "Traceback" not in shell.stderr, shell.stderr
