"""ONNX graphs of a trained policy and a predictor, built op by op from their parameters.

The graphs are written with ``onnx.helper`` from the arrays the JAX code uses, each op the
one the JAX code applies, in the same order (so float32 results agree to rounding):

- policy: ``(obs - mean) / max(sqrt(var + 1e-8), min_std)``, clipped to [-10, 10] (``RunningNorm``);
  the actor MLP (``MatMul`` + ``Add``, ``Elu``; the critic and the log-std are left out:
  the deployed action is the mean); the clip to [-1, 1] and ``to_command``'s scaling
  ``low + (a + 1) * 0.5 * (high - low)``.
- recurrent policy (``rnn_rl``): the same with the actor's GRU between the normaliser and
  the MLP (``MatMul`` + ``Add``, ``Split`` into the three gates, ``Sigmoid``, ``Tanh``),
  its hidden state an input (``memory_in``) and an output (``memory_out``).
- predictor: ``(x - in_mean) / in_std``, the MLP (``Gelu`` with the tanh approximation, as
  ``flax.linen.gelu``), the output rotated by ``yaw_out`` (``rotate``).

Every input has a symbolic batch axis ``batch``: one vector is a batch of one.
"""

from __future__ import annotations

import numpy as np
import onnx
from onnx import TensorProto, helper, numpy_helper

OPSET = 20
"""ONNX opset of the exported graphs (20 is the first with ``Gelu``)."""
IR_VERSION = 9
"""ONNX IR version: the lowest that carries opset 20, so older runtimes load the files."""
NORM_CLIP = 10.0
"""``RunningNorm``'s clip of normalised observations."""
NORM_EPS = 1e-8
"""``RunningNorm``'s variance floor."""


class _Graph:
    """Accumulates nodes and float32 constants under unique names."""

    def __init__(self):
        self.nodes: list[onnx.NodeProto] = []
        self.consts: list[onnx.TensorProto] = []

    def const(self, name: str, value) -> str:
        self.consts.append(numpy_helper.from_array(np.asarray(value, np.float32), name))
        return name

    def int_const(self, name: str, values: list[int]) -> str:
        self.consts.append(numpy_helper.from_array(np.asarray(values, np.int64), name))
        return name

    def op(self, op_type: str, inputs: list[str], out: str, **attrs) -> str:
        self.nodes.append(helper.make_node(op_type, inputs, [out], name=out, **attrs))
        return out

    def mlp(self, x: str, layers: list[dict], activation: str, prefix: str, **attrs) -> str:
        """Dense layers ``x @ kernel + bias`` with ``activation`` between them."""
        for i, layer in enumerate(layers):
            w = self.const(f"{prefix}/{i}/kernel", layer["kernel"])
            b = self.const(f"{prefix}/{i}/bias", layer["bias"])
            x = self.op(
                "Add", [self.op("MatMul", [x, w], f"{prefix}/{i}/matmul"), b], f"{prefix}/{i}"
            )
            if i + 1 < len(layers):
                x = self.op(activation, [x], f"{prefix}/{i}/{activation.lower()}", **attrs)
        return x

    def model(self, name: str, inputs, outputs, doc: str) -> onnx.ModelProto:
        graph = helper.make_graph(self.nodes, name, inputs, outputs, self.consts)
        model = helper.make_model(
            graph,
            opset_imports=[helper.make_opsetid("", OPSET)],
            producer_name="dyncatch",
            ir_version=IR_VERSION,
            doc_string=doc,
        )
        onnx.checker.check_model(model, full_check=True)
        return model


def dense_layers(params: dict) -> list[dict]:
    """The ``Dense_i`` layers of a flax MLP's params, in order: [{kernel (I, O), bias (O,)}]."""
    names = sorted((k for k in params if k.startswith("Dense_")), key=lambda k: int(k[6:]))
    if len(names) != len(params):
        raise ValueError(f"not a plain MLP: layers {sorted(params)}")
    return [
        {"kernel": np.asarray(params[k]["kernel"]), "bias": np.asarray(params[k]["bias"])}
        for k in names
    ]


