"""`hadim world`: look at the simulated world of the configured body (render a scene, list its
entities): the rover's room or the arm's table."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from hadim_cli.commands.common import ConfigOption, JsonOption, SetOption
from hadim_cli.config import load_config
from hadim_cli.errors import HadimError

app = typer.Typer(help="Look at the simulated world (the rover's room, or the arm's table with "
                  "--config configs/arm.toml): render a scene, list its entities.",
                  no_args_is_help=True)

SeedOption = Annotated[int, typer.Option("--seed", help="Seed of the scene drawn at reset.")]


@app.command("render")
def render(
    seed: SeedOption,
    out: Annotated[Path, typer.Option("--out", "-o", help="PNG file to write.")],
    config: ConfigOption = None,
    set_: SetOption = None,
    random_actions: Annotated[int, typer.Option(
        "--random-actions", min=0, help="Execute this many uniform random actions first.")] = 0,
    episode_actions: Annotated[Path | None, typer.Option(
        "--episode-actions", help="Execute these actions first: a .npy or text/CSV file, one "
        "action a row (N×2 for the rover, N×3 for the arm).",
    )] = None,
    no_lidar: Annotated[bool, typer.Option("--no-lidar", help="Do not draw the rays.")] = False,
) -> None:
    """Draw the world of scene SEED after some actions, with the actor's trajectory."""
    import numpy as np

    from hadim_cli.world import actions as action_files
    from hadim_cli.world.environment import make_world
    from hadim_cli.world.render import render_scene

    if random_actions and episode_actions is not None:
        raise HadimError("give --random-actions or --episode-actions, not both")
    cfg = load_config(config, set_ or [])
    world = make_world(cfg.world)
    if episode_actions is not None:
        actions = action_files.load_actions(episode_actions, world.action_space)
    else:
        actions = world.action_space.sample(np.random.default_rng([seed, 1]), random_actions)
    trajectory = [world.reset(seed=seed)]
    trajectory += [world.step(action) for action in actions]
    title = f"seed {seed}, after {len(actions)} action{'s' if len(actions) != 1 else ''}"
    path = render_scene(world, out, trajectory=np.array(trajectory), lidar=not no_lidar,
                        title=title)
    typer.echo(f"wrote {path}")


@app.command("info")
def info(
    seed: SeedOption,
    config: ConfigOption = None,
    set_: SetOption = None,
    json_: JsonOption = False,
) -> None:
    """List the actor (the robot, or the arm's effector) and the objects of scene SEED."""
    from hadim_cli.config import Body
    from hadim_cli.world.environment import make_world
    from hadim_cli.world.placement import arm_scene_rows, scene_rows

    cfg = load_config(config, set_ or [])
    world = make_world(cfg.world)
    world.reset(seed=seed)
    rows_of = arm_scene_rows if cfg.world.body is Body.ARM else scene_rows
    rows = rows_of(cfg.world, world.scene)
    if json_:
        typer.echo(json.dumps({"seed": seed, "entities": rows}))
        return
    from rich.console import Console
    from rich.table import Table

    table = Table(title=f"scene of seed {seed}")
    for column in ("entity", "kind", "x m", "y m", "radius m", "height m", "mass kg", "colour"):
        if column in ("entity", "kind"):
            widest = max(len(str(row[column])) for row in rows)
            table.add_column(column, no_wrap=True, min_width=widest)
        else:
            table.add_column(column, justify="right")
    for row in rows:
        mass = ("fixed" if row["kind"] == "red" else "–" if row["mass"] is None
                else f"{row['mass']:.3f}")
        hex_rgb = "#" + "".join(f"{round(255 * c):02x}" for c in row["color"])
        table.add_row(row["entity"], row["kind"], f"{row['x']:+.3f}", f"{row['y']:+.3f}",
                      f"{row['radius']:.3f}", f"{row['height']:.3f}", mass,
                      f"[{hex_rgb}]██[/] {hex_rgb}")
    Console().print(table)
