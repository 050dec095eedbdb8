"""JSON documents as jethr1 writes them (summary.json and every --json output), and read back with
bounds: a size, a nesting depth, one-line errors."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from jethr1_plan.errors import InputError
from jethr1_plan.io.input_file import read_input

__all__ = ["MAX_JSON_BYTES", "MAX_JSON_DEPTH", "json_document", "json_text", "read_json"]

MAX_JSON_BYTES = 50_000_000  # a summary.json is a few kilobytes (a balance space's, a few hundred)
MAX_JSON_DEPTH = 32  # jethr1 writes documents 6 levels deep


def json_text(doc: dict) -> str:
    """JSON text; a value that is not a finite number (no such value: a row without a posture) is null."""
    return json.dumps(_finite_only(doc), indent=2, sort_keys=False, allow_nan=False, default=_jsonable) + "\n"


def _finite_only(x: Any) -> Any:
    if isinstance(x, dict):
        return {k: _finite_only(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_finite_only(v) for v in x]
    if isinstance(x, float | np.floating) and not math.isfinite(float(x)):
        return None
    return x


def _jsonable(x: Any) -> Any:
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    raise TypeError(f"not JSON serialisable: {type(x).__name__}")


def read_json(path: Path, max_bytes: int = MAX_JSON_BYTES, max_depth: int = MAX_JSON_DEPTH) -> dict:
    """The JSON object in the regular file ``path``, at most ``max_bytes`` long and ``max_depth`` levels deep,
    every number finite (jethr1 writes ``null`` where there is none).

    Raises:
        InputError: not a regular file, unreadable, too large, not JSON, NaN or an infinity, nested too deeply,
            or not an object.
    """
    return json_document(read_input(path, max_bytes, "a JSON document"), str(path), max_depth)


def _no_constant(name: str) -> float:
    raise ValueError(f"{name} is not a finite number (jethr1 writes null where there is no number)")


def json_document(data: bytes, src: str, max_depth: int = MAX_JSON_DEPTH) -> dict:
    """The JSON object in ``data`` (see :func:`read_json`); ``src`` names it in messages."""
    try:
        doc = json.loads(data.decode("utf-8"), parse_constant=_no_constant)
    except RecursionError:
        raise InputError(src, "", f"nested more than {max_depth} levels deep") from None
    except (UnicodeDecodeError, ValueError) as exc:
        raise InputError(src, "", f"cannot read: {str(exc).splitlines()[0][:100]}") from None
    if not isinstance(doc, dict):
        raise InputError(src, "", "expected a JSON object")
    if _depth(doc) > max_depth:
        raise InputError(src, "", f"nested more than {max_depth} levels deep")
    return doc


def _depth(doc: Any) -> int:
    """The nesting depth of a JSON value (a scalar: 0), without recursion."""
    deepest, stack = 0, [(doc, 1)]
    while stack:
        node, level = stack.pop()
        if isinstance(node, dict | list):
            deepest = max(deepest, level)
            stack.extend((v, level + 1) for v in (node.values() if isinstance(node, dict) else node))
    return deepest
