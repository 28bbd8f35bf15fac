"""The visual classifier p_A: learning, balanced replay, determinism, persistence."""

from __future__ import annotations

import hashlib
import json
import subprocess
import sys

import numpy as np
import pytest
import torch

from hadim_cli.learner.classifier import VisualClassifier

N_FEATURES = 6  # radius, height, R, G, B, shape


def objects(rng: np.random.Generator, n: int, green: bool) -> np.ndarray:
    """Scaled object features: random radius and height, a shade of green or of red."""
    x = np.empty((n, N_FEATURES))
    x[:, 0] = rng.uniform(0.0, 1.0, n)
    x[:, 1] = rng.uniform(0.0, 1.0, n)
    main, other = rng.uniform(0.5, 1.0, n), rng.uniform(0.0, 0.3, n)
    x[:, 2] = other if green else main
    x[:, 3] = main if green else other
    x[:, 4] = rng.uniform(0.0, 0.3, n)
    x[:, 5] = 0.0
    return x


def toy(rng: np.random.Generator, n_pos: int, n_neg: int) -> tuple[np.ndarray, np.ndarray]:
    x = np.concatenate([objects(rng, n_pos, True), objects(rng, n_neg, False)])
    y = np.concatenate([np.ones(n_pos, bool), np.zeros(n_neg, bool)])
    return x, y


def weights(c: VisualClassifier) -> dict[str, np.ndarray]:
    return {k: v for k, v in c.state().items() if k.startswith("weight.")}


