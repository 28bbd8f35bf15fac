"""Forward neighbourhoods chosen by each model's own rows (`LocalLinearModel.k_choices`)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from hadim_cli.config import ConfigError, LearnerConfig, WorldConfig
from hadim_cli.learner.affordance import Fitter
from hadim_cli.learner.dataset import Dataset
from hadim_cli.learner.frames import Frame, FramedModel
from hadim_cli.learner.models import LocalLinearModel
from hadim_cli.learner.spaces import ACTION, Role, RoleSpace, Rows, SpaceReader
from hadim_cli.world.actions import ROVER_ACTIONS
from hadim_cli.world.layout import Property
from hadim_cli.world.world import World


def noisy_line(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    """y = 2x plus noise: a wide neighbourhood averages the noise away."""
    x = rng.uniform(-1.0, 1.0, (n, 1))
    return x, 2.0 * x + rng.normal(0.0, 0.3, (n, 1))


def sharp_wave(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    """y = sin(12x), no noise: a wide neighbourhood smears the wave."""
    x = rng.uniform(-1.0, 1.0, (n, 1))
    return x, np.sin(12.0 * x)


@pytest.mark.parametrize("data, wanted", [(noisy_line, 30), (sharp_wave, 5)])
def test_the_neighbourhood_of_least_error_is_chosen(data, wanted) -> None:
    x, y = data(np.random.default_rng(3), 400)
    model = LocalLinearModel(1, 1, k_forward=10, k_choices=(5, 30))
    model.add(x, None, y)
    assert model.k_fit == wanted
    errors = {}
    for k in (5, 30):
        plain = LocalLinearModel(1, 1, k_forward=k)
        plain.add(x, None, y)
        errors[k] = float(np.mean(np.abs(plain.predict_loo() - y)))
    assert errors[wanted] < min(errors.values()) + 1e-12
    # The chosen neighbourhood is the one forward fits (and leave-one-out) use from then on.
    same = LocalLinearModel(1, 1, k_forward=wanted)
    same.add(x, None, y)
    q = np.linspace(-0.9, 0.9, 7)[:, None]
    np.testing.assert_array_equal(model.predict(q), same.predict(q))
    np.testing.assert_array_equal(model.predict_loo(), same.predict_loo())


def noisy_line_in_runs(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    """y = 2x plus noise, recorded in runs of five nearly equal rows sharing their noise (the
    actions of one pursuit): a row's own run repeats it."""
    x = np.repeat(rng.uniform(-1.0, 1.0, (n // 5, 1)), 5, 0)
    x = x + rng.normal(0.0, 1e-4, x.shape)
    return x, 2.0 * x + np.repeat(rng.normal(0.0, 0.3, (n // 5, 1)), 5, 0)


def test_the_neighbourhood_is_chosen_on_rows_of_other_moments() -> None:
    """Left out one by one, a row of a run is predicted by the rest of its run, which shares
    its noise: five neighbours look best. Predicted from other moments (the rows stored
    around it left out), the noise must be averaged away: thirty."""
    x, y = noisy_line_in_runs(np.random.default_rng(5), 400)
    model = LocalLinearModel(1, 1, k_forward=10, k_choices=(5, 30))
    model.add(x, None, y)
    assert model.k_fit == 30
    loo = {}
    for k in (5, 30):
        plain = LocalLinearModel(1, 1, k_forward=k)
        plain.add(x, None, y)
        loo[k] = float(np.mean(np.abs(plain.predict_loo() - y)))
    assert loo[5] < loo[30]  # what plain leave-one-out would have chosen


@pytest.mark.parametrize("seed", range(3))
def test_a_row_is_never_among_its_own_neighbours_when_rows_of_its_moment_fill_in(seed) -> None:
    """32 rows of noise in 20 inputs, choices 5 and 31: 31 neighbours need rows of the same
    moment to fill in (only 15 others lie outside a middle row's window), but never the row
    itself. Without it a fit of 21 unknowns on the 31 others predicts the row badly, worse
    than the mean of five: five are chosen. With the row among its neighbours the wide fit
    nearly passes through it and would win."""
    rng = np.random.default_rng(seed)
    x, y = rng.uniform(-1.0, 1.0, (32, 20)), rng.normal(0.0, 1.0, (32, 1))
    model = LocalLinearModel(20, 1, k_forward=10, k_choices=(5, 31))
    model.add(x, None, y)
    assert model.k_fit == 5


def test_without_choices_the_neighbourhood_stays_k_forward() -> None:
    x, y = noisy_line(np.random.default_rng(4), 300)
    model = LocalLinearModel(1, 1, k_forward=10)
    model.add(x, None, y)
    assert model.k_fit == 10


def test_the_choice_is_made_again_each_time_the_rows_have_doubled() -> None:
    x, y = noisy_line(np.random.default_rng(5), 300)
    model = LocalLinearModel(1, 1, k_choices=(5, 30))
    made = []
    for i in range(300):
        before = model._chosen_at
        model.add(x[i:i + 1], None, y[i:i + 1])
        if model._chosen_at != before:
            made.append(model.n)
    assert made == [32, 64, 128, 256]


def framed(choices: tuple[int, ...]) -> FramedModel:
    return FramedModel(2, 2, [2], Frame(0, True, True), k_choices=choices)


def pushes(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A push along the relation r, with noise: a wide neighbourhood predicts it best."""
    a = rng.uniform(-np.pi, np.pi, n)
    r = 0.3 * np.c_[np.cos(a), np.sin(a)]
    x = rng.uniform(-0.15, 0.15, (n, 2))
    along = np.einsum("ij,ij->i", x, r) / 0.3
    y = r / 0.3 * np.maximum(along, 0.0)[:, None] + rng.normal(0.0, 0.02, (n, 2))
    return x, r, y


@pytest.mark.parametrize("kind", ["plain", "framed"])
def test_the_chosen_neighbourhood_survives_a_state_round_trip(kind) -> None:
    rng = np.random.default_rng(6)
    if kind == "plain":
        x, y = noisy_line(rng, 700)
        c = None
        model, cls = LocalLinearModel(1, 1, k_choices=(5, 30)), LocalLinearModel
    else:
        x, c, y = pushes(rng, 700)
        model, cls = framed((5, 30)), FramedModel

    def rows(i, j):
        return x[i:j], None if c is None else c[i:j], y[i:j]

    for i in range(0, 300, 25):
        model.add(*rows(i, i + 25))
    inner = getattr(model, "inner", model)
    assert (inner.k_fit, inner._chosen_at) == (30, 200)
    copy = cls.from_state(model.state(), **model.params())
    inner_copy = getattr(copy, "inner", copy)
    # Taken back as saved, not chosen again on the 300 rows restored.
    assert (inner_copy.k_fit, inner_copy._chosen_at, inner_copy.k_choices) == (30, 200, (5, 30))
    np.testing.assert_array_equal(copy.predict_loo(), model.predict_loo())
    for m in (model, copy):  # both choose again at 400 rows, alike
        for i in range(300, 700, 25):
            m.add(*rows(i, i + 25))
    assert inner_copy._chosen_at == inner._chosen_at == 400
    np.testing.assert_array_equal(copy.predict_loo(), model.predict_loo())


def test_a_state_saved_before_choices_existed_keeps_k_forward() -> None:
    x, y = noisy_line(np.random.default_rng(7), 300)
    model = LocalLinearModel(1, 1, k_forward=10)
    model.add(x, None, y)
    old = model.state()
    old["k"] = old["k"][:4]
    del old["k_choices"]
    copy = LocalLinearModel.from_state(old)
    assert (copy.k_fit, copy.k_choices) == (10, ())
    np.testing.assert_array_equal(copy.predict_loo(), model.predict_loo())


def test_the_learner_config_reaches_the_models() -> None:
    layout = World(WorldConfig()).layout
    robot = RoleSpace(Role.ROBOT, Property.POSITION)
    heading = RoleSpace(Role.ROBOT, Property.HEADING)
    for choices in ((), (7, 40)):
        config = dataclasses.replace(LearnerConfig(), k_choices=choices)
        fitter = Fitter(Dataset(layout.size, 2), SpaceReader(layout, actions=ROVER_ACTIONS), config)
        for contexts in ((), (heading,)):
            assert fitter.new_model(ACTION, robot, contexts).params()["k_choices"] == choices
    assert LearnerConfig().k_choices == (10, 20, 30, 60)
    with pytest.raises(ConfigError, match="k_choices"):
        dataclasses.replace(LearnerConfig(), k_choices=(10, 0)).validate()
    with pytest.raises(ValueError, match="k_choices"):
        LocalLinearModel(1, 1, k_choices=(0,))


def test_a_trial_model_keeps_k_forward(monkeypatch) -> None:
    """A context trial fits a model, scores it once and drops it: it does not choose (every
    trial it is compared with keeps `k_forward` too; choosing in each cost 2.5x the learning
    time), while the affordance's own model does."""
    layout = World(WorldConfig()).layout
    robot = RoleSpace(Role.ROBOT, Property.POSITION)
    heading = RoleSpace(Role.ROBOT, Property.HEADING)
    fitter = Fitter(Dataset(layout.size, 2), SpaceReader(layout, actions=ROVER_ACTIONS),
                    LearnerConfig())
    assert fitter.new_model(ACTION, robot, (heading,), trial=True).params()["k_choices"] == ()
    assert fitter.new_model(ACTION, robot, (heading,)).params()["k_choices"] == (10, 20, 30, 60)
    seen = []
    real = Fitter.fit

    def spy(self, *args, trial=False, **kwargs):
        seen.append(trial)
        return real(self, *args, trial=trial, **kwargs)

    monkeypatch.setattr(Fitter, "fit", spy)
    fitter.trial(ACTION, robot, (heading,), Rows.empty(), np.random.default_rng(0))
    assert seen == [True]
