"""The full bodies of one evaluation split over worker processes: ``BodyWorkers``.

Body ``i`` lives in worker ``i % n`` (a ``fullbody.bodies.Bodies`` there); one 50 Hz step of
a batch sends each worker its bodies' commands and targets, and all workers simulate at
once, one core each. The workers are started with the ``spawn`` method (a fresh
interpreter: no fork of a process that holds JAX's threads) and hold nothing but MuJoCo
and the controllers, so the policy and the JAX world stay in the parent. The interface is
``Bodies``'; an episode's outcome is the same to the bit with any number of workers
(``tests/fullbody/test_workers.py``).
"""

from __future__ import annotations

import multiprocessing as mp
from collections.abc import Callable

import numpy as np

from dyncatch.fullbody.bodies import ROW_SIZE, Bodies, Reach, StepOut
from dyncatch.fullbody.config import FullBodyCfg


def _serve(conn, fullbody: FullBodyCfg, record: int | None, probe: Callable | None) -> None:
    """A worker's loop: ``Bodies`` methods by name until ``close``."""
    bodies = Bodies(fullbody, record, probe)
    while True:
        name, args = conn.recv()
        if name == "close":
            conn.close()
            return
        try:
            out = getattr(bodies, name)(*args) if name != "probe" else bodies.probe
        except Exception as e:  # noqa: BLE001 -- sent to the parent, which raises it
            conn.send(("error", repr(e)))
            continue
        if name != "reset":
            conn.send(("ok", out))


class BodyWorkers:
    """``n`` worker processes with the interface of ``Bodies``. ``close()`` ends them."""

    def __init__(
        self,
        fullbody: FullBodyCfg,
        n: int,
        record: int | None = None,
        probe: Callable | None = None,
    ):
        ctx = mp.get_context("spawn")
        self.n, self._conns, self._procs = n, [], []
        for _ in range(n):
            parent, child = ctx.Pipe()
            proc = ctx.Process(target=_serve, args=(child, fullbody, record, probe), daemon=True)
            proc.start()
            child.close()
            self._conns.append(parent)
            self._procs.append(proc)
        self.record = record

    def _reply(self, w: int):
        status, out = self._conns[w].recv()
        if status == "error":
            raise RuntimeError(f"full-body worker {w} failed: {out}")
        return out

    def reset(self, i: int, xy_m: np.ndarray, yaw_rad: float) -> None:
        """Body ``i`` is made in its worker; no reply is awaited (the pipe keeps order)."""
        self._conns[i % self.n].send(("reset", (i, xy_m, yaw_rad)))

    def _split(self, ids: np.ndarray) -> list[np.ndarray]:
        return [np.flatnonzero(ids % self.n == w) for w in range(self.n)]

    def step(self, reach: Reach, ids, ended, commands, targets_xy_m) -> StepOut:
        parts = self._split(ids)
        for w, p in enumerate(parts):
            if len(p):
                args = (reach, ids[p], ended[p], commands[p], targets_xy_m[p])
                self._conns[w].send(("step", args))
        k = len(ids)
        rows, best = np.zeros((k, ROW_SIZE)), np.full(k, np.inf)
        fell, over = np.zeros(k, bool), np.zeros(k, bool)
        stepped = 0
        for w, p in enumerate(parts):
            if len(p):
                out: StepOut = self._reply(w)
                rows[p], best[p], fell[p], over[p] = out.rows, out.best_m, out.fell, out.over_limit
                stepped += out.stepped
        return StepOut(rows, best, fell, over, stepped)

    def peaks(self, ids: np.ndarray) -> np.ndarray:
        parts = self._split(ids)
        out = np.zeros((len(ids), 2))
        for w, p in enumerate(parts):
            self._conns[w].send(("peaks", (ids[p],)))
            out[p] = self._reply(w)
        return out

    def recorded(self) -> dict[str, np.ndarray]:
        if self.record is None:
            return {}
        w = self.record % self.n
        self._conns[w].send(("recorded", ()))
        return self._reply(w)

    def probes(self) -> list:
        """Each worker's copy of the probe, with what it saw."""
        out = []
        for w in range(self.n):
            self._conns[w].send(("probe", ()))
            out.append(self._reply(w))
        return out

    def close(self) -> None:
        for conn in self._conns:
            try:
                conn.send(("close", ()))
            except (BrokenPipeError, OSError):
                pass
        for proc in self._procs:
            proc.join(timeout=10)
            if proc.is_alive():
                proc.terminate()
