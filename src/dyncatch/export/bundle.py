"""Export a trained run as files a robot runs without dyncatch, JAX or pickle.

``export_run(run_dir, out)`` writes into ``out``:

- ``policy.onnx``: the method's input vector (batch, D) -> the base command (batch, 3) in
  m/s, m/s, rad/s (normalisation, the actor's mean action, clip and scaling); for a method
  with memory (``rnn_rl``) also the actor's GRU state in (``memory_in``, zeros at an
  episode's start) and out (``memory_out``, fed back at the next control step);
- ``predictor.onnx`` (methods that read a predictor): the predictor's encoded inputs
  (batch, D_pred) and output yaws (batch,) -> the target's world velocity (batch, 2), m/s;
- ``export.json``: every input's layout (names, offsets, units, meanings), the rates, the
  frames, the command limits, the method and the versions, and each file's SHA-256.

The policy input of a predictor method is ``Obs.flat`` followed by the predictor's output
rotated into the base frame (``world_to_body(v, robot yaw)``), zeroed unless the last two
camera frames saw the target, and that flag (``export.json`` says so under
``predictor.to_policy``).
"""

from __future__ import annotations

import hashlib
import json
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

import numpy as np
import onnx

from dyncatch.export.graphs import (
    IR_VERSION,
    OPSET,
    policy_model,
    predictor_model,
    recurrent_policy_model,
)
from dyncatch.export.layout import FRAMES, command_layout, policy_layout, predictor_layout
from dyncatch.predictor.features import get_encoder
from dyncatch.rl.networks import ActorCritic
from dyncatch.rl.policy import Run, load_run
from dyncatch.rl.recurrent import RecurrentActorCritic

FORMAT = "dyncatch.export/1"
POLICY_FILE = "policy.onnx"
PREDICTOR_FILE = "predictor.onnx"
MANIFEST_FILE = "export.json"

MEMORY_DOC = (
    "the actor's GRU hidden state: zeros at an episode's start, then the previous control "
    "step's memory_out (one row per robot)"
)

TO_POLICY = (
    "v_world = predictor output; ok = 1 if the last two camera frames both saw the target "
    "else 0; target_vel_body_mps = ok * R(-robot yaw now) v_world; target_vel_defined = ok"
)


def _version(package: str) -> str:
    try:
        return version(package)
    except PackageNotFoundError:
        return "unknown"


def _write(model: onnx.ModelProto, path: Path) -> str:
    """Serialise (protobuf, no pickle) and return the file's SHA-256."""
    data = model.SerializeToString()
    path.write_bytes(data)
    return hashlib.sha256(data).hexdigest()


def _vector(name: str, layout: list[dict], doc: str) -> dict:
    size = sum(e["size"] for e in layout)
    return {
        "name": name,
        "shape": ["batch", size],
        "dtype": "float32",
        "doc": doc,
        "layout": layout,
    }


