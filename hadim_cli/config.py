"""Configuration: frozen dataclasses loaded from TOML, validated at load.

Every section is a frozen dataclass whose fields carry a docstring (the string literal that
follows them). `load_config` reads `configs/default.toml` (or a user's file), applies repeated
`--set section.key=value` overrides and validates; any unknown key, wrong type or impossible
value raises `ConfigError` naming the key and what is allowed.
"""

from __future__ import annotations

import ast
import dataclasses
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


@dataclass(frozen=True)
class WorldConfig:
    """The simulated room of the paper (§3.1)."""

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
    """No object within this distance of the robot's start (m)."""
    object_gap: float = 0.05
    """Smallest free gap between two objects and between an object and a wall (m)."""
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
        needed = n * (2 * r) ** 2 * 1.6
        _check(free >= needed, "world.n_green",
               f"{n} objects of radius up to {self.object_radius_max} m do not fit in a "
               f"{self.room_width}x{self.room_height} m room; lower the count or the radius",
               self.n_green)


@dataclass(frozen=True)
class LearnerConfig:
    """The learner of the paper (§3.2–4): exploration, models, adaptation, planning."""

    sigma: float = 0.7
    """Probability of goal babbling (vs a random controllable) once H is not empty (paper σ)."""
    random_sequence_length: int = 8
    """Primitive actions of one random-action learning episode (motor babbling)."""
    k_forward: int = 10
    """Neighbours of the forward model's local linear fit (until `k_choices` chose one)."""
    k_choices: tuple[int, ...] = (10, 20, 30)
    """Neighbourhoods each model's forward fits may take: whenever its rows have doubled
    (from 32), the one of least leave-one-out error on them (`LocalLinearModel.k_choices`).
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
    free_motion: bool = True
    """The robot's own motion affordances (primitive action → robot position or heading)
    learn from the actions it took clear of everything: no object within contact (plus
    `affordance.CONTACT_MARGIN`) and no LIDAR ray shorter than its radius plus that margin,
    before and after the action. A robot pressed against a wall or an object does not move as
    its wheels say; such rows among free moves bent the local fits (held-out error on free
    moves: 90th percentile 3.8 cm with them, 1.0 cm without, docs/notes.md). Off: every
    action's row."""
    body_frame: bool = True
    """With `relation_frames`: fit the robot's own motion affordances (primitive action →
    robot position or heading) with the robot's heading as a context in the frame of that
    heading, where a wheel command moves the robot the same way whichever way it faces. Off:
    in room coordinates, where neighbours of other headings turn each prediction."""
    zero_eps: float = 0.004
    """An outcome smaller than this (in its space's units) counts as null."""
    tau_creation: float = 0.3
    """Competence a new affordance needs to be added to H (paper τ_creation)."""
    tau_modification: float = 0.3
    """Competence a context change needs to be kept (paper τ_modification)."""
    context_gain: float = 0.1
    """A context change must also raise competence by at least this much (half of it for a
    replacement, tested on one held-out split; see `context_splits`)."""
    context_splits: int = 1
    """Held-out splits on which a replacement of a context that falls short of half
    `context_gain` on the first is tested again: it is made when its gain, paired split by
    split, exceeds twice its standard error. 1: never — the default (with 5, a tool
    affordance went over to the robot's relation mid-run on a paired gain the later data
    reversed: `push-with-tool` 0.34 at 2000 instead of 0.60, 10 seeds; docs/algorithm.md)."""
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
    chain_objects: bool = True
    """ObjectSelection for an affordance acting through a tool takes, of the pairs p_A and the
    tool's controller accept, the (target, tool) whose chain is shortest: the robot's way to
    the tool plus the tool's way to the target (for one object, the paper's closest object).
    Off: the closest target, then the tool nearest it, however far the robot must go first."""
    own_relations: bool = True
    """A context about an entity the affordance neither acts with nor acts on (the robot's
    relation to the target, or its heading, for a push through a tool) counts as one more
    context: it must beat the others by `context_gain`. Such a relation predicts about as
    well while the entity trails the affordance's input (the robot behind the tool), but the
    planner cannot establish it through that input: held for a thousand iterations it left
    the tool level placing the robot (docs/algorithm.md). Off: ranked by competence alone."""
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
    untried_interest: bool = False
    """AffordanceSelection takes an affordance that has been tried on fewer goals than
    `interest_window` (its learning progress not measured yet) as interesting as the most
    interesting one, so every affordance H gains is practised before its interest decides.
    Off: its map's interest (the unexplored floor, then the progress of its few goals)."""
    paper_interest: bool = False
    """The interest maps as the paper has them (§4.4 and Algorithm 1's UpdateInterestMaps):
    after every learning episode, goal babbling or random, each affordance's map records every
    non-null outcome the episode reached in its output space, with the competence of the
    forward model's estimate for the controllable executed (1 − min(1, error / the output's
    range)); a region's interest is the mean of its last `interest_window` learning progresses
    (`interest.paper_progress`). Off: a map records goal-babbling attempts only, with the
    competence of the attempt, and a region's interest is the half-window difference
    (docs/algorithm.md, "Interest maps", for what each measured)."""
    surface_relations: bool = True
    """Read relative positions (target-robot, target-tool, …) between the two bodies'
    surfaces, offset by `relation_offset`, instead of centre to centre (the paper's wording):
    a contact then reads the same whatever the objects' sizes."""
    relation_offset: float = 0.3
    """Length (m) a relation reads at contact when `surface_relations` is on (> 0: a contact
    keeps its direction); about the robot's radius plus a middling object's."""
    relation_frames: bool = True
    """Fit the models of an affordance with a relation context (target-robot, target-tool) in
    the frame of that relation: a push then reads the same from any bearing (the physics of
    the room turns with the scene). Off: in room coordinates."""
    classifier_hidden: int = 32
    """Width of the two hidden layers of each visual classifier p_A."""
    classifier_steps: int = 30
    """Training steps of p_A after each learning episode that gave it examples."""
    p_a_blocked_pushes: bool = False
    """Also teach p_A of an affordance acting from the robot's motion (`robot.position →
    target.position`) the objects that *stopped* the robot: touched, the robot's motion model
    predicting a move that would have pushed them, neither moving — in every learning
    episode, including those where nothing moved. Such rows are outside the affordance's
    domain (its input did not change), so without this its p_A hardly ever sees a red object
    as a negative (docs/algorithm.md, p_A). Off: not measured enough to be the default."""
    open_contexts: bool = True
    """Let Algorithm 2 pick contexts among every observed space of the objects an affordance
    binds (absolute position, colour, shape as well as the relation to the robot, radius and
    height), as the paper does (the default since 2026-11-25: no worse on twenty seeds); off:
    the fixed list of `spaces.context_candidates` (docs/algorithm.md, "Departures from the
    paper that remain", for what each measured)."""
    open_outputs: bool = False
    """Let the LIDAR be the output of an affordance too (`spaces.OPEN_OUTPUT_SPACES`), as the
    paper lets any space be; off: the robot's position and heading and an object's position
    (docs/algorithm.md, departures, for what opening it measured)."""
    absorb_mismatch: bool = False
    """An affordance keeps the rows of an update that did not match (its competence fell by
    more than `match_tolerance`) even when no context change makes them fit. Off (the paper's
    Algorithm 2, the default since 2026-11-25: no worse on twenty seeds): such rows are given
    back and the affordance refitted without them (docs/algorithm.md, "Departures from the
    paper that remain", for what each measured)."""
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
    p_a_pooled: bool = True
    """Teach p_A of every affordance with the same output (`target.position`: every
    object-moving affordance) the same examples: the objects any of them moved (positives),
    those any of them was applied to in vain (or, with `p_a_refusals`, that refused the
    robot), and the robot (negatives), one per object and label per learning episode. Whether
    an object's position can be changed is a fact about the object, seen by whichever
    affordance acted on it; a fixed object stops the robot or the tool, so its pushes in vain
    are seldom rows of the pushing or the tool affordance (docs/algorithm.md, p_A). Off: each
    affordance learns from its own rows only."""
    p_a_refusals: bool = True
    """With `p_a_pooled`: p_A's negatives for the object-moving affordances are the objects
    that *refused* the robot — it touched one, its motion model (the most competent
    controller of `robot.position` from the actions) meant to move at least half its step
    into the object, the robot moved less than half as far as it meant, and the object did
    not move in the environment episode — taught after every learning episode, whatever
    moved in it. They replace the objects an affordance's own model expected to move
    (`Adaptation._applied_in_vain`), which made pushable objects negatives after grazes and
    backing away. Off: those (docs/algorithm.md, p_A, for what each measured)."""

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
                     "classifier_steps", "deletion_patience", "context_review_every",
                     "context_splits"):
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
        _check(self.p_a_pooled or not self.p_a_refusals, "learner.p_a_refusals",
               "needs learner.p_a_pooled = true (refusals are taught to every object-moving "
               "affordance)", self.p_a_refusals)
        _check(self.paper_matching or not self.paper_match_adds, "learner.paper_match_adds",
               "needs learner.paper_matching = true (it adds the data a match with another "
               "output found)", self.paper_match_adds)
        for name in ("zero_eps", "competence_sharpness", "zero_ratio", "reach_tolerance",
                     "relation_offset"):
            value = getattr(self, name)
            _check(value > 0, f"learner.{name}", "must be > 0", value)


