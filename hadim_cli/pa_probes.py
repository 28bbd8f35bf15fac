"""p_A asked about probes: the entities of a reference scene (`reports.probe_scene`: the
rover's push-object task's, 6 green, 3 red objects and the robot; another body's scene of seed
0) and objects of shades and sizes the world never draws.

`hadim affordances RUN --pa` renders it. A probe's features are read from an observation of a
real `World` (`SpaceReader.visual_features`, p_A's one definition of its input), so a probe is
seen exactly as an object of a learning episode would be.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from hadim_cli.world.layout import Property
from hadim_cli.world.scene import ObjectSpec, Scene

if TYPE_CHECKING:  # the learner (and torch) only where p_A is asked
    from hadim_cli.config import WorldConfig
    from hadim_cli.learner.affordance import Affordance
    from hadim_cli.learner.spaces import SpaceReader
    from hadim_cli.session import Session


@dataclass(frozen=True)
class Probe:
    """One thing p_A is asked about, and whether it should accept it (pushable)."""

    name: str
    features: np.ndarray
    pushable: bool


@dataclass(frozen=True)
class Unseen:
    """An object of a size or shade outside the world's ranges (radius, height, colour)."""

    name: str
    radius: float
    """As a multiple of the world's range: below 1, that fraction of `object_radius_min`;
    above 1, that multiple of `object_radius_max`; 1, the middle of the range."""
    height: float
    """As `radius`, of the height's range."""
    color: tuple[float, float, float]
    pushable: bool


# The world draws a shade's dominant channel in [0.55, 1] and the others in [0, 0.3]
# (`world.placement.shade`): a dark shade has a dominant channel of 0.45, a pale one others
# of 0.35. Small: 0.6 × the smallest radius and height. Large: 1.2 × the largest radius at a
# middling height — a green cylinder both wider and taller than any the world draws is too
# heavy for the robot's drive (r 0.3 m, h 0.7 m: moved 3 mm in 5 full-forward actions; r 0.3,
# h 0.35: 0.71 m), and p_A rejecting it would be right. `test_p_a_pooled` checks in the World
# that every pushable probe moves when pushed and no fixed one does.
UNSEEN: tuple[Unseen, ...] = (
    Unseen("green-small", 0.6, 0.6, (0.1, 0.7, 0.1), True),
    Unseen("green-large", 1.2, 1.0, (0.2, 0.9, 0.2), True),
    Unseen("green-dark", 1.0, 1.0, (0.1, 0.45, 0.1), True),
    Unseen("green-pale", 1.0, 1.0, (0.35, 0.8, 0.35), True),
    Unseen("red-small", 0.6, 0.6, (0.8, 0.1, 0.1), False),
    Unseen("red-large", 1.2, 1.0, (0.9, 0.2, 0.2), False),
    Unseen("red-dark", 1.0, 1.0, (0.45, 0.1, 0.1), False),
    Unseen("red-pale", 1.0, 1.0, (0.8, 0.35, 0.35), False),
)


def _scaled(low: float, high: float, factor: float) -> float:
    if factor < 1:
        return low * factor
    return high * factor if factor > 1 else (low + high) / 2


def unseen_size(config: WorldConfig, u: Unseen) -> tuple[float, float]:
    """(radius, height) of `u` in a world of `config`."""
    return (_scaled(config.object_radius_min, config.object_radius_max, u.radius),
            _scaled(config.object_height_min, config.object_height_max, u.height))


def unseen_scenes(world, unseen: tuple[Unseen, ...] = UNSEEN) -> list[Any]:
    """Scenes of `world` holding every `unseen` object (a scene has the layout's number of
    objects: the last ones are repeated to fill it), on a ring 0.7 m inside the bounds of the
    objects' positions, the body posed as in its scene of seed 0."""
    config, layout = world.config, world.layout
    n = len(layout.objects)
    bounds = layout.space(layout.objects[0], Property.POSITION)
    ring = min(min(abs(v) for v in bounds.low), min(bounds.high)) - 0.7
    pose = world.draw_scene(np.random.default_rng(0))
    scenes = []
    for start in range(0, len(unseen), n):
        chunk = list(unseen[start:start + n])
        chunk += [chunk[-1]] * (n - len(chunk))
        objects = []
        for i, u in enumerate(chunk):
            r, h = unseen_size(config, u)
            a = 2 * math.pi * i / n
            objects.append(ObjectSpec(ring * math.cos(a), ring * math.sin(a), r, h, u.color,
                                      u.pushable))
        scenes.append(replace(pose, objects=tuple(objects)))
    return scenes


