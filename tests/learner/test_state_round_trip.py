"""A learner saved and restored is the same learner, field by field — every field, found by
walking the objects, not a list someone remembered to write down."""

from __future__ import annotations

import dataclasses
import enum
import json
from functools import cached_property
from typing import Any

import numpy as np
import torch
from handmade import (
    ROBOT_HEADING,
    ROBOT_POSITION,
    TARGET_POSITION,
    TARGET_ROBOT,
    Room,
)
from scipy.spatial import cKDTree

from hadim_cli.learner.explorer import Learner
from hadim_cli.learner.hierarchy import EventKind
from hadim_cli.learner.spaces import ACTION, Rows
from hadim_cli.learner.state import event_to_json, learner_state, restore_learner
from hadim_cli.world.actions import ROVER_ACTIONS

IGNORED: dict[str, str] = {}
"""Attribute paths allowed to differ after a restore, with the reason. Empty: none may."""
CACHES = {"_scale_cache", "_answers", "_answered_at", "buffer", "buffer_tree", "_candidates"}
"""What a model fills when asked and rebuilds on demand (its scales, its last inverse
answers, the normalised rows an index has not yet built into its tree) or a fitter keeps to
extend rather than read again (`Fitter.all_candidates`): a learner that was used has them,
its restored copy not yet (`assert_same(..., ignore=CACHES)`)."""
BUFFERS = {"_data", "_room", "_actions", "_contexts", "_outcomes"}
"""Arrays grown by doubling: rows past their owner's `n` (or `len`) are spare capacity."""


def assert_same(a: Any, b: Any, path: str = "learner", seen: set | None = None,
                ignore: frozenset[str] | set[str] = frozenset()) -> int:
    """Walk `a` and `b` together and fail at the first difference; returns fields compared.
    `ignore`: attribute names not compared (e.g. `CACHES`)."""
    seen = set() if seen is None else seen
    if path in IGNORED or path.rpartition(".")[2] in ignore:
        return 0
    if isinstance(a, np.ndarray):
        assert isinstance(b, np.ndarray) and a.shape == b.shape, path
        assert np.array_equal(a, b, equal_nan=a.dtype.kind == "f"), path
        return 1
    if isinstance(a, torch.Tensor):
        assert torch.equal(a, b), path
        return 1
    if isinstance(a, cKDTree):  # a neighbour index: the points and parameters it was built on
        assert isinstance(b, cKDTree), path
        return assert_same((a.data, a.leafsize, a.n, a.m), (b.data, b.leafsize, b.n, b.m),
                           path, seen, ignore)
    if isinstance(a, torch.nn.Module | torch.optim.Optimizer):
        return assert_same(_tensors(a.state_dict()), _tensors(b.state_dict()), path, seen,
                           ignore)
    assert type(a) is type(b), f"{path}: {type(a)} vs {type(b)}"
    if isinstance(a, float):
        assert a == b or (np.isnan(a) and np.isnan(b)), f"{path}: {a} vs {b}"
        return 1
    if isinstance(a, str | int | bool | type(None) | enum.Enum | frozenset):  # sets of ids
        assert a == b, f"{path}: {a!r} vs {b!r}"
        return 1
    if isinstance(a, dict):
        assert a.keys() == b.keys(), f"{path}: keys {sorted(map(str, a))} vs " \
                                     f"{sorted(map(str, b))}"
        return sum(assert_same(a[k], b[k], f"{path}[{k!r}]", seen, ignore) for k in a)
    if isinstance(a, list | tuple):
        assert len(a) == len(b), f"{path}: length {len(a)} vs {len(b)}"
        return sum(assert_same(x, y, f"{path}[{i}]", seen, ignore)
                   for i, (x, y) in enumerate(zip(a, b, strict=True)))
    if id(a) in seen:
        return 0
    seen.add(id(a))
    fa, fb = _fields(a), _fields(b)
    assert fa.keys() == fb.keys(), path
    for k in BUFFERS & fa.keys():
        n = a.n if hasattr(a, "n") else len(a)
        fa[k], fb[k] = fa[k][:n], fb[k][:n]
    return sum(assert_same(v, fb[k], f"{path}.{k}", seen, ignore) for k, v in fa.items())


def _fields(obj: Any) -> dict[str, Any]:
    """An object's attributes, less `functools.cached_property` values (derived, filled on
    first use)."""
    if hasattr(obj, "__dict__"):
        return {k: v for k, v in vars(obj).items()
                if not isinstance(getattr(type(obj), k, None), cached_property)}
    slots = getattr(type(obj), "__slots__", ())
    if slots:
        return {s: getattr(obj, s) for s in slots}
    raise AssertionError(f"cannot compare a {type(obj).__name__}")


def _tensors(state: dict) -> dict:
    return {str(k): v for k, v in state.items()}


