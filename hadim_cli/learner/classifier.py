"""The visual classifier p_A: which objects can fill an affordance's target role.

A small binary torch MLP (features → hidden → hidden → 1, ReLU, BCE on logits) over an
object's properties (radius, height, colour, shape, … already scaled to about [0, 1] by the
caller), trained on balanced replay: one FIFO buffer of positive examples and one of negatives,
every batch half of each. Everything runs in float64 on the CPU with plain Linear/ReLU ops, so
that the same inputs and generator states give bit-identical weights (nothing global is set:
not the torch seed, not deterministic-algorithms mode, not the thread count: a `Session`
sets that when it starts).

Randomness: the initial weights come from a `torch.Generator` seeded with one integer drawn
from the numpy generator given to the constructor; batches are drawn with the numpy generator
given to `train`. The global torch and numpy random states are never read or advanced.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch
from torch import nn

DTYPE = torch.float64
"""Weights and computations in float64: as fast as float32 at this size, and less fragile."""

_HYPER = ("n_features", "hidden", "lr", "replay_size", "batch_size")


def _as_features(features: np.ndarray, n_features: int) -> np.ndarray:
    x = np.asarray(features, dtype=np.float64)
    if x.ndim == 1:
        x = x.reshape(1, -1)
    if x.ndim != 2 or x.shape[1] != n_features:
        raise ValueError(f"features must have shape (n, {n_features}), got {x.shape}")
    if not np.all(np.isfinite(x)):
        raise ValueError("features must be finite")
    return x


class VisualClassifier:
    """p_A: P(an object with these features can fill the affordance's target role).

    Before it has been trained (it needs both positives and negatives) it answers a prior:
    1 if it has only seen positives, 0 if only negatives, 0.5 if nothing (or both but no
    training yet).
    """

    def __init__(self, n_features: int, *, hidden: int = 32, lr: float = 1e-2,
                 replay_size: int = 2000, batch_size: int = 64, rng: np.random.Generator):
        self._setup(n_features, hidden, lr, replay_size, batch_size)
        g = torch.Generator().manual_seed(int(rng.integers(2**63 - 1)))
        with torch.no_grad():
            for layer in self._linears():
                # torch's default Linear init, drawn from our generator.
                bound = 1.0 / float(np.sqrt(layer.in_features))
                layer.weight.uniform_(-bound, bound, generator=g)
                layer.bias.uniform_(-bound, bound, generator=g)

    def _setup(self, n_features: int, hidden: int, lr: float, replay_size: int,
               batch_size: int) -> None:
        if n_features < 1 or hidden < 1 or replay_size < 1 or batch_size < 2 or lr <= 0:
            raise ValueError("need n_features, hidden, replay_size >= 1, batch_size >= 2 "
                             "and lr > 0")
        self.n_features, self.hidden, self.lr = int(n_features), int(hidden), float(lr)
        self.replay_size, self.batch_size = int(replay_size), int(batch_size)
        # skip_init builds the layers without touching the global torch RNG.
        self.net = nn.Sequential(
            nn.utils.skip_init(nn.Linear, self.n_features, self.hidden, dtype=DTYPE),
            nn.ReLU(),
            nn.utils.skip_init(nn.Linear, self.hidden, self.hidden, dtype=DTYPE),
            nn.ReLU(),
            nn.utils.skip_init(nn.Linear, self.hidden, 1, dtype=DTYPE),
        )
        self.optimizer = torch.optim.Adam(self.net.parameters(), lr=self.lr, foreach=False)
        self._loss = nn.BCEWithLogitsLoss()
        self._positives = np.zeros((0, self.n_features), dtype=np.float64)
        self._negatives = np.zeros((0, self.n_features), dtype=np.float64)
        self.n_positive = 0
        """Positive examples ever added (the replay keeps the last `replay_size`)."""
        self.n_negative = 0
        """Negative examples ever added (the replay keeps the last `replay_size`)."""
        self.train_steps = 0
        """Optimiser steps taken so far."""

    def _linears(self) -> list[nn.Linear]:
        return [m for m in self.net if isinstance(m, nn.Linear)]

    # ------------------------------------------------------------------ data and training
    def add(self, features: np.ndarray, labels: np.ndarray) -> None:
        """Add examples (n × n_features, n labels) to the replay of their class."""
        x = _as_features(features, self.n_features)
        y = np.asarray(labels).reshape(-1)
        if y.shape[0] != x.shape[0]:
            raise ValueError(f"{x.shape[0]} feature rows but {y.shape[0]} labels")
        y = y.astype(bool)
        pos, neg = x[y], x[~y]
        self._positives = np.concatenate([self._positives, pos])[-self.replay_size:]
        self._negatives = np.concatenate([self._negatives, neg])[-self.replay_size:]
        self.n_positive += int(pos.shape[0])
        self.n_negative += int(neg.shape[0])

    def train(self, rng: np.random.Generator, steps: int = 50) -> float:
        """`steps` Adam steps on balanced batches; the mean loss, or NaN if nothing was
        trained (one class has no example yet). Draws nothing from `rng` in that case."""
        n_pos, n_neg = self._positives.shape[0], self._negatives.shape[0]
        if n_pos == 0 or n_neg == 0 or steps <= 0:
            return float("nan")
        half = self.batch_size // 2
        data = torch.from_numpy(np.concatenate([self._positives, self._negatives]))
        target = torch.cat([torch.ones(half, 1, dtype=DTYPE),
                            torch.zeros(self.batch_size - half, 1, dtype=DTYPE)])
        total = torch.zeros((), dtype=DTYPE)
        self.net.train()
        for _ in range(steps):
            idx = np.concatenate([rng.integers(n_pos, size=half),
                                  n_pos + rng.integers(n_neg, size=self.batch_size - half)])
            batch = data[torch.from_numpy(idx)]
            self.optimizer.zero_grad(set_to_none=True)
            loss = self._loss(self.net(batch), target)
            loss.backward()
            self.optimizer.step()
            total += loss.detach()
        self.train_steps += steps
        return float(total) / steps

    # ------------------------------------------------------------------ prediction
    def predict_proba(self, features: np.ndarray) -> np.ndarray:
        """P(positive) for each row of `features` (float64, shape (n,))."""
        x = _as_features(features, self.n_features)
        if self.train_steps == 0:
            prior = 0.5
            if self.n_positive > 0 and self.n_negative == 0:
                prior = 1.0
            elif self.n_negative > 0 and self.n_positive == 0:
                prior = 0.0
            return np.full(x.shape[0], prior)
        self.net.eval()
        with torch.no_grad():
            p = torch.sigmoid(self.net(torch.from_numpy(x)))
        return p.numpy().reshape(-1).astype(np.float64)

    def accepts(self, features: np.ndarray, threshold: float = 0.5) -> np.ndarray:
        """Boolean mask: p_A(features) >= threshold."""
        return self.predict_proba(features) >= threshold

    # ------------------------------------------------------------------ persistence
    def params(self) -> dict[str, Any]:
        return {name: getattr(self, name) for name in _HYPER}

    def state(self) -> dict[str, np.ndarray]:
        """Everything for an exact continuation: hyper-parameters, weights, Adam moments,
        replay buffers and counters, as numpy arrays (no pickle)."""
        out: dict[str, np.ndarray] = {
            "hyper": np.array([getattr(self, n) for n in _HYPER], dtype=np.float64),
            "counters": np.array([self.n_positive, self.n_negative, self.train_steps],
                                 dtype=np.int64),
            "replay.positive": self._positives.copy(),
            "replay.negative": self._negatives.copy(),
        }
        for name, p in self.net.named_parameters():
            out[f"weight.{name}"] = p.detach().numpy().copy()
            st = self.optimizer.state.get(p)
            if st:
                out[f"adam.{name}.exp_avg"] = st["exp_avg"].numpy().copy()
                out[f"adam.{name}.exp_avg_sq"] = st["exp_avg_sq"].numpy().copy()
                out[f"adam.{name}.step"] = np.array(float(st["step"]), dtype=np.float64)
        return out

    @classmethod
    def from_state(cls, state: dict[str, np.ndarray], **params: Any) -> VisualClassifier:
        """Rebuild from `state()`. Hyper-parameters come from the state; any given in `params`
        (n_features, hidden, lr, replay_size, batch_size) must agree with it."""
        try:
            stored = dict(zip(_HYPER, state["hyper"].tolist(), strict=True))
        except (KeyError, ValueError) as exc:
            raise ValueError(f"classifier state has no valid hyper-parameters: {exc}") from exc
        for name, value in params.items():
            if name not in stored:
                raise TypeError(f"unknown classifier parameter {name!r}")
            if float(value) != stored[name]:
                raise ValueError(f"classifier state has {name}={stored[name]:g}, "
                                 f"but {name}={value} was asked for")
        obj = cls.__new__(cls)
        obj._setup(int(stored["n_features"]), int(stored["hidden"]), stored["lr"],
                   int(stored["replay_size"]), int(stored["batch_size"]))
        try:
            obj._load(state)
        except (KeyError, RuntimeError, ValueError) as exc:
            raise ValueError(f"classifier state is inconsistent: {exc}") from exc
        return obj

    def _load(self, state: dict[str, np.ndarray]) -> None:
        n_pos, n_neg, steps = (int(v) for v in state["counters"])
        self.n_positive, self.n_negative, self.train_steps = n_pos, n_neg, steps
        self._positives = _as_features(state["replay.positive"], self.n_features).copy()
        self._negatives = _as_features(state["replay.negative"], self.n_features).copy()
        with torch.no_grad():
            for name, p in self.net.named_parameters():
                p.copy_(torch.from_numpy(np.array(state[f"weight.{name}"], dtype=np.float64)))
        opt_state = {}
        for i, (name, _) in enumerate(self.net.named_parameters()):
            if f"adam.{name}.step" not in state:
                continue
            opt_state[i] = {
                "step": torch.tensor(float(state[f"adam.{name}.step"]), dtype=torch.float32),
                "exp_avg": torch.from_numpy(np.array(state[f"adam.{name}.exp_avg"])),
                "exp_avg_sq": torch.from_numpy(np.array(state[f"adam.{name}.exp_avg_sq"])),
            }
        groups = self.optimizer.state_dict()["param_groups"]
        self.optimizer.load_state_dict({"state": opt_state, "param_groups": groups})
