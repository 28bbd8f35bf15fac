"""Configuration: frozen dataclasses loaded from TOML, validated at load.

Every section is a frozen dataclass whose fields carry a docstring (the string literal that
follows them). `load_config` reads `configs/default.toml` (or a user's file), applies repeated
`--set section.key=value` overrides and validates; any unknown key, wrong type or impossible
value raises `ConfigError` naming the key and what is allowed.
"""

from __future__ import annotations

import ast
import dataclasses
import enum
import inspect
import math
import os
import tomllib
import typing
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

from hadim_cli.errors import ConfigError

CONFIG_DIR_ENV = "HADIM_CONFIGS"


def configs_dir() -> Path:
    """The folder holding default.toml and tasks/: `$HADIM_CONFIGS`; in a source checkout (or
    an editable install) the repository's `configs/`, the source of truth; in an installed
    wheel, the copy shipped as the package data `hadim_cli/configs` (pyproject.toml)."""
    env = os.environ.get(CONFIG_DIR_ENV)
    if env:
        return Path(env)
    checkout = Path(__file__).resolve().parents[1] / "configs"
    if (checkout / "default.toml").is_file():
        return checkout
    return Path(str(resources.files("hadim_cli") / "configs"))


def _check(cond: bool, key: str, allowed: str, value: Any) -> None:
    if not cond:
        raise ConfigError(f"config key '{key}' = {value!r} is impossible: {allowed}")


class Body(enum.StrEnum):
    """The body the learner acts through (`world.body`)."""

    ROVER = "rover"
    """The paper's two-wheeled robot in a closed room (§3.1)."""
    ARM = "arm"
    """A planar three-link arm on a table (the paper's future work)."""


@dataclass(frozen=True)
class ArmConfig:
    """The planar arm seen from above (`world.body = "arm"`): a fixed base at the table's
    centre, links joined by motorised pivot joints, a disc end effector (docs/world.md)."""

    link_lengths: tuple[float, ...] = (0.6, 0.5, 0.4)
    """Length of each link from the base outwards (m), at least two; one joint and one action
    component per link. Their sum is the arm's reach."""
    joint_limits: tuple[float, ...] = (2.0, 2.0)
    """How far each joint after the shoulder turns either way from straight (rad, at most π),
    one per joint from the elbow outwards: short of folding back, so the effector keeps off
    its base (by default it comes no nearer than 0.20 m). The shoulder turns all round (±π
    from the table's +x axis), so the arm reaches a whole annulus round its base."""
    max_joint_speed: float = 0.12
    """Joint speed at command 1 (rad/s), the same for every joint: the effector then moves at
    0.34 m/s at most (the arm straight, every joint at full speed one way), about the rover's
    0.3 m/s, so that the arm, and what it pushed, come to rest within `settle_time`."""
    motor_torques: tuple[float, ...] = (40.0, 25.0, 12.0)
    """Largest torque each joint's motor exerts (N·m), one per link: enough to push the
    heaviest green object (23.1 N of ground friction) in almost every pose and direction,
    more slowly than a light one; a red object stops the arm."""
    link_mass: float = 3.0
    """Mass of each link (kg), spread evenly along it."""
    joint_inertia: float = 1.0
    """Moment of inertia each joint's motor and gearbox add to the link it turns (kg·m²): in
    a real arm the rotor's, reflected through the gearing, outweighs the link's own. It also
    keeps pymunk's chain of joints stiff: with the links' own inertia alone (0.09 kg·m² at
    most) the effector strayed up to 5 mm from where its joint angles put it; with 1, 0.3 mm
    (docs/world.md)."""
    effector_radius: float = 0.05
    """Radius of the disc end effector at the tip of the last link (m): the only part of the
    arm that touches the objects (the links pass above them)."""
    effector_height: float = 0.1
    """Height of the end effector (m); one of its visual properties."""
    base_radius: float = 0.1
    """Radius of the fixed base at the table's centre (m); objects cannot cross it."""
    table_width: float = 4.0
    """Inner width of the table (m); a low rim round it keeps the objects on it."""
    table_height: float = 4.0
    """Inner depth of the table (m)."""

    def validate(self) -> None:
        n = len(self.link_lengths)
        _check(n >= 2, "world.arm.link_lengths", "must hold at least two lengths",
               list(self.link_lengths))
        _check(all(v > 0 for v in self.link_lengths), "world.arm.link_lengths",
               "every length must be > 0", list(self.link_lengths))
        _check(len(self.motor_torques) == n, "world.arm.motor_torques",
               f"must hold one torque per link ({n}, as world.arm.link_lengths)",
               list(self.motor_torques))
        _check(len(self.joint_limits) == n - 1, "world.arm.joint_limits",
               f"must hold one limit per joint after the shoulder ({n - 1}: one less than "
               "world.arm.link_lengths)", list(self.joint_limits))
        _check(all(0 < v <= math.pi for v in self.joint_limits), "world.arm.joint_limits",
               "every limit must be in (0, π]", list(self.joint_limits))
        _check(all(v > 0 for v in self.motor_torques), "world.arm.motor_torques",
               "every torque must be > 0", list(self.motor_torques))
        for name in ("max_joint_speed", "link_mass", "effector_radius", "effector_height",
                     "base_radius"):
            value = getattr(self, name)
            _check(value > 0, f"world.arm.{name}", "must be > 0", value)
        _check(self.joint_inertia >= 0, "world.arm.joint_inertia", "must be >= 0",
               self.joint_inertia)
        room = self.reach + self.effector_radius
        for name in ("table_width", "table_height"):
            value = getattr(self, name)
            _check(value / 2 > room, f"world.arm.{name}",
                   f"must exceed {2 * room:g} m (twice the arm's reach plus its effector's "
                   "radius), so the arm stays on the table", value)

    @property
    def reach(self) -> float:
        """Distance from the base to the effector with the arm straight (m)."""
        return sum(self.link_lengths)


