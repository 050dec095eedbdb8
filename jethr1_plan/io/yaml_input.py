"""YAML input files (scenarios, walks): bounded reading, parsing, and one-line messages for every problem.

Every problem is an :class:`~jethr1_plan.errors.InputError` naming the file, the key path and what
is wrong: a path that is not a regular file (a FIFO, a device: ``io.input_file``), bytes that are not
UTF-8, a file far larger than any input, YAML that does not parse or expands (through aliases) to too
many values, a key that is not text (``1:`` beside ``name:``), an integer of more digits than any
bound allows, a number that is not finite, a key the schema does not know or a value it does not
allow. Every YAML document jethr1 reads (scenarios, walks, terrains, robot YAMLs, batch manifests, the
scenario a summary.json holds) goes through :func:`read_document` or :class:`YamlLoader`.
"""

from __future__ import annotations

import math
import re
from dataclasses import fields, replace
from pathlib import Path

import yaml

from jethr1_plan.errors import InputError
from jethr1_plan.io.input_file import read_input_text

__all__ = ["MAX_INT_DIGITS", "YamlLoader", "check_finite", "check_schema", "count_values", "describe", "fill_dataclass",
           "keypath", "load_yaml", "read_document", "read_text", "short"]


MAX_INT_DIGITS = 30  # an integer in any of jethr1's files: a seed (19 digits) at most


class YamlLoader(yaml.SafeLoader):
    """PyYAML's safe loader, reading ``1e-10`` as a float (YAML 1.2) rather than as a string, refusing
    a key given twice in one mapping (YAML forbids it; PyYAML would keep the last), a key that is not
    text (every key of jethr1's files is a name) and an integer longer than :data:`MAX_INT_DIGITS`
    (Python refuses to read one of over 4,300 digits; none of jethr1's bounds needs more than 19)."""

    def construct_mapping(self, node, deep=False):
        seen = set()
        for key_node, _ in node.value if isinstance(node, yaml.MappingNode) else ():
            if key_node.tag == "tag:yaml.org,2002:merge":
                continue
            key = self.construct_object(key_node, deep=True)
            if not isinstance(key, str):
                raise yaml.constructor.ConstructorError(None, None, f"the key {short(key, 30)} is not text: every key "
                                                        "is a name", key_node.start_mark)
            if key in seen:
                raise yaml.constructor.ConstructorError(None, None, f"the key {short(key)} appears twice in one "
                                                        "mapping", key_node.start_mark)
            seen.add(key)
        return super().construct_mapping(node, deep=deep)

    def construct_yaml_int(self, node):
        text = str(node.value).replace("_", "").lstrip("+-")
        if len(text) > MAX_INT_DIGITS:
            raise yaml.constructor.ConstructorError(None, None, f"an integer of {len(text):,} digits: no value of "
                                                    f"jethr1's has more than {MAX_INT_DIGITS}", node.start_mark)
        return super().construct_yaml_int(node)


YamlLoader.add_constructor("tag:yaml.org,2002:int", YamlLoader.construct_yaml_int)


YamlLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"""^(?:[-+]?(?:[0-9][0-9_]*)\.[0-9_]*(?:[eE][-+]?[0-9]+)?
                  |[-+]?(?:[0-9][0-9_]*)(?:[eE][-+]?[0-9]+)
                  |\.[0-9_]+(?:[eE][-+][0-9]+)?
                  |[-+]?\.(?:inf|Inf|INF)
                  |\.(?:nan|NaN|NAN))$""", re.X),
    list("-+0123456789."))


def keypath(path) -> str:
    """``a.b[2].c``: a key path for a message."""
    out = ""
    for p in path:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else str(p))
    return out or "(top level)"


def check_finite(doc, src: str, path=()) -> None:
    """Refuse NaN and infinities anywhere in the document."""
    if isinstance(doc, dict):
        for k, v in doc.items():
            check_finite(v, src, (*path, k))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            check_finite(v, src, (*path, i))
    elif isinstance(doc, float) and not math.isfinite(doc):
        raise InputError(src, keypath(path), f"{doc} is not a finite number")


#: keys an earlier version of the files spelled otherwise: the old spelling and its successors (the one the
#: schema at that place knows is named). The thrust limit is ``thrust_max_n`` (a fan's, a scenario's cap); the
#: largest thrust a plan uses is ``peak_thrust_n``.
RENAMED_KEYS: dict[str, tuple[str, ...]] = {"max_thrust_n": ("thrust_max_n", "peak_thrust_n")}


def renamed(err) -> tuple[str, str] | None:
    """An unknown key that an earlier version spelled this way: (its key path, the problem naming its new
    spelling)."""
    if err.validator != "additionalProperties" or not isinstance(err.instance, dict):
        return None
    known = err.schema.get("properties", {})
    for old in sorted(set(err.instance) & set(RENAMED_KEYS)):
        new = [k for k in RENAMED_KEYS[old] if k in known]
        if new:
            return keypath([*err.absolute_path, old]), f"renamed: write {new[0]} instead"
    return None


