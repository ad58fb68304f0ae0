"""Flight code from a run folder: a trained policy as C99 or ONNX, the same function as its
``predict(obs, deterministic=True)``.

``python -m rbenv export RUN --format c|onnx --out DIR`` (or :func:`export`) writes:

``policy.h``, ``policy.c`` (``--format c``)
    ``void rbenv_policy(const float *obs, float *action);`` with ``RBENV_OBS_DIM`` and
    ``RBENV_ACT_DIM``: the env's raw observation in, the env's action out. Inside, in float32:
    the run's observation normalisation, the network, the squashing or clipping and the action
    scaling. C99, weights as ``static const`` arrays, no heap, no global that changes, from libm
    only what the activations and the output stage need (``tanhf``; ``erfcf`` and ``expf`` for
    PPO's mean throttle).
``policy.onnx`` (``--format onnx``)
    The same function as an ONNX graph (input ``obs`` ``(n, obs_dim)``, output ``action``
    ``(n, act_dim)``), checked with ``onnx.checker`` and run with onnxruntime (the export extra).
``footprint.json``
    Weight bytes (flash), activation bytes (RAM), multiply-adds and transcendental calls per call.
``export.json``
    Where it came from: the run, algorithm, env id, scene, env options and observation layout.

Every kind of policy a run folder holds is exported: PPO (its deterministic action: the clipped
mean, or the mean throttle E[clip(μ + σε, 0, 1)] on thruster scenes, as
:class:`~rbenv.agents.policies.sb3.RunPolicy` acts), SAC, TQC, CrossQ (batch renormalisation
folded into the next layer) and TD3 (tanh, then scaled to the action bounds), and an RLlib MLP.
What cannot be written exactly is refused with a named error (:class:`RecurrentPolicyError`,
:class:`UnsupportedActivationError`, :class:`UnsupportedLayerError`), never approximated. An
export checks itself before it returns: the network it read, the ONNX graph under onnxruntime
and, where a C compiler exists, the compiled C all reproduce the policy's own ``predict`` on
observations of its own episodes, to :data:`TOLERANCE` of each action's range
(:class:`ExportMismatchError` otherwise).
"""

from __future__ import annotations

import dataclasses
import json
import math
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import gymnasium as gym
import numpy as np
from rbenv.agents.policies import compiled
from rbenv.agents.policies.load import load_policy
from rbenv.agents.policies.rllib import RLlibPolicy
from rbenv.agents.policies.runfolder import RunFolderError, write_json
from rbenv.agents.policies.sb3 import RunPolicy
from rbenv.core.errors import InvalidParameterError

FORMATS = ("c", "onnx")
ONNX_FILE, FOOTPRINT = "policy.onnx", "footprint.json"
TOLERANCE = 1e-5  # of each action entry's range (high - low): the export's agreement check
OPSET, IR_VERSION = 17, 8
EXPORT_EXTRA = "pip install 'rbenv[export]'"


class ExportError(RunFolderError):
    """A policy cannot be exported exactly, or its export does not reproduce it."""


class UnsupportedPolicyError(ExportError):
    """The policy is not a feed-forward network rbenv can write (an image encoder, gSDE, ...)."""


class RecurrentPolicyError(UnsupportedPolicyError):
    """The policy keeps a state between calls (LSTM, GRU, attention): not a pure function."""


class UnsupportedLayerError(UnsupportedPolicyError):
    """The network holds a layer that the C and ONNX writers do not implement."""


class UnsupportedActivationError(UnsupportedLayerError):
    """The network uses an activation that the C and ONNX writers do not implement."""


class MissingExportExtraError(ExportError):
    """onnx or onnxruntime, the export extra, is not installed."""


class ExportMismatchError(ExportError):
    """The exported function differs from the policy's ``predict`` by more than the tolerance."""


# --- the network, engine-neutral -------------------------------------------------------------

@dataclass(frozen=True)
class Dense:
    """y = W x + b; weight (n_out, n_in), bias (n_out,), float32. Quantised (:func:`to_int8`):
    weight int8 and ``scale`` (n_out,) float32, y = scale · (W x) + b."""

    weight: np.ndarray
    bias: np.ndarray
    scale: np.ndarray | None = None

    def apply(self, x: np.ndarray) -> np.ndarray:
        if self.scale is None:
            return x @ self.weight.T + self.bias
        return (x @ self.weight.T.astype(np.float32)) * self.scale + self.bias


@dataclass(frozen=True)
class Activation:
    """An elementwise activation: tanh, relu, leaky_relu (slope ``alpha``), elu (``alpha``),
    sigmoid."""

    kind: str
    alpha: float = 0.0


@dataclass(frozen=True)
class Clamp:
    """y = min(max(x, low), high), elementwise (a ``Hardtanh``)."""

    low: float
    high: float


# libm calls per element of each activation (what the C calls, what footprint.json counts).
ACTIVATIONS = {"tanh": {"tanhf": 1}, "relu": {}, "leaky_relu": {}, "elu": {"expm1f": 1},
               "sigmoid": {"expf": 1}}
_TORCH_ACTIVATIONS = {"Tanh": "tanh", "ReLU": "relu", "LeakyReLU": "leaky_relu", "ELU": "elu",
                      "Sigmoid": "sigmoid"}
_RECURRENT = ("RNN", "LSTM", "GRU", "RNNCell", "LSTMCell", "GRUCell", "MultiheadAttention",
              "Transformer", "TransformerEncoder", "TransformerEncoderLayer")
_PASS_THROUGH = ("Identity", "Flatten", "Dropout")

# The output stage: what turns the network's output μ into the env's action.
HEADS = {
    "clip": "clip(mu, low, high): the Gaussian's mean, clipped to the action space (SB3 "
            "predict, RLlib)",
    "tanh_scale": "low + (tanh(mu) + 1) (high - low) / 2: the squashed mean, scaled to the "
                  "action space (SAC, TQC, CrossQ, TD3)",
    "mean_throttle": "E[clip(mu + std eps, low, high)], eps ~ N(0, 1): the mean action of the "
                     "clipped Gaussian PPO policy (RunPolicy's mean_throttle)",
}
_HEAD_CALLS = {"clip": {}, "tanh_scale": {"tanhf": 1},
               "mean_throttle": {"erfcf": 3, "expf": 2}}