@dataclass(frozen=True)
class WorldConfig:
    """The simulated world: the body (`body`), the rover's room (the paper's, §3.1: the keys
    from `room_width` to `random_heading` and the LIDAR's), the arm's table (`[world.arm]`),
    and the objects and timing both share."""

    body: Body = Body.ROVER
    """The body the learner acts through: "rover" (the paper's robot in its room) or "arm"
    (a planar arm on a table, configured by `[world.arm]`)."""
    arm: ArmConfig = field(default_factory=ArmConfig)
    """The arm's own keys (used when `body = "arm"`)."""
    room_width: float = 4.0
    """Inner width of the closed room (m)."""
    room_height: float = 4.0
    """Inner height of the closed room (m)."""
    robot_radius: float = 0.15
    """Radius of the disc-shaped robot (m)."""
    robot_height: float = 0.3
    """Height of the robot (m); one of its visual properties."""
    robot_mass: float = 4.0
    """Mass of the robot (kg)."""
    wheel_base: float = 0.3
    """Distance between the two wheels (m)."""
    max_wheel_speed: float = 0.3
    """Wheel ground speed at intensity 1 (m/s)."""
    drive_force: float = 26.0
    """Largest force the wheels can exert (N): above the ground friction of the heaviest green
    object (23.1 N by default), so every one is pushable, yet close enough that a heavy load
    slows the robot down."""
    drive_torque: float = 6.0
    """Largest torque the wheels can exert when turning (N·m)."""
    action_duration: float = 0.5
    """Simulated time one primitive action is held (s)."""
    settle_time: float = 0.1
    """After the hold, the wheels stop and the world runs this long (s) before it is observed:
    the robot, and what it pushed, come to rest, so every action starts from standstill. 0:
    the next action starts at the speed the last one left, which no observation holds (the
    robot's motion model then errs by up to ~9 cm after a reversal; docs/world.md)."""
    physics_dt: float = 1.0 / 60.0
    """Fixed physics step (s)."""
    n_green: int = 6
    """Number of pushable (green) cylinders."""
    n_red: int = 3
    """Number of fixed (red) cylinders."""
    object_radius_min: float = 0.08
    """Smallest cylinder radius (m)."""
    object_radius_max: float = 0.25
    """Largest cylinder radius (m)."""
    object_height_min: float = 0.1
    """Smallest cylinder height (m)."""
    object_height_max: float = 0.6
    """Largest cylinder height (m)."""
    object_density: float = 50.0
    """Density of green cylinders (kg/m³): mass = density·π·r²·h."""
    ground_friction: float = 0.4
    """Coulomb coefficient μ of the ground; friction force μ·m·g."""
    start_clearance: float = 0.5
    """No object within this distance of the robot's start (m); the rover's only (the arm's
    objects keep `object_gap` from its effector's start)."""
    object_gap: float = 0.05
    """Smallest free gap between two objects and between an object and a wall (m) (the
    arm's: also its base and its effector's start)."""
    random_heading: bool = False
    """Robot heading at reset drawn uniformly (True) or facing +x (False, the default: every
    episode starts from the same pose, as the paper's robot "always starts at the centre")."""
    lidar_rays: int = 16
    """Number of LIDAR rays, evenly spread around the robot."""
    lidar_range: float = 1.5
    """LIDAR range measured from the robot's centre (m)."""
    episode_length: int = 100
    """Primitive actions per episode, after which the scene is drawn anew."""

    def validate(self) -> None:
        for name in (
            "room_width", "room_height", "robot_radius", "robot_height", "robot_mass",
            "wheel_base", "max_wheel_speed", "drive_force", "drive_torque", "action_duration",
            "physics_dt", "object_radius_min", "object_height_min", "object_density",
            "lidar_range",
        ):
            value = getattr(self, name)
            _check(value > 0, f"world.{name}", "must be > 0", value)
        for name in ("ground_friction", "start_clearance", "object_gap", "settle_time"):
            value = getattr(self, name)
            _check(value >= 0, f"world.{name}", "must be >= 0", value)
        _check(self.object_radius_max >= self.object_radius_min, "world.object_radius_max",
               f"must be >= world.object_radius_min ({self.object_radius_min})",
               self.object_radius_max)
        _check(self.object_height_max >= self.object_height_min, "world.object_height_max",
               f"must be >= world.object_height_min ({self.object_height_min})",
               self.object_height_max)
        _check(self.physics_dt <= self.action_duration, "world.physics_dt",
               f"must be <= world.action_duration ({self.action_duration})", self.physics_dt)
        _check(self.n_green >= 0, "world.n_green", "must be >= 0", self.n_green)
        _check(self.n_red >= 0, "world.n_red", "must be >= 0", self.n_red)
        _check(self.lidar_rays >= 1, "world.lidar_rays", "must be >= 1", self.lidar_rays)
        _check(self.episode_length >= 1, "world.episode_length", "must be >= 1",
               self.episode_length)
        _check(2 * self.robot_radius < min(self.room_width, self.room_height), "world.robot_radius",
               "the robot must fit in the room", self.robot_radius)
        self.arm.validate()
        if self.body is Body.ARM:
            self._validate_arm_packing()
        else:
            self._validate_packing()

    def _validate_packing(self) -> None:
        """Refuse layouts that cannot fit: area of the largest objects against the free room."""
        n = self.n_green + self.n_red
        if n == 0:
            return
        r = self.object_radius_max + self.object_gap
        usable_w = self.room_width - 2 * r
        usable_h = self.room_height - 2 * r
        _check(usable_w > 0 and usable_h > 0, "world.object_radius_max",
               "objects of that size do not fit in the room", self.object_radius_max)
        # A square packing of discs of radius r (gap included) is always achievable, so
        # require it with the start clearance zone removed; random placement retries within it.
        free = usable_w * usable_h - math.pi * (self.start_clearance + r) ** 2
        _check(free >= _packed_area(n, r), "world.n_green",
               f"{n} objects of radius up to {self.object_radius_max} m do not fit in a "
               f"{self.room_width}x{self.room_height} m room; lower the count or the radius",
               self.n_green)

    def _validate_arm_packing(self) -> None:
        """The same test on the disc the arm reaches, less its base and its effector."""
        n = self.n_green + self.n_red
        if n == 0:
            return
        arm, r = self.arm, self.object_radius_max + self.object_gap
        free = math.pi * (arm.reach ** 2 - (arm.base_radius + r) ** 2
                          - (arm.effector_radius + r) ** 2)
        _check(free >= _packed_area(n, r), "world.n_green",
               f"{n} objects of radius up to {self.object_radius_max} m do not fit within the "
               f"arm's reach ({arm.reach:g} m); lower the count or the radius, or lengthen "
               "world.arm.link_lengths", self.n_green)


