"""Safe user expressions for custom model terms (``--term "vib:extra.vib_g**2"``).

An expression is parsed with :mod:`ast` and walked node by node; nothing is ever passed to
``eval``. Allowed:

* numbers (evaluated as float64, so ``10**10**10`` overflows to inf instead of hanging);
* ``+ - * / **`` and unary ``-``/``+``;
* channel references ``temp.NAME`` (also ``T.NAME``), ``field.NAME`` (also ``H.NAME``),
  ``extra.NAME`` and the same with a subscript for awkward names (``extra["vib g"]``);
  the bare names ``supply`` (V), ``table_rate`` (deg/h), ``t`` (s from the log start) and
  ``t_h`` (h);
* the functions ``abs sqrt exp log log10 sin cos tan tanh arctan sign square minimum maximum
  clip`` (numpy, element-wise) and two signal helpers: ``ddt(x)`` = smoothed time derivative of
  x per hour (the same smoother as the dT/dt term) and ``lag(x, tau_s)`` = first-order lag of
  x with time constant tau_s seconds.

Anything else (attributes other than the channel namespaces, comprehensions, lambdas,
comparisons, strings outside a subscript, keyword arguments, ...) is rejected with a message
naming the offending part.
"""

from __future__ import annotations

import ast
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np

from ..core.errors import InputError

#: element-wise numpy functions allowed in expressions: name -> (function, number of args)
FUNCTIONS: dict[str, tuple[Callable, tuple[int, ...]]] = {
    "abs": (np.abs, (1,)),
    "sqrt": (np.sqrt, (1,)),
    "exp": (np.exp, (1,)),
    "log": (np.log, (1,)),
    "log10": (np.log10, (1,)),
    "sin": (np.sin, (1,)),
    "cos": (np.cos, (1,)),
    "tan": (np.tan, (1,)),
    "tanh": (np.tanh, (1,)),
    "arctan": (np.arctan, (1,)),
    "sign": (np.sign, (1,)),
    "square": (np.square, (1,)),
    "minimum": (np.minimum, (2,)),
    "maximum": (np.maximum, (2,)),
    "clip": (np.clip, (3,)),
}
SIGNAL_FUNCTIONS = {"ddt": (1,), "lag": (2,)}

#: namespace name -> channel group of :class:`gyrotest.envmodel.terms.EnvFrame`
NAMESPACES = {"temp": "temperature", "T": "temperature", "field": "field", "H": "field",
              "extra": "extra"}
SCALARS = {"supply": "supply", "table_rate": "table_rate", "t": "t", "t_h": "t_h"}

_BINOPS = {ast.Add: np.add, ast.Sub: np.subtract, ast.Mult: np.multiply,
           ast.Div: np.divide, ast.Pow: np.power}
_UNARY = {ast.USub: np.negative, ast.UAdd: np.positive}
MAX_LEN = 300
MAX_NODES = 200


@dataclass(frozen=True)
class ChannelRef:
    """A channel named in an expression: group (temperature/field/extra/supply/...) and name."""

    group: str
    name: str

    def __str__(self) -> str:
        return self.name if self.group in SCALARS.values() else f"{self.group}.{self.name}"


@dataclass
class SafeExpression:
    """A validated expression; :meth:`evaluate` computes it on an EnvFrame."""

    text: str
    tree: ast.Expression
    channels: list[ChannelRef] = field(default_factory=list)

    def evaluate(self, frame: Any, *, smoothing_s: float, raw_ddt: bool = False) -> np.ndarray:
        """Evaluate on ``frame`` (an :class:`~gyrotest.envmodel.terms.EnvFrame`); returns a
        float64 array of the frame's length (scalars are broadcast). ``raw_ddt``: ``ddt(x)``
        is the plain central-difference derivative, for a caller that applies the working
        smoother to the whole expression afterwards (the smoother then acts once, as on the
        gyro rate: S_W(dx/dt) = d(S_W x)/dt)."""
        with np.errstate(all="ignore"):
            out = _Evaluator(frame, smoothing_s, self.text, raw_ddt).visit(self.tree.body)
        out = np.broadcast_to(np.asarray(out, dtype=np.float64), (frame.n,)).copy()
        return out


def _err(text: str, why: str) -> InputError:
    return InputError(f"custom term expression {text!r}: {why}")


def parse_expression(text: str) -> SafeExpression:
    """Parse and validate ``text``; raise :class:`InputError` naming what is not allowed.

    Grammar: numbers, channel references, ``+ - * / **``, unary minus and the whitelisted
    functions (see the module docstring). Returns a :class:`SafeExpression` listing the
    channels it reads.
    """
    if not text or not text.strip():
        raise _err(text, "empty expression")
    if len(text) > MAX_LEN:
        raise _err(text[:40] + "...", f"longer than {MAX_LEN} characters")
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as e:
        raise _err(text, f"syntax error at column {e.offset}") from None
    nodes = list(ast.walk(tree))
    if len(nodes) > MAX_NODES:
        raise _err(text, f"too complex (more than {MAX_NODES} nodes)")
    channels: list[ChannelRef] = []
    _validate(tree.body, text, channels)
    if not channels:
        raise _err(text, "names no channel (use temp.NAME, field.NAME, extra.NAME, supply, "
                         "table_rate, t or t_h)")
    return SafeExpression(text=text.strip(), tree=tree, channels=list(dict.fromkeys(channels)))


