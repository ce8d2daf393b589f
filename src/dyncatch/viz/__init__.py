"""Visualisation at the edge: record one episode to numpy, draw it top-down, write a video.

Nothing in ``dyncatch.sim`` imports from here; matplotlib is imported only by ``render``.
"""

from dyncatch.viz.trajectory import record_episode

__all__ = ["record_episode"]
