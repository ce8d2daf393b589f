"""ONNX graphs of a trained policy and a predictor, built op by op from their parameters.

The graphs are written with ``onnx.helper`` from the arrays the JAX code uses, each op the
one the JAX code applies, in the same order (so float32 results agree to rounding):

- policy: ``(obs - mean) / max(sqrt(var + 1e-8), min_std)``, clipped to [-10, 10] (``RunningNorm``);
  the actor MLP (``MatMul`` + ``Add``, ``Elu``; the critic and the log-std are left out:
  the deployed action is the mean); the clip to [-1, 1] and ``to_command``'s scaling
  ``low + (a + 1) * 0.5 * (high - low)``.
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


def policy_model(
    actor: dict, norm_mean, norm_var, low, high, doc: str = "", min_std: float = 0.0
) -> onnx.ModelProto:
    """``obs`` (batch, D) -> ``command`` (batch, 3): (vx m/s, vy m/s, yaw rate rad/s).

    ``actor`` is the actor MLP's flax params (``params["params"]["actor"]``); ``norm_mean``
    and ``norm_var`` (D,) the observation normaliser's statistics; ``low`` and ``high`` (3,)
    the command limits the policy was trained with; ``min_std`` the normaliser's floor of
    its scale (``RunningNorm.min_std``).
    """
    mean = np.asarray(norm_mean, np.float32)
    std = np.sqrt(np.asarray(norm_var, np.float32) + np.float32(NORM_EPS))
    std = np.maximum(std, np.float32(min_std))
    low, high = np.asarray(low, np.float32), np.asarray(high, np.float32)
    layers = dense_layers(actor)
    g = _Graph()
    z = g.op("Sub", ["obs", g.const("norm/mean", mean)], "norm/centred")
    z = g.op("Div", [z, g.const("norm/std", std)], "norm/scaled")
    lim = g.const("norm/clip", NORM_CLIP), g.const("norm/-clip", -NORM_CLIP)
    z = g.op("Clip", [z, lim[1], lim[0]], "norm/clipped")
    a = g.mlp(z, layers, "Elu", "actor", alpha=1.0)
    a = g.op("Clip", [a, g.const("one/neg", -1.0), g.const("one", 1.0)], "action/clipped")
    a = g.op("Add", [a, "one"], "command/shifted")
    a = g.op("Mul", [a, g.const("half", 0.5)], "command/unit")
    a = g.op("Mul", [a, g.const("command/range", high - low)], "command/ranged")
    g.op("Add", [g.const("command/low", low), a], "command")
    d, n_out = mean.shape[0], layers[-1]["bias"].shape[0]
    return g.model(
        "dyncatch_policy",
        [_value_info("obs", ["batch", d])],
        [_value_info("command", ["batch", n_out])],
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
