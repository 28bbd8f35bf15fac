"""The learner and its exploration loop (paper Algorithm 1).

A *learning episode* is one pass of Algorithm 1 (`Learner.learning_episode`, written as the
paper's pseudo-code): with probability σ (once H is not empty) goal babbling —
AffordanceSelection, GoalSelection, ObjectSelection, Plan/Execute, interest update — otherwise
a random value in a random controllable space; then the executed actions are adapted to
(Algorithm 2). Every fallback from what σ drew is recorded in the episode. An
*environment episode* (100 primitive actions) holds several learning episodes; the world is
reset between them and a learning episode in progress is cut there.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field, replace

import numpy as np

from hadim_cli.config import LearnerConfig, PlannerConfig
from hadim_cli.learner.adaptation import Adaptation
from hadim_cli.learner.affordance import Affordance, Fitter, output_bounds
from hadim_cli.learner.controller import Controller
from hadim_cli.learner.dataset import Dataset
from hadim_cli.learner.goals import Actuator, Binding
from hadim_cli.learner.hierarchy import Event, Hierarchy
from hadim_cli.learner.interest import select_index
from hadim_cli.learner.spaces import ACTION, Property, Role, RoleSpace, SpaceReader
from hadim_cli.world.actions import ActionSpace
from hadim_cli.world.layout import ObservationLayout


class Mode(enum.StrEnum):
    """How a learning episode explored."""

    RANDOM_ACTION = "random-action"
    RANDOM_CONTROLLABLE = "random-controllable"
    GOAL = "goal"


class Fallback(enum.StrEnum):
    """Why a learning episode explored otherwise than it set out to (σ's draw)."""

    GOAL_NO_OBJECT = "goal-no-object"
    """Goal babbling: no object for the affordance's roles (p_A accepts none, no tool)."""
    GOAL_NO_PLAN = "goal-no-plan"
    """Goal babbling: the controller executed no action towards the goal."""
    RANDOM_NO_OBJECT = "random-no-object"
    """A random controllable value: no object for its controller's roles."""
    RANDOM_NO_PLAN = "random-no-plan"
    """A random controllable value: the controller executed no action towards it."""


@dataclass(frozen=True)
class Explored:
    """What the exploration step of one learning episode did."""

    mode: Mode
    affordance_id: int = -1
    goal: np.ndarray = field(default_factory=lambda: np.zeros(0))
    competence: float = 0.0
    fallbacks: tuple[Fallback, ...] = ()

    def after(self, why: Fallback) -> Explored:
        """This exploration, done as the fallback `why` of another."""
        return replace(self, fallbacks=(why, *self.fallbacks))


@dataclass(frozen=True)
class LearningEpisode:
    """What one pass of Algorithm 1 did."""

    mode: Mode
    """How it explored in the end."""
    start: int
    stop: int
    affordance_id: int
    goal: tuple[float, ...]
    competence: float
    events: tuple[Event, ...]
    drawn: Mode = Mode.RANDOM_CONTROLLABLE
    """What σ's draw chose: GOAL (goal babbling) or RANDOM_CONTROLLABLE."""
    fallbacks: tuple[Fallback, ...] = ()
    """The fallbacks taken on the way from `drawn` to `mode`, in order."""


class Learner:
    """D, H and the machinery acting on them; knows nothing of the world but what it
    declares: its observation layout and its primitive action space."""

    def __init__(self, config: LearnerConfig, layout: ObservationLayout, actions: ActionSpace,
                 planner: PlannerConfig | None = None):
        self.config = config
        self.layout = layout
        self.actions = actions
        self.reader = SpaceReader(layout, config.relation_offset, actions)
        self.dataset = Dataset(layout.size, actions.dim)
        self.hierarchy = Hierarchy()
        self.fitter = Fitter(self.dataset, self.reader, config)
        self.adaptation = Adaptation(self.hierarchy, self.fitter, config)
        self.controller = Controller(self.hierarchy, self.reader, config,
                                     PlannerConfig() if planner is None else planner)
        """Turns goals into primitive actions (D and H are data; the controller is code)."""
        self.learning_episodes = 0

    @property
    def iteration(self) -> int:
        return len(self.dataset)

    # ------------------------------------------------------------------ object selection
    def accepted_objects(self, aff: Affordance, obs: np.ndarray) -> np.ndarray:
        """Entity indices of the objects p_A accepts (all objects while p_A knows nothing)."""
        objects = np.arange(1, len(self.layout.entities))
        if aff.classifier is None or aff.classifier.n_positive == 0:
            return objects
        features = np.stack([self.reader.visual_features(obs, int(e)) for e in objects])
        return objects[aff.classifier.accepts(features)]

    def closest(self, candidates: np.ndarray, obs: np.ndarray, exclude: int = -1,
                to: int = 0) -> int:
        """The candidate entity nearest entity `to` (the robot by default)."""
        anchor = self.reader.entity_position(obs, to)
        best, best_d = -1, np.inf
        for e in candidates:
            if int(e) == exclude:
                continue
            d = float(np.linalg.norm(self.reader.entity_position(obs, int(e)) - anchor))
            if d < best_d:
                best, best_d = int(e), d
        return best

    def select_binding(self, aff: Affordance, obs: np.ndarray) -> Binding | None:
        """ObjectSelection: the closest object p_A accepts; through a tool, of the pairs p_A
        and the tool's controller accept, the (target, tool) whose chain is shortest — the
        robot's way to the tool plus the tool's way to the target (for one object, the
        paper's closest object)."""
        if not aff.has_target:
            return Binding()
        targets = self.accepted_objects(aff, obs)
        if not targets.size:
            return None
        if not aff.has_tool:
            return Binding(target=self.closest(targets, obs))
        movers = self.hierarchy.controllers(aff.input)
        if not movers:
            return None
        return self._shortest_chain(targets, self.accepted_objects(movers[0], obs), obs)

    def _shortest_chain(self, targets: np.ndarray, tools: np.ndarray, obs: np.ndarray
                        ) -> Binding | None:
        """The (target, tool) pair whose chain is shortest: the robot's way to the tool plus
        the tool's way to the target; None when no two objects pair."""
        where = {int(e): self.reader.entity_position(obs, int(e))
                 for e in np.union1d(targets, tools)}
        robot = self.reader.entity_position(obs, 0)
        best, best_d = None, np.inf
        for tool in map(int, tools):
            reach = float(np.linalg.norm(where[tool] - robot))
            for target in map(int, targets):
                d = reach + float(np.linalg.norm(where[target] - where[tool]))
                if target != tool and d < best_d:
                    best, best_d = Binding(target=target, tool=tool), d
        return best

    def salient_goal(self, aff: Affordance, binding: Binding, obs: np.ndarray,
                     rng: np.random.Generator) -> np.ndarray | None:
        """For a share `salient_goals` of goals in an object's position space (random or by
        goal babbling), a goal where objects meet: the position of the object nearest the
        target among those `aff`'s p_A accepts (within reach of one attempt), pushed on by
        `salient_beyond` along the line from the target, so that the target has to push that
        object on (a long push, with the target as a tool); through a tool (`binding.tool`
        bound), the target itself pushed on along the line from the tool, i.e. the tool
        driven straight into it from where it is. None for the other goals."""
        space = aff.output
        if (space.role is not Role.TARGET or space.prop is not Property.POSITION
                or binding.target < 0 or rng.random() >= self.config.salient_goals):
            return None
        if binding.tool >= 0:
            there = self.reader.entity_position(obs, binding.target)
            line = there - self.reader.entity_position(obs, binding.tool)
        else:
            other = self.closest(self.accepted_objects(aff, obs), obs, exclude=binding.target,
                                 to=binding.target)
            if other < 0:
                return None
            there = self.reader.entity_position(obs, other)
            line = there - self.reader.entity_position(obs, binding.target)
        unit = line / max(float(np.linalg.norm(line)), 1e-9)
        return there + self.config.salient_beyond * unit

    # ------------------------------------------------------------------ Algorithm 1
    def learning_episode(self, actuator: Actuator, rng: np.random.Generator) -> LearningEpisode:
        """One pass of Algorithm 1 (paper §4.2).

            with probability σ (once H is not empty):            goal babbling
                A    ← AffordanceSelection   (in proportion to interest)
                g    ← GoalSelection         (A's interest map; or a salient goal)
                o    ← ObjectSelection       (the closest object p_A accepts)
                Plan / Execute (A, o, g)     → competence
                update A's interest map with (g, competence)       (not with paper_interest)
            otherwise:                                            random controllable
                a random primitive sequence, or a random value of a controllable space
            UpdateInterestMaps with the episode's outcomes        (with paper_interest)
            Adapt H to the episode's data    (Algorithm 2)

        Fallbacks are explicit and recorded (`LearningEpisode.fallbacks`): goal babbling with
        no object to bind or nothing the controller could do becomes a random controllable; a
        random controllable that cannot be reached becomes one random action.
        """
        start = self.iteration
        drawn = Mode.RANDOM_CONTROLLABLE
        if len(self.hierarchy) and rng.random() < self.config.sigma:
            drawn = Mode.GOAL
            done = self._goal_babbling(actuator, rng)
        else:
            done = self._random_controllable(actuator, rng)
        stop = self.iteration
        events: tuple[Event, ...] = ()
        if stop > start:
            if self.config.paper_interest:
                self.update_interest_maps(np.arange(start, stop, dtype=np.int64))
            events = tuple(self.adaptation.run(start, stop, stop, self.learning_episodes, rng))
        self.learning_episodes += 1
        return LearningEpisode(done.mode, start, stop, done.affordance_id,
                               tuple(float(g) for g in done.goal), done.competence, events,
                               drawn, done.fallbacks)

    def affordance_selection(self, rng: np.random.Generator) -> Affordance:
        """AffordanceSelection: an affordance of H in proportion to its map's interest
        (uniformly with probability `interest_epsilon`)."""
        affordances = list(self.hierarchy)
        interests = [a.interest.interest for a in affordances]
        return affordances[select_index(interests, rng, self.config.interest_epsilon)]

    def _goal_babbling(self, actuator: Actuator, rng: np.random.Generator) -> Explored:
        aff = self.affordance_selection(rng)
        goal = aff.interest.sample_goal(rng, epsilon=self.config.interest_epsilon)
        binding = self.select_binding(aff, actuator.obs)
        if binding is None:
            return self._random_controllable(actuator, rng).after(Fallback.GOAL_NO_OBJECT)
        # The interest map's goal is drawn first either way: one layout of the random stream.
        salient = self.salient_goal(aff, binding, actuator.obs, rng)
        if salient is not None:
            goal = salient
        attempt = self.controller.reach(aff, binding, goal, actuator, self.config.goal_budget)
        if attempt.actions == 0:
            return self._random_controllable(actuator, rng).after(Fallback.GOAL_NO_PLAN)
        if not self.config.paper_interest:  # (the paper's maps learn from every outcome)
            aff.interest.add(goal, attempt.competence, self.iteration)
        return Explored(Mode.GOAL, aff.id, goal, attempt.competence)

    def update_interest_maps(self, t: np.ndarray) -> None:
        """UpdateInterestMaps(D, D_episodic) of the paper's Algorithm 1 (`paper_interest`):
        every map records the outcomes the learning episode (iterations `t`) reached in its
        affordance's output space, with the competence of the forward model that planned them
        (`Fitter.reached`); run before Algorithm 2, as the paper orders them."""
        for aff in self.hierarchy:
            for value, competence, it in zip(*self.fitter.reached(aff, t), strict=True):
                aff.interest.add(value, float(competence), int(it))

    def _random_controllable(self, actuator: Actuator, rng: np.random.Generator) -> Explored:
        spaces: list[RoleSpace] = [ACTION, *sorted(self.hierarchy.controllable())]
        space = spaces[int(rng.integers(len(spaces)))]
        if space is ACTION:
            for _ in range(self.config.random_sequence_length):
                if actuator.exhausted:
                    break
                actuator.act(self.random_action(rng))
            return Explored(Mode.RANDOM_ACTION)
        aff = self.hierarchy.controllers(space)[0]
        binding = self.select_binding(aff, actuator.obs)
        if binding is None:
            return self._random_action(actuator, rng, Fallback.RANDOM_NO_OBJECT)
        goal = self.salient_goal(aff, binding, actuator.obs, rng)
        if goal is None:
            low, high = output_bounds(space, self.reader)
            goal = rng.uniform(low, high)
        attempt = self.controller.reach(aff, binding, goal, actuator, self.config.goal_budget)
        if attempt.actions == 0:
            return self._random_action(actuator, rng, Fallback.RANDOM_NO_PLAN)
        return Explored(Mode.RANDOM_CONTROLLABLE, aff.id, goal, attempt.competence)

    def random_action(self, rng: np.random.Generator) -> np.ndarray:
        """One primitive action uniform in the world's action box."""
        return self.actions.sample(rng, 1)[0]

    def _random_action(self, actuator: Actuator, rng: np.random.Generator,
                       why: Fallback) -> Explored:
        actuator.act(self.random_action(rng))
        return Explored(Mode.RANDOM_ACTION, fallbacks=(why,))
