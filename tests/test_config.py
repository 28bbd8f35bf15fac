from __future__ import annotations

import dataclasses

import pytest

from hadim_cli.app import app
from hadim_cli.config import (
    Config,
    WorldConfig,
    config_from_dict,
    field_docs,
    load_config,
    parse_override,
    stored_config,
    with_overrides,
)
from hadim_cli.errors import ConfigError


def test_default_toml_matches_dataclass_defaults():
    assert load_config() == Config()


def _tables(values: object, name: str):
    """(name, dataclass instance) of a section and of every table within it (`world.arm`)."""
    yield name, values
    for f in dataclasses.fields(values):
        value = getattr(values, f.name)
        if dataclasses.is_dataclass(value):
            yield from _tables(value, f"{name}.{f.name}")


def test_every_field_is_documented():
    for section in dataclasses.fields(Config):
        for _, values in _tables(getattr(Config(), section.name), section.name):
            cls = type(values)
            docs = field_docs(cls)
            missing = [f.name for f in dataclasses.fields(cls) if not docs.get(f.name)]
            assert not missing, f"{cls.__name__} fields without a docstring: {missing}"


def test_override_types():
    assert parse_override("world.n_green=3") == {"world": {"n_green": 3}}
    assert parse_override("world.random_heading=false") == {"world": {"random_heading": False}}
    config = load_config(overrides=["world.room_width=5", "world.n_red=1"])
    assert config.world.room_width == 5.0 and isinstance(config.world.room_width, float)
    assert config.world.n_red == 1


def test_file_then_overrides(tmp_path):
    path = tmp_path / "mine.toml"
    path.write_text("[world]\nn_green = 2\nlidar_rays = 8\n")
    config = load_config(path, ["world.n_green=4"])
    assert (config.world.n_green, config.world.lidar_rays) == (4, 8)


@pytest.mark.parametrize(
    ("override", "message"),
    [
        ("world.nope=1", "unknown config key 'world.nope'"),
        ("nosection.x=1", "unknown config key 'nosection'"),
        ("world.n_green=1.5", "'world.n_green' must be an integer"),
        ("world.robot_radius=-0.1", "'world.robot_radius' = -0.1 is impossible"),
        ("world.n_green=200", "do not fit"),
        ("world.object_radius_max=0.01", "world.object_radius_max"),
        ("world.random_heading=1", "must be true or false"),
        ("world.lidar_range=nan", "must be finite"),
        ("planner.commands=1", "'planner.commands' = 1 is impossible"),
        ("planner.clearance=-0.1", "'planner.clearance' = -0.1 is impossible"),
        ("planner.convoy=true", "unknown config key 'planner.convoy'"),
        ("world", "section.key=value"),
        ("world.body=leg", "'world.body' must be one of 'rover', 'arm', got 'leg'"),
        ("world.body=1", "'world.body' must be one of"),
        ("world.arm.joint_limits=[1,2,3]", "must hold one limit per joint after the shoulder (2"),
        ("world.arm.joint_limits=[4,1]", "every limit must be in (0, π]"),
        ("world.arm.motor_torques=[1,0,1]", "every torque must be > 0"),
        ("world.arm.motor_torques=[1,1]", "must hold one torque per link (3"),
        ("world.arm.link_lengths=[1.0]", "must hold at least two lengths"),
        ("world.arm.max_joint_speed=0", "'world.arm.max_joint_speed' = 0.0 is impossible"),
        ("world.arm.table_width=2", "so the arm stays on the table"),
        ("world.arm.reach=1", "unknown config key 'world.arm.reach'"),
    ],
)
def test_bad_values_name_the_key(override, message):
    with pytest.raises(ConfigError, match=message.replace(".", r"\.").replace("(", r"\(")):
        load_config(overrides=[override])


def test_round_trip_through_dict():
    config = with_overrides(Config(), ["world.n_green=2"])
    assert config_from_dict(config.to_dict()) == config
    assert config.world == dataclasses.replace(WorldConfig(), n_green=2)


def test_a_stored_run_without_a_newer_key_keeps_the_behaviour_it_was_trained_with():
    """Runs stored before `surface_relations` existed read relations centre to centre: a
    stored config lacking the key restores with the legacy value, one holding it keeps it."""
    values = Config().to_dict()
    for key in ("surface_relations", "relation_frames"):
        assert values["learner"][key] is True
        del values["learner"][key]
    legacy = stored_config(values).learner
    assert legacy.surface_relations is False and legacy.relation_frames is False
    assert stored_config(Config().to_dict()) == Config()