@dataclass(frozen=True)
class Head:
    """The output stage (:data:`HEADS`); low, high (act_dim,); std (act_dim,) for
    mean_throttle."""

    kind: str
    low: np.ndarray
    high: np.ndarray
    std: np.ndarray | None = None


@dataclass(frozen=True)
class FlightPolicy:
    """A feed-forward policy as plain arrays: raw observation → env action.

    obs_mean, obs_scale (obs_dim,): the normalised input is clip((obs - mean) * scale,
    -obs_clip, obs_clip) (no normalisation when obs_mean is None). layers: Dense, Activation,
    Clamp, in order. info: where it came from (run, algo, env id, scene, layout).
    """

    obs_dim: int
    obs_mean: np.ndarray | None
    obs_scale: np.ndarray | None
    obs_clip: float
    layers: tuple
    head: Head
    info: dict = field(default_factory=dict)

    @property
    def act_dim(self) -> int:
        return len(self.head.low)

    @property
    def widths(self) -> list[int]:
        """The input width and every dense layer's output width."""
        return [self.obs_dim] + [layer.weight.shape[0] for layer in self.layers
                                 if isinstance(layer, Dense)]

    def __call__(self, obs) -> np.ndarray:
        """The actions for observations (n, obs_dim) in NumPy float32 (the C's arithmetic)."""
        x = np.asarray(obs, np.float32)
        if self.obs_mean is not None:
            x = np.clip((x - self.obs_mean) * self.obs_scale, -self.obs_clip, self.obs_clip)
        for layer in self.layers:
            if isinstance(layer, Dense):
                x = layer.apply(x)
            elif isinstance(layer, Clamp):
                x = np.clip(x, np.float32(layer.low), np.float32(layer.high))
            else:
                x = _activate(layer, x)
        return _head(self.head, x.astype(np.float64)).astype(np.float32)


PRECISIONS = ("float32", "int8")


def to_int8(flight: FlightPolicy) -> FlightPolicy:
    """``flight`` with every dense layer's weights as int8, one float32 scale per row (the
    row's largest |w| / 127, rounded to nearest): 4× less flash for the weights; biases,
    normalisation and the output stage stay float32. Not the same function: measure it."""
    layers = []
    for layer in flight.layers:
        if isinstance(layer, Dense) and layer.scale is None:
            w = layer.weight.astype(np.float64)
            scale = np.abs(w).max(axis=1) / 127.0
            scale = np.where(scale > 0, scale, 1.0)
            q = np.clip(np.rint(w / scale[:, None]), -127, 127).astype(np.int8)
            layer = Dense(q, layer.bias, scale.astype(np.float32))
        layers.append(layer)
    return dataclasses.replace(flight, layers=tuple(layers))


def _activate(layer: Activation, x: np.ndarray) -> np.ndarray:
    a = np.float32(layer.alpha)
    return {"tanh": np.tanh, "relu": lambda v: np.maximum(v, np.float32(0)),
            "leaky_relu": lambda v: np.where(v > 0, v, a * v),
            "elu": lambda v: np.where(v > 0, v, a * np.expm1(v)),
            "sigmoid": lambda v: np.float32(1) / (np.float32(1) + np.exp(-v))}[layer.kind](x)


def _head(head: Head, mu: np.ndarray) -> np.ndarray:
    if head.kind == "clip":
        return np.clip(mu, head.low, head.high)
    if head.kind == "tanh_scale":
        return head.low + 0.5 * (np.tanh(mu) + 1.0) * (head.high - head.low)
    from rbenv.agents.policies.sb3 import expected_throttle

    return expected_throttle(mu, head.std, head.low, head.high)


# --- reading a trained policy ----------------------------------------------------------------

def from_policy(policy, run: str | None = None) -> FlightPolicy:
    """The :class:`FlightPolicy` of a loaded policy (:func:`rbenv.agents.policies.load_policy`):
    an SB3 :class:`~.sb3.RunPolicy` or an :class:`~.rllib.RLlibPolicy`."""
    if isinstance(policy, RLlibPolicy):
        modules, head = _rllib_parts(policy)
        obs_mean = obs_scale = None
        clip = math.inf
        algo = "rllib-" + str((policy.config or {}).get("algo", "ppo"))
    elif isinstance(policy, RunPolicy):
        modules, head = _sb3_parts(policy)
        obs_mean, obs_scale, clip = _normalisation(policy)
        algo = type(policy.model).__name__.lower()
    else:
        raise UnsupportedPolicyError(
            f"only trained policies (SB3 RunPolicy, RLlibPolicy) are exported, got "
            f"{type(policy).__name__}; a scripted baseline needs no export")
    obs_dim = int(np.prod(policy_obs_shape(policy)))
    layers = _layers(modules)
    _check_shapes(layers, obs_dim, len(head.low))
    info = _provenance(policy, run, algo)
    return FlightPolicy(obs_dim, obs_mean, obs_scale, clip, tuple(layers), head, info)


def policy_obs_shape(policy) -> tuple:
    if isinstance(policy, RLlibPolicy):
        return tuple(policy.module.observation_space.shape)
    return tuple(policy.model.observation_space.shape)


def _normalisation(policy: RunPolicy):
    stats = policy.vecnormalize
    if stats is None or not getattr(stats, "norm_obs", True):
        return None, None, math.inf
    mean = np.asarray(stats.obs_rms.mean, np.float64)
    scale = 1.0 / np.sqrt(np.asarray(stats.obs_rms.var, np.float64) + float(stats.epsilon))
    return mean.astype(np.float32), scale.astype(np.float32), float(stats.clip_obs)


