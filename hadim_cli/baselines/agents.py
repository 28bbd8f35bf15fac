"""The four algorithms of the comparison behind one small interface: `learn(steps)`,
`act(obs)` (greedy, for evaluation), `state(...)` / `restore(...)` as JSON and arrays.

- `q-learning`: ours (`qlearning.TabularQ`), numpy, seeded from the run's generator.
- `dqn`, `a2c`: stable-baselines3 with `MultiInputPolicy` (a UVFA: the goal is an input),
  device "cpu". Two small subclasses fix the exploration schedule's horizon to the run's (SB3
  reads it from each `learn` call, and a run learns chunk by chunk).
- `curious`: SB3's DQN with `HerReplayBuffer` (future, k = 4) over `curious.ModularGoalEnv`.

SB3 draws from the global numpy, torch and Python generators (seeded by its `seed=`, an
integer drawn from the run's generator) and from the action space's generator; all of their
states are checkpointed. Replay buffers are checkpointed as the rows each chunk added (a
recording buffer keeps the arguments of every `add`); a restore replays them into a fresh
buffer, which rebuilds SB3's circular and HER episode bookkeeping exactly.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from hadim_cli.baselines.config import Algorithm, BaselineConfig
from hadim_cli.baselines.curious import ModularGoalEnv, modular_her_buffer
from hadim_cli.baselines.env import GoalWorldEnv
from hadim_cli.baselines.qlearning import QLearningParams, TabularQ
from hadim_cli.baselines.state import global_rngs, join, set_global_rngs, split

# --------------------------------------------------------------------------- agents

ENV_PARAMS = ("reward_scale",)
"""Parameters of the environment, not of the algorithm (`variants`)."""
POLICY_PARAMS = ("goal_frame",)


def environment(cfg: BaselineConfig) -> GoalWorldEnv:
    return GoalWorldEnv(cfg.task, cfg.actions, cfg.reward, cfg.world_config, cfg.episode_length,
                        reward_scale=float(cfg.params.get("reward_scale", 1.0)))


def _algorithm_params(cfg: BaselineConfig) -> dict[str, Any]:
    return {k: v for k, v in cfg.params.items() if k not in ENV_PARAMS + POLICY_PARAMS}


class QAgent:
    """Tabular Q-learning over a goal environment."""

    def __init__(self, cfg: BaselineConfig, seed: int):
        self.base = environment(cfg)
        self.env = self.base
        self.bases = [self.base]
        self.q = TabularQ(self.base, QLearningParams(**_algorithm_params(cfg)), cfg.horizon,
                          np.random.default_rng(seed))

    @property
    def iterations(self) -> int:
        return self.q.iterations

    def learn(self, steps: int) -> None:
        self.q.learn(steps)

    def act(self, obs: dict[str, np.ndarray]) -> int:
        return self.q.greedy(obs)

    def state(self) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        meta, arrays = self.q.state_dict()
        return {"q": meta, "env": self.base.snapshot()}, arrays

    def restore(self, meta: dict[str, Any], arrays: dict[str, np.ndarray],
                chunks: list[dict[str, np.ndarray]]) -> None:  # noqa: ARG002
        obs = self.base.restore(meta["env"])
        self.q.load_state_dict(meta["q"], arrays, obs)


def _recording(buffer_class: type) -> type:
    """`buffer_class` whose `add` also keeps its arguments (the rows of the current chunk)."""

    class Recording(buffer_class):  # type: ignore[misc, valid-type]
        def __init__(self, *args: Any, **kwargs: Any):
            super().__init__(*args, **kwargs)
            self.log: list[tuple] = []

        def add(self, obs, next_obs, action, reward, done, infos):  # noqa: PLR0913
            timeout = [bool(i.get("TimeLimit.truncated", False)) for i in infos]
            row = ({k: np.array(v) for k, v in obs.items()},
                   {k: np.array(v) for k, v in next_obs.items()},
                   np.array(action), np.array(reward), np.array(done), np.array(timeout))
            if getattr(self, "copy_info_dict", False):  # HER recomputing a guided reward
                row += ({k: np.stack([i[k] for i in infos]) for k in INFO_KEYS},)
            self.log.append(row)
            super().add(obs, next_obs, action, reward, done, infos)

    Recording.__name__ = f"Recording{buffer_class.__name__}"
    return Recording


def _horizon(algo_class: type) -> type:
    """`algo_class` whose schedules span the run's horizon, not one `learn` call."""

    class Horizon(algo_class):  # type: ignore[misc, valid-type]
        horizon = 1

        def _update_current_progress_remaining(self, num_timesteps: int,
                                               total_timesteps: int) -> None:  # noqa: ARG002
            super()._update_current_progress_remaining(num_timesteps, self.horizon)

    Horizon.__name__ = algo_class.__name__
    return Horizon


