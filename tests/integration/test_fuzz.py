"""Property-based fuzzing of scenario files through the command line's entry point.

Mutations of the example scenarios (types, magnitudes, special floats, deletions,
duplications, truncations, encodings) are validated in-process; the property: exit status 2
with an ``error:`` line that names the file (and, for a mutated value, its key), or a clean
``ok``; never a traceback or an internal error.
"""

from __future__ import annotations

import re

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tests.helpers import ROOT, cli

SCENARIOS = ROOT / "scenarios"
EXAMPLES = sorted(p for p in SCENARIOS.glob("*.toml") if p.name != "elcentro.toml")
NAMED = re.compile(r"( \(sweep point [^)]*\))?: [A-Za-z_][\w.]*( = |: )")
ASSIGNMENT = re.compile(r"^(\s*)([A-Za-z_][A-Za-z0-9_]*)(\s*=\s*)(.+)$")

#: Replacement values: other types, magnitudes, special floats, sizes.
VALUES = ['"1.0"', "true", "false", "1.5", "0", "-1", "-1.0", "0.0", "1e308", "-1e308", "1e-300", "1e15",
          "1e16", "nan", "inf", "-inf", "9223372036854775808", "[]", "[1.0, 2.0]", "{}", "{ a = 1 }", '""',
          '"x"', "[[[[[[[[[[[[[[1]]]]]]]]]]]]]]", "1979-05-27", "100000000000", "2.5e9",
          '"../../x"', '"/srv/x"', '"a\\u0000b"', '"a\\tb\\u0007"', "{ logspace = [1.0, 1e300, 3] }"]


def mutate(text: str, kind: str, line: int, value: str, cut: float) -> tuple[bytes, str | None]:
    """One mutation of scenario text: the bytes to write and the key it touched (if any)."""
    lines = text.splitlines()
    assignments = [i for i, text_line in enumerate(lines) if ASSIGNMENT.match(text_line)]
    i = assignments[line % len(assignments)]
    m = ASSIGNMENT.match(lines[i])
    key = m.group(2)
    if kind == "value":
        lines[i] = f"{m.group(1)}{key}{m.group(3)}{value}"
    elif kind == "delete":
        del lines[i]
    elif kind == "duplicate":
        lines.insert(i, lines[i])
    elif kind == "truncate":
        return text[:int(cut * len(text))].encode(), None
    elif kind in ("utf-16", "latin-1"):
        return (text.replace('"', '"\u00e9', 1) if kind == "latin-1" else text).encode(kind), None
    return ("\n".join(lines) + "\n").encode(), key if kind == "value" else None


@settings(max_examples=600, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(example=st.sampled_from(EXAMPLES),
       kind=st.sampled_from(["value"] * 6 + ["delete", "duplicate", "truncate", "utf-16", "latin-1"]),
       line=st.integers(0, 10_000), value=st.sampled_from(VALUES), cut=st.floats(0.0, 1.0))
def test_mutated_scenarios_end_in_a_clear_error_or_ok(tmp_path_factory, example, kind, line, value, cut):
    folder = tmp_path_factory.mktemp("fuzz")
    (folder / "records").symlink_to(SCENARIOS / "records")
    data, key = mutate(example.read_text(), kind, line, value, cut)
    path = folder / example.name
    path.write_bytes(data)
    code, err = cli("validate", path)
    assert code in (0, 2), err
    if code == 2:
        assert err.startswith("error: ") and "Traceback" not in err, err
        assert str(path) in err, err
        rest = err[len(f"error: {path}"):]
        if key is not None and "TOML syntax error" not in rest and not rest.startswith(": line "):
            assert NAMED.match(rest), err  # a dotted key named, with its value where it has one
