"""The type check every settings dataclass and stage argument goes through before any work
(docs/architecture.md, "Reliability": one validated front door).

:func:`check_fields` walks a config dataclass (nested ones too) and compares each value with its
field's annotation: an ``int`` field takes an integer (not a bool, not ``"1"``), a ``float`` field a
finite number, a ``str`` field a string, ``X | None`` also None, a nested config an instance of its
class. Seeds lie in ``[0, MAX_SEED]`` (numpy's generators take 32 bits) and every integer fits 64
bits, so no value reaches torch or numpy as one they overflow on. A wrong value raises
:class:`~inpaint360gs.core.errors.InputError` naming the setting (``TrainConfig.iterations``), which
the CLI shows as its option. Ranges of a particular setting stay with its config (``validate``).
"""

from __future__ import annotations

import dataclasses
import functools
import math
import types
import typing

from inpaint360gs.core.errors import InputError

MAX_SEED = 2**32 - 1  # numpy.random.default_rng and torch.manual_seed both take it
MAX_INT = 2**63 - 1  # torch's and numpy's int64


def _name(tp) -> str:
    if tp is type(None):
        return "None"
    if isinstance(tp, type):
        return {"int": "an integer", "float": "a number", "str": "a string", "bool": "true or false", "dict": "a mapping", "tuple": "a tuple",
                "list": "a list"}.get(tp.__name__, f"a {tp.__name__}")  # fmt: skip
    origin = typing.get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        return " or ".join(_name(a) for a in typing.get_args(tp))
    return _name(origin) if isinstance(origin, type) else str(tp)


def check_value(value, tp, setting: str) -> None:
    """:class:`InputError` naming ``setting`` unless ``value`` is of type ``tp`` (an annotation, see
    the module docstring); the ``setting``'s last part ``seed`` also bounds it to ``[0, MAX_SEED]``."""
    if tp is typing.Any or tp is object:
        return
    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if origin in (typing.Union, types.UnionType):
        problems = []
        for a in args:
            try:
                return check_value(value, a, setting)
            except InputError as e:
                problems.append(e)
        if value is not None and len(args) == 2 and type(None) in args:  # X | None: the X's own reason (a range, ...)
            raise problems[[a is type(None) for a in args].index(False)]
        raise InputError(f"expected {_name(tp)}, got {value!r:.60}", setting=setting)
    if tp is type(None):
        if value is not None:
            raise InputError(f"expected None, got {value!r:.60}", setting=setting)
        return
    if origin is tuple:
        if not isinstance(value, (tuple, list)):
            raise InputError(f"expected a tuple, got {value!r:.60}", setting=setting)
        items = args[:1] * len(value) if len(args) == 2 and args[1] is Ellipsis else args
        if len(items) != len(value):
            raise InputError(f"expected {len(items)} values, got {len(value)}", setting=setting)
        for v, a in zip(value, items):
            check_value(v, a, setting)
        return
    if origin in (list, dict) or tp in (list, dict):
        if not isinstance(value, origin or tp):
            raise InputError(f"expected {_name(origin or tp)}, got {value!r:.60}", setting=setting)
        return
    if tp is bool:
        if not isinstance(value, bool):
            raise InputError(f"expected true or false, got {value!r:.60}", setting=setting)
        return
    if tp is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise InputError(f"expected an integer, got {value!r:.60}", setting=setting)
        if setting.rpartition(".")[2] == "seed" and not 0 <= value <= MAX_SEED:
            raise InputError(f"a seed lies in 0..{MAX_SEED}, got {value}", setting=setting)
        if abs(value) > MAX_INT:
            raise InputError(f"{value:.3g} does not fit 64 bits", setting=setting)
        return
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise InputError(f"expected a number, got {value!r:.60}", setting=setting)
        if isinstance(value, int) and abs(value) > MAX_INT or not math.isfinite(value):
            raise InputError(f"expected a finite number, got {value!r:.60}", setting=setting)
        return
    if isinstance(tp, type):
        if not isinstance(value, tp):
            raise InputError(f"expected {_name(tp)}, got {value!r:.60}", setting=setting)
        if dataclasses.is_dataclass(tp):
            check_fields(value)
        return


@functools.lru_cache(maxsize=None)
def _hints(cls: type) -> dict:
    return typing.get_type_hints(cls)


def check_fields(cfg) -> None:
    """Check every field of the dataclass instance ``cfg`` against its annotation (module docstring);
    :class:`InputError` naming the first wrong one as ``Class.field``."""
    cls = type(cfg)
    hints = _hints(cls)
    for f in dataclasses.fields(cfg):
        if f.name in hints:
            check_value(getattr(cfg, f.name), hints[f.name], f"{cls.__name__}.{f.name}")
