"""The generated reference pages: every scenario key from the pydantic schema
(``vines_stoch.scenario.Scenario``) and every command and option of the command line (the typer
app, read as the click command it builds).

The schema gives each key's type, default and allowed range; ``docs/scenario_keys.toml`` gives
its meaning and units, one entry per model field.  ``scenario_reference`` refuses a field without
an entry and an entry without a field, so the page cannot drift from the code.  As a Sphinx
extension it writes both pages into ``docs/reference/`` before each build.
"""

from __future__ import annotations

import re
import tomllib
import types
import typing
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import annotated_types
from pydantic import BaseModel
from pydantic.fields import FieldInfo

#: The meanings and units of the scenario keys, by model and field.
KEYS_FILE = Path(__file__).resolve().parent.parent / "scenario_keys.toml"

#: The pages this extension writes (relative to the documentation's source folder).
SCENARIO_PAGE = Path("reference/scenario-keys.md")
CLI_PAGE = Path("reference/cli.md")


@dataclass
class Key:
    """One scenario key: its dotted path, the model and field it comes from, and what the schema says."""

    path: str
    model: str
    field: str
    type: str
    default: str
    allowed: str


class Undocumented(ValueError):
    """A schema field without a meaning in ``scenario_keys.toml``, or an entry without a field."""


def _constraints(metadata: list[Any], unit: str = "item") -> list[str]:
    """The bounds of a field's metadata as text (``> 0``, ``<= 1e+15``, ``2 items``); ``unit``
    counts a length (items of a list, characters of a text)."""
    out, lengths = [], [None, None]
    for item in metadata:
        if isinstance(item, FieldInfo):  # (a Field(...) inside Annotated: its own metadata)
            out += _constraints(item.metadata, unit)
            continue
        for cls, attr, op in ((annotated_types.Gt, "gt", ">"), (annotated_types.Ge, "ge", ">="),
                              (annotated_types.Lt, "lt", "<"), (annotated_types.Le, "le", "<=")):
            if isinstance(item, cls):
                bound = getattr(item, attr)
                out.append(f"{op} {bound}" if isinstance(bound, int) else f"{op} {bound:g}")
        if isinstance(item, annotated_types.MinLen):
            lengths[0] = item.min_length
        if isinstance(item, annotated_types.MaxLen):
            lengths[1] = item.max_length
    if lengths != [None, None]:
        low, high = lengths
        out.append(f"{low} {unit}s" if low == high else f"{low or 0} to {high} {unit}s" if high is not None
                   else f"at least {low} {unit}{'s' * (low != 1)}")
    return out


def _describe(annotation: Any, metadata: list[Any] | None = None) -> tuple[str, list[str]]:
    """``(type, constraints)`` of an annotation as a reader of a TOML file sees them."""
    bounds = _constraints(metadata or [], "character" if annotation is str else "item")
    origin, args = typing.get_origin(annotation), typing.get_args(annotation)
    if origin is typing.Annotated:
        inner, inner_bounds = _describe(args[0], list(args[1:]))
        return inner, inner_bounds + bounds
    if origin in (typing.Union, types.UnionType):
        parts = [_describe(a) for a in args if a is not type(None)]
        if len(parts) > 1 and all(p[0].startswith("table (") for p in parts):
            return "table (by its tag)", bounds
        if len(parts) == 1:
            return parts[0][0], parts[0][1] + bounds
        return " or ".join(p[0] for p in parts), [b for p in parts for b in p[1]] + bounds
    if origin is Literal:
        return "text" if all(isinstance(a, str) for a in args) else "integer", \
            ["one of " + ", ".join(f"`{a!r}`".replace("'", '"') for a in args)] + bounds
    if origin is list:
        item, item_bounds = _describe(args[0])
        return f"list of {item.replace('table', 'tables', 1)}", [f"each {b}" for b in item_bounds] + bounds
    if origin is dict:
        item, _ = _describe(args[1])
        return f"table of {item.replace('table', 'tables', 1)}", bounds
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return f"table ({annotation.__name__})", bounds
    names = {float: "number", int: "integer", str: "text", bool: "boolean"}
    return names.get(annotation, "any value"), bounds


def _default(info: Any) -> str:
    """A field's default as TOML would spell it, or ``required``."""
    if info.is_required():
        return "required"
    value = info.get_default(call_default_factory=True)
    if value is None:
        return "none"
    if isinstance(value, BaseModel):
        return "the table's defaults"
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, str):
        return f'`"{value}"`'
    if isinstance(value, float):
        return f"`{value:g}`"
    return f"`{value!r}`".replace("'", '"')