def rich_learner() -> Room:
    """A learner with something in every field: affordances with and without p_A, trained
    classifiers, interest maps split and with a split put off, creation back-offs, low
    streaks, histories, events, deleted ids."""
    room = Room()
    rng = np.random.default_rng(0)
    room.episode()
    t = room.moves(rng, 300)
    mover = room.affordance(t, (ROBOT_HEADING,), rng=rng)
    # Rows of an object's moves taken in by the drive (`learner.paper_match_adds`).
    mover.rows = mover.rows.concat(Rows(t[:10], np.full(10, 1), np.full(10, -1)).lending())
    mover.model = room.fitter.fit(mover.input, mover.output, mover.contexts, mover.rows)
    gone = room.affordance(t[:50], (), out=ROBOT_HEADING, rng=rng)
    room.hierarchy.delete(gone, len(room.dataset))
    pusher = room.affordance(t[:20], (TARGET_ROBOT,), inp=ROBOT_POSITION, out=TARGET_POSITION,
                             rng=rng)
    pusher.rows = Rows(t[:20], np.full(20, 1), np.full(20, -1))
    # A model holds the values of its affordance's rows (checkpoints rebuild it from them).
    pusher.model = room.fitter.fit(pusher.input, pusher.output, pusher.contexts, pusher.rows)
    pusher.classifier.add(rng.uniform(0, 1, (6, pusher.classifier.n_features)),
                          np.array([1, 0, 1, 0, 1, 0], dtype=bool))
    pusher.classifier.train(rng, steps=5)
    for i in range(120):  # splits, then piles goals in one corner: a split put off
        mover.interest.add(rng.uniform(-2, 2, 2), float(rng.uniform()), i)
    for i in range(60):
        mover.interest.add([1.99, 1.99], 0.5, 200 + i)
    assert any(leaf.next_split_at > 0 for leaf in mover.interest._leaves.values())
    assert mover.interest.n_regions > 1
    room.adaptation.backoff.failed(ACTION, TARGET_POSITION, 3)
    room.adaptation.backoff.failed(ACTION, TARGET_POSITION, 5)
    mover.low_streak, pusher.low_streak = 2, 1
    mover.history.append((301, 0.75))
    room.learner.learning_episodes = 17
    return room


def restored(room: Room) -> Learner:
    meta, arrays = learner_state(room.learner)
    meta = json.loads(json.dumps(meta))  # what the store keeps: JSON and .npy arrays
    copy = Learner(room.config, room.layout, ROVER_ACTIONS)
    for ep in room.dataset.episodes():
        s = slice(ep.start, ep.stop)
        copy.dataset.extend(room.dataset.actions[s], room.dataset.contexts[s],
                            room.dataset.outcomes[s])
    restore_learner(copy, meta, arrays)
    return copy


def test_a_restored_learner_equals_the_saved_one_in_every_field():
    room = rich_learner()
    copy = restored(room)
    compared = assert_same(room.learner, copy)
    assert compared > 500  # the walk went deep (models, maps, p_A weights, optimiser)


def test_the_comparison_sees_a_field_the_state_forgets():
    """The walk is what makes the test above strong: a field left at its default on
    restore — the creation back-off, a map's postponed split — is a difference."""
    room = rich_learner()
    copy = restored(room)
    copy.adaptation.backoff.wait.clear()
    try:
        assert_same(room.learner, copy)
    except AssertionError as exc:
        assert "backoff" in str(exc)
    else:
        raise AssertionError("a forgotten back-off went unnoticed")


def test_a_restored_learner_goes_on_as_the_saved_one():
    room = rich_learner()
    copy = restored(room)
    mover = room.hierarchy.with_output(ROBOT_POSITION)[0]
    twin = copy.hierarchy.with_output(ROBOT_POSITION)[0]
    a, b = np.random.default_rng(9), np.random.default_rng(9)
    for i in range(30):  # the postponed split happens at the same goal in both
        mover.interest.add([1.98, 1.98], 0.1 * (i % 3), 400 + i)
        twin.interest.add([1.98, 1.98], 0.1 * (i % 3), 400 + i)
    assert np.array_equal(mover.interest.sample_goal(a), twin.interest.sample_goal(b))
    assert_same(room.learner, copy)


def test_a_state_that_does_not_fit_its_learner_is_refused():
    """A learner is restored only onto the D its checkpoint was taken with, from a format
    this version reads: D of another length, rows beyond D or an unknown format is an
    error naming what is wrong, never a learner quietly wrong."""
    import pytest

    room = rich_learner()
    meta, arrays = learner_state(room.learner)
    meta = json.loads(json.dumps(meta))

    def blank(rows: int | None = None) -> Learner:
        copy = Learner(room.config, room.layout, ROVER_ACTIONS)
        n = len(room.dataset) if rows is None else rows
        copy.dataset.extend(room.dataset.actions[:n], room.dataset.contexts[:n],
                            room.dataset.outcomes[:n])
        return copy

    with pytest.raises(ValueError, match="D holds 299 iterations, the checkpoint 300"):
        restore_learner(blank(299), meta, arrays)
    with pytest.raises(ValueError, match="unsupported learner state format 3"):
        restore_learner(blank(), {**meta, "format": 3}, arrays)
    with pytest.raises(ValueError, match="unsupported learner state format None"):
        restore_learner(blank(), {k: v for k, v in meta.items() if k != "format"}, arrays)
    mover = room.hierarchy.with_output(ROBOT_POSITION)[0]
    beyond = dict(arrays)
    beyond[f"aff{mover.id}.rows.t"] = arrays[f"aff{mover.id}.rows.t"] + 1
    with pytest.raises(ValueError, match=f"affordance {mover.id} has rows beyond D"):
        restore_learner(blank(), meta, beyond)
    restore_learner(blank(), {**meta, "format": 1}, arrays)  # format 1 still reads