def _packed_area(n: int, r: float) -> float:
    """Area `n` discs of radius `r` need to be placed at random without overlap (m²)."""
    return n * (2 * r) ** 2 * 1.6


@dataclass(frozen=True)
class LearnerConfig:
    """The learner of the paper (§3.2–4): exploration, models, adaptation, planning."""

    sigma: float = 0.7
    """Probability of goal babbling (vs a random controllable) once H is not empty (paper σ)."""
    random_sequence_length: int = 8
    """Primitive actions of one random-action learning episode (motor babbling)."""
    k_forward: int = 10
    """Neighbours of the forward model's local linear fit (until `k_choices` chose one), and
    of every competence's fits (`Fitter.competence`: trials and affordances alike)."""
    k_choices: tuple[int, ...] = (10, 20, 30, 60)
    """Neighbourhoods each model's forward fits may take: whenever its rows have doubled
    (from 32), the one that predicts them best from other moments (each row without the
    actions just before and after it: `LocalLinearModel._choose_k`).
    Fitted on 10 neighbours, the push model answered a push 5° off its contact line with an
    outcome 40° off, and the planner could not steer on it (docs/algorithm.md, "each model
    chooses its forward neighbourhood"). Empty: always `k_forward`."""
    k_inverse: int = 20
    """Recorded outcomes the inverse model starts from."""
    robust_fit: int = 0
    """Robustness refits of every local linear fit (`LocalLinearModel.robust_iterations`,
    Cleveland's bisquare weights): rows unlike their neighbours — the robot blocked by a wall
    or an object among free moves — weigh less in the fits round them. 0 (the default):
    plain weighted fits. With 1, the tool task scored 0.79 against 0.72 on seeds 0–9 and
    less than the plain fits on seeds 10–19 (docs/notes.md); the motion model's error on
    free moves hardly moved, because blocked rows come in runs of identical inputs that
    outnumber the free ones round them."""
    zero_eps: float = 0.004
    """An outcome smaller than this (in its space's units) counts as null."""
    tau_creation: float = 0.3
    """Competence a new affordance needs to be added to H (paper τ_creation)."""
    tau_modification: float = 0.3
    """Competence a context change needs to be kept (paper τ_modification)."""
    context_gain: float = 0.1
    """A context change must also raise competence by at least this much (half of it for a
    replacement, none for a removal), each tested on one held-out split."""
    match_tolerance: float = 0.05
    """New data match an affordance if its competence drops by less than this."""
    context_review_every: int = 5
    """Also try context changes every this many updates of an affordance, matched or not."""
    tau_deletion: float = 0.1
    """An affordance whose competence stays below this for `deletion_patience` updates goes."""
    deletion_patience: int = 8
    """Consecutive low-competence updates before an affordance is deleted."""
    competence_sharpness: float = 20.0
    """s in C(e) = clip((1 − e²)·exp(−s·e), 0, 1)."""
    competence_rows: int = 300
    """Rows a competence estimate uses at most (a seeded random subset beyond that)."""
    creation_rows: int = 600
    """Rows of D a creation or context trial is fitted on at most."""
    zero_ratio: float = 1.0
    """Null-outcome rows kept per non-null row in an affordance's data."""
    salient_goals: float = 0.5
    """Share of goals in an object's position space (random or by goal babbling) set where
    objects meet: at the position of the pushable object nearest the target, pushed on by
    `salient_beyond` (where pushing one object with another can be found); for an affordance
    acting through a tool, the target pushed on along the line from the tool."""
    salient_beyond: float = 0.3
    """How far (m) beyond the other object, along the line from the target, a salient goal
    lies: the target has to push that object out of its way instead of stopping at it."""
    goal_budget: int = 40
    """Primitive actions one goal attempt may use."""
    subgoal_budget: int = 1
    """Primitive actions one sub-goal (a lower affordance's step, a trip to a place) may use
    before the level above replans: 1, every level decides again after every action."""
    reach_tolerance: float = 0.05
    """A goal counts as reached within this fraction of its initial distance."""
    interest_max_goals: int = 50
    """Goals a region of an interest map holds before it splits."""
    interest_window: int = 20
    """Competences the learning progress of a region is computed over."""
    interest_epsilon: float = 0.2
    """Probability of a uniform choice (of affordance, of region) instead of by interest."""
    paper_interest: bool = False
    """The interest maps as the paper has them (§4.4 and Algorithm 1's UpdateInterestMaps):
    after every learning episode, goal babbling or random, each affordance's map records every
    non-null outcome the episode reached in its output space, with the competence of the
    forward model's estimate for the controllable executed (1 − min(1, error / the output's
    range)); a region's interest is the mean of its last `interest_window` learning progresses
    (`interest.paper_progress`). Off: a map records goal-babbling attempts only, with the
    competence of the attempt, and a region's interest is the half-window difference
    (docs/algorithm.md, "Interest maps", for what each measured)."""
    relation_offset: float = 0.3
    """Relative positions (target-robot, target-tool, …) are read between the two bodies'
    surfaces, not centre to centre as the paper words it, so that a contact reads the same
    whatever the objects' sizes: this is the length (m) a relation reads at contact (> 0: a
    contact keeps its direction); about the robot's radius plus a middling object's."""
    classifier_hidden: int = 32
    """Width of the two hidden layers of each visual classifier p_A."""
    classifier_steps: int = 30
    """Training steps of p_A after each learning episode that gave it examples."""
    open_outputs: bool = False
    """Let the LIDAR be the output of an affordance too (`spaces.OPEN_OUTPUT_SPACES`), as the
    paper lets any space be; off: the robot's position and heading and an object's position
    (docs/algorithm.md, departures, for what opening it measured)."""
    paper_picks: bool = False
    """Algorithm 2's PickSpace as the paper writes it: a space is picked k times at random
    among those with a non-null outcome in the learning episode, k = their number, with
    replacement — some are adapted twice (the second pick adds nothing: their affordances
    hold the episode's rows already) and some not at all. Off: each non-null
    space once, in random order (docs/algorithm.md, departures, for what each measured)."""
    paper_matching: bool = False
    """Algorithm 2's Matches as the paper writes it: a picked space S's data are matched
    against *every* affordance of H, not only those with output S. An affordance of another
    output of the same property (a position for a position) matches when its
    model, given the episode's rows with S's outcome in place of its own, keeps its held-out
    competence within `match_tolerance` (`Adaptation.matches_other_output`); such a match
    explains S, and no new affordance is tried for S at that pick (the paper creates one only
    when nothing matched). Off: only the affordances with output S are matched."""
    paper_match_adds: bool = False
    """With `paper_matching`: the rest of Algorithm 2's body for an affordance of another
    output, as the paper writes it — every affordance of H is tried (not the first match
    only); one that matches takes S's data in (rows read in S's space, `Rows.borrowed`); one
    that does not is given k' random context candidates (k' = their number) and takes the
    first with which it holds the data at competence ≥ τ_modification, with the data
    (`Adaptation._borrow`). Off: a match only stands for creation, nothing is added."""

    def validate(self) -> None:
        for name in ("sigma", "match_tolerance", "context_gain", "interest_epsilon",
                     "salient_goals"):
            value = getattr(self, name)
            _check(0.0 <= value <= 1.0, f"learner.{name}", "must be in [0, 1]", value)
        for name in ("tau_creation", "tau_modification", "tau_deletion"):
            value = getattr(self, name)
            _check(0.0 <= value <= 1.0, f"learner.{name}", "must be in [0, 1]", value)
        for name in ("random_sequence_length", "k_forward", "k_inverse", "goal_budget",
                     "subgoal_budget", "interest_window", "classifier_hidden",
                     "classifier_steps", "deletion_patience", "context_review_every"):
            value = getattr(self, name)
            _check(value >= 1, f"learner.{name}", "must be >= 1", value)
        _check(self.robust_fit >= 0, "learner.robust_fit", "must be >= 0", self.robust_fit)
        _check(all(k >= 1 for k in self.k_choices), "learner.k_choices",
               "must hold neighbour counts >= 1", list(self.k_choices))
        _check(self.interest_max_goals >= 2, "learner.interest_max_goals", "must be >= 2",
               self.interest_max_goals)
        _check(self.competence_rows >= 20, "learner.competence_rows", "must be >= 20",
               self.competence_rows)
        _check(self.creation_rows >= 20, "learner.creation_rows", "must be >= 20",
               self.creation_rows)
        _check(self.salient_beyond >= 0, "learner.salient_beyond", "must be >= 0",
               self.salient_beyond)
        _check(self.paper_matching or not self.paper_match_adds, "learner.paper_match_adds",
               "needs learner.paper_matching = true (it adds the data a match with another "
               "output found)", self.paper_match_adds)
        for name in ("zero_eps", "competence_sharpness", "zero_ratio", "reach_tolerance",
                     "relation_offset"):
            value = getattr(self, name)
            _check(value > 0, f"learner.{name}", "must be > 0", value)


