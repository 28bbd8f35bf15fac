"""`hadim world`: look at the simulated room (render a scene, list its objects)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from hadim_cli.commands.common import ConfigOption, JsonOption, SetOption
from hadim_cli.config import load_config
from hadim_cli.errors import HadimError

app = typer.Typer(help="Look at the simulated room: render a scene, list its objects.",
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
        "--episode-actions", help="Execute these actions first: a .npy or text/CSV file, N×2.",
    )] = None,
    no_lidar: Annotated[bool, typer.Option("--no-lidar", help="Do not draw the rays.")] = False,
) -> None:
    """Draw the room of scene SEED after some actions, with the robot's trajectory."""
    import numpy as np

    from hadim_cli.world import actions as action_files
    from hadim_cli.world.render import render_scene
    from hadim_cli.world.world import World

    if random_actions and episode_actions is not None:
        raise HadimError("give --random-actions or --episode-actions, not both")
    cfg = load_config(config, set_ or [])
    if episode_actions is not None:
        actions = action_files.load_actions(episode_actions)
    else:
        actions = action_files.random_actions(np.random.default_rng([seed, 1]), random_actions)
    world = World(cfg.world)
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
    """List the robot and the objects of scene SEED."""
    from hadim_cli.world.placement import scene_rows
    from hadim_cli.world.world import World

    cfg = load_config(config, set_ or [])
    world = World(cfg.world)
    world.reset(seed=seed)
    rows = scene_rows(cfg.world, world.scene)
    if json_:
        typer.echo(json.dumps({"seed": seed, "entities": rows}))
        return
    from rich.console import Console
    from rich.table import Table

    table = Table(title=f"scene of seed {seed}")
    for column in ("entity", "kind", "x m", "y m", "radius m", "height m", "mass kg", "colour"):
        table.add_column(column, justify="left" if column in ("entity", "kind") else "right")
    for row in rows:
        mass = "fixed" if row["mass"] is None else f"{row['mass']:.3f}"
        hex_rgb = "#" + "".join(f"{round(255 * c):02x}" for c in row["color"])
        table.add_row(row["entity"], row["kind"], f"{row['x']:+.3f}", f"{row['y']:+.3f}",
                      f"{row['radius']:.3f}", f"{row['height']:.3f}", mass,
                      f"[{hex_rgb}]██[/] {hex_rgb}")
    Console().print(table)
