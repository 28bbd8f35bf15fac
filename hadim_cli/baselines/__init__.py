"""The paper's reinforcement-learning comparison (§5.3): goal-conditioned environments over
the same `World`, tabular Q-learning, DQN and A2C (stable-baselines3) as UVFAs, and CURIOUS."""