@dataclass(frozen=True)
class PlannerConfig:
    """The controller's constants: how a goal of an affordance becomes primitive actions, by
    one receding-horizon search through the chain's forward models (paper §4.3;
    hadim_cli/learner/controller.py, docs/controller.md). They are code, not data: a stored
    run is evaluated, forked and resumed with the installed version's."""

    commands: int = 9
    """Values the search tries per component of the primitive action: a grid of every
    combination over the action space (n² commands for two components, n³ for three)."""
    horizon: int = 1
    """Actions a searched sequence looks ahead (1: each action valued by the estimated
    actions to go from where it is predicted to end)."""
    beam: int = 8
    """Imagined states kept at each depth of the search."""
    clearance: float = 0.02
    """Gap (m) kept from a body no level of the chain moves (and the overlap allowed between
    bodies a level moves, for the models' error)."""
    step_quantile: float = 0.9
    """An affordance's step: this quantile of its non-null outcomes' norms."""
    context_support: float = 0.1
    """Relations further apart than this (in their model's scale) vote apart when choosing
    where an affordance acts from."""
    agreement: float = 0.4
    """Rows within this (in their model's scale) of the densest relation fit the place."""

    def validate(self) -> None:
        for name in ("commands", "horizon", "beam"):
            _check(getattr(self, name) >= 1, f"planner.{name}", "must be >= 1",
                   getattr(self, name))
        _check(self.commands >= 2, "planner.commands", "must be >= 2", self.commands)
        _check(0.0 < self.step_quantile <= 1.0, "planner.step_quantile",
               "must be in (0, 1]", self.step_quantile)
        for name in ("context_support", "agreement"):
            _check(getattr(self, name) > 0, f"planner.{name}", "must be > 0",
                   getattr(self, name))
        _check(self.clearance >= 0, "planner.clearance", "must be >= 0", self.clearance)