def test_the_timeline_and_counters_come_back_as_saved():
    """Events keep their kind, spaces, contexts, competence and detail; the next id, the
    learning episodes and the creation back-off are those saved."""
    room = rich_learner()
    copy = restored(room)
    h, c = room.hierarchy, copy.hierarchy
    assert len(h.events) >= 3 and c.events == h.events
    assert {e.kind for e in c.events} >= {EventKind.CREATED, EventKind.DELETED}
    assert c.next_id == h.next_id and copy.learning_episodes == 17
    assert copy.adaptation.backoff.next_try == room.adaptation.backoff.next_try != {}
    assert copy.adaptation.backoff.wait == room.adaptation.backoff.wait != {}
    for a, b in zip(room.hierarchy, c, strict=True):
        assert (b.id, b.input, b.output, b.contexts, b.created_at, b.competence,
                b.low_streak, b.history) == (a.id, a.input, a.output, a.contexts,
                                             a.created_at, a.competence, a.low_streak,
                                             a.history)
        assert (b.classifier is None) == (a.classifier is None)


def test_a_model_stored_in_another_frame_comes_back_as_the_installed_code_fits_it():
    """A run of a version that read a model in room coordinates, where the installed code
    reads it in a frame (the robot's motion in its heading's): the model's rows are data,
    its frame is code — it comes back framed, fitted on the same rows, answering as a model
    the installed code fits on them."""
    from hadim_cli.learner.frames import FramedModel
    from hadim_cli.learner.models import LocalLinearModel

    room = rich_learner()
    mover = room.hierarchy.with_output(ROBOT_POSITION)[0]
    installed = mover.model
    assert isinstance(installed, FramedModel)
    x, c, y = installed.data()
    old = LocalLinearModel(x.shape[1], y.shape[1], [c.shape[1]])
    old.add(x, c, y)
    mover.model = old
    twin = restored(room).hierarchy.with_output(ROBOT_POSITION)[0]
    assert isinstance(twin.model, FramedModel) and twin.model.frame == installed.frame
    for got, want in zip(twin.model.data(), installed.data(), strict=True):
        np.testing.assert_array_equal(got, want)
    q = np.random.default_rng(1).uniform(-1, 1, (20, x.shape[1]))
    h = np.random.default_rng(2).normal(size=(20, 2))
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    np.testing.assert_allclose(twin.model.predict(q, h), installed.predict(q, h), atol=1e-12)


def test_a_format_1_state_keeps_each_affordances_history_in_its_json():
    """Format 1 kept an affordance's competence history in the JSON, not in an array: such
    a state restores each history as saved."""
    room = rich_learner()
    meta, arrays = learner_state(room.learner)
    meta = json.loads(json.dumps(meta))
    old = dict(arrays)
    for m in meta["affordances"]:
        m["history"] = old.pop(f"aff{m['id']}.history").tolist()
    copy = Learner(room.config, room.layout, ROVER_ACTIONS)
    copy.dataset.extend(room.dataset.actions[:len(room.dataset)],
                        room.dataset.contexts[:len(room.dataset)],
                        room.dataset.outcomes[:len(room.dataset)])
    restore_learner(copy, {**meta, "format": 1}, old)
    assert [a.history for a in copy.hierarchy] == [a.history for a in room.hierarchy]
    assert any(len(a.history) > 1 for a in copy.hierarchy)


def test_a_state_whose_classifiers_differ_from_the_config_is_refused():
    """p_A's hidden layer is the config's (`learner.classifier_hidden`): a checkpoint whose
    classifiers have another is an error naming it, not a learner quietly unlike its config."""
    import pytest

    room = rich_learner()
    meta, arrays = learner_state(room.learner)
    copy = Learner(dataclasses.replace(room.config, classifier_hidden=16), room.layout,
                   ROVER_ACTIONS)
    copy.dataset.extend(room.dataset.actions[:len(room.dataset)],
                        room.dataset.contexts[:len(room.dataset)],
                        room.dataset.outcomes[:len(room.dataset)])
    with pytest.raises(ValueError, match="hidden=32.*hidden=16 was asked for"):
        restore_learner(copy, json.loads(json.dumps(meta)), arrays)


def test_an_events_stored_form_is_its_fields_as_json_values():
    room = rich_learner()
    e = room.hierarchy.events[0]
    assert event_to_json(e) == {"iteration": e.iteration, "affordance_id": e.affordance_id,
                                "kind": e.kind.value, "input": e.input, "output": e.output,
                                "contexts": list(e.contexts), "competence": e.competence,
                                "detail": e.detail}