def _channel_of(node: ast.AST, text: str) -> ChannelRef | None:
    if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name):
        ns = node.value.id
        if ns not in NAMESPACES:
            raise _err(text, f"unknown namespace {ns!r} (use temp, field or extra)")
        return ChannelRef(NAMESPACES[ns], node.attr)
    if isinstance(node, ast.Subscript) and isinstance(node.value, ast.Name):
        ns = node.value.id
        if ns not in NAMESPACES:
            raise _err(text, f"unknown namespace {ns!r} (use temp, field or extra)")
        sl = node.slice
        if not (isinstance(sl, ast.Constant) and isinstance(sl.value, str)):
            raise _err(text, f"{ns}[...] needs a quoted channel name")
        return ChannelRef(NAMESPACES[ns], sl.value)
    return None


def _validate(node: ast.AST, text: str, channels: list[ChannelRef]) -> None:
    ref = _channel_of(node, text)
    if ref is not None:
        channels.append(ref)
        return
    if isinstance(node, ast.Constant):
        if isinstance(node.value, bool) or not isinstance(node.value, (int, float)):
            raise _err(text, f"only numeric constants are allowed, not {node.value!r}")
        return
    if isinstance(node, ast.Name):
        if node.id in SCALARS:
            channels.append(ChannelRef(SCALARS[node.id], node.id))
            return
        raise _err(text, f"unknown name {node.id!r} (channels are temp.NAME, field.NAME, "
                         "extra.NAME, supply, table_rate, t, t_h)")
    if isinstance(node, ast.BinOp):
        if type(node.op) not in _BINOPS:
            raise _err(text, f"operator {type(node.op).__name__} is not allowed (use + - * / **)")
        _validate(node.left, text, channels)
        _validate(node.right, text, channels)
        return
    if isinstance(node, ast.UnaryOp):
        if type(node.op) not in _UNARY:
            raise _err(text, f"operator {type(node.op).__name__} is not allowed")
        _validate(node.operand, text, channels)
        return
    if isinstance(node, ast.Call):
        if not isinstance(node.func, ast.Name):
            raise _err(text, "only plain function names may be called (e.g. sqrt(x))")
        name = node.func.id
        if node.keywords:
            raise _err(text, f"{name}(): keyword arguments are not allowed")
        if name in FUNCTIONS:
            nargs = FUNCTIONS[name][1]
        elif name in SIGNAL_FUNCTIONS:
            nargs = SIGNAL_FUNCTIONS[name]
        else:
            allowed = ", ".join(sorted(list(FUNCTIONS) + list(SIGNAL_FUNCTIONS)))
            raise _err(text, f"function {name!r} is not allowed (allowed: {allowed})")
        if len(node.args) not in nargs:
            raise _err(text, f"{name}() takes {' or '.join(map(str, nargs))} argument(s)")
        if name == "lag" and not isinstance(node.args[1], ast.Constant):
            raise _err(text, "lag(x, tau_s): tau_s must be a number of seconds")
        for a in node.args:
            _validate(a, text, channels)
        return
    if isinstance(node, (ast.Attribute, ast.Subscript)):
        raise _err(text, "attributes/subscripts are only allowed on temp, field and extra")
    raise _err(text, f"{type(node).__name__} is not allowed")


class _Evaluator:
    def __init__(self, frame: Any, smoothing_s: float, text: str, raw_ddt: bool = False):
        self.frame = frame
        self.smoothing_s = smoothing_s
        self.text = text
        self.raw_ddt = raw_ddt

    def visit(self, node: ast.AST):
        ref = _channel_of(node, self.text)
        if ref is not None:
            return self.frame.channel_values(ref.group, ref.name)
        if isinstance(node, ast.Constant):
            return np.float64(node.value)
        if isinstance(node, ast.Name):
            return self.frame.channel_values(SCALARS[node.id], node.id)
        if isinstance(node, ast.BinOp):
            return _BINOPS[type(node.op)](self.visit(node.left), self.visit(node.right))
        if isinstance(node, ast.UnaryOp):
            return _UNARY[type(node.op)](self.visit(node.operand))
        if isinstance(node, ast.Call):
            name = cast(ast.Name, node.func).id  # the parser admits only named calls
            if name == "ddt":
                from .effects import smoothed_rate

                x = np.broadcast_to(np.asarray(self.visit(node.args[0]), float), (self.frame.n,))
                if self.raw_ddt:
                    out = np.zeros(self.frame.n)
                    for a, b in self.frame.bounds:
                        if b - a > 1:
                            out[a:b] = np.gradient(x[a:b], self.frame.dt) * 3600.0
                    return out
                return smoothed_rate(x, self.frame.dt, self.smoothing_s, self.frame.bounds)
            if name == "lag":
                from .effects import first_order_lag

                x = np.broadcast_to(np.asarray(self.visit(node.args[0]), float), (self.frame.n,))
                tau = float(cast(ast.Constant, node.args[1]).value)
                if not tau > 0:
                    raise _err(self.text, "lag(x, tau_s): tau_s must be > 0")
                return first_order_lag(x, self.frame.t, tau, self.frame.bounds)
            fn = FUNCTIONS[name][0]
            return fn(*[self.visit(a) for a in node.args])
        raise _err(self.text, f"{type(node).__name__} is not allowed")  # pragma: no cover