@dataclass(frozen=True)
class EvaluationConfig:
    """Periodic evaluation during training (paper §5.1, Fig. 2)."""

    every: int = 200
    """Evaluate every this many iterations (a multiple of the episode length); 0 = never."""
    tasks: tuple[str, ...] = ("move-robot", "push-object", "push-with-tool")
    """Tasks (files in configs/tasks/) evaluated periodically."""

    def validate(self) -> None:
        _check(self.every >= 0, "evaluation.every", "must be >= 0 (0 disables)", self.every)


@dataclass(frozen=True)
class Config:
    """The whole resolved configuration of a run."""

    world: WorldConfig = field(default_factory=WorldConfig)
    """The simulated world: the body and its objects."""
    learner: LearnerConfig = field(default_factory=LearnerConfig)
    """The affordance learner."""
    planner: PlannerConfig = field(default_factory=PlannerConfig)
    """The controller that chains affordances to reach goals."""
    evaluation: EvaluationConfig = field(default_factory=EvaluationConfig)
    """Periodic evaluation."""

    def validate(self) -> None:
        for f in dataclasses.fields(self):
            getattr(self, f.name).validate()
        every, length = self.evaluation.every, self.world.episode_length
        _check(every % length == 0, "evaluation.every",
               f"must be a multiple of world.episode_length ({length})", every)

    def to_dict(self) -> dict[str, dict[str, Any]]:
        return dataclasses.asdict(self)