INFO_KEYS = ("chain_before", "chain_after")
"""What a relabelled guided reward reads from a transition's info (kept with its row)."""
_COUNTERS = ("num_timesteps", "_n_calls", "_n_updates", "_episode_num", "exploration_rate",
             "_current_progress_remaining")
_BUFFER_PARTS = ("obs", "next_obs")


class SB3Agent:
    """DQN, A2C or CURIOUS from stable-baselines3 over a goal environment."""

    def __init__(self, cfg: BaselineConfig, seed: int):
        from stable_baselines3 import A2C, DQN, HerReplayBuffer
        from stable_baselines3.common.buffers import DictReplayBuffer
        from stable_baselines3.common.logger import Logger
        from stable_baselines3.common.vec_env import DummyVecEnv

        self.algorithm = Algorithm(cfg.algorithm)
        self.bases = [environment(cfg) for _ in range(cfg.n_envs)]
        self.envs: list[GoalWorldEnv | ModularGoalEnv] = [
            ModularGoalEnv(b) if self.algorithm is Algorithm.CURIOUS else b for b in self.bases]
        self.base, self.env = self.bases[0], self.envs[0]
        vec = DummyVecEnv([lambda e=e: e for e in self.envs])
        params = _algorithm_params(cfg)
        common = {"policy": "MultiInputPolicy", "env": vec, "seed": seed, "device": "cpu",
                  "verbose": 0}
        if cfg.params.get("goal_frame"):
            from hadim_cli.baselines.features import goal_frame_extractor

            slots = self.envs[0].n_modules if self.algorithm is Algorithm.CURIOUS else 1
            common["policy_kwargs"] = {
                "features_extractor_class": goal_frame_extractor(),
                "features_extractor_kwargs": {"slots": slots}}
        if self.algorithm is Algorithm.A2C:
            self.model = _horizon(A2C)(**common, **params)
        else:
            her = dict(params.pop("her", None) or {}) or None
            modular = bool(her and her.pop("modular", False))
            buffer = _recording(HerReplayBuffer if her else DictReplayBuffer)
            if modular:
                buffer = modular_her_buffer(buffer)
            self.model = _horizon(DQN)(**common, **params, replay_buffer_class=buffer,
                                       replay_buffer_kwargs=her)
            if modular:
                self.model.replay_buffer.module_probabilities = self.envs[0].probabilities
                self.model.replay_buffer.objects_at = \
                    self.envs[0].base.position_columns(1).start
        self.model.horizon = cfg.horizon
        # A logger that writes nowhere: SB3's own makes a new directory under the system's
        # temporary one at every `learn` call (one per chunk: thousands per sweep).
        self.model.set_logger(Logger(folder=None, output_formats=[]))

    @property
    def iterations(self) -> int:
        return int(self.model.num_timesteps)

    def learn(self, steps: int) -> None:
        self.model.learn(steps, reset_num_timesteps=False, progress_bar=False)

    def act(self, obs: dict[str, np.ndarray]):
        action, _ = self.model.predict(obs, deterministic=True)
        return action

    # ------------------------------------------------------------------ checkpoints

    def state(self) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        """This chunk's checkpoint: networks, optimiser, counters, generators, the episode
        in progress, and the replay rows added since the last checkpoint."""
        m = self.model
        arrays: dict[str, np.ndarray] = {}
        meta: dict[str, Any] = {
            "policy": split(m.policy.state_dict(), "policy", arrays),
            "optimizer": split(m.policy.optimizer.state_dict(), "optim", arrays),
            "counters": {k: getattr(m, k) for k in _COUNTERS if hasattr(m, k)},
            "episode_starts": (None if m._last_episode_starts is None
                               else m._last_episode_starts.tolist()),
            "action_space": m.action_space.np_random.bit_generator.state,
            # one environment: its snapshot (the format of runs stored before n_envs)
            "env": (self.env.snapshot() if len(self.envs) == 1
                    else [e.snapshot() for e in self.envs]),
            "rng": global_rngs(arrays),
        }
        buffer = getattr(m, "replay_buffer", None)
        if buffer is not None:
            arrays.update(_rows(buffer.log))
            meta["buffer_rows"] = len(buffer.log)
            buffer.log.clear()
        return meta, arrays

    def restore(self, meta: dict[str, Any], arrays: dict[str, np.ndarray],
                chunks: list[dict[str, np.ndarray]]) -> None:
        """The state of `meta`/`arrays`; `chunks` are every checkpoint's arrays up to it, in
        order, whose replay rows are added again."""
        m = self.model
        buffer = getattr(m, "replay_buffer", None)
        if buffer is not None:
            for rows in chunks:
                _replay(buffer, rows)
            buffer.log.clear()
        m.policy.load_state_dict(join(meta["policy"], arrays))
        m.policy.optimizer.load_state_dict(join(meta["optimizer"], arrays))
        for key, value in meta["counters"].items():
            setattr(m, key, value)
        if meta["episode_starts"] is not None:
            m._last_episode_starts = np.array(meta["episode_starts"], dtype=bool)
        m.action_space.np_random.bit_generator.state = meta["action_space"]
        snaps = meta["env"] if isinstance(meta["env"], list) else [meta["env"]]
        obs = [e.restore(snap) for e, snap in zip(self.envs, snaps, strict=True)]
        if obs[0] is not None:
            m._last_obs = {k: np.stack([o[k] for o in obs]) for k in obs[0]}
            m._last_original_obs = m._last_obs
        set_global_rngs(meta["rng"], arrays)


