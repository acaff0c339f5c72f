"""From pydantic's errors to one line per mistake naming the file, the dotted key, the value
and what is allowed, e.g. ``scenarios/x.toml: absorbers.1.restitution = 1.4: must be in [0, 1]``.

The translator walks the error locations through the root model it is given (``validate``).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any, TypeVar

from annotated_types import Ge, Gt, Le, Lt
from pydantic import BaseModel, ValidationError

from .fields import LARGEST, SMALLEST_MASS

ModelT = TypeVar("ModelT", bound=BaseModel)

#: Marks a key absent from the file, and a value too large to quote (its size is the message).
MISSING = object()
_SIZED = object()


class ScenarioError(ValueError):
    """A scenario file that cannot be run; the message names file, key, value and rule
    (``keys``: the dotted keys it names, where they are known)."""

    def __init__(self, message: str, keys: tuple[str, ...] = ()):
        super().__init__(message)
        self.keys = keys


class Mistakes:
    """The mistakes of one file, collected so that all of them are reported at once."""

    def __init__(self) -> None:
        self.lines: list[str] = []

    @contextmanager
    def kept(self) -> Iterator[None]:
        """Run a block of checks; a ScenarioError ends the block and its lines are kept."""
        try:
            yield
        except ScenarioError as exc:
            self.lines.extend(str(exc).split("\n"))

    def __bool__(self) -> bool:
        return bool(self.lines)

    def raise_any(self) -> None:
        """Raise ScenarioError with one line per mistake kept (each once), if there are any."""
        if self.lines:
            raise ScenarioError("\n".join(dict.fromkeys(self.lines)))


class FieldError(ValueError):
    """Raised inside validators to report a dotted key with its value and rule."""

    def __init__(self, key: str, value: Any, rule: str):
        super().__init__(rule)
        self.key, self.value, self.rule = key, value, rule


def _num(x: float) -> str:
    """A bound as written in a rule: integers in full, other numbers short."""
    return str(x) if isinstance(x, int) else f"{x:g}"


def _interval(metadata: list[Any], value: Any) -> str | None:
    """The rule of a bounded field; the magnitude limit ``LARGEST`` is named only to a value past it."""
    lo = hi = None
    lo_open = hi_open = True
    for m in metadata:
        if isinstance(m, Ge):
            lo, lo_open = m.ge, False
        elif isinstance(m, Gt):
            lo, lo_open = m.gt, True
        elif isinstance(m, Le):
            hi, hi_open = m.le, False
        elif isinstance(m, Lt):
            hi, hi_open = m.lt, True
    number = isinstance(value, (int, float)) and not isinstance(value, bool)
    if lo == SMALLEST_MASS and hi == LARGEST:
        units = " (use other units)" if number and value > 0 else ""
        return f"must be in [{SMALLEST_MASS:g}, {LARGEST:g}]{units}"
    if hi == LARGEST and lo == -LARGEST and number and abs(value) > LARGEST:
        return f"its magnitude must be <= {LARGEST:g} (use other units)"
    if hi == LARGEST and not (number and value > hi):
        hi = None
    if lo == -LARGEST and not (number and value < lo):
        lo = None
    if lo is None and hi is None:
        return None
    if hi == LARGEST and lo is not None:
        return f"must be {'>' if lo_open else '>='} {_num(lo)} and <= {LARGEST:g} (use other units)"
    if hi is None:
        return f"must be {'>' if lo_open else '>='} {_num(lo)}"
    if lo is None:
        return f"must be {'<' if hi_open else '<='} {_num(hi)}"
    return f"must be in {'(' if lo_open else '['}{_num(lo)}, {_num(hi)}{')' if hi_open else ']'}"


def _constraints(info: Any) -> list[Any]:
    """Bound constraints of a field, also inside ``Optional[Annotated[...]]`` and lists of
    them (``Optional[list[Annotated[...]]]``: the bound of the items)."""
    found = list(info.metadata)

    def walk(annotation: Any) -> None:
        for arg in getattr(annotation, "__args__", ()):
            for meta in getattr(arg, "__metadata__", ()):
                found.extend(getattr(meta, "metadata", [meta]))
            walk(arg)

    walk(info.annotation)
    return found


def _field_info(root: type[BaseModel], loc: tuple[Any, ...]):
    """Walk a pydantic error location through the models from ``root`` to the FieldInfo it names."""
    model: Any = root
    info = None
    for part in loc:
        if isinstance(part, int) or model is None:
            continue
        if isinstance(model, type) and issubclass(model, BaseModel):
            if part not in model.model_fields:
                return None
            info = model.model_fields[part]
            model = _inner_model(info.annotation)
        elif isinstance(model, dict):  # tagged union: part is the tag (or a key of a table of them)
            model = model.get(part, model)
    return info


def _members(annotation: Any) -> list[type[BaseModel]]:
    """Model classes inside an annotation (through lists, unions and Annotated)."""
    found: list[type[BaseModel]] = []
    for arg in getattr(annotation, "__args__", ()):
        if isinstance(arg, type) and issubclass(arg, BaseModel):
            found.append(arg)
        else:
            found += _members(arg)
    return found


def _inner_model(annotation: Any) -> Any:
    """The model (or tag -> model map for a tagged union) inside an annotation, if any."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    members = _members(annotation)
    if len(members) == 1:
        return members[0]
    if members:
        return {m.model_fields[_tag(m)].annotation.__args__[0]: m for m in members}
    return None