# --------------------------------------------------------------------------- loading

def field_docs(cls: type) -> dict[str, str]:
    """The docstring following each field of a dataclass, read from its source."""
    try:
        tree = ast.parse(inspect.getsource(cls))
    except (OSError, TypeError):
        return {}
    body = tree.body[0].body  # type: ignore[attr-defined]
    docs: dict[str, str] = {}
    for stmt, nxt in zip(body, body[1:], strict=False):
        if (isinstance(stmt, ast.AnnAssign) and isinstance(stmt.target, ast.Name)
                and isinstance(nxt, ast.Expr) and isinstance(nxt.value, ast.Constant)
                and isinstance(nxt.value.value, str)):
            docs[stmt.target.id] = nxt.value.value
    return docs


def _coerce(key: str, value: Any, annotation: Any) -> Any:
    """Check a TOML value against a field's type; ints are accepted for floats."""
    kind = annotation if isinstance(annotation, type) else typing.get_origin(annotation)
    if isinstance(kind, type) and issubclass(kind, enum.Enum):
        return _coerce_enum(key, value, kind)
    if kind is float:
        return _coerce_float(key, value)
    if kind is bool:
        if not isinstance(value, bool):
            raise ConfigError(f"config key '{key}' must be true or false, got {value!r}")
        return value
    if kind is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(f"config key '{key}' must be an integer, got {value!r}")
        return value
    if kind is str:
        if not isinstance(value, str):
            raise ConfigError(f"config key '{key}' must be a string, got {value!r}")
        return value
    if kind is tuple:
        (item,) = {a for a in typing.get_args(annotation) if a is not Ellipsis}
        if not isinstance(value, list | tuple):
            raise ConfigError(f"config key '{key}' must be a list, got {value!r}")
        return tuple(_coerce(key, v, item) for v in value)
    raise ConfigError(f"config key '{key}' has an unsupported type {annotation!r}")