@dataclass(frozen=True)
class PlannerConfig:
    """How goals become primitive actions through the chain of learned affordances (paper
    §4.3, docs/algorithm.md "Planner"). Stored with each run; a run stored before this section
    existed keeps the planner it trained with (`LEGACY_DEFAULTS`: no navigation)."""

    max_depth: int = 4
    """Deepest chain of affordances one goal is decomposed through."""
    step_quantile: float = 0.9
    """Sub-goals are cut to this quantile of an affordance's non-null outcome norms."""
    context_support: float = 0.1
    """Relations further apart than this (in their model's scale) vote apart when choosing the
    context an outcome is usually produced from."""
    agreement: float = 0.4
    """Rows whose relation is within this (in their model's scale) of the densest one's agree
    with it; the needed relation is fitted on them."""
    place_support: float = 0.1
    """A relation further than this many spreads (of that relation over the rows with an
    effect) from the needed one is not the same place."""
    realign: float = 0.45
    """With `replace_by_cost` off: re-place when the current relation has drifted further than
    this many spreads from the needed one."""
    support_neighbours: int = 3
    """Forward neighbours looked at to decide whether a context is supported by data."""
    pose_match: float = 0.3
    """Rows whose outcome is within this fraction of a step's length count as producing it."""
    small_correction: float = 0.5
    """A sub-goal's remainder shorter than this fraction of a typical step is not worth
    re-placing for."""
    subgoal_tolerance: float = 0.3
    """A sub-goal counts as reached within this fraction of its affordance's typical step."""
    approach_margin: float = 0.06
    """Clearance (m) kept round an object when the route to a place goes round it."""
    max_detours: int = 3
    """Objects a route to a place goes round at most."""
    avoid_margin: float = 0.05
    """Gap (m) the robot keeps from an entity it must not touch (the target while a tool
    moves it): the contact margin (0.02 m) plus about the held-out error of the robot's
    motion model over one action."""
    navigation: bool = True
    """Reach the robot's places by a search over its learned motion (forward models of
    action → robot.position and action → robot.heading), arriving facing the way the next
    step moves; off: through the inverse model of action → robot.position, turning first."""
    navigation_grid: int = 9
    """Wheel commands per wheel (an n × n grid over [-1, 1]²) the navigation search scores."""
    heading_tolerance: float = 0.35
    """A place is reached facing the wanted way within this angle (rad); either way along it
    counts (the robot drives backwards as well as forwards)."""
    approach_distance: float = 0.08
    """The last stretch (m) before a place is driven straight along the wanted heading."""
    steer: bool = True
    """Roughly aligned (the context relation within `realign` spreads of the needed one, but
    off by more than `place_support`), a level pushes on and steers: its input entity moves by
    the step asked from the needed relation plus the way back to that relation (a tool that
    slid along the target's side is pushed on and back behind it), instead of a trip to the
    needed place. Off: the fixed rule (`realign`) decides between pushing on as is and a
    trip."""
    pursue_line: bool = True
    """With `hold_relation`: the input heads for the point one inverse-model step ahead of it
    on the line it must push along (from its place in the needed relation to the output now,
    toward the goal): pure pursuit, which brings an input off the line back onto it and turns
    its contact with the output back onto the way. Off: it heads for its final place (the goal
    less the needed relation), which corrects a lateral offset only as slowly as the distance
    left allows while the contact slides further off."""
    hold_relation: bool = True
    """An input that is itself an object pushed by another affordance (the tool of
    `tool.position → target.position`) heads, while its relation to the output is within
    `realign` spreads of the needed one, for where it will be when the output is at its goal
    (that goal less the needed relation), one inverse-model step at a time — instead of a
    fresh inverse answer and steering each step. Its direction then stays put between steps,
    and every change of it would cost its pusher a trip round it. Off: the inverse answer
    and `steer` as for any input."""
    finish_trips: bool = False
    """A level whose last action served a trip to its needed context goes on with the trip
    until it is within `place_support` of that context, instead of deciding afresh (and
    pushing or steering as soon as the relation is back within `realign`). Off: every action
    decides anew whether to re-place (docs/algorithm.md: fewer trips, a lower score retrained)."""
    pose_places: bool = True
    """An affordance acting from the robot's actions with the robot's heading as a context
    besides a relation (`action → target.position | target-robot, robot.heading`): the place it
    pushes from is chosen with the heading of the data there (pushes like the wanted one were
    made facing it), and the robot drives there arriving facing it, in one trip. Off: the
    heading needed is the one the robot had before the trip, and the robot turns back to it
    after driving there."""
    closer_places: bool = True
    """A relation on the bearing of the needed one but shorter (the pusher nearer its object,
    down to contact) counts as the needed place: only the bearing, and being further than
    needed, take a pusher off its place. Off: any difference of the relation does (the push
    that closed a gap read as a pusher off its place, and the next step sent it back)."""
    contact_places: bool = True
    """With `closer_places`: a trip to a needed relation that reads a gap between the bodies
    drives to contact (plus the contact margin) on that relation's bearing instead, so the
    first action from there pushes. Off (or `closer_places` off): to the needed relation as
    it reads, from where the push's first action closes the gap."""
    relations_seen: bool = False
    """A needed relative position fitted shorter than every row it was fitted on (rows from
    both sides of an object averaging to a place inside it) is replaced by the relation of
    the row most rows agree with. Off: the fit stands."""
    replace_by_cost: bool = False
    """Re-place only when the trip (its estimated actions) plus pushing from the new place
    costs less than pushing on from here at the rate the forward model predicts; off: the
    fixed `realign` / `place_support` tolerances decide."""
    near_pursuit: bool = True
    """With `closer_places` and `pursue_line`: an input nearer its output than the needed
    relation, on its bearing, pursues the line from where it stands (the needed relation
    brought to its length), as it counts as at its place. Off: from the needed relation's
    place behind it, so that a tool 9 cm nearer the target than needed was asked a move of
    3 cm sideways — shorter than the tolerance of its pusher's sub-goal: nothing moved, and
    the point stalled with its budget left (one retrained learner scored 0.00)."""
    precise_places: bool = True
    """Within a place's tolerance the navigator still prefers, of the commands it scores, the
    one ending nearest the place: a push steers by a few centimetres (a contact 5° off the
    line is 2 cm), less than the tolerance of a push's sub-goal. Off: every command ending
    within the tolerance is as good, and the first of the grid (a full-speed straight drive)
    is taken."""

    route_search: bool = True
    """With `navigation`: a trip of the robot to the place an affordance pushes from is
    planned as a sequence of primitive actions (a search over the learned motion, at most
    `route_depth` actions deep, that keeps out of every object and estimates what is left
    round the objects in its way), replanned after every action. Off: one action at a time
    toward waypoints round the objects in the way (out to each waypoint, a turn on the spot,
    the next one)."""
    route_depth: int = 6
    """Actions ahead the trip search looks (`route_search`)."""
    route_beam: int = 24
    """Sequences the trip search keeps at each depth, the cheapest by their estimated
    actions (`route_search`)."""
    pusher_contacts: bool = True
    """With `contact_places`: only a relation to the entity that pushes (the tool, for an
    affordance acting through one; else the robot) is brought to contact on a trip. Off:
    every relation the planner drives is, the robot's to the target under a tool affordance
    too (runs stored before keep it off)."""
    spare_stagings: bool = True
    """A level whose input is another object (the tool level) spares a trip for a remainder
    shorter than `small_correction` steps once its output has moved towards the goal, as a
    goal with an entity to avoid does: that trip stages the object round the output, and its
    pushes can shove the output further off than the remainder. Off: such a level chases
    every remainder (runs stored before keep it off)."""

    line_stagings: bool = False
    """Option, off: an object staged round another to the place it pushes from (the tool to
    behind the target) goes in one leg to the nearest point further back on the push's own
    line (from the other object through that place) whose straight way there clears every
    object, then along that line to the place: it arrives moving the way it will push, and
    its pusher makes one trip round it for the turn instead of one per leg. Off (or no such
    point inside the room): round the object in the way by two waypoints on an arc, a leg
    for each third of the turn. Evaluation only it lowered the robot-only share a little;
    retrained, not (docs/notes.md, eighteenth session)."""

    direct_remainders: bool = False
    """Option, off: with `hold_relation`, the last stretch of a level whose input is another
    object (a remainder shorter than `small_correction` steps) is pushed by the inverse
    model's answer from where the input stands, not by pursuit of the line: near the goal
    the pursuit's point one step ahead can lie as far sideways as forward, and its pusher's
    trip for that sideways move is refused as a small remainder, which ended goals 5-6 cm
    short with most of their budget left. Off: the pursuit to the end (docs/notes.md,
    eighteenth session)."""

    skip_idle_repeats: bool = True
    """A primitive action that moved nothing (no value of the observation changed) is not
    asked again from the observation it left: the level asking gets nothing done, and gives
    up or tries another way. Off: the planner, which decides from the observation alone,
    repeats it until the attempt's budget is spent (a robot backing into a fixed object 28
    times; runs stored before keep it off)."""

    drifting_places: bool = True
    """The navigator's stall count (a place given up after actions that get no closer)
    follows a place that moved by less than its tolerance since the last action as the same
    place. Off: a place is the same only to a tenth of a millimetre, and one computed afresh
    every action (behind an object) never stalls (runs stored before keep it off)."""

    face_places: bool = True
    """With `navigation`: a trip of the robot that has brought it to its place goes on until
    the robot faces the heading the place was taken with (the trip search arrives facing it
    when it can), instead of ending there and leaving the turn to the push (a robot turned
    57° by its trip turned 57° back for its first push). Off: the trip ends at the place
    (runs stored before keep it off)."""

    mirrored_relations: bool = True
    """The place an affordance acts from (`Planner.needed_context`) is fitted over its rows and
    their mirror images across the line of the wanted outcome: the room's physics is the same
    in a mirror, and the place fitted over both sides of the line lies on it. Off: over the
    rows as stored, whose place came out 3-8° (median) off the line of the push, at the edge
    of the cone within which a pushed object keeps moving with its pusher (runs stored
    before keep it off)."""

    convoy: bool = True
    """With `hold_relation`: an object pushing another (the tool pushing the target) within
    `realign` of its place is asked to move along the move wanted of the output, at the length
    whose outcome its forward model predicts nearest that move (`Planner.straight_move`),
    instead of pursuing the line behind the output; and the robot pushing it for that move
    pushes along the move asked of the object, at the length its own forward model predicts
    best. A pushed object moves with its pusher while robot, tool and target are bent by less
    than about 10° (docs/algorithm.md); the pursuit's sideways part and the push level's
    redundant inverse answers bent the chain 14° (median) at the target's first push, and the
    target left its way by 10°. Off: the pursuit and the inverse answers (runs stored before
    keep it off)."""

    convoy_facing: bool = True
    """With `convoy`: the robot's push in a convoy step is a pose, its place and a heading
    along the push (either way along it), so the robot drives straight along the move it is
    asked for. A chain of discs goes where its pusher drives; asked for a place alone, the
    robot reached each push's end by an arc, ±12° about the way, one arc one way and the next
    the other, and the target went up to 15° off (docs/algorithm.md). Off: the place alone
    (runs stored before keep it off)."""

    convoy_plan: bool = True
    """With `convoy`: each action of a convoy (the robot behind the object, within `realign`
    of its place, the object within `realign` of its own) is chosen through the chain's
    forward models — the robot's motion, its push of the object, the object's push of the
    output — by the output's predicted distance to its goal and the two relations' predicted
    drift (`Planner._convoy_plan`). The convoy pushed straight drifts 6-10° a push, the target
    going along the tool-target line of centres, until a correction of about 18 robot-only
    actions (docs/notes.md, twenty-third session); retrained on thirty-five seeds the tool
    task's robot-only share fell from 62.2 to 58.1 % (docs/algorithm.md). Off: the straight
    convoy step (runs stored before keep it off)."""

    convoy_turn: float = 8.0
    """With `convoy_plan`: the largest predicted turn (degrees) of the robot's commands it
    considers: the push's model reads the robot's net move, which an arc and a straight push
    share, and errs 0.6 cm (median) under 5°, 1.6-1.9 cm at 5-30°."""

    convoy_drift_cost: float = 3.0
    """With `convoy_plan`: the cost, in steps of the output's way, of a relation predicted to
    drift to `realign` (where a correction of two trips would follow)."""

    convoy_trailing: bool = True
    """With `convoy`: an object behind the output on the bearing of its place but short of
    it (the tool trailing behind the target, not yet touching it) holds the relation for a
    convoy: the relation's gap to its place is taken at its own length (`Planner._convoy_hold`),
    and the convoy's first push closes the distance. Off: the distance counts as drift, and a
    tool staged a few centimetres short, or set out behind the target from the start, cost a
    trip to the place at contact before the convoy (runs stored before keep it off)."""

    convoy_goes_on: bool = True
    """With `convoy_plan`: a convoy whose tool–target relation drifted past `realign` goes on
    through the chain, instead of a correction, while pushing on along the tool–target line
    would bring the target within `small_correction` of a step of its goal
    (`Planner._goes_on`): near a goal a correction gains little (traced: three corrections of
    13–24 actions for 8 cm, each leaving the line 15–25° off again). Off: every drift past
    `realign` re-stages the tool (runs stored before keep it off)."""

    convoy_depth: int = 1
    """With `convoy_plan`: how many actions in a row the convoy imagines through the chain's
    forward models before it chooses the first."""

    stall_trips: bool = True
    """A sub-goal's correction shorter than `small_correction` steps is spared a trip while
    the goal it serves can do something else; once that goal stalled (its last step moved
    nothing) while still more than `small_correction` of its own steps away, the next one is
    made. Off: always spared: a staging whose tool was a few centimetres off its place, the
    tool's pusher refused the trip, the tool level asked for the same staging again, and the
    point ended with its target unmoved (seed 59 at 2000: 0.02; docs/algorithm.md). Runs
    stored before keep it off."""

    room_places: bool = True
    """A place for the robot or an object closer to a wall than the body's radius (outside the
    room's position space, less that radius) is one it cannot take: the step that needs it is
    not taken. Off: driven toward all the same — in training a tool goal whose target stood
    against a wall sent the tool toward a place beyond the wall for the whole 40-action
    budget (docs/algorithm.md). Runs stored before keep it off."""

    solid_bodies: bool = True
    """A needed relative position that places an object overlapping another (shorter than
    contact: a young model's fit, or rows from both sides of an object averaging to a place
    inside it) is brought out to contact on its own bearing: no object is staged inside
    another. The robot's place pressed into the object it pushes stands (its trip ends
    pushing). Off: the fit stands, and a tool asked to stand inside its target shoves the
    target while it is staged, the place behind it moving with every push (seed 10 at 2000:
    0.53; docs/algorithm.md). Runs stored before keep it off."""

    short_subgoals: bool = True
    """A sub-goal shorter than its affordance's typical step counts as reached within
    `subgoal_tolerance` of its own length, not of a step: the convoy's last step asked the
    tool for 3.7 cm, its pusher's sub-goal read as reached within 4.5 cm before any action,
    and the point ended 3.7 cm from its goal with 75 of its 80 actions left. A goal reached
    through an affordance's steps only: the navigator's place for one move of the robot keeps
    the share of a step (made relative too, the robot-only share rose: docs/algorithm.md).
    Off: the share of a step whatever the sub-goal's length (runs stored before keep it
    off)."""

    def validate(self) -> None:
        for name in ("max_depth", "support_neighbours", "max_detours", "navigation_grid",
                     "route_depth", "route_beam"):
            value = getattr(self, name)
            _check(value >= 1, f"planner.{name}", "must be >= 1", value)
        _check(self.navigation_grid >= 3, "planner.navigation_grid", "must be >= 3",
               self.navigation_grid)
        _check(0.0 < self.step_quantile <= 1.0, "planner.step_quantile", "must be in (0, 1]",
               self.step_quantile)
        for name in ("context_support", "agreement", "place_support", "realign", "pose_match",
                     "small_correction", "subgoal_tolerance", "heading_tolerance"):
            value = getattr(self, name)
            _check(value > 0, f"planner.{name}", "must be > 0", value)
        for name in ("approach_margin", "avoid_margin", "approach_distance",
                     "convoy_drift_cost"):
            value = getattr(self, name)
            _check(value >= 0, f"planner.{name}", "must be >= 0", value)
        _check(0.0 <= self.convoy_turn <= 180.0, "planner.convoy_turn", "must be in [0, 180]",
               self.convoy_turn)
        _check(self.convoy_depth >= 1, "planner.convoy_depth", "must be >= 1",
               self.convoy_depth)