def test_a_run_stored_before_the_papers_rules_were_the_default_keeps_its_own():
    """`open_contexts` and `absorb_mismatch` became the paper's (on, off) on 2026-11-25: a
    stored config lacking them restores the rules it was trained with (closed, absorbing);
    one holding them keeps what it holds."""
    values = Config().to_dict()
    assert (values["learner"]["open_contexts"], values["learner"]["absorb_mismatch"]) == (
        True, False)
    stored = stored_config(values).learner
    assert (stored.open_contexts, stored.absorb_mismatch) == (True, False)
    for key in ("open_contexts", "absorb_mismatch"):
        del values["learner"][key]
    legacy = stored_config(values).learner
    assert (legacy.open_contexts, legacy.absorb_mismatch) == (False, True)


def test_a_run_stored_before_tools_were_chosen_by_their_chain_keeps_its_objects():
    """`learner.chain_objects` (on since 2026-11-26): a stored config lacking it restores the
    ObjectSelection it trained with (the closest target, then the tool nearest it); one
    holding it keeps it. `learner.own_relations` (on since 2026-11-28) likewise: contexts
    ranked by competence alone."""
    for key in ("chain_objects", "own_relations"):
        values = Config().to_dict()
        assert values["learner"][key] is True
        assert getattr(stored_config(values).learner, key) is True
        del values["learner"][key]
        assert getattr(stored_config(values).learner, key) is False


def test_a_stored_run_s_controller_keys_are_the_installed_code_s():
    """A run stored by a version with other controller constants (the rule-based planner's
    `[planner]` keys, the search variant's `[controller]` section) restores with the
    installed controller's; its learner's keys are kept as stored."""
    values = Config().to_dict()
    values["planner"] = {"convoy": True, "navigation": True, "route_beam": 24, "beam": 5}
    values["controller"] = {"kind": "search", "stall": 8}
    values["learner"]["goal_budget"] = 33
    config = stored_config(values)
    assert config.planner == dataclasses.replace(Config().planner, beam=5)
    assert config.learner.goal_budget == 33
    values["learner"]["no_such_key"] = 1
    with pytest.raises(ConfigError, match="learner.no_such_key"):
        stored_config(values)


def test_missing_or_broken_file(tmp_path):
    with pytest.raises(ConfigError, match="not found"):
        load_config(tmp_path / "absent.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[world\n")
    with pytest.raises(ConfigError, match="not valid TOML"):
        load_config(bad)


def test_cli_bad_key_is_one_line_and_nonzero(runner):
    result = runner.invoke(app, ["config", "show", "--set", "world.bogus=1"])
    assert result.exit_code == 2
    assert result.output.strip().count("\n") == 0
    assert "unknown config key 'world.bogus'" in result.output


def test_cli_show_json(runner):
    import json

    result = runner.invoke(app, ["config", "show", "--json", "--set", "world.n_red=2"])
    assert result.exit_code == 0, result.output
    assert json.loads(result.output)["world"]["n_red"] == 2


def test_default_toml_lists_every_key_of_every_section():
    """configs/default.toml is the reference a user reads and copies: a key missing from it
    silently falls back to the dataclass's default, which `load_config() == Config()` cannot
    notice."""
    import tomllib

    from hadim_cli.config import configs_dir

    written = tomllib.loads((configs_dir() / "default.toml").read_text())
    assert set(written) == {f.name for f in dataclasses.fields(Config)}
    for section in dataclasses.fields(Config):
        for name, values in _tables(getattr(Config(), section.name), section.name):
            table = written
            for part in name.split("."):
                table = table[part]
            fields = {f.name for f in dataclasses.fields(values)}
            keys = set(table)
            assert keys <= fields, f"[{name}] keys no field has: {sorted(keys - fields)}"
            assert keys == fields, f"[{name}] lacks {sorted(fields - keys)}"


def test_the_body_is_chosen_by_config_and_a_stored_run_without_one_is_the_rover():
    """`configs/arm.toml` selects the arm (its own keys under `[world.arm]`, overridable with
    `--set world.arm.KEY=…`); a run stored before `world.body` existed restores as the rover
    it was, with every other key as stored."""
    from hadim_cli.config import Body, configs_dir

    arm = load_config(configs_dir() / "arm.toml", ["world.arm.link_lengths=[0.7, 0.5, 0.3]"])
    assert arm.world.body is Body.ARM and arm.world.arm.link_lengths == (0.7, 0.5, 0.3)
    assert config_from_dict(arm.to_dict()) == arm
    assert Config().world.body is Body.ROVER
    values = Config().to_dict()
    del values["world"]["body"], values["world"]["arm"]
    assert stored_config(values) == Config()