def _sb3_parts(policy: RunPolicy):
    """The actor's modules in order and its output stage, for each SB3 policy kind."""
    model = policy.model
    p = model.policy
    space = model.action_space
    low, high = (np.asarray(b, np.float64) for b in (space.low, space.high))
    _no_recurrence(p)
    if hasattr(p, "mlp_extractor"):  # PPO's actor-critic policy
        _flatten_only(getattr(p, "pi_features_extractor", p.features_extractor))
        if p.squash_output or getattr(p, "use_sde", False):
            raise UnsupportedPolicyError(
                f"{type(model).__name__} with gSDE (use_sde) is not exported: its noise "
                "depends on the state")
        modules = [p.mlp_extractor.policy_net, p.action_net]
        if policy.action == "mean_throttle":
            std = p.log_std.detach().exp().cpu().numpy().astype(np.float64)
            lo, hi = (np.broadcast_to(np.asarray(b, np.float64), std.shape).copy()
                      for b in policy.clip_bounds)
            return modules, Head("mean_throttle", lo, hi, std)
        return modules, Head("clip", low, high)
    actor = getattr(p, "actor", None)
    if actor is None:
        raise UnsupportedPolicyError(f"{type(p).__name__} has no actor network to export")
    _flatten_only(actor.features_extractor)
    if getattr(actor, "use_sde", False):
        raise UnsupportedPolicyError(
            f"{type(model).__name__} with gSDE (use_sde) is not exported")
    if hasattr(actor, "latent_pi"):  # SAC, TQC, CrossQ: tanh of the Gaussian's mean
        return [actor.latent_pi, actor.mu], Head("tanh_scale", low, high)
    leaves = _leaves([actor.mu])  # TD3: the last module is the tanh
    if not leaves or type(leaves[-1]).__name__ != "Tanh":
        raise UnsupportedPolicyError(f"{type(model).__name__}'s actor does not end in tanh")
    return leaves[:-1], Head("tanh_scale", low, high)


def _rllib_parts(policy: RLlibPolicy):
    """RLlib's default PPO module: the actor encoder, then the policy head's mean."""
    module = policy.module
    outer = getattr(module, "encoder", None)
    # Separate actor and critic encoders (rbenv's setting), or one shared encoder.
    encoder = getattr(outer, "actor_encoder", None) or getattr(outer, "encoder", None)
    pi = getattr(module, "pi", None)
    if encoder is None or pi is None:
        raise UnsupportedPolicyError(
            f"RLlib module {type(module).__name__} is not RLlib's default MLP (encoder."
            "actor_encoder and pi): only that is exported")
    _no_recurrence(module)
    leaves = _leaves([encoder, getattr(pi, "net", pi)])
    low, high = (np.asarray(b, np.float64) for b in (policy.low, policy.high))
    n_act = len(low)
    last = [m for m in leaves if type(m).__name__ == "Linear"][-1]
    if last.out_features == 2 * n_act:  # mean and log std from one layer: keep the mean rows
        import torch

        mean_rows = torch.nn.Linear(last.in_features, n_act)
        mean_rows.weight.data = last.weight.data[:n_act].clone()
        mean_rows.bias.data = last.bias.data[:n_act].clone()
        leaves[leaves.index(last)] = mean_rows
    return leaves, Head("clip", low, high)


def _no_recurrence(module) -> None:
    for name, sub in module.named_modules():
        if type(sub).__name__ in _RECURRENT:
            raise RecurrentPolicyError(
                f"the policy holds a recurrent or attention layer ({name}: "
                f"{type(sub).__name__}): its action depends on a state kept between calls, "
                "which a pure rbenv_policy(obs, action) cannot hold")


def _flatten_only(extractor) -> None:
    if extractor is not None and type(extractor).__name__ != "FlattenExtractor":
        raise UnsupportedPolicyError(
            f"features extractor {type(extractor).__name__} is not exported (only "
            "FlattenExtractor, the MlpPolicy's)")


def _leaves(modules: Sequence) -> list:
    """The leaf modules of ``modules``, in order (children before siblings)."""
    out = []
    for module in modules:
        children = list(module.children())
        if children and type(module).__name__ not in _RECURRENT \
                and type(module).__name__ != "BatchRenorm1d":
            out.extend(_leaves(children))
        else:
            out.append(module)
    return out


def _layers(modules: Sequence) -> list:
    """Torch leaf modules → Dense / Activation / Clamp; batch norms folded into the next Dense."""
    layers, affine = [], None
    for m in _leaves(modules):
        kind = type(m).__name__
        if kind in _RECURRENT:
            raise RecurrentPolicyError(f"the policy holds a {kind} layer: its action depends "
                                       "on a state kept between calls")
        if kind in _PASS_THROUGH:
            continue
        if kind == "Linear":
            w = m.weight.detach().cpu().numpy().astype(np.float64)
            b = (m.bias.detach().cpu().numpy().astype(np.float64) if m.bias is not None
                 else np.zeros(w.shape[0]))
            if affine is not None:  # W (s x + t) + b = (W s) x + (W t + b)
                scale, shift = affine
                w, b = w * scale[None, :], b + w @ shift
                affine = None
            layers.append(Dense(_f32(w), _f32(b)))
        elif kind in ("BatchRenorm1d", "BatchNorm1d"):
            if affine is not None:
                raise UnsupportedLayerError("two batch norms in a row are not exported")
            affine = _batch_norm_affine(m)
        elif kind in _TORCH_ACTIVATIONS:
            alpha = {"LeakyReLU": "negative_slope", "ELU": "alpha"}.get(kind)
            layers.append(Activation(_TORCH_ACTIVATIONS[kind],
                                     float(getattr(m, alpha)) if alpha else 0.0))
        elif kind == "Hardtanh":
            layers.append(Clamp(float(m.min_val), float(m.max_val)))
        elif "activation" in type(m).__module__:
            raise UnsupportedActivationError(
                f"activation {kind} is not exported; supported: "
                f"{', '.join(sorted(_TORCH_ACTIVATIONS))}")
        else:
            raise UnsupportedLayerError(
                f"layer {kind} is not exported; supported: Linear, batch norm (folded), "
                f"Hardtanh and the activations {', '.join(sorted(_TORCH_ACTIVATIONS))}")
    if affine is not None:
        raise UnsupportedLayerError("a batch norm after the last linear layer is not exported")
    return layers


