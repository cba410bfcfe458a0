"""JSON read with limits: every JSON input (terrain files and uploads, the web API's bodies) goes through
`loads_strict`, which refuses, with one line naming the problem, what Python's ``json`` would take or choke on:

- more than ``max_bytes`` of input, text that is not UTF-8;
- nesting deeper than ``max_depth`` (arrays and objects), more than ``max_values`` values in all;
- a number written with more than ``max_number_chars`` characters (Python refuses to convert integers
  of more than 4,300 digits with a long traceback; no quantity here needs more than a few dozen);
- an object with a duplicate key (``{"gait": "walk", "gait": "trot"}`` would silently keep the last);
- invalid JSON (with line and column).

``NaN`` and ``Infinity`` are read (as floats) so that the validation downstream can name the field that
holds them ("goal_x: expected a finite number"). The cost is linear in the input: a regular expression
scan for long numbers, one pass of the C parser, one walk over the values level by level.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from typing import Any


class JsonInputError(ValueError):
    """JSON input refused: the message is one line and names the source and the problem."""


@dataclass(frozen=True)
class JsonLimits:
    """Bounds on a JSON input (defaults: generous for any terrain or request of this project)."""

    max_bytes: int = 1_000_000
    max_depth: int = 32
    max_values: int = 1_000_000
    max_number_chars: int = 64


DEFAULT_LIMITS = JsonLimits()


class _DuplicateKey(Exception):
    pass


class _NumberTooLong(Exception):
    pass


def _reject_duplicates(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    result: dict[str, Any] = {}
    for key, value in pairs:
        if key in result:
            raise _DuplicateKey(key)
        result[key] = value
    return result


def _excerpt(text: str, limit: int = 24) -> str:
    return text if len(text) <= limit else text[:limit] + "..."


def loads_strict(data: bytes | str, source: str = "input", limits: JsonLimits = DEFAULT_LIMITS) -> Any:
    """The value of a JSON document, or `JsonInputError` naming ``source`` and what is wrong."""
    size = len(data.encode("utf-8")) if isinstance(data, str) else len(data)
    if size > limits.max_bytes:
        raise JsonInputError(f"{source}: {size} bytes of JSON; the limit is {limits.max_bytes} bytes")
    if isinstance(data, bytes | bytearray):
        try:
            text = bytes(data).decode("utf-8")
        except UnicodeDecodeError as exc:
            raise JsonInputError(f"{source}: not UTF-8 text (byte {exc.start})") from None
    else:
        text = data

    def number(kind: type):
        def parse(literal: str) -> int | float:
            if len(literal) > limits.max_number_chars:
                raise _NumberTooLong(literal)
            return kind(literal)

        return parse

    # Number literals are maximal runs of [-+.0-9eE] outside strings: when no such run anywhere is longer
    # than the limit, none can be, and the C parser converts numbers without a Python call per number.
    long_run = re.compile(f"[-+.0-9eE]{{{limits.max_number_chars + 1},}}")
    hooks = {} if long_run.search(text) is None else {"parse_int": number(int), "parse_float": number(float)}
    try:
        value = json.loads(text, object_pairs_hook=_reject_duplicates, **hooks)
    except json.JSONDecodeError as exc:
        raise JsonInputError(f"{source}: not valid JSON: {exc.msg} (line {exc.lineno}, column {exc.colno})") from None
    except RecursionError:
        raise JsonInputError(f"{source}: JSON nested deeper than {limits.max_depth} levels") from None
    except _DuplicateKey as exc:
        raise JsonInputError(f"{source}: duplicate key {_excerpt(json.dumps(exc.args[0]))} in a JSON object") from None
    except _NumberTooLong as exc:
        raise JsonInputError(f"{source}: a number of {len(exc.args[0])} characters ({_excerpt(exc.args[0])}); "
                             f"the limit is {limits.max_number_chars}") from None
    _check_shape(value, source, limits)
    return value


def _check_shape(value: Any, source: str, limits: JsonLimits) -> None:
    """Depth and value count, walked level by level (no recursion on hostile input; linear in the values)."""
    level = [value]
    depth = count = 0
    while level:
        depth += 1
        count += len(level)
        if count > limits.max_values:
            raise JsonInputError(f"{source}: more than {limits.max_values} JSON values")
        containers = [item for item in level if type(item) is list or type(item) is dict]
        if containers and depth > limits.max_depth:
            raise JsonInputError(f"{source}: JSON nested deeper than {limits.max_depth} levels")
        level = []
        for item in containers:
            level.extend(item.values() if type(item) is dict else item)