def _coerce_float(key: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ConfigError(f"config key '{key}' must be a number, got {value!r}")
    value = float(value)
    if not math.isfinite(value):
        raise ConfigError(f"config key '{key}' must be finite, got {value!r}")
    return value


def _coerce_enum(key: str, value: Any, kind: type[enum.Enum]) -> enum.Enum:
    try:
        return kind(value)
    except ValueError:
        allowed = ", ".join(repr(m.value) for m in kind)
        raise ConfigError(f"config key '{key}' must be one of {allowed}, got {value!r}"
                          ) from None


def _build(cls: type, values: Mapping[str, Any], prefix: str) -> Any:
    hints = typing.get_type_hints(cls)
    names = {f.name for f in dataclasses.fields(cls)}
    kwargs: dict[str, Any] = {}
    for key, value in values.items():
        full = f"{prefix}{key}"
        if key not in names:
            allowed = ", ".join(sorted(names))
            raise ConfigError(f"unknown config key '{full}' (allowed: {allowed})")
        hint = hints[key]
        if dataclasses.is_dataclass(hint):
            if not isinstance(value, Mapping):
                raise ConfigError(f"config key '{full}' must be a table [{full}]")
            kwargs[key] = _build(hint, value, f"{full}.")
        else:
            kwargs[key] = _coerce(full, value, hint)
    return cls(**kwargs)


def _merge(base: dict[str, Any], extra: Mapping[str, Any]) -> dict[str, Any]:
    out = dict(base)
    for key, value in extra.items():
        if isinstance(value, Mapping) and isinstance(out.get(key), Mapping):
            out[key] = _merge(out[key], value)
        else:
            out[key] = value
    return out


def parse_override(text: str) -> dict[str, Any]:
    """`section.key=value` → nested dict; the value is read as TOML, else as a string."""
    if "=" not in text:
        raise ConfigError(f"override '{text}' must look like section.key=value")
    dotted, raw = text.split("=", 1)
    parts = [p.strip() for p in dotted.strip().split(".")]
    if not all(parts):
        raise ConfigError(f"override '{text}' must look like section.key=value")
    try:
        value = tomllib.loads(f"v = {raw.strip()}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw.strip()
    nested: dict[str, Any] = {parts[-1]: value}
    for part in reversed(parts[:-1]):
        nested = {part: nested}
    return nested


def read_toml(path: Path, what: str = "config file") -> dict[str, Any]:
    """The TOML file `path`; `what` names it in a refusal ("config file", "task file")."""
    try:
        with path.open("rb") as fh:
            return tomllib.load(fh)
    except FileNotFoundError:
        raise ConfigError(f"{what} not found: {path}") from None
    except IsADirectoryError:
        raise ConfigError(f"{what} {path} is a directory") from None
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{what} {path} is not valid TOML: {exc}") from None


def config_from_dict(values: Mapping[str, Any]) -> Config:
    """Build and validate a Config from nested plain values (e.g. a stored run's config)."""
    config = _build(Config, values, "")
    config.validate()
    return config


def stored_config(values: Mapping[str, Any]) -> Config:
    """The Config of a stored run: `values` without the keys and tables the installed version
    does not know (`unknown_keys`), and the installed defaults for those it lacks
    (`missing_keys`). A stored config was validated when it was stored, so an unknown key is
    one a later version removed, a missing one a key added since; the installed code acts in
    their place (a run's D, H and models are data, the code that learns and acts on them is
    the installed version's), and `runs.version_note` names both."""
    return config_from_dict(_compare(Config, values, "")[0])


def unknown_keys(values: Mapping[str, Any]) -> list[str]:
    """The dotted keys of `values` the installed Config does not know (`stored_config`)."""
    return _compare(Config, values, "")[1]


def missing_keys(values: Mapping[str, Any]) -> list[str]:
    """The dotted keys of the installed Config that `values` lacks: a stored run of an earlier
    version takes the installed defaults for them (`stored_config`)."""
    return _compare(Config, values, "")[2]


def _compare(cls: type, values: Mapping[str, Any], prefix: str
             ) -> tuple[dict[str, Any], list[str], list[str]]:
    """`values` against the dataclass `cls`, table by table: the values of the keys it knows,
    the dotted keys it does not know, and those of its own that `values` lacks."""
    hints = typing.get_type_hints(cls)
    known: dict[str, Any] = {}
    unknown: list[str] = []
    for key, value in values.items():
        if key not in hints:
            unknown.append(f"{prefix}{key}")
            continue
        if dataclasses.is_dataclass(hints[key]) and isinstance(value, Mapping):
            value, more, _ = _compare(hints[key], value, f"{prefix}{key}.")
            unknown.extend(more)
        known[key] = value
    missing: list[str] = []
    for key, hint in hints.items():
        if key not in values:
            missing.append(f"{prefix}{key}")
        elif dataclasses.is_dataclass(hint) and isinstance(values[key], Mapping):
            missing.extend(_compare(hint, values[key], f"{prefix}{key}.")[2])
    return known, unknown, missing


def load_config(path: Path | None = None, overrides: Iterable[str] = ()) -> Config:
    """The defaults, then `path` (a TOML file), then each `section.key=value` override."""
    values = read_toml(configs_dir() / "default.toml")
    if path is not None:
        values = _merge(values, read_toml(Path(path)))
    for text in overrides:
        values = _merge(values, parse_override(text))
    return config_from_dict(values)


def with_overrides(config: Config, overrides: Iterable[str]) -> Config:
    """A copy of `config` with `section.key=value` overrides applied and validated."""
    values: dict[str, Any] = config.to_dict()
    for text in overrides:
        values = _merge(values, parse_override(text))
    return config_from_dict(values)