def _value_info(name: str, dims: list) -> onnx.ValueInfoProto:
    return helper.make_tensor_value_info(name, TensorProto.FLOAT, dims)


def _normalised(g: _Graph, x: str, norm_mean, norm_var, min_std: float) -> str:
    """``RunningNorm``: ``(x - mean) / max(sqrt(var + 1e-8), min_std)`` clipped to [-10, 10]."""
    mean = np.asarray(norm_mean, np.float32)
    std = np.sqrt(np.asarray(norm_var, np.float32) + np.float32(NORM_EPS))
    std = np.maximum(std, np.float32(min_std))
    z = g.op("Sub", [x, g.const("norm/mean", mean)], "norm/centred")
    z = g.op("Div", [z, g.const("norm/std", std)], "norm/scaled")
    lim = g.const("norm/clip", NORM_CLIP), g.const("norm/-clip", -NORM_CLIP)
    return g.op("Clip", [z, lim[1], lim[0]], "norm/clipped")


def _command(g: _Graph, a: str, low, high) -> str:
    """``to_command``: the action clipped to [-1, 1], then ``low + (a + 1) * 0.5 * (high -
    low)``, as ``command``."""
    low, high = np.asarray(low, np.float32), np.asarray(high, np.float32)
    a = g.op("Clip", [a, g.const("one/neg", -1.0), g.const("one", 1.0)], "action/clipped")
    a = g.op("Add", [a, "one"], "command/shifted")
    a = g.op("Mul", [a, g.const("half", 0.5)], "command/unit")
    a = g.op("Mul", [a, g.const("command/range", high - low)], "command/ranged")
    return g.op("Add", [g.const("command/low", low), a], "command")


def policy_model(
    actor: dict, norm_mean, norm_var, low, high, doc: str = "", min_std: float = 0.0
) -> onnx.ModelProto:
    """``obs`` (batch, D) -> ``command`` (batch, 3): (vx m/s, vy m/s, yaw rate rad/s).

    ``actor`` is the actor MLP's flax params (``params["params"]["actor"]``); ``norm_mean``
    and ``norm_var`` (D,) the observation normaliser's statistics; ``low`` and ``high`` (3,)
    the command limits the policy was trained with; ``min_std`` the normaliser's floor of
    its scale (``RunningNorm.min_std``).
    """
    layers = dense_layers(actor)
    g = _Graph()
    z = _normalised(g, "obs", norm_mean, norm_var, min_std)
    _command(g, g.mlp(z, layers, "Elu", "actor", alpha=1.0), low, high)
    d, n_out = np.asarray(norm_mean).shape[0], layers[-1]["bias"].shape[0]
    return g.model(
        "dyncatch_policy",
        [_value_info("obs", ["batch", d])],
        [_value_info("command", ["batch", n_out])],
        doc,
    )


def _gru(g: _Graph, x: str, h: str, params: dict, out: str) -> str:
    """``rl.recurrent.GRU``, op for op: r, z, n from the fused input and hidden products,
    then ``(1 - z) * n + z * h`` as ``out``."""
    width = np.asarray(params["hidden"]["kernel"]).shape[0]
    sizes = g.int_const("gru/sizes", [width] * 3)
    parts = {}
    for name, src in (("input", x), ("hidden", h)):
        w = g.const(f"gru/{name}/kernel", params[name]["kernel"])
        b = g.const(f"gru/{name}/bias", params[name]["bias"])
        y = g.op("Add", [g.op("MatMul", [src, w], f"gru/{name}/matmul"), b], f"gru/{name}")
        parts[name] = [f"gru/{name}/{gate}" for gate in ("r", "z", "n")]
        g.nodes.append(helper.make_node("Split", [y, sizes], parts[name], axis=1))
    (ir, iz, i_n), (hr, hz, h_n) = parts["input"], parts["hidden"]
    r = g.op("Sigmoid", [g.op("Add", [ir, hr], "gru/r_in")], "gru/r")
    z = g.op("Sigmoid", [g.op("Add", [iz, hz], "gru/z_in")], "gru/z")
    n = g.op("Tanh", [g.op("Add", [i_n, g.op("Mul", [r, h_n], "gru/rh")], "gru/n_in")], "gru/n")
    keep = g.op("Sub", [g.const("gru/one", 1.0), z], "gru/keep")
    new = g.op("Mul", [keep, n], "gru/new")
    return g.op("Add", [new, g.op("Mul", [z, h], "gru/old")], out)


