"""The `.usda` text of instance placements, written directly instead of through Sdf specs.

A placement is always the same few lines (an instanceable Xform, a reference, its xformOps, an
optional material binding), and a scene can have 10^5 of them.  Authoring them as Sdf specs costs
~12 us per attribute spec plus the export (benchmarks/RESULTS.md, Compiler); formatting their text
costs a few microseconds.  For a text output the writer therefore leaves `/World/Instances`
empty in the layer, and `splice` puts the formatted children into the layer's exported text.

The text is byte-identical to what Sdf writes for the same specs (tests/compiler/
test_placements_text.py compares both paths on every gallery and course scene and on random
transform chains): property order is USD's dictionary order, numbers use USD's shortest
round-trip formatting.  Animated placements (time samples) are not handled here; `eligible` says
when the fast path applies, and the writer uses Sdf otherwise.
"""
from __future__ import annotations

import math
import re
from decimal import Decimal
from typing import Callable, Iterable

from .scene import Placement

#: The empty scope the writer leaves in the layer, as Sdf exports it (a child of /World).
EMPTY_SCOPE = '    def Scope "Instances"\n    {\n    }\n'
_INDENT = "        "


def eligible(placements: Iterable[Placement]) -> bool:
    """True when every placement is static (one sample, no time code), which is what the text
    path writes."""
    return all(not p.motion.is_animated for p in placements)


def usd_double(x: float) -> str:
    """A double as USD's text format writes it: the shortest digits that round-trip (as Python's
    repr), in positional notation for decimal exponents -6..14, otherwise `<digits>e<exp>`
    without a '+' or leading zeros; integral values without '.0'; -0.0 as '-0'."""
    x = float(x)
    a = abs(x)
    if 1e-4 <= a < 1e15:                    # repr is positional here too: only drop a '.0'
        r = repr(x)
        return r[:-2] if r.endswith(".0") else r
    if a == 0.0:
        return "-0" if math.copysign(1.0, x) < 0 else "0"
    sign, digits, exponent = Decimal(repr(x)).normalize().as_tuple()
    digits = "".join(map(str, digits))
    sci = len(digits) + exponent - 1       # x = d.ddd * 10^sci
    head = "-" if sign else ""
    if -6 <= sci < 15:
        if exponent >= 0:
            return head + digits + "0" * exponent
        point = len(digits) + exponent
        if point > 0:
            return head + digits[:point] + "." + digits[point:]
        return head + "0." + "0" * (-point) + digits
    mantissa = digits[0] + ("." + digits[1:] if len(digits) > 1 else "")
    return f"{head}{mantissa}e{sci}"


def _dictionary_key(name: str):
    """USD's property order (TfDictionaryLessThan) for the names written here: case-insensitive,
    digit runs compared as numbers."""
    return [int(part) if part.isdigit() else part.lower() for part in re.split(r"(\d+)", name)]


def _value_text(kind: str, value) -> str:
    if kind in ("translate", "scale"):
        return f"({usd_double(value[0])}, {usd_double(value[1])}, {usd_double(value[2])})"
    return usd_double(value)


def placements_text(placements: list[Placement], name_of: Callable[[Placement], str],
                    prototype_path: Callable[[Placement], str], op_plan: Callable) -> str:
    """The children of /World/Instances, in order, as Sdf would export them.

    `name_of` gives each placement's unique prim name, `prototype_path` the path its reference
    targets (a placement's shader is its prototype's: `usd_writer.prototypes_per_shader`), and
    `op_plan` the xformOp names and USD value types of a sequence of operation kinds (the writer's own
    `_op_plan`, so both paths name ops identically)."""
    out = []
    layouts: dict[tuple[str, ...], tuple] = {}
    for p in placements:
        name = name_of(p)
        samples = p.motion.samples
        ops = samples[0].ops if samples else ()
        kinds = tuple([op.kind for op in ops])
        layout = layouts.get(kinds)
        if layout is None:
            layout = layouts[kinds] = _layout(kinds, op_plan)
        names, types, order_line, sort_index = layout
        lines = [f"{_INDENT}def Xform \"{name}\" (\n"]
        lines.append(f"{_INDENT}    instanceable = true\n"
                     f"{_INDENT}    prepend references = <{prototype_path(p)}>\n"
                     f"{_INDENT})\n{_INDENT}{{\n")
        for k in sort_index:
            lines.append(f"{_INDENT}    {types[k]} {names[k]} = {_value_text(kinds[k], ops[k].value)}\n")
        if order_line:
            lines.append(order_line)
        lines.append(f"{_INDENT}}}\n")
        out.append("".join(lines))
    return "\n".join(out)


def _layout(kinds: tuple[str, ...], op_plan: Callable) -> tuple:
    if not kinds:
        return (), (), "", ()
    names, types = op_plan(kinds)
    type_text = tuple(str(t) for t in types)
    order = ", ".join(f'"{n}"' for n in names)
    order_line = f"{_INDENT}    uniform token[] xformOpOrder = [{order}]\n"
    sort_index = tuple(sorted(range(len(names)), key=lambda k: _dictionary_key(names[k])))
    return names, type_text, order_line, sort_index


def splice(layer_text: str, children: str) -> str:
    """Put `children` into the layer text's empty /World/Instances scope."""
    if layer_text.count(EMPTY_SCOPE) != 1:
        raise ValueError("the exported layer has no single empty /World/Instances scope")
    filled = f'    def Scope "Instances"\n    {{\n{children}    }}\n'
    return layer_text.replace(EMPTY_SCOPE, filled)