def _batch_norm_affine(m) -> tuple[np.ndarray, np.ndarray]:
    """Eval-mode batch (re)normalisation as x·s + t: running statistics, then the affine."""
    if getattr(m, "training", False):
        raise UnsupportedLayerError(f"{type(m).__name__} is in training mode: its output "
                                    "depends on the batch; export a policy in eval mode")
    mean = getattr(m, "ra_mean", getattr(m, "running_mean", None))
    var = getattr(m, "ra_var", getattr(m, "running_var", None))
    mean, var = (v.detach().cpu().numpy().astype(np.float64) for v in (mean, var))
    s = 1.0 / np.sqrt(var + float(m.eps))
    t = -mean * s
    weight = getattr(m, "scale", getattr(m, "weight", None))
    if getattr(m, "affine", True) and weight is not None:
        g = weight.detach().cpu().numpy().astype(np.float64)
        beta = m.bias.detach().cpu().numpy().astype(np.float64)
        s, t = s * g, t * g + beta
    return s, t


def _f32(a: np.ndarray) -> np.ndarray:
    a = np.asarray(a, np.float32)
    if not np.isfinite(a).all():
        raise ExportError("the network holds non-finite weights (NaN or inf): not exported")
    return a


def _check_shapes(layers: list, obs_dim: int, act_dim: int) -> None:
    width = obs_dim
    for layer in layers:
        if isinstance(layer, Dense):
            if layer.weight.shape[1] != width:
                raise UnsupportedPolicyError(
                    f"a dense layer takes {layer.weight.shape[1]} inputs after a layer of "
                    f"{width}: the modules are not one chain")
            width = layer.weight.shape[0]
    if width != act_dim:
        raise UnsupportedPolicyError(f"the network ends in {width} outputs, the action space "
                                     f"has {act_dim}")


def _provenance(policy, run, algo: str) -> dict:
    config = policy.config or {}
    env = policy.make_env()
    try:
        layout = dict(env.unwrapped.observation_structure)
        scene = env.unwrapped.plant.scene.name
    finally:
        env.close()
    steps = getattr(getattr(policy, "model", None), "num_timesteps", None)
    return {"run": run, "algo": algo, "env_id": policy.env_id, "scene": scene,
            "env_kwargs": policy.env_kwargs, "observation_layout": layout,
            "seed": config.get("seed"), "timesteps": steps,
            "source": str(getattr(policy, "source", ""))}


# --- footprint ---------------------------------------------------------------------------------

def footprint(flight: FlightPolicy) -> dict:
    """Per call of ``rbenv_policy``: constant bytes (flash), activation bytes (RAM, the two
    stack buffers), multiply-adds and libm calls (float32 throughout)."""
    dense = [layer for layer in flight.layers if isinstance(layer, Dense)]
    constants = sum(d.bias.size + (0 if d.scale is None else d.scale.size) for d in dense)
    macs = sum(d.weight.size for d in dense)
    if flight.obs_mean is not None:
        constants += 2 * flight.obs_dim
        macs += flight.obs_dim
    constants += (4 if flight.head.std is not None else 2) * flight.act_dim
    weight_bytes = 4 * constants + sum(d.weight.nbytes for d in dense)
    calls: dict[str, int] = {}
    for layer in flight.layers:
        if isinstance(layer, Activation):
            width = _width_before(flight, layer)
            for fn, n in ACTIVATIONS[layer.kind].items():
                calls[fn] = calls.get(fn, 0) + n * width
    for fn, n in _HEAD_CALLS[flight.head.kind].items():
        calls[fn] = calls.get(fn, 0) + n * flight.act_dim
    return {"weight_bytes": int(weight_bytes), "activation_bytes": 8 * max(flight.widths),
            "multiply_adds": int(macs), "transcendental_calls": calls,
            "layers": flight.widths, "head": flight.head.kind,
            "weights": "int8" if any(d.scale is not None for d in dense) else "float32"}


def _width_before(flight: FlightPolicy, target) -> int:
    width = flight.obs_dim
    for layer in flight.layers:
        if layer is target:
            return width
        if isinstance(layer, Dense):
            width = layer.weight.shape[0]
    raise ValueError("layer not in the policy")


# --- C -----------------------------------------------------------------------------------------

def _c_float(v) -> str:
    text = np.format_float_scientific(np.float32(v), unique=True, trim="-")
    return text + "f"


def _c_array(name: str, values: np.ndarray, size: str) -> str:
    flat = [_c_float(v) for v in np.asarray(values, np.float32).ravel()]
    rows = [", ".join(flat[i:i + 8]) for i in range(0, len(flat), 8)]
    body = ",\n    ".join(rows)
    return f"static const float {name}[{size}] = {{\n    {body}\n}};\n"


def _c_int8_array(name: str, values: np.ndarray, size: str) -> str:
    flat = [str(int(v)) for v in np.asarray(values, np.int8).ravel()]
    rows = [", ".join(flat[i:i + 16]) for i in range(0, len(flat), 16)]
    body = ",\n    ".join(rows)
    return f"static const signed char {name}[{size}] = {{\n    {body}\n}};\n"


def _comment(flight: FlightPolicy) -> str:
    i = flight.info
    layout, start = [], 0
    for name, width in (i.get("observation_layout") or {}).items():
        layout.append(f" *     obs[{start}..{start + width - 1}]  {name}")
        start += width
    fp = footprint(flight)
    return "\n".join([
        "/* Exported by `rbenv export` from a trained rbenv policy; do not edit.",
        f" *   run:       {i.get('run')}",
        f" *   algorithm: {i.get('algo')} ({i.get('timesteps')} env steps, seed "
        f"{i.get('seed')})",
        f" *   env id:    {i.get('env_id')}",
        f" *   scene:     {i.get('scene')}",
        f" *   env options: {json.dumps(i.get('env_kwargs'), sort_keys=True)}",
        " *   observation layout (the env's raw observation, float32):",
        *layout,
        f" *   network: {' -> '.join(map(str, flight.widths))}; output stage: "
        f"{flight.head.kind}",
        f" *     {HEADS[flight.head.kind]}",
        f" *   per call: {fp['multiply_adds']} multiply-adds, libm calls "
        f"{json.dumps(fp['transcendental_calls'], sort_keys=True)}, "
        f"{fp['weight_bytes']} bytes of constants, {fp['activation_bytes']} bytes of stack",
        " */"])