@dataclass(frozen=True)
class EvaluationConfig:
    """Periodic evaluation during training (paper §5.1, Fig. 2)."""

    every: int = 200
    """Evaluate every this many iterations (a multiple of the episode length); 0 = never."""
    tasks: tuple[str, ...] = ("move-robot", "push-object", "push-with-tool")
    """Tasks (files in configs/tasks/) evaluated periodically."""

    def validate(self) -> None:
        _check(self.every >= 0, "evaluation.every", "must be >= 0 (0 disables)", self.every)


CONTROLLERS = ("rules", "search")
"""The controllers that turn goals into primitive actions (`ControllerConfig.kind`)."""


@dataclass(frozen=True)
class ControllerConfig:
    """Which controller turns goals into primitive actions, and the search controller's
    constants (hadim_cli/learner/controller.py, docs/algorithm.md "The search controller")."""

    kind: str = "rules"
    """"rules": the planner of docs/algorithm.md, the default; "search": one receding-horizon
    search over the chain's forward models (it does not yet reach the planner's scores on the
    tool task: docs/results.md)."""
    commands: int = 9
    """Primitive actions the search tries: an n × n grid over the action space."""
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
        _check(self.kind in CONTROLLERS, "controller.kind",
               f"must be one of {', '.join(CONTROLLERS)}", self.kind)
        for name in ("commands", "horizon", "beam"):
            _check(getattr(self, name) >= 1, f"controller.{name}", "must be >= 1",
                   getattr(self, name))
        _check(self.commands >= 2, "controller.commands", "must be >= 2", self.commands)
        _check(0.0 < self.step_quantile <= 1.0, "controller.step_quantile",
               "must be in (0, 1]", self.step_quantile)
        for name in ("context_support", "agreement"):
            _check(getattr(self, name) > 0, f"controller.{name}", "must be > 0",
                   getattr(self, name))
        _check(self.clearance >= 0, "controller.clearance", "must be >= 0", self.clearance)