def same_state(a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> bool:
    return a.keys() == b.keys() and all(np.array_equal(a[k], b[k]) for k in a)


def test_learns_green_versus_red() -> None:
    rng = np.random.default_rng(0)
    c = VisualClassifier(N_FEATURES, rng=rng)
    c.add(*toy(rng, 100, 100))
    losses = [c.train(rng, steps=50) for _ in range(4)]
    assert losses[-1] < losses[0]
    x, y = toy(np.random.default_rng(1), 500, 500)
    assert (c.accepts(x) == y).mean() >= 0.95
    p = c.predict_proba(x)
    assert p.dtype == np.float64 and p.shape == (1000,)
    assert np.all((p >= 0) & (p <= 1))


def test_balanced_replay_learns_minority_class() -> None:
    rng = np.random.default_rng(2)
    c = VisualClassifier(N_FEATURES, rng=rng)
    c.add(*toy(rng, 20, 200))  # 10 negatives per positive
    assert (c.n_positive, c.n_negative) == (20, 200)
    for _ in range(4):
        c.train(rng, steps=50)
    x, y = toy(np.random.default_rng(3), 500, 500)
    accepted = c.accepts(x)
    assert accepted[y].mean() >= 0.95  # the minority (positive) class
    assert (~accepted[~y]).mean() >= 0.95


def test_replay_is_bounded_fifo() -> None:
    rng = np.random.default_rng(4)
    c = VisualClassifier(N_FEATURES, replay_size=30, rng=rng)
    x, y = toy(rng, 50, 10)
    c.add(x, y)
    s = c.state()
    assert s["replay.positive"].shape == (30, N_FEATURES)
    assert np.array_equal(s["replay.positive"], x[20:50])
    assert s["replay.negative"].shape == (10, N_FEATURES)
    assert (c.n_positive, c.n_negative) == (50, 10)


def test_priors_before_training() -> None:
    rng = np.random.default_rng(5)
    x = objects(rng, 4, True)
    c = VisualClassifier(N_FEATURES, rng=rng)
    assert np.all(c.predict_proba(x) == 0.5)
    assert np.isnan(c.train(rng))
    c.add(x, np.ones(4, bool))
    state = rng.bit_generator.state
    assert np.isnan(c.train(rng))  # one class only: nothing trained, nothing drawn
    assert rng.bit_generator.state == state
    assert np.all(c.predict_proba(x) == 1.0) and np.all(c.accepts(x))
    neg = VisualClassifier(N_FEATURES, rng=rng)
    neg.add(x, np.zeros(4, bool))
    assert np.all(neg.predict_proba(x) == 0.0) and not np.any(neg.accepts(x))


def test_bad_input_is_refused() -> None:
    c = VisualClassifier(N_FEATURES, rng=np.random.default_rng(6))
    with pytest.raises(ValueError):
        c.add(np.zeros((3, N_FEATURES + 1)), np.ones(3, bool))
    with pytest.raises(ValueError):
        c.add(np.zeros((3, N_FEATURES)), np.ones(2, bool))
    with pytest.raises(ValueError):
        c.predict_proba(np.full((1, N_FEATURES), np.nan))
    assert c.predict_proba(np.zeros(N_FEATURES)).shape == (1,)


def test_global_random_state_untouched() -> None:
    torch_state = torch.random.get_rng_state().clone()
    np_state = np.random.get_state()[1].copy()
    rng = np.random.default_rng(7)
    c = VisualClassifier(N_FEATURES, rng=rng)
    c.add(*toy(rng, 30, 30))
    c.train(rng, steps=5)
    assert torch.equal(torch.random.get_rng_state(), torch_state)
    assert np.array_equal(np.random.get_state()[1], np_state)


def trained(seed: int, steps: int = 50) -> VisualClassifier:
    rng = np.random.default_rng(seed)
    c = VisualClassifier(N_FEATURES, rng=rng)
    c.add(*toy(rng, 40, 60))
    c.train(rng, steps=steps)
    return c


def test_same_seed_same_weights() -> None:
    a, b = trained(8), trained(8)
    assert same_state(a.state(), b.state())
    assert not same_state(weights(a), weights(trained(9)))


_CHILD = """
import hashlib, json, sys
sys.path[:0] = json.loads(sys.argv[1])
import hadim_cli  # pins the numerical kernels before numpy is loaded, as in the parent
import numpy as np
import torch
torch.set_num_threads(int(sys.argv[2]))  # as in the parent: sessions set 1 thread
from tests.learner.test_classifier import trained
s = trained(8).state()
h = hashlib.sha256()
for k in sorted(s):
    h.update(k.encode()); h.update(np.ascontiguousarray(s[k]).tobytes())
print(h.hexdigest())
"""


@pytest.mark.scenario
def test_same_seed_same_weights_across_processes() -> None:
    s = trained(8).state()
    h = hashlib.sha256()
    for k in sorted(s):
        h.update(k.encode())
        h.update(np.ascontiguousarray(s[k]).tobytes())
    threads = str(torch.get_num_threads())  # earlier tests' sessions may have set it to 1
    out = subprocess.run([sys.executable, "-c", _CHILD, json.dumps(sys.path), threads],
                         capture_output=True, text=True, check=True, timeout=120)
    assert out.stdout.strip() == h.hexdigest()


def test_state_round_trip_continues_identically() -> None:
    rng = np.random.default_rng(10)
    c = VisualClassifier(N_FEATURES, hidden=16, batch_size=32, rng=rng)
    c.add(*toy(rng, 40, 60))
    c.train(rng, steps=20)
    saved = {k: v.copy() for k, v in c.state().items()}
    assert all(v.dtype != object for v in saved.values())
    restored = VisualClassifier.from_state(saved, hidden=16)
    assert same_state(restored.state(), c.state())
    extra_x, extra_y = toy(np.random.default_rng(11), 5, 5)
    for clf in (c, restored):
        clf.add(extra_x, extra_y)
    r1, r2 = np.random.default_rng(12), np.random.default_rng(12)
    assert c.train(r1, steps=30) == restored.train(r2, steps=30)
    assert same_state(restored.state(), c.state())
    x, _ = toy(np.random.default_rng(13), 20, 20)
    assert np.array_equal(c.predict_proba(x), restored.predict_proba(x))


def test_round_trip_before_training_and_mismatched_params() -> None:
    c = VisualClassifier(N_FEATURES, rng=np.random.default_rng(14))
    c.add(objects(np.random.default_rng(15), 3, True), np.ones(3, bool))
    restored = VisualClassifier.from_state(c.state())
    assert same_state(restored.state(), c.state())
    assert restored.n_positive == 3
    with pytest.raises(ValueError, match="hidden"):
        VisualClassifier.from_state(c.state(), hidden=64)


def test_training_equals_autograd_and_a_per_layer_adam() -> None:
    """The classifier's own gradients and one Adam over its flat weights give, bit for bit,
    what `nn.Linear` layers under autograd and torch's Adam over each layer give from the same
    weights and batches (computed here with torch's modules, not the classifier's code)."""
    rng = np.random.default_rng(21)
    c = VisualClassifier(N_FEATURES, hidden=16, batch_size=32, lr=1e-2, rng=rng)
    c.add(*toy(rng, 50, 30))
    c.train(np.random.default_rng(0), steps=3)  # Adam's moments under way on both sides
    start = c.state()
    net = torch.nn.Sequential(torch.nn.Linear(N_FEATURES, 16, dtype=torch.float64),
                              torch.nn.ReLU(), torch.nn.Linear(16, 16, dtype=torch.float64),
                              torch.nn.ReLU(), torch.nn.Linear(16, 1, dtype=torch.float64))
    with torch.no_grad():
        for name, p in net.named_parameters():
            p.copy_(torch.from_numpy(start[f"weight.{name}"]))
    adam = torch.optim.Adam(net.parameters(), lr=1e-2)
    adam.load_state_dict({"state": {i: {
        "step": torch.tensor(float(start[f"adam.{name}.step"])),
        "exp_avg": torch.from_numpy(start[f"adam.{name}.exp_avg"].copy()),
        "exp_avg_sq": torch.from_numpy(start[f"adam.{name}.exp_avg_sq"].copy())}
        for i, (name, _) in enumerate(net.named_parameters())},
        "param_groups": adam.state_dict()["param_groups"]})
    pos, neg = start["replay.positive"], start["replay.negative"]
    data = torch.from_numpy(np.concatenate([pos, neg]))
    target = torch.cat([torch.ones(16, 1, dtype=torch.float64),
                        torch.zeros(16, 1, dtype=torch.float64)])
    batches = np.random.default_rng(5)
    for _ in range(40):
        idx = np.concatenate([batches.integers(len(pos), size=16),
                              len(pos) + batches.integers(len(neg), size=16)])
        adam.zero_grad()
        torch.nn.BCEWithLogitsLoss()(net(data[torch.from_numpy(idx)]), target).backward()
        adam.step()
    c.train(np.random.default_rng(5), steps=40)
    got = c.state()
    for name, p in net.named_parameters():
        assert np.array_equal(got[f"weight.{name}"], p.detach().numpy()), name
        assert np.array_equal(got[f"adam.{name}.exp_avg"], adam.state[p]["exp_avg"].numpy())
