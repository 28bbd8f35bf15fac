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
    missing_keys,
    parse_override,
    stored_config,
    unknown_keys,
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


def test_a_stored_run_s_removed_keys_are_ignored_and_named():
    """A run stored by a version with other keys (the rule-based planner's `[planner]` keys,
    the search variant's `[controller]` section, learner switches since removed) restores with
    the installed code in their place: the keys it still has are kept as stored, the others
    dropped and named (`unknown_keys`, which the version note prints)."""
    values = Config().to_dict()
    values["planner"] = {"convoy": True, "navigation": True, "route_beam": 24, "beam": 5}
    values["controller"] = {"kind": "search", "stall": 8}
    values["learner"].update(goal_budget=33, surface_relations=False, p_a_pooled=False)
    values["world"]["arm"]["elbow"] = 1
    config = stored_config(values)
    assert config.planner == dataclasses.replace(Config().planner, beam=5)
    assert config.learner == dataclasses.replace(Config().learner, goal_budget=33)
    assert config.world == Config().world
    assert unknown_keys(values) == [
        "world.arm.elbow", "learner.surface_relations", "learner.p_a_pooled", "planner.convoy",
        "planner.navigation", "planner.route_beam", "controller"]
    assert unknown_keys(Config().to_dict()) == []
    assert stored_config(Config().to_dict()) == Config()
    assert missing_keys(Config().to_dict()) == []
    del values["learner"]["k_choices"], values["world"]["arm"]["link_mass"]
    assert missing_keys(values) == [
        "world.arm.link_mass", "learner.k_choices", "planner.commands", "planner.horizon",
        "planner.clearance", "planner.step_quantile", "planner.context_support",
        "planner.agreement"]
    assert stored_config(values).learner.k_choices == Config().learner.k_choices


@pytest.mark.parametrize("override", ["learner.surface_relations=false",
                                      "learner.context_splits=5", "planner.convoy=true"])
def test_a_removed_key_given_by_a_user_is_refused(override):
    """A user's config or `--set` is read as the installed version's: a key it no longer has
    is an error naming it (only a stored run's are dropped)."""
    key = override.split("=")[0]
    with pytest.raises(ConfigError, match=key.replace(".", r"\.")):
        load_config(overrides=[override])
    with pytest.raises(ConfigError, match=key.replace(".", r"\.")):
        with_overrides(Config(), [override])


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
