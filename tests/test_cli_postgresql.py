"""Every kind of command on a shared PostgreSQL store (--store and HADIM_STORE), and a server
that cannot be reached: one line, exit 2."""

from __future__ import annotations

import json

from hadim_cli.app import app

SHORT = ["--set", "world.episode_length=50", "--eval-every", "0"]


def _ok(runner, *args, env=None):
    result = runner.invoke(app, [str(a) for a in args], env=env)
    assert result.exit_code == 0, (args, result.output, result.exception)
    return result.stdout


def test_commands_on_a_postgresql_store(runner, postgres_url, tmp_path):
    store = ["--store", postgres_url]
    assert _ok(runner, "train", "-n", 100, "--seed", 2, *SHORT, *store).strip() == "run-1"
    _ok(runner, "resume", "run-1", "-n", 150, "--eval-every", 0, *store)
    assert _ok(runner, "fork", "run-1", "--at", 100, *store).strip() == "run-2"
    listed = json.loads(_ok(runner, "runs", "list", "--json", env={"HADIM_STORE": postgres_url}))
    assert [(r["name"], r["iterations"], r["parent"]) for r in listed] == [
        ("run-1", 150, None), ("run-2", 100, "run-1")]
    shown = json.loads(_ok(runner, "runs", "show", "run-1", "--json", *store))
    assert shown["status"] == "finished" and shown["seed"] == 2
    assert json.loads(_ok(runner, "affordances", "run-1", "--json", *store))
    # the same run trained into a file store has the same D
    file_store = ["--store", tmp_path / "same.db"]
    _ok(runner, "train", "-n", 150, "--seed", 2, *SHORT, *file_store)
    same = json.loads(_ok(runner, "runs", "show", "run-1", "--json", *file_store))
    assert same["dataset_sha256"] == shown["dataset_sha256"]


def test_unreachable_server_is_one_line(runner, tmp_path):
    url = f"postgresql://nobody@/hadim?host={tmp_path}&port=9"
    for args in (["train", "-n", "50", "--store", url], ["runs", "list", "--store", url]):
        result = runner.invoke(app, args)
        assert result.exit_code == 2
        lines = result.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("error: cannot open the store at"), lines