def c_header(flight: FlightPolicy) -> str:
    return "\n".join([
        _comment(flight), "#ifndef RBENV_POLICY_H", "#define RBENV_POLICY_H", "",
        f"#define RBENV_OBS_DIM {flight.obs_dim}", f"#define RBENV_ACT_DIM {flight.act_dim}",
        "",
        "/* The env's action for its raw observation: normalisation, network, output stage.",
        " * Deterministic and reentrant: no heap, no state, no global that changes. */",
        "void rbenv_policy(const float *obs, float *action);", "",
        "#endif /* RBENV_POLICY_H */", ""])


def c_source(flight: FlightPolicy) -> str:
    width = max(flight.widths)
    needs_libm = any(ACTIVATIONS[layer.kind] for layer in flight.layers
                     if isinstance(layer, Activation)) or _HEAD_CALLS[flight.head.kind]
    parts = [_comment(flight), '#include "policy.h"']
    parts += ["#include <math.h>", ""] if needs_libm else [""]
    parts.append(f"#define WIDTH {width}\n")
    if flight.obs_mean is not None:
        parts.append(_c_array("OBS_MEAN", flight.obs_mean, "RBENV_OBS_DIM"))
        parts.append(_c_array("OBS_SCALE", flight.obs_scale, "RBENV_OBS_DIM"))
    for k, layer in enumerate(layer for layer in flight.layers if isinstance(layer, Dense)):
        n_out, n_in = layer.weight.shape
        if layer.scale is None:
            parts.append(_c_array(f"W{k}", layer.weight, f"{n_out} * {n_in}"))
        else:
            parts.append(_c_int8_array(f"W{k}", layer.weight, f"{n_out} * {n_in}"))
            parts.append(_c_array(f"S{k}", layer.scale, f"{n_out}"))
        parts.append(_c_array(f"B{k}", layer.bias, f"{n_out}"))
    h = flight.head
    parts.append(_c_array("ACT_LOW", h.low, "RBENV_ACT_DIM"))
    parts.append(_c_array("ACT_HIGH", h.high, "RBENV_ACT_DIM"))
    if h.std is not None:
        parts.append(_c_array("ACT_INV_STD", 1.0 / h.std, "RBENV_ACT_DIM"))
        parts.append(_c_array("ACT_STD", h.std, "RBENV_ACT_DIM"))
    quantised = [layer.scale is not None for layer in flight.layers if isinstance(layer, Dense)]
    if not all(quantised):
        parts.append(_C_DENSE)
    if any(quantised):
        parts.append(_C_DENSE_INT8)
    kinds = {layer.kind for layer in flight.layers if isinstance(layer, Activation)}
    parts += [_C_ACTIVATIONS[k] for k in sorted(kinds)]
    if any(isinstance(layer, Clamp) for layer in flight.layers):
        parts.append(_C_CLAMP)
    parts.append(_C_HEADS[h.kind])
    parts.append(_c_body(flight))
    return "\n".join(parts)


