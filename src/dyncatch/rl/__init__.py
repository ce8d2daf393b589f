"""PPO for the high-level catching policy: pure functions, the whole update in one jit."""
