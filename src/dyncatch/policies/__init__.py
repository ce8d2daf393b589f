"""Policies: pure functions ``(obs, key) -> action`` for one environment (vmap for a batch)."""