_C_DENSE = """\
/* y = W x + b, W row-major (n_out rows of n_in); eight rows at a time share each load of x. */
static void dense(const float *w, const float *b, int n_in, int n_out, const float *x, float *y)
{
    int i = 0, j, k;
    for (; i + 7 < n_out; i += 8) {
        const float *r = w + (long)i * n_in;
        float s[8];
        for (k = 0; k < 8; ++k)
            s[k] = b[i + k];
        for (j = 0; j < n_in; ++j) {
            float xj = x[j];
            s[0] += r[j] * xj;
            s[1] += r[n_in + j] * xj;
            s[2] += r[2 * n_in + j] * xj;
            s[3] += r[3 * n_in + j] * xj;
            s[4] += r[4 * n_in + j] * xj;
            s[5] += r[5 * n_in + j] * xj;
            s[6] += r[6 * n_in + j] * xj;
            s[7] += r[7 * n_in + j] * xj;
        }
        for (k = 0; k < 8; ++k)
            y[i + k] = s[k];
    }
    for (; i < n_out; ++i) {
        const float *row = w + (long)i * n_in;
        float t = b[i];
        for (j = 0; j < n_in; ++j)
            t += row[j] * x[j];
        y[i] = t;
    }
}
"""
_C_DENSE_INT8 = """\
/* y = s (Q x) + b, Q int8 row-major (n_out rows of n_in), one scale s per row; eight rows at a
 * time share each load of x. */
static void dense_int8(const signed char *q, const float *s, const float *b, int n_in,
                       int n_out, const float *x, float *y)
{
    int i = 0, j, k;
    for (; i + 7 < n_out; i += 8) {
        const signed char *r = q + (long)i * n_in;
        float t[8];
        for (k = 0; k < 8; ++k)
            t[k] = 0.0f;
        for (j = 0; j < n_in; ++j) {
            float xj = x[j];
            t[0] += (float)r[j] * xj;
            t[1] += (float)r[n_in + j] * xj;
            t[2] += (float)r[2 * n_in + j] * xj;
            t[3] += (float)r[3 * n_in + j] * xj;
            t[4] += (float)r[4 * n_in + j] * xj;
            t[5] += (float)r[5 * n_in + j] * xj;
            t[6] += (float)r[6 * n_in + j] * xj;
            t[7] += (float)r[7 * n_in + j] * xj;
        }
        for (k = 0; k < 8; ++k)
            y[i + k] = t[k] * s[i + k] + b[i + k];
    }
    for (; i < n_out; ++i) {
        const signed char *row = q + (long)i * n_in;
        float u = 0.0f;
        for (j = 0; j < n_in; ++j)
            u += (float)row[j] * x[j];
        y[i] = u * s[i] + b[i];
    }
}
"""
_C_ACTIVATIONS = {
    "tanh": "static void act_tanh(float *x, int n, float alpha)\n{\n    int i;\n    (void)alpha;"
            "\n    for (i = 0; i < n; ++i)\n        x[i] = tanhf(x[i]);\n}\n",
    "relu": "static void act_relu(float *x, int n, float alpha)\n{\n    int i;\n    (void)alpha;"
            "\n    for (i = 0; i < n; ++i)\n        x[i] = x[i] > 0.0f ? x[i] : 0.0f;\n}\n",
    "leaky_relu": "static void act_leaky_relu(float *x, int n, float alpha)\n{\n    int i;\n"
                  "    for (i = 0; i < n; ++i)\n        x[i] = x[i] > 0.0f ? x[i] : alpha * x[i];"
                  "\n}\n",
    "elu": "static void act_elu(float *x, int n, float alpha)\n{\n    int i;\n"
           "    for (i = 0; i < n; ++i)\n        x[i] = x[i] > 0.0f ? x[i] : alpha * expm1f(x[i]);"
           "\n}\n",
    "sigmoid": "static void act_sigmoid(float *x, int n, float alpha)\n{\n    int i;\n"
               "    (void)alpha;\n    for (i = 0; i < n; ++i)\n"
               "        x[i] = 1.0f / (1.0f + expf(-x[i]));\n}\n",
}
_C_CLAMP = """\
static void clamp(float *x, int n, float low, float high)
{
    int i;
    for (i = 0; i < n; ++i)
        x[i] = x[i] < low ? low : (x[i] > high ? high : x[i]);
}
"""
_C_HEADS = {
    "clip": """\
/* clip(mu, low, high) */
static void head(const float *mu, float *action)
{
    int i;
    for (i = 0; i < RBENV_ACT_DIM; ++i) {
        float a = mu[i] < ACT_LOW[i] ? ACT_LOW[i] : mu[i];
        action[i] = a > ACT_HIGH[i] ? ACT_HIGH[i] : a;
    }
}
""",
    "tanh_scale": """\
/* low + (tanh(mu) + 1) (high - low) / 2 */
static void head(const float *mu, float *action)
{
    int i;
    for (i = 0; i < RBENV_ACT_DIM; ++i)
        action[i] = ACT_LOW[i] + 0.5f * (tanhf(mu[i]) + 1.0f) * (ACT_HIGH[i] - ACT_LOW[i]);
}
""",
    "mean_throttle": """\
/* E[clip(mu + std eps, low, high)], eps ~ N(0, 1), with Phi(z) = erfc(-z / sqrt 2) / 2 and
 * phi(z) = exp(-z^2 / 2) / sqrt(2 pi):
 * mu (Phi(zh) - Phi(zl)) + std (phi(zl) - phi(zh)) + high Phi(-zh) + low Phi(zl). */
#define RBENV_SQRT1_2 0.70710678118654752f
#define RBENV_INV_SQRT_2PI 0.39894228040143268f
static void head(const float *mu, float *action)
{
    int i;
    for (i = 0; i < RBENV_ACT_DIM; ++i) {
        float zl = (ACT_LOW[i] - mu[i]) * ACT_INV_STD[i];
        float zh = (ACT_HIGH[i] - mu[i]) * ACT_INV_STD[i];
        float cdf_l = 0.5f * erfcf(-zl * RBENV_SQRT1_2);
        float cdf_h = 0.5f * erfcf(-zh * RBENV_SQRT1_2);
        float sf_h = 0.5f * erfcf(zh * RBENV_SQRT1_2);
        float pdf_l = RBENV_INV_SQRT_2PI * expf(-0.5f * zl * zl);
        float pdf_h = RBENV_INV_SQRT_2PI * expf(-0.5f * zh * zh);
        action[i] = mu[i] * (cdf_h - cdf_l) + ACT_STD[i] * (pdf_l - pdf_h)
                    + ACT_HIGH[i] * sf_h + ACT_LOW[i] * cdf_l;
    }
}
""",
}


def _c_body(flight: FlightPolicy) -> str:
    lines = ["void rbenv_policy(const float *obs, float *action)", "{",
             "    float a[WIDTH], b[WIDTH];", "    float *x = a, *y = b, *t;", "    int i;", ""]
    if flight.obs_mean is not None:
        c = _c_float(flight.obs_clip)
        lines += ["    for (i = 0; i < RBENV_OBS_DIM; ++i) {",
                  "        float z = (obs[i] - OBS_MEAN[i]) * OBS_SCALE[i];",
                  f"        x[i] = z < -{c} ? -{c} : (z > {c} ? {c} : z);", "    }"]
    else:
        lines += ["    for (i = 0; i < RBENV_OBS_DIM; ++i)", "        x[i] = obs[i];"]
    width, k = flight.obs_dim, 0
    for layer in flight.layers:
        if isinstance(layer, Dense):
            n_out = layer.weight.shape[0]
            call = (f"dense(W{k}, B{k}, " if layer.scale is None
                    else f"dense_int8(W{k}, S{k}, B{k}, ")
            lines += [f"    {call}{width}, {n_out}, x, y);", "    t = x; x = y; y = t;"]
            width, k = n_out, k + 1
        elif isinstance(layer, Clamp):
            lines.append(f"    clamp(x, {width}, {_c_float(layer.low)}, {_c_float(layer.high)});")
        else:
            lines.append(f"    act_{layer.kind}(x, {width}, {_c_float(layer.alpha)});")
    lines += ["    (void)y;", "    head(x, action);", "}", ""]
    return "\n".join(lines)


def write_c(flight: FlightPolicy, out: Path) -> list[Path]:
    """``out/policy.h`` and ``out/policy.c``."""
    out = Path(out)
    header, source = out / compiled.C_HEADER, out / compiled.C_SOURCE
    header.write_text(c_header(flight))
    source.write_text(c_source(flight))
    return [header, source]


