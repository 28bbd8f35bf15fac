"""The learner's state as (JSON, named arrays) — no pickle — and back.

D is not part of it: the store holds D episode by episode and restores it first. Nor are the
models' rows: an affordance's rows of D (`aff<id>.rows.*`) and its spaces give them again
(`Fitter.values`), bit for bit, so a model is saved as its parameters and index sizes and
rebuilt from D at restore. Everything that grows with the run is an array or a list that only
grows at its end (rows, competence history, interest goals in the order recorded, events), which the
store writes as deltas (store/deltas.py). Format 1 (models with their rows, history in JSON)
still restores.
"""

from __future__ import annotations

from dataclasses import asdict
from typing import Any

import numpy as np

from hadim_cli.learner.affordance import Affordance
from hadim_cli.learner.classifier import VisualClassifier
from hadim_cli.learner.explorer import Learner
from hadim_cli.learner.frames import Frame
from hadim_cli.learner.hierarchy import Event, EventKind
from hadim_cli.learner.interest import InterestMap
from hadim_cli.learner.models import Model
from hadim_cli.learner.spaces import Rows, parse_space

FORMAT = 2
READABLE_FORMATS = (1, 2)
_MODEL_ROWS = ("x", "c", "y")


def _prefixed(prefix: str, arrays: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    return {f"{prefix}.{k}": np.asarray(v) for k, v in arrays.items()}


def _strip(prefix: str, arrays: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    head = prefix + "."
    return {k[len(head):]: v for k, v in arrays.items() if k.startswith(head)}


def event_to_json(e: Event) -> dict[str, Any]:
    out = asdict(e)
    out["kind"] = e.kind.value
    out["contexts"] = list(e.contexts)
    return out


def event_from_json(d: dict[str, Any]) -> Event:
    return Event(int(d["iteration"]), int(d["affordance_id"]), EventKind(d["kind"]), d["input"],
                 d["output"], tuple(d["contexts"]), float(d["competence"]),
                 dict(d.get("detail", {})))


def affordance_state(aff: Affordance) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    p = f"aff{aff.id}"
    interest_json, interest_arrays = aff.interest.state()
    meta = {
        "id": aff.id, "input": aff.input.name, "output": aff.output.name,
        "contexts": [c.name for c in aff.contexts], "created_at": aff.created_at,
        "competence": aff.competence, "low_streak": aff.low_streak, "interest": interest_json,
        "classifier": aff.classifier is not None,
    }
    history = np.array(aff.history, dtype=np.float64).reshape(-1, 2)
    arrays = {f"{p}.rows.t": aff.rows.t, f"{p}.rows.target": aff.rows.target,
              f"{p}.rows.tool": aff.rows.tool, f"{p}.history": history}
    if aff.rows.borrowed is not None:
        arrays[f"{p}.rows.borrowed"] = aff.rows.borrowed.astype(np.int8)
    model = {k: v for k, v in aff.model.state().items() if k not in _MODEL_ROWS}
    arrays.update(_prefixed(f"{p}.model", model))
    arrays.update(_prefixed(f"{p}.interest", interest_arrays))
    if aff.classifier is not None:
        arrays.update(_prefixed(f"{p}.classifier", aff.classifier.state()))
    return meta, arrays


def learner_state(learner: Learner) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    h = learner.hierarchy
    affs, arrays = [], {}
    for aff in h:
        meta, arr = affordance_state(aff)
        affs.append(meta)
        arrays.update(arr)
    meta = {
        "format": FORMAT,
        "iteration": learner.iteration,
        "learning_episodes": learner.learning_episodes,
        "next_id": h.next_id,
        "events": [event_to_json(e) for e in h.events],
        "affordances": affs,
        "backoff": {"next_try": learner.adaptation.backoff.next_try,
                    "wait": learner.adaptation.backoff.wait},
    }
    return meta, arrays


def _model_from_state(template: Model, state: dict[str, np.ndarray]) -> Model:
    """The model `state` saved, as the installed code fits it (`template`: an empty model of
    the installed code for the affordance): restored bit for bit when the installed code reads
    it in the same frame, or none; else `template` fitted on the state's rows (stored in room
    coordinates either way): a run of a version that read the model in another frame."""
    stored = Frame.from_array(state["frame"]) if "frame" in state else None
    if stored == getattr(template, "frame", None):
        return type(template).from_state(state, **template.params())
    if state["x"].shape[0]:
        template.add(state["x"], state["c"], state["y"])
    return template


def _restore_affordance(learner: Learner, meta: dict[str, Any],
                        arrays: dict[str, np.ndarray]) -> Affordance:
    p = f"aff{meta['id']}"
    inp, out = parse_space(meta["input"]), parse_space(meta["output"])
    contexts = tuple(parse_space(c) for c in meta["contexts"])
    borrowed = arrays.get(f"{p}.rows.borrowed")
    rows = Rows(arrays[f"{p}.rows.t"].astype(np.int64), arrays[f"{p}.rows.target"].astype(
        np.int64), arrays[f"{p}.rows.tool"].astype(np.int64),
        None if borrowed is None else borrowed.astype(bool))
    if len(rows) and int(rows.t.max()) >= len(learner.dataset):
        raise ValueError(f"affordance {meta['id']} has rows beyond D")
    model_state = _strip(f"{p}.model", arrays)
    if "x" not in model_state:  # format 2: the model's rows are read again from D
        sample = learner.fitter.values(inp, out, contexts, rows)
        model_state.update(x=sample.x, c=sample.c, y=sample.y)
    model = _model_from_state(learner.fitter.new_model(inp, out, contexts), model_state)
    interest = InterestMap.from_state(meta["interest"], _strip(f"{p}.interest", arrays))
    classifier = None
    if meta["classifier"]:
        classifier = VisualClassifier.from_state(_strip(f"{p}.classifier", arrays),
                                                 hidden=learner.config.classifier_hidden)
    if "history" in meta:  # format 1
        history = [(int(i), float(c)) for i, c in meta["history"]]
    else:
        history = [(int(i), float(c)) for i, c in arrays[f"{p}.history"]]
    aff = Affordance(int(meta["id"]), inp, out, contexts, int(meta["created_at"]), rows, model,
                     interest, classifier, float(meta["competence"]), history,
                     int(meta["low_streak"]))
    return aff


def restore_learner(learner: Learner, meta: dict[str, Any],
                    arrays: dict[str, np.ndarray]) -> None:
    """Load H and counters into `learner`, whose D must already hold the checkpoint's data."""
    if meta.get("format") not in READABLE_FORMATS:
        raise ValueError(f"unsupported learner state format {meta.get('format')!r}")
    if len(learner.dataset) != int(meta["iteration"]):
        raise ValueError(f"D holds {len(learner.dataset)} iterations, the checkpoint "
                         f"{meta['iteration']}")
    h = learner.hierarchy
    h.affordances.clear()
    for m in meta["affordances"]:
        aff = _restore_affordance(learner, m, arrays)
        h.affordances[aff.id] = aff
    h.next_id = int(meta["next_id"])
    h.events[:] = [event_from_json(e) for e in meta["events"]]
    learner.learning_episodes = int(meta["learning_episodes"])
    learner.adaptation.backoff.next_try = {k: int(v) for k, v in
                                           meta["backoff"]["next_try"].items()}
    learner.adaptation.backoff.wait = {k: int(v) for k, v in meta["backoff"]["wait"].items()}