#: Fields that tag the members of a tagged union (absorbers and loads, distributions).
TAGS = ("type", "distribution")


def _tag(model: type[BaseModel]) -> str:
    return next(t for t in TAGS if t in model.model_fields)


def _dotted(loc: tuple[Any, ...], data: Any) -> tuple[str, Any, tuple[Any, ...]]:
    """Dotted key, the user's value at it, and the location without union tags."""
    parts: list[str] = []
    clean: list[Any] = []
    node, tagged = data, None
    for part in loc:
        if isinstance(part, str) and isinstance(node, dict) and node is not tagged and part in (
                node.get(t) for t in TAGS):
            tagged = node  # the tag of a tagged union, not a key of the file (once: a gap
            continue  # absorber's tag is "gap", its field too)
        if isinstance(node, dict) and part in node:
            node = node[part]
        elif isinstance(node, list) and isinstance(part, int) and part < len(node):
            node = node[part]
        else:
            node = MISSING
        parts.append(str(part))
        clean.append(part)
    return ".".join(parts), node, tuple(clean)



def _describe(root: type[BaseModel], err: dict[str, Any], data: Any) -> tuple[str, Any, str]:
    key, value, loc = _dotted(tuple(err["loc"]), data)
    kind = err["type"]
    info = _field_info(root, tuple(err["loc"]))
    if kind == "missing":
        what = "section" if info is not None and _inner_model(info.annotation) is not None else "key"
        return key, MISSING, f"missing required {what}"
    if kind == "extra_forbidden":
        allowed = _allowed_keys(root, loc[:-1], data)
        return key, value, f"unknown key; allowed keys: {', '.join(allowed)}" if allowed else "unknown key"
    if kind in ("union_tag_invalid", "union_tag_not_found"):
        tag = err.get("ctx", {}).get("discriminator", "'type'").strip("'")
        key = f"{key}.{tag}" if key else tag
        value = value.get(tag, MISSING) if isinstance(value, dict) else value
        tags = err.get("ctx", {}).get("expected_tags", "")
        members = _inner_model(info.annotation) if info is not None else None
        if not tags and isinstance(members, dict):
            tags = ", ".join(repr(t) for t in members)
        return key, value, f"must be one of {tags}"
    if kind in ("greater_than", "greater_than_equal", "less_than", "less_than_equal") and info:
        return key, value, _interval(_constraints(info), value) or err["msg"]
    if kind in ("float_parsing", "float_type", "int_parsing", "int_type", "int_from_float"):
        return key, value, ("must be " + ("an integer" if kind.startswith("int") else "a number")
                            + _not(value))
    if kind == "bool_type":
        return key, value, "must be true or false" + _not(value)
    if kind == "string_type":
        return key, value, "must be a string (in quotes)"
    if kind in ("too_long", "too_short"):
        ctx = err.get("ctx", {})
        limit = ctx.get("max_length") if kind == "too_long" else ctx.get("min_length")
        return key, _SIZED, f"holds {ctx.get('actual_length')} entries; it may hold at " \
                            f"{'most' if kind == 'too_long' else 'least'} {limit}"
    if kind == "finite_number":
        return key, value, "must be a finite number"
    if kind == "literal_error":
        return key, value, "must be " + err["msg"].removeprefix("Input should be ")
    if kind in ("model_type", "model_attributes_type", "dict_type"):
        return key, value, "must be a table"
    if kind == "list_type":
        return key, value, "must be a list"
    if kind == "value_error" and isinstance(err.get("ctx", {}).get("error"), FieldError):
        e = err["ctx"]["error"]
        value = e.value if e.value is not None else MISSING
        return (f"{key}.{e.key}" if key else e.key), value, e.rule
    return key, value, err["msg"]