def _features(world, reader: SpaceReader, scene: Scene) -> np.ndarray:
    obs = world.reset(scene=scene)
    return np.stack([reader.visual_features(obs, i) for i in range(len(world.layout.entities))])


def scene_probes(world, reader: SpaceReader, scene: Scene) -> list[Probe]:
    """The robot and every object of `scene` (green: pushable, red: fixed)."""
    feats = _features(world, reader, scene)
    truth = [False] + [o.pushable for o in scene.objects]
    names = world.layout.entities
    from hadim_cli.reports import entity_label

    return [Probe(entity_label(name, scene), f, t)
            for name, f, t in zip(names, feats, truth, strict=True)]


def unseen_probes(world, reader: SpaceReader, unseen: tuple[Unseen, ...] = UNSEEN
                  ) -> list[Probe]:
    """The `unseen` objects as the robot would see them."""
    out: list[Probe] = []
    for k, scene in enumerate(unseen_scenes(world, unseen)):
        feats = _features(world, reader, scene)[1:]  # not the robot
        chunk = unseen[k * len(feats):(k + 1) * len(feats)]
        out += [Probe(u.name, f, u.pushable) for u, f in zip(chunk, feats, strict=False)]
    return out


@dataclass(frozen=True)
class Verdict:
    """p_A of one affordance on the probes."""

    affordance: str
    id: int
    scene: dict[str, float]
    """P(accept) per entity of the reference scene."""
    unseen: dict[str, float]
    scene_wrong: tuple[str, ...]
    unseen_wrong: tuple[str, ...]
    replay: dict[str, int]
    """What p_A learned from: positives; negatives that are the robot; other negatives."""

    def as_json(self) -> dict[str, Any]:
        return {"id": self.id, "affordance": self.affordance, "scene": self.scene,
                "unseen": self.unseen, "scene_right": not self.scene_wrong,
                "unseen_right": not self.unseen_wrong, "scene_wrong": list(self.scene_wrong),
                "unseen_wrong": list(self.unseen_wrong), "replay": self.replay}


def _ask(aff: Affordance, probes: list[Probe]) -> tuple[dict[str, float], tuple[str, ...]]:
    assert aff.classifier is not None
    p = aff.classifier.predict_proba(np.stack([q.features for q in probes]))
    wrong = tuple(q.name for q, v in zip(probes, p, strict=True) if (v >= 0.5) != q.pushable)
    return {q.name: round(float(v), 4) for q, v in zip(probes, p, strict=True)}, wrong


def verdicts(session: Session) -> list[Verdict]:
    """p_A of every affordance of H that has one, on the reference scene and unseen objects."""
    from hadim_cli.learner.spaces import SpaceReader
    from hadim_cli.reports import probe_scene
    from hadim_cli.world.environment import make_world

    world = make_world(session.config.world)
    reader = SpaceReader(world.layout)  # p_A's features do not depend on the relations' offset
    scene = scene_probes(world, reader, probe_scene(world))
    unseen = unseen_probes(world, reader)
    robot = scene[0].features
    out = []
    for aff in session.learner.hierarchy:
        c = aff.classifier
        if c is None:
            continue
        on_scene, scene_wrong = _ask(aff, scene)
        on_unseen, unseen_wrong = _ask(aff, unseen)
        state = c.state()
        negatives = state["replay.negative"]
        is_robot = np.all(np.isclose(negatives, robot), axis=1)
        out.append(Verdict(aff.describe(), aff.id, on_scene, on_unseen, scene_wrong,
                           unseen_wrong, {"positives": int(state["replay.positive"].shape[0]),
                                          "negatives_robot": int(is_robot.sum()),
                                          "negatives_objects": int((~is_robot).sum())}))
    return out