def recurrent_policy_model(
    actor_memory: dict,
    actor: dict,
    norm_mean,
    norm_var,
    low,
    high,
    doc: str = "",
    min_std: float = 0.0,
) -> onnx.ModelProto:
    """``obs`` (batch, D) and ``memory_in`` (batch, H) -> ``command`` (batch, 3) and
    ``memory_out`` (batch, H): one control step of a recurrent policy
    (``rl.recurrent.MemoryPolicy``). The normaliser, the actor's GRU
    (``params["params"]["actor_memory"]``), its MLP head and the command scaling; the caller
    feeds ``memory_out`` back as the next step's ``memory_in`` and zeros at an episode's
    start. The other arguments are ``policy_model``'s.
    """
    layers = dense_layers(actor)
    g = _Graph()
    z = _normalised(g, "obs", norm_mean, norm_var, min_std)
    h = _gru(g, z, "memory_in", actor_memory, "memory_out")
    _command(g, g.mlp(h, layers, "Elu", "actor", alpha=1.0), low, high)
    d, n_out = np.asarray(norm_mean).shape[0], layers[-1]["bias"].shape[0]
    width = np.asarray(actor_memory["hidden"]["kernel"]).shape[0]
    return g.model(
        "dyncatch_recurrent_policy",
        [_value_info("obs", ["batch", d]), _value_info("memory_in", ["batch", width])],
        [_value_info("command", ["batch", n_out]), _value_info("memory_out", ["batch", width])],
        doc,
    )


def predictor_model(params: dict, doc: str = "") -> onnx.ModelProto:
    """``features`` (batch, D) and ``yaw_out_rad`` (batch,) -> ``target_vel_world_mps``
    (batch, 2): the predictor's network from its encoded inputs (``Predictor.apply_encoded``).

    ``params`` is a predictor's ``{"mlp", "in_mean", "in_std"}``.
    """
    layers = dense_layers(params["mlp"])
    g = _Graph()
    z = g.op("Sub", ["features", g.const("in/mean", params["in_mean"])], "in/centred")
    z = g.op("Div", [z, g.const("in/std", params["in_std"])], "in/scaled")
    v = g.mlp(z, layers, "Gelu", "mlp", approximate="tanh")
    # rotate(v, yaw): (c vx - s vy, s vx + c vy), with c and s as (batch, 1) columns.
    axis = g.int_const("axis/1", [1])
    c = g.op("Unsqueeze", [g.op("Cos", ["yaw_out_rad"], "yaw/cos"), axis], "yaw/cos_col")
    s = g.op("Unsqueeze", [g.op("Sin", ["yaw_out_rad"], "yaw/sin"), axis], "yaw/sin_col")
    vx, vy = "v/x", "v/y"
    g.nodes.append(helper.make_node("Split", [v, g.int_const("v/sizes", [1, 1])], [vx, vy], axis=1))
    x = g.op("Sub", [g.op("Mul", [c, vx], "rot/cx"), g.op("Mul", [s, vy], "rot/sy")], "rot/x")
    y = g.op("Add", [g.op("Mul", [s, vx], "rot/sx"), g.op("Mul", [c, vy], "rot/cy")], "rot/y")
    g.op("Concat", [x, y], "target_vel_world_mps", axis=1)
    d = np.asarray(params["in_mean"]).shape[0]
    return g.model(
        "dyncatch_predictor",
        [_value_info("features", ["batch", d]), _value_info("yaw_out_rad", ["batch"])],
        [_value_info("target_vel_world_mps", ["batch", 2])],
        doc,
    )