# --- ONNX --------------------------------------------------------------------------------------

def _onnx():
    try:
        import onnx
        from onnx import helper, numpy_helper
    except ImportError:
        raise MissingExportExtraError(f"ONNX export needs the onnx package: {EXPORT_EXTRA} "
                                      "(the export extra)") from None
    return onnx, helper, numpy_helper


def onnx_model(flight: FlightPolicy):
    """The ONNX ModelProto of ``flight``: input ``obs`` (n, obs_dim) float32, output
    ``action`` (n, act_dim)."""
    onnx, helper, numpy_helper = _onnx()
    nodes, inits = [], []
    count = [0]

    def const(name, value):
        inits.append(numpy_helper.from_array(np.asarray(value, np.float32), name))
        return name

    def node(op, inputs, **attrs):
        count[0] += 1
        out = f"{op.lower()}_{count[0]}"
        nodes.append(helper.make_node(op, inputs, [out], **attrs))
        return out

    x = "obs"
    if flight.obs_mean is not None:
        x = node("Mul", [node("Sub", [x, const("obs_mean", flight.obs_mean)]),
                         const("obs_scale", flight.obs_scale)])
        if math.isfinite(flight.obs_clip):
            x = node("Clip", [x, const("obs_clip_low", -flight.obs_clip),
                              const("obs_clip_high", flight.obs_clip)])
    k = 0
    for layer in flight.layers:
        if isinstance(layer, Dense):
            w = (layer.weight if layer.scale is None  # int8: the same function, dequantised
                 else layer.weight.astype(np.float32) * layer.scale[:, None])
            x = node("Gemm", [x, const(f"W{k}", w), const(f"B{k}", layer.bias)], transB=1)
            k += 1
        elif isinstance(layer, Clamp):
            x = node("Clip", [x, const(f"clamp{count[0]}_low", layer.low),
                              const(f"clamp{count[0]}_high", layer.high)])
        elif layer.kind in ("leaky_relu", "elu"):
            x = node({"leaky_relu": "LeakyRelu", "elu": "Elu"}[layer.kind], [x],
                     alpha=layer.alpha)
        else:
            x = node({"tanh": "Tanh", "relu": "Relu", "sigmoid": "Sigmoid"}[layer.kind], [x])
    x = _onnx_head(flight.head, x, node, const)
    nodes.append(helper.make_node("Identity", [x], ["action"]))
    graph = helper.make_graph(
        nodes, "rbenv_policy",
        [helper.make_tensor_value_info("obs", onnx.TensorProto.FLOAT, ["n", flight.obs_dim])],
        [helper.make_tensor_value_info("action", onnx.TensorProto.FLOAT,
                                       ["n", flight.act_dim])], inits)
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", OPSET)],
                              producer_name="rbenv export", ir_version=IR_VERSION)
    info = flight.info
    helper.set_model_props(model, {k: json.dumps(info.get(k)) for k in
                                   ("run", "algo", "env_id", "scene", "env_kwargs",
                                    "observation_layout")})
    onnx.checker.check_model(model, full_check=True)
    return model


def _onnx_head(h: Head, mu: str, node, const) -> str:
    low = const("act_low", h.low)
    if h.kind == "tanh_scale":
        half = node("Mul", [node("Add", [node("Tanh", [mu]), const("one", 1.0)]),
                            const("half", 0.5)])
        return node("Add", [low, node("Mul", [half, const("act_range", h.high - h.low)])])
    high = const("act_high", h.high)
    if h.kind == "clip":
        return node("Min", [node("Max", [mu, low]), high])
    # mean_throttle: Phi(z) = (1 + erf(z / sqrt 2)) / 2, phi(z) = exp(-z^2 / 2) / sqrt(2 pi)
    inv_std = const("act_inv_std", 1.0 / h.std)
    r2, one, half = const("sqrt1_2", math.sqrt(0.5)), const("one", 1.0), const("half", 0.5)

    def cdf(z):
        return node("Mul", [node("Add", [one, node("Erf", [node("Mul", [z, r2])])]), half])

    def pdf(z):
        e = node("Exp", [node("Mul", [node("Mul", [z, z]), const(f"mhalf{z}", -0.5)])])
        return node("Mul", [e, const(f"inv_sqrt_2pi{z}", 1.0 / math.sqrt(2 * math.pi))])

    zl = node("Mul", [node("Sub", [low, mu]), inv_std])
    zh = node("Mul", [node("Sub", [high, mu]), inv_std])
    cl, ch = cdf(zl), cdf(zh)
    sf_h = node("Sub", [one, ch])
    terms = [node("Mul", [mu, node("Sub", [ch, cl])]),
             node("Mul", [const("act_std", h.std), node("Sub", [pdf(zl), pdf(zh)])]),
             node("Mul", [high, sf_h]), node("Mul", [low, cl])]
    return node("Add", [node("Add", [terms[0], terms[1]]), node("Add", [terms[2], terms[3]])])


def write_onnx(flight: FlightPolicy, out: Path) -> list[Path]:
    onnx, _, _ = _onnx()
    path = Path(out) / ONNX_FILE
    onnx.save(onnx_model(flight), str(path))
    return [path]


def run_onnx(path: Path, obs: np.ndarray) -> np.ndarray:
    """``policy.onnx`` on observations (n, obs_dim), through onnxruntime (CPU)."""
    try:
        import onnxruntime
    except ImportError:
        raise MissingExportExtraError(f"running ONNX needs onnxruntime: {EXPORT_EXTRA} (the "
                                      "export extra)") from None
    options = onnxruntime.SessionOptions()
    options.intra_op_num_threads = options.inter_op_num_threads = 1
    session = onnxruntime.InferenceSession(str(path), options,
                                           providers=["CPUExecutionProvider"])
    return session.run(["action"], {"obs": np.asarray(obs, np.float32)})[0]


# --- checks and the whole export -------------------------------------------------------------