def _models(annotation: Any) -> list[type[BaseModel]]:
    """The models an annotation holds (the members of a tagged union, a list's or table's items)."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return [annotation]
    return [m for a in typing.get_args(annotation) for m in _models(a)]


def _container(annotation: Any) -> str:
    """How a field's models are addressed below it: ``list`` (``.N``), ``dict`` (``.NAME``) or ``model``."""
    origin = typing.get_origin(annotation)
    if origin is typing.Annotated:
        return _container(typing.get_args(annotation)[0])
    if origin in (typing.Union, types.UnionType):
        kinds = {_container(a) for a in typing.get_args(annotation) if a is not type(None)}
        return kinds.pop() if len(kinds) == 1 else "model"
    return {list: "list", dict: "dict"}.get(origin, "model")


def _tag(model: type[BaseModel]) -> str:
    """The ``type = "..."`` (or ``distribution = "..."``) that selects a member of a tagged union."""
    for name in ("type", "distribution"):
        field = model.model_fields.get(name)
        if field is not None and typing.get_origin(field.annotation) is Literal:
            return f'{name} = "{typing.get_args(field.annotation)[0]}"'
    return ""


def schema_keys(root: type[BaseModel] | None = None) -> list[tuple[str, str, type[BaseModel], list[Key]]]:
    """Every model reachable from the root scenario, in reading order: ``(where, tag, model, keys)``
    with ``where`` the dotted path of its table (``absorbers.N``, ``limits.NAME``)."""
    if root is None:
        from vines_stoch.scenario import Scenario as root
    sections: list[tuple[str, str, type[BaseModel], list[Key]]] = []
    seen: set[tuple[str, type]] = set()

    def visit(model: type[BaseModel], where: str) -> None:
        if (where, model) in seen:
            return
        seen.add((where, model))
        keys = []
        for name, info in model.model_fields.items():
            kind, bounds = _describe(info.annotation, info.metadata)
            path = f"{where}.{name}" if where else name
            keys.append(Key(path, model.__name__, name, kind, _default(info), "; ".join(bounds)))
        sections.append((where, _tag(model), model, keys))
        for name, info in model.model_fields.items():
            path = f"{where}.{name}" if where else name
            below = {"list": ".N", "dict": ".NAME", "model": ""}[_container(info.annotation)]
            if name == "uncertain" or name == "parameters":
                below = ".KEY"
            for sub in _models(info.annotation):
                visit(sub, path + below)

    visit(root, "")
    return sections


def meanings(path: Path = KEYS_FILE) -> dict[str, dict[str, str]]:
    """``scenario_keys.toml``: the meaning (with units) of each field, by model name."""
    return tomllib.loads(path.read_text(encoding="utf-8"))


def check_coverage(sections: list[tuple[str, str, type[BaseModel], list[Key]]],
                   text: dict[str, dict[str, str]]) -> None:
    """Raise ``Undocumented`` naming every field without a meaning and every entry without a field."""
    fields = {(key.model, key.field) for _, _, _, keys in sections for key in keys}
    written = {(model, field) for model, table in text.items() for field, value in table.items()
               if isinstance(value, str) and value.strip()}
    missing = sorted(fields - written)
    stale = sorted({(m, f) for m, table in text.items() for f in table} - fields)
    lines = ([f"{m}.{f}: a scenario key without a meaning in {KEYS_FILE.name}" for m, f in missing]
             + [f"{m}.{f}: in {KEYS_FILE.name} but not a field of the schema" for m, f in stale])
    if lines:
        raise Undocumented("\n".join(lines))


def _cell(text: str) -> str:
    """Text for a Markdown table cell: pipes escaped, angle brackets outside code not read as HTML."""
    parts = text.replace("|", "\\|").replace("\n", " ").split("`")
    return "`".join(part if i % 2 else part.replace("<", "&lt;") for i, part in enumerate(parts))