@dataclass(frozen=True)
class Config:
    """The whole resolved configuration of a run."""

    world: WorldConfig = field(default_factory=WorldConfig)
    """The simulated room."""
    learner: LearnerConfig = field(default_factory=LearnerConfig)
    """The affordance learner."""
    planner: PlannerConfig = field(default_factory=PlannerConfig)
    """The planner that chains affordances to reach goals."""
    controller: ControllerConfig = field(default_factory=ControllerConfig)
    """Which controller turns goals into actions (the planner's rules, or the search)."""
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
    if kind is float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ConfigError(f"config key '{key}' must be a number, got {value!r}")
        value = float(value)
        if not math.isfinite(value):
            raise ConfigError(f"config key '{key}' must be finite, got {value!r}")
        return value
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


LEGACY_DEFAULTS: dict[str, dict[str, Any]] = {
    "world": {"settle_time": 0.0},
    "learner": {"surface_relations": False, "relation_frames": False, "context_splits": 1,
                "p_a_pooled": False, "free_motion": False, "body_frame": False,
                "p_a_refusals": False, "open_contexts": False, "absorb_mismatch": True,
                "k_choices": (), "chain_objects": False,
                "own_relations": False},
    "planner": {"navigation": False, "steer": False, "hold_relation": False,
                "pose_places": False, "pursue_line": False, "closer_places": False,
                "contact_places": False, "precise_places": False,
                "near_pursuit": False, "route_search": False, "spare_stagings": False,
                "pusher_contacts": False, "skip_idle_repeats": False,
                "drifting_places": False, "face_places": False,
                "mirrored_relations": False, "convoy": False,
                "convoy_facing": False, "short_subgoals": False, "convoy_plan": False,
                "stall_trips": False, "room_places": False, "solid_bodies": False,
                "convoy_trailing": False, "convoy_goes_on": False},
}
"""Keys added after runs were first stored, with the value that reproduces what a run stored
without them did (its defaults then): a stored run restores the learner it trained (the
planner's constants are code, and follow the installed version)."""


CODE_SECTIONS = ("planner", "controller")
"""Sections whose keys are constants of the installed code, not of the run: a stored run's
keys that the installed version no longer has are dropped (a run's D, H and models are data;
how goals are turned into actions is code)."""


def stored_config(values: Mapping[str, Any]) -> Config:
    """The Config of a stored run: `values`, with `LEGACY_DEFAULTS` for keys it lacks and
    without the keys of `CODE_SECTIONS` the installed version does not know."""
    filled = dict(values)
    for section in CODE_SECTIONS:
        if isinstance(filled.get(section), Mapping):
            known = {f.name for f in dataclasses.fields(typing.get_type_hints(Config)[section])}
            filled[section] = {k: v for k, v in filled[section].items() if k in known}
    for section, legacy in LEGACY_DEFAULTS.items():
        table = dict(filled.get(section, {}))
        for key, value in legacy.items():
            table.setdefault(key, value)
        filled[section] = table
    return config_from_dict(filled)


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