def episode_observations(policy, episodes: int = 8, steps: int = 64, seed: int = 0
                         ) -> np.ndarray:
    """Observations (n, obs_dim) of ``policy``'s own seeded episodes in its run's env: the
    first ``steps`` steps of ``episodes`` episodes side by side (episode i seeded seed + i)."""
    envs = gym.make_vec(policy.env_id, num_envs=episodes,
                        vectorization_mode="vector_entry_point", **policy.env_kwargs)
    try:
        obs, _ = envs.reset(seed=seed)
        seen = []
        for _ in range(steps):
            seen.append(np.asarray(obs, np.float32).copy())
            action, _ = policy.predict(obs, deterministic=True)
            obs, *_ = envs.step(action)
    finally:
        envs.close()
    return np.concatenate(seen)


def max_error(flight_or_head, got: np.ndarray, want: np.ndarray) -> float:
    """The largest |got - want| as a fraction of each action entry's range (high - low)."""
    head = getattr(flight_or_head, "head", flight_or_head)
    span = np.where(head.high > head.low, head.high - head.low, 1.0)
    return float(np.max(np.abs(np.asarray(got, np.float64) - want) / span))


def check(flight: FlightPolicy, what: str, got: np.ndarray, want: np.ndarray,
          tolerance: float = TOLERANCE) -> float:
    err = max_error(flight, got, want)
    if not err <= tolerance:
        raise ExportMismatchError(
            f"{what} differs from the policy's predict by {err:.3g} of the action range "
            f"(tolerance {tolerance:g}) on {len(want)} observations: not exported")
    return err


@dataclass(frozen=True)
class Exported:
    """What :func:`export` wrote and measured: files, footprint, agreement (fraction of range)."""

    files: list
    footprint: dict
    errors: dict


def export(source, formats: str | Sequence[str] = "c", out="export", *,
           trust_pickle: bool = False, check_observations: np.ndarray | None = None,
           precision: str = "float32") -> Exported:
    """Export a trained policy (a run folder, its policy.pt, a checkpoint, or a loaded policy)
    to ``out`` in ``formats`` (``"c"``, ``"onnx"`` or both), with footprint.json and
    export.json; every format written is checked against the policy's ``predict`` first.

    check_observations: the observations for the check (default: the policy's own episodes,
    :func:`episode_observations`). trust_pickle: an RLlib run (RLlib pickles its modules).
    precision: ``"int8"`` writes the dense weights as int8 with a scale per row
    (:func:`to_int8`): the C and ONNX are then checked against that quantised network, and
    its difference from the policy's ``predict`` is measured (``errors["int8_vs_policy"]``),
    not bounded.
    """
    if precision not in PRECISIONS:
        raise InvalidParameterError(f"precision must be one of {list(PRECISIONS)}, got "
                                    f"{precision!r}")
    formats = (formats,) if isinstance(formats, str) else tuple(formats)
    for fmt in formats:
        if fmt not in FORMATS:
            raise InvalidParameterError(f"format must be one of {list(FORMATS)}, got {fmt!r}")
    if "onnx" in formats:
        _onnx()
    policy = source if hasattr(source, "predict") else load_policy(source,
                                                                   trust_pickle=trust_pickle)
    run = getattr(policy, "source", None) if hasattr(source, "predict") else str(source)
    flight = from_policy(policy, run=None if run is None else str(run))
    obs = (episode_observations(policy) if check_observations is None
           else np.asarray(check_observations, np.float32))
    want, _ = policy.predict(obs, deterministic=True)
    errors = {"network": check(flight, "the network read from the policy", flight(obs), want)}
    if precision == "int8":
        flight = to_int8(flight)
        want = flight(obs)  # what the written files must compute
        errors["int8_vs_policy"] = max_error(flight, want, policy.predict(obs)[0])
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    files = []
    if "c" in formats:
        files += write_c(flight, out)
        if compiled.compiler() is not None:
            with tempfile.TemporaryDirectory(prefix="rbenv-export-") as tmp:
                lib = compiled.compile_shared(out / compiled.C_SOURCE, Path(tmp) / "p.so")
                errors["c"] = check(flight, "the compiled C", _call_library(lib, flight, obs),
                                    want)
    if "onnx" in formats:
        files += write_onnx(flight, out)
        errors["onnx"] = check(flight, "the ONNX graph (onnxruntime)",
                               run_onnx(out / ONNX_FILE, obs), want)
    fp = footprint(flight)
    files.append(write_json(out / FOOTPRINT, fp))
    files.append(write_json(out / compiled.MANIFEST, {
        **flight.info, "obs_dim": flight.obs_dim, "act_dim": flight.act_dim,
        "output_stage": flight.head.kind, "formats": list(formats), "precision": precision,
        "check": {"observations": len(obs), "max_error_of_range": errors,
                  "tolerance": TOLERANCE}}))
    return Exported(files, fp, errors)


def _call_library(lib: Path, flight: FlightPolicy, obs: np.ndarray) -> np.ndarray:
    """The compiled ``rbenv_policy`` on ``obs`` (before export.json exists)."""
    import ctypes

    fn = ctypes.CDLL(str(Path(lib).resolve())).rbenv_policy
    f32 = ctypes.POINTER(ctypes.c_float)
    fn.argtypes, fn.restype = [f32, f32], None
    batch = np.ascontiguousarray(obs, np.float32)
    out = np.empty((len(batch), flight.act_dim), np.float32)
    for row, act in zip(batch, out, strict=True):
        fn(row.ctypes.data_as(f32), act.ctypes.data_as(f32))
    return out


def format_footprint(fp: dict) -> str:
    """The footprint as a few lines for the terminal."""
    calls = ", ".join(f"{n} {fn}" for fn, n in sorted(fp["transcendental_calls"].items()))
    return (f"network {' -> '.join(map(str, fp['layers']))} ({fp['head']})\n"
            f"weights (flash): {fp['weight_bytes']} bytes\n"
            f"activations (RAM): {fp['activation_bytes']} bytes\n"
            f"multiply-adds per call: {fp['multiply_adds']}\n"
            f"transcendental calls per call: {calls or 'none'}")