def _allowed_keys(root: type[BaseModel], loc: tuple[Any, ...], data: Any) -> list[str]:
    """The keys the model at ``loc`` (below ``root``) allows."""
    model: Any = root
    node = data
    for part in loc:
        node = (node[part] if isinstance(node, (dict, list))
                and part in (node if isinstance(node, dict) else range(len(node))) else None)
        if isinstance(part, int) or isinstance(model, dict):
            continue  # a list index, or a key of a table of tagged models
        info = model.model_fields.get(part) if isinstance(model, type) else None
        model = _inner_model(info.annotation) if info else None
    if isinstance(model, dict):
        tag = next((node[t] for t in TAGS if isinstance(node, dict) and t in node), None)
        model = model.get(tag)
    return list(model.model_fields) if isinstance(model, type) else []


def _not(value: Any) -> str:
    """Why a value of the wrong type is not taken as it looks (types are never converted)."""
    if isinstance(value, bool):
        return ", not true or false"
    if isinstance(value, str):
        return ", not a string (no quotes)"
    if isinstance(value, float):
        return ", not a number with a decimal point or exponent"
    if isinstance(value, (list, dict)):
        return f", not {'a list' if isinstance(value, list) else 'a table'}"
    return ""


#: Longest value quoted in a message (longer ones are cut).
QUOTE = 80


def quote(value: Any) -> str:
    """``repr(value)``, cut to ``QUOTE`` characters."""
    text = repr(value)
    return text if len(text) <= QUOTE else text[:QUOTE - 3] + "..."


def format_error(source: str, key: str, value: Any, rule: str) -> str:
    """One line: ``source: key = value: rule`` (without ``= value`` where it is missing, the
    value cut to ``QUOTE`` characters)."""
    if len(key) > QUOTE:
        key = key[:QUOTE - 3] + "..."
    where = f"{source}: {key}" if key else source
    if value is MISSING or value is _SIZED:
        return f"{where}: {rule}"
    return f"{where} = {quote(value)}: {rule}"


def validate(root: type[ModelT], data: dict[str, Any], source: str) -> ModelT:
    """``data`` validated as ``root``, or ScenarioError with one line per mistake."""
    try:
        return root.model_validate(data)
    except ValidationError as exc:
        described = [_describe(root, e, data) for e in exc.errors(include_url=False)]
        lines = [format_error(source, *d) for d in described]
        raise ScenarioError("\n".join(dict.fromkeys(lines)), tuple(d[0] for d in described)) from None