def _rows(log: list[tuple]) -> dict[str, np.ndarray]:
    if not log:
        return {}
    out: dict[str, np.ndarray] = {}
    for part, index in zip(_BUFFER_PARTS, (0, 1), strict=True):
        for key in log[0][index]:
            out[f"buffer.{part}.{key}"] = np.stack([row[index][key] for row in log])
    for name, index in (("action", 2), ("reward", 3), ("done", 4), ("timeout", 5)):
        out[f"buffer.{name}"] = np.stack([row[index] for row in log])
    if len(log[0]) > 6:
        for key in INFO_KEYS:
            out[f"buffer.info.{key}"] = np.stack([row[6][key] for row in log])
    return out


def _replay(buffer, rows: dict[str, np.ndarray]) -> None:
    if "buffer.action" not in rows:
        return
    keys = [k.removeprefix("buffer.obs.") for k in rows if k.startswith("buffer.obs.")]
    for i in range(len(rows["buffer.action"])):
        obs = {k: rows[f"buffer.obs.{k}"][i] for k in keys}
        nxt = {k: rows[f"buffer.next_obs.{k}"][i] for k in keys}
        infos = [{"TimeLimit.truncated": bool(t)} for t in rows["buffer.timeout"][i]]
        if "buffer.info.chain_before" in rows:
            for e, info in enumerate(infos):
                info.update({k: rows[f"buffer.info.{k}"][i][e] for k in INFO_KEYS})
        buffer.add(obs, nxt, rows["buffer.action"][i], rows["buffer.reward"][i],
                   rows["buffer.done"][i], infos)


def make_agent(cfg: BaselineConfig, seed: int) -> QAgent | SB3Agent:
    if Algorithm(cfg.algorithm) is Algorithm.Q_LEARNING:
        return QAgent(cfg, seed)
    return SB3Agent(cfg, seed)