def export(run: Run, out: str | Path, source: dict | None = None) -> dict:
    """Write ``run``'s policy (and predictor) as ONNX plus ``export.json`` into ``out``.

    Returns the manifest written to ``export.json``. ``source`` (JSON-able) records where
    the run came from.
    """
    policy = run.policy
    if not isinstance(policy.net, ActorCritic | RecurrentActorCritic):
        raise ValueError(
            f"cannot export a {type(policy.net).__name__}: only ActorCritic and "
            "RecurrentActorCritic"
        )
    if policy.obs_fn.stateful:
        raise ValueError(
            f"cannot export {run.method!r}: its tracker carries a memory between steps, "
            "which the ONNX export does not write yet (export a stateless method)"
        )
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    world, obs_fn = run.world, policy.obs_fn
    spec = policy.env.action_spec
    low, high = np.asarray(spec.low, np.float32), np.asarray(spec.high, np.float32)
    inputs = policy_layout(obs_fn, world)
    doc = f"dyncatch {run.method} policy ({run.behavior}): obs (batch, D) -> command (batch, 3)"
    norm, params = policy.norm, policy.params["params"]
    recurrent = isinstance(policy.net, RecurrentActorCritic)
    if recurrent:
        doc += "; memory_in (batch, H) -> memory_out (batch, H)"
        model = recurrent_policy_model(
            params["actor_memory"],
            params["actor"],
            norm.mean,
            norm.var,
            low,
            high,
            doc,
            norm.min_std,
        )
    else:
        model = policy_model(params["actor"], norm.mean, norm.var, low, high, doc, norm.min_std)
    manifest = {
        "format": FORMAT,
        "method": run.method,
        "trained_method": run.trained_method,
        "behavior": run.behavior,
        "rates_hz": {
            "control": float(world.episode.control_hz),
            "camera": float(world.sensor.rate_hz),
        },
        "frames": FRAMES,
        "policy": {
            "file": POLICY_FILE,
            "sha256": _write(model, out / POLICY_FILE),
            "velocity_input": obs_fn.velocity_input,
            "inputs": [_vector("obs", inputs, "the method's input vector, one row per robot")],
            "outputs": [
                {
                    **_vector(
                        "command",
                        command_layout(),
                        "the actor's mean action as a base command, clipped to [low, high]",
                    ),
                    "low": low.tolist(),
                    "high": high.tolist(),
                }
            ],
        },
        "predictor": None,
        "versions": {
            "dyncatch": _version("dyncatch"),
            "jax": _version("jax"),
            "flax": _version("flax"),
            "onnx": onnx.__version__,
            "opset": OPSET,
            "ir_version": IR_VERSION,
        },
        "source": source or {},
    }
    if recurrent:
        state = {"shape": ["batch", policy.net.memory_size], "dtype": "float32", "unit": "1"}
        manifest["policy"]["inputs"].append({"name": "memory_in", **state, "doc": MEMORY_DOC})
        manifest["policy"]["outputs"].append(
            {"name": "memory_out", **state, "doc": "the GRU hidden state after this step"}
        )
    if obs_fn.predictor is None:
        (out / PREDICTOR_FILE).unlink(missing_ok=True)  # an earlier export's, now stale
    else:
        predictor = obs_fn.predictor
        encoder = get_encoder(predictor.cfg.kind, predictor.cfg.frame)
        doc = f"dyncatch {predictor.cfg.kind} predictor: features, yaw_out -> world velocity"
        model = predictor_model(obs_fn.predictor_params, doc)
        manifest["predictor"] = {
            "file": PREDICTOR_FILE,
            "sha256": _write(model, out / PREDICTOR_FILE),
            "kind": predictor.cfg.kind,
            "frame": predictor.cfg.frame,
            "arena_size_m": predictor.arena_size_m,
            "frame_dt_s": predictor.frame_dt_s,
            "inputs": [
                _vector(
                    "features",
                    predictor_layout(predictor),
                    "the encoded history: the last two sightings, the robot poses at their "
                    "captures, its velocity now (dyncatch.predictor.features)",
                ),
                {
                    "name": "yaw_out_rad",
                    "shape": ["batch"],
                    "dtype": "float32",
                    "unit": "rad",
                    "doc": f"the output's rotation into the world: {encoder.yaw_out}",
                },
            ],
            "outputs": [
                {
                    "name": "target_vel_world_mps",
                    "shape": ["batch", 2],
                    "dtype": "float32",
                    "unit": "m/s",
                    "doc": "the target's mean velocity over the next camera "
                    "period, v_hat_{t+1}, world axes",
                }
            ],
            "to_policy": TO_POLICY,
        }
    (out / MANIFEST_FILE).write_text(json.dumps(manifest, indent=2) + "\n")
    return manifest


def export_run(
    run: str | Path,
    out: str | Path,
    as_method: str | None = None,
    predictor: str | Path | None = None,
) -> dict:
    """Load a run folder written by ``dyncatch train`` (``load_run``'s arguments) and
    ``export`` it into ``out``; returns the manifest."""
    loaded = load_run(run, as_method, predictor)
    source = {"run": str(run)}
    if loaded.policy.obs_fn.predictor is not None:
        source["predictor"] = str(predictor or loaded.header.get("predictor"))
    return export(loaded, out, source)
