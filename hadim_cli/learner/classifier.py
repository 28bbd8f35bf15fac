"""The visual classifier p_A: which objects can fill an affordance's target role.

A small binary torch MLP (features → hidden → hidden → 1, ReLU, BCE on logits) over an
object's properties (radius, height, colour, shape, … already scaled to about [0, 1] by the
caller), trained on balanced replay: one FIFO buffer of positive examples and one of negatives,
every batch half of each. Everything runs in float64 on the CPU with plain linear/ReLU ops, so
that the same inputs and generator states give bit-identical weights (nothing global is set:
not the torch seed, not deterministic-algorithms mode, not the thread count: a `Session`
sets that when it starts).

The weights are views of one flat tensor, and a training step computes its gradients with
the very ops torch's autograd runs for these layers (`addmm`'s, `threshold_backward`, the
logits loss's), then takes one Adam step over the flat tensor with the ops of torch's own
`Adam` (β = 0.9, 0.999, ε = 1e-8): the same weights, bit for bit, as `nn.Linear` layers under
autograd and `torch.optim.Adam` over each layer (`tests/learner/test_classifier.py` checks
it), without building a graph, looping over six tensors, or importing the compiler machinery
`torch.optim` loads, each of a session's ten thousand steps.

Randomness: the initial weights come from a `torch.Generator` seeded with one integer drawn
from the numpy generator given to the constructor; batches are drawn with the numpy generator
given to `train`. The global torch and numpy random states are never read or advanced.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

DTYPE = torch.float64
"""Weights and computations in float64: as fast as float32 at this size, and less fragile."""

_BETA1, _BETA2, _EPS = 0.9, 0.999, 1e-8
"""torch `Adam`'s defaults."""

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
        for w, b in self._layers():
            # torch's default Linear init, drawn from our generator.
            bound = 1.0 / float(np.sqrt(w.shape[1]))
            w.uniform_(-bound, bound, generator=g)
            b.uniform_(-bound, bound, generator=g)

    def _setup(self, n_features: int, hidden: int, lr: float, replay_size: int,
               batch_size: int) -> None:
        if n_features < 1 or hidden < 1 or replay_size < 1 or batch_size < 2 or lr <= 0:
            raise ValueError("need n_features, hidden, replay_size >= 1, batch_size >= 2 "
                             "and lr > 0")
        self.n_features, self.hidden, self.lr = int(n_features), int(hidden), float(lr)
        self.replay_size, self.batch_size = int(replay_size), int(batch_size)
        shapes = {"0.weight": (self.hidden, self.n_features), "0.bias": (self.hidden,),
                  "2.weight": (self.hidden, self.hidden), "2.bias": (self.hidden,),
                  "4.weight": (1, self.hidden), "4.bias": (1,)}
        self._flat = torch.zeros(sum(int(np.prod(v)) for v in shapes.values()), dtype=DTYPE)
        self._params: dict[str, torch.Tensor] = {}
        """The layers' weights and biases by `nn.Sequential` name: views of `_flat`."""
        start = 0
        for name, shape in shapes.items():
            size = int(np.prod(shape))
            self._params[name] = self._flat[start:start + size].view(shape)
            start += size
        self._moments: tuple[torch.Tensor, torch.Tensor] | None = None
        """Adam's first and second moments of the flat weights (None before the first step)."""
        self._adam_steps = 0
        self._positives = np.zeros((0, self.n_features), dtype=np.float64)
        self._negatives = np.zeros((0, self.n_features), dtype=np.float64)
        self.n_positive = 0
        """Positive examples ever added (the replay keeps the last `replay_size`)."""
        self.n_negative = 0
        """Negative examples ever added (the replay keeps the last `replay_size`)."""
        self.train_steps = 0
        """Optimiser steps taken so far."""

    def _slices(self) -> dict[str, slice]:
        out, start = {}, 0
        for name, p in self._params.items():
            out[name] = slice(start, start + p.numel())
            start += p.numel()
        return out

    def _layers(self) -> list[tuple[torch.Tensor, torch.Tensor]]:
        p = self._params
        return [(p["0.weight"], p["0.bias"]), (p["2.weight"], p["2.bias"]),
                (p["4.weight"], p["4.bias"])]

    def _forward(self, x: torch.Tensor) -> list[torch.Tensor]:
        """Each layer's input and the logits: [x, h1, h2, logits]."""
        out = [x]
        for i, (w, b) in enumerate(self._layers()):
            z = torch.addmm(b, out[-1], w.t())  # what `F.linear` runs for a 2-D input
            out.append(torch.relu(z) if i < 2 else z)
        return out

    def _step(self, batch: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
        """One Adam step on `batch`; its loss. The gradients are autograd's for these ops:
        addmm's (bias: the sum over rows; weight: gradᵀ·input; input: grad·weight), ReLU's
        `threshold_backward` on its output, and the mean logits loss's (σ(z) − y) / N."""
        acts = self._forward(batch)
        logits = acts[-1]
        loss = torch.nn.functional.binary_cross_entropy_with_logits(logits, target)
        grad = (torch.sigmoid(logits) - target).div_(logits.numel())
        grads: list[torch.Tensor] = []
        for i in (2, 1, 0):
            w, _ = self._layers()[i]
            grads[:0] = [grad.t().mm(acts[i]).reshape(-1), grad.sum(0)]
            if i:
                grad = torch.ops.aten.threshold_backward(grad.mm(w), acts[i], 0)
        self._adam(torch.cat(grads))
        return loss

    def _adam(self, grad: torch.Tensor) -> None:
        """One Adam step of the flat weights: torch's `Adam` (single-tensor, no weight decay,
        no amsgrad), op for op."""
        if self._moments is None:
            self._moments = (torch.zeros_like(self._flat), torch.zeros_like(self._flat))
        exp_avg, exp_avg_sq = self._moments
        self._adam_steps += 1
        exp_avg.lerp_(grad, 1 - _BETA1)
        exp_avg_sq.mul_(_BETA2).addcmul_(grad, grad, value=1 - _BETA2)
        step = float(self._adam_steps)
        step_size = self.lr / (1 - _BETA1 ** step)
        denom = (exp_avg_sq.sqrt() / (1 - _BETA2 ** step) ** 0.5).add_(_EPS)
        self._flat.addcdiv_(exp_avg, denom, value=-step_size)

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
        for _ in range(steps):
            idx = np.concatenate([rng.integers(n_pos, size=half),
                                  n_pos + rng.integers(n_neg, size=self.batch_size - half)])
            total += self._step(data[torch.from_numpy(idx)], target)
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
        p = torch.sigmoid(self._forward(torch.from_numpy(x))[-1])
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
        for (name, p), sl in zip(self._params.items(), self._slices().values(), strict=True):
            out[f"weight.{name}"] = p.numpy().copy()
            if self._moments is not None:
                for moment, values in zip(("exp_avg", "exp_avg_sq"), self._moments, strict=True):
                    out[f"adam.{name}.{moment}"] = values[sl].reshape(p.shape).numpy().copy()
                out[f"adam.{name}.step"] = np.array(float(self._adam_steps), dtype=np.float64)
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
        for name, p in self._params.items():
            weight = np.array(state[f"weight.{name}"], dtype=np.float64)
            if weight.shape != tuple(p.shape):
                raise ValueError(f"weight.{name} has shape {weight.shape}, not {tuple(p.shape)}")
            p.copy_(torch.from_numpy(weight))
        names = list(self._params)
        if all(f"adam.{name}.step" in state for name in names):
            steps = {float(state[f"adam.{name}.step"]) for name in names}
            if len(steps) != 1:
                raise ValueError(f"the layers' Adam steps differ: {sorted(steps)}")
            moments = tuple(torch.from_numpy(np.concatenate(
                [np.array(state[f"adam.{name}.{m}"], dtype=np.float64).reshape(-1)
                 for name in names])) for m in ("exp_avg", "exp_avg_sq"))
            if moments[0].numel() != self._flat.numel():
                raise ValueError("the Adam moments do not match the layers")
            self._moments, self._adam_steps = moments, int(steps.pop())
        else:
            self._moments, self._adam_steps = None, 0