def scenario_reference() -> str:
    """The scenario reference page (Markdown): one table per model, every key with its meaning,
    type, default and allowed range."""
    sections = schema_keys()
    text = meanings()
    check_coverage(sections, text)
    out = ["# Scenario keys", "",
           "Generated from the schema (`vines_stoch.scenario`) at every build: the type, default and",
           "range of each key are the code's own. Numbers are bounded by 1e15 in magnitude and masses are",
           "at least 1e-15 (see [Scenario files](../guide/scenarios.md)). `N` is a list index (from 0),",
           "`NAME` a name you choose, `KEY` a dotted key of the file. Units: any consistent set, except",
           "where a key names its own (rad/s, Hz, m, m/s, g); see [Units](../guide/scenarios.md#units).", ""]
    for where, tag, model, keys in sections:
        title = where or "top level"
        out += [f"## `{title}`" + (f" with `{tag}`" if tag else ""), ""]
        doc = _sources(_plain(model.__doc__ or ""))
        if doc:
            out += [doc, ""]
        out += ["| key | meaning | type | default | allowed |", "| --- | --- | --- | --- | --- |"]
        for key in keys:
            out.append(f"| `{key.path}` | {_cell(text[key.model][key.field])} | {key.type} | "
                       f"{key.default} | {_cell(key.allowed) or '-'} |")
        out.append("")
    return "\n".join(out)


def cli_parameters(command: Any) -> list[Any]:
    """The parameters of a command a user can give (``--help`` left out)."""
    return [p for p in command.params if p.name != "help"]


def cli_commands() -> tuple[Any, dict[str, Any]]:
    """The command group typer builds from ``vines_stoch.cli.app`` and its commands by name."""
    import typer

    from vines_stoch.cli import app

    group = typer.main.get_command(app)
    return group, dict(group.commands)


def _range(param: Any) -> str:
    low, high = getattr(param, "min", None), getattr(param, "max", None)
    if low is None and high is None:
        return ""
    return f" ({'' if low is None else f'{low} <= '}x{'' if high is None else f' <= {high}'})"


def cli_reference() -> str:
    """The command-line reference page (Markdown): every command with its usage, help and each
    argument and option (type, default, help)."""
    group, commands = cli_commands()
    out = ["# Command line", "",
           "Generated from the commands themselves (`vines_stoch/cli.py`) at every build.", "",
           _plain(group.help or ""), "", "```text", f"vines-stoch {{{','.join(commands)}}} ...", "```", "",
           "Mistakes in the input end in one `error: ...` line and exit status 2; an interrupted run in exit "
           "status 130; an unexpected exception (a bug) in one `error: internal error ...` line and exit "
           "status 3 (`VINES_STOCH_TRACEBACK=1` shows its traceback).", ""]
    for name, command in commands.items():
        usage = " ".join(["vines-stoch", name, "[OPTIONS]"]
                         + [(p.name or "").upper() + ("..." if p.nargs == -1 else "")
                            for p in cli_parameters(command) if p.param_type_name == "argument"])
        out += [f"## `vines-stoch {name}`", "", "```text", usage, "```", "", _plain(command.help or ""), "",
                "| argument or option | type | default | meaning |", "| --- | --- | --- | --- |"]
        for param in cli_parameters(command):
            flag = bool(getattr(param, "is_flag", False))
            if param.param_type_name == "option":
                names = ", ".join(param.opts + param.secondary_opts)
            else:
                names = (param.name or "").upper()
            default = ("required" if param.required else "off" if flag and not param.default
                       else "none" if param.default is None else f"`{param.default}`")
            kind = "flag" if flag else param.bare_type() + _range(param)
            many = " (repeatable)" if getattr(param, "multiple", False) or param.nargs == -1 else ""
            out.append(f"| `{names}` | {kind}{many} | {default} | {_cell(_plain(param.help or ''))} |")
        out.append("")
    return "\n".join(out)


def _plain(text: str) -> str:
    """Help text as one paragraph, reST double back-quotes as Markdown code."""
    return re.sub(r"``([^`]+)``", r"`\1`", " ".join(text.split()))


def _sources(text: str) -> str:
    """A docstring's references to the project's contracts as links to their pages here."""
    text = text.replace(" (SCENARIOS.md)", "").replace("SCENARIOS.md", "the scenario reference")
    return re.sub(r"MODEL\.md(?: sections?)?", "[the model](../model.md), section", text).replace(
        "section,", "sections").replace("section)", ")")


def write_pages(source: Path) -> list[Path]:
    """Write both generated pages under the documentation's source folder; return their paths."""
    written = []
    for page, text in ((SCENARIO_PAGE, scenario_reference()), (CLI_PAGE, cli_reference())):
        path = source / page
        path.parent.mkdir(parents=True, exist_ok=True)
        if not path.exists() or path.read_text(encoding="utf-8") != text:
            path.write_text(text, encoding="utf-8")
        written.append(path)
    return written


def _on_builder_inited(app: Any) -> None:
    write_pages(Path(app.srcdir))


def setup(app: Any) -> dict[str, Any]:
    """Sphinx entry point: the pages are written before the sources are read."""
    app.connect("builder-inited", _on_builder_inited)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
