"""JSON documents as jethr1 writes them (summary.json and every --json output), and read back with
bounds: a size, a nesting depth, one-line errors."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from jethr1_plan.errors import InputError

__all__ = ["MAX_JSON_BYTES", "MAX_JSON_DEPTH", "json_text", "read_json"]

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
    """The JSON object in ``path``, at most ``max_bytes`` long and ``max_depth`` levels deep.

    Raises:
        InputError: unreadable, too large, not JSON, nested too deeply, or not an object.
    """
    src = str(path)
    try:
        with open(path, "rb") as f:
            data = f.read(max_bytes + 1)
    except OSError as exc:
        raise InputError(src, "", f"cannot read: {exc.strerror or exc}") from None
    if len(data) > max_bytes:
        raise InputError(src, "", f"larger than {max_bytes:,} bytes: not one of jethr1's documents")
    try:
        doc = json.loads(data.decode("utf-8"))
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
