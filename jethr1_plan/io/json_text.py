"""JSON documents as jethr1 writes them (summary.json and every --json output)."""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np

__all__ = ["json_text"]


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