def check_schema(doc: dict, src: str, schema: dict) -> None:
    """The first violation of ``schema`` as one short InputError (unknown key, missing key, type, bound; a key
    spelled as an earlier version did is named with its new spelling)."""
    import jsonschema

    validator = jsonschema.Draft202012Validator(schema)
    errors = sorted(validator.iter_errors(doc), key=lambda e: (len(e.absolute_path), list(map(str, e.absolute_path))))
    if not errors:
        return
    for e in errors:
        old = renamed(e)
        if old is not None:
            raise InputError(src, *old)
    err = errors[0]
    # for oneOf failures, report the most specific error of the branch the value was meant for: the one whose
    # discriminator (``kind``) matched, else the one whose shape it has (its keys, its type)
    while err.context:
        branches: dict = {}
        for sub in err.context:
            branches.setdefault(sub.relative_schema_path[0], []).append(sub)
        matched = [errs for errs in branches.values() if not any(e.validator == "const" for e in errs)]
        depth = len(err.absolute_path)
        pool = min(matched, key=lambda errs: _shape_errors(errs, depth)) if matched else err.context
        err = sorted(pool, key=lambda e: (-len(e.absolute_path), str(e.message)))[0]
    if err.validator == "additionalProperties":
        extra = sorted(set(err.instance) - set(err.schema.get("properties", {})))
        raise InputError(src, keypath([*err.absolute_path, extra[0]]) if extra else keypath(err.absolute_path),
                         "unknown key")
    if err.validator == "required":
        missing = err.message.split("'")[1] if "'" in err.message else err.message
        raise InputError(src, keypath([*err.absolute_path, missing]), "missing")
    raise InputError(src, keypath(err.absolute_path), describe(err))


def _shape_errors(errors: list, depth: int) -> int:
    """How many of a oneOf branch's ``errors`` say the value is not of the branch's shape (a key it requires
    missing, a key it does not know, another type) rather than a bad value inside it: at the value itself
    (``depth``: the length of its key path)."""
    return sum(len(e.absolute_path) == depth and e.validator in ("required", "additionalProperties", "type")
               for e in errors)


def short(value, limit: int = 60) -> str:
    """A value for a message: its repr, cut to ``limit`` characters (never a whole document)."""
    text = repr(value)
    return text if len(text) <= limit else text[:limit] + "..."


def describe(err) -> str:
    """One short line for a JSON-Schema error (jsonschema's own messages print the whole value)."""
    kind, bound, value = err.validator, err.validator_value, err.instance
    if kind == "type":
        return f"expected {bound if isinstance(bound, str) else ' or '.join(bound)}, got {short(value)}"
    if kind == "minimum":
        return f"{short(value)} is below the smallest allowed, {bound:g}"
    if kind == "exclusiveMinimum":
        return f"{short(value)}: must be more than {bound:g}"
    if kind == "maximum":
        return f"{short(value)} is above the largest allowed, {bound:g}"
    if kind == "exclusiveMaximum":
        return f"{short(value)}: must be less than {bound:g}"
    if kind == "enum":
        return f"{short(value)}: expected one of {', '.join(map(str, bound))}"
    if kind == "const":
        return f"{short(value)}: expected {bound!r}"
    if kind == "pattern":
        return f"{short(value)}: must be {err.schema.get('description') or f'text matching {bound}'}"
    if kind in ("minItems", "maxItems"):
        return f"{len(value)} items: expected {'at least' if kind == 'minItems' else 'at most'} {bound}"
    if kind == "maxLength":
        return f"{len(value)} characters: at most {bound}"
    return err.message if len(err.message) <= 120 else err.message[:120] + "..."


def count_values(doc, src: str, cap: int, what: str) -> None:
    """Refuse a document that expands (through YAML aliases) to more than ``cap`` values."""
    stack, count = [doc], 0
    while stack:
        node = stack.pop()
        count += 1
        if count > cap:
            raise InputError(src, "(top level)", f"the document expands to more than {cap:,} values (YAML aliases?); "
                             f"{what} has a few hundred")
        if isinstance(node, dict):
            stack.extend(node.keys())
            stack.extend(node.values())
        elif isinstance(node, list):
            stack.extend(node)


def read_text(path: str | Path, max_bytes: int, what: str) -> str:
    """The UTF-8 text of the regular file ``path`` (at most ``max_bytes``; :func:`~jethr1_plan.io.input_file.
    read_input_text`); ``what`` names the kind of file in messages."""
    return read_input_text(path, max_bytes, what)


def load_yaml(text: str, src: str):
    """The YAML document in ``text`` (:class:`YamlLoader`), any problem one line naming ``src``."""
    try:
        return yaml.load(text, Loader=YamlLoader)  # a SafeLoader subclass
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"line {mark.line + 1}" if mark else ""
        problem = str(getattr(exc, "problem", None) or exc).splitlines()[0][:120]
        raise InputError(src, where, f"not valid YAML: {problem}") from None
    except RecursionError:
        raise InputError(src, "", "not valid YAML: nested too deeply") from None
    except ValueError as exc:  # a number PyYAML's constructors cannot read (an integer too long for Python)
        raise InputError(src, "", f"not valid YAML: {str(exc).splitlines()[0][:120]}") from None


def read_document(text: str, src: str, schema: dict, max_values: int, what: str) -> dict:
    """The YAML mapping in ``text``, its size, numbers and structure checked against ``schema``."""
    doc = load_yaml(text, src)
    if not isinstance(doc, dict):
        raise InputError(src, "(top level)", "expected a mapping")
    count_values(doc, src, max_values, what)
    check_finite(doc, src)
    check_schema(doc, src, schema)
    return doc


def fill_dataclass(default, given: dict, **more):
    """``default`` (a frozen dataclass: the defaults, stated once there) with the keys a document gives
    (validated by its schema) and ``more``; integers given for float fields as floats."""
    values = {**given, **more}
    for f in fields(default):
        v = values.get(f.name)
        if f.type in ("float", float) and isinstance(v, int) and not isinstance(v, bool):
            values[f.name] = float(v)
    return replace(default, **values)


