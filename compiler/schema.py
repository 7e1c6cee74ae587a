"""The scene XSD (schemas/scene.xsd): what is known, and validation with file:line messages.

The course parsers ignore unknown elements and attributes (spec Q15).  rtc reports each one as a
warning with its line and removes it before validating, so the schema can stay closed (every
declared element checked) while unknown input never becomes an error.  The table of known
elements and attributes is read from the XSD itself, so the schema is the single source of truth.
"""
from __future__ import annotations

import functools
import re
from dataclasses import dataclass, field
from pathlib import Path

from lxml import etree

from .diagnostics import Diagnostics

XSD_PATH = Path(__file__).resolve().parents[1] / "schemas" / "scene.xsd"
_XS = "{http://www.w3.org/2001/XMLSchema}"


@dataclass
class _Node:
    """What one element may contain: child elements (name -> node), attributes, and whether it
    holds text (simple content) or only elements."""

    children: dict[str, "_Node"] = field(default_factory=dict)
    attributes: set[str] = field(default_factory=set)
    has_text: bool = False


@functools.lru_cache(maxsize=1)
def _schema() -> tuple[etree.XMLSchema, _Node]:
    doc = etree.parse(str(XSD_PATH))
    return etree.XMLSchema(doc), _KnownTable(doc.getroot()).root()


class _KnownTable:
    """Walks the subset of XSD used by scene.xsd: global element, named/anonymous complex types,
    choice/sequence, group refs, simpleContent extensions, attributes."""

    def __init__(self, xsd_root):
        self.types = {e.get("name"): e for e in xsd_root.iter(_XS + "complexType") if e.get("name")}
        self.groups = {e.get("name"): e for e in xsd_root.iter(_XS + "group") if e.get("name")}
        self.top = {e.get("name"): e for e in xsd_root.findall(_XS + "element")}
        self._memo: dict[str, _Node] = {}

    def root(self) -> _Node:
        return _Node(children={name: self._element(e) for name, e in self.top.items()})

    def _element(self, el) -> _Node:
        type_name = el.get("type")
        if type_name in self.types:
            if type_name not in self._memo:
                self._memo[type_name] = self._complex(self.types[type_name])
            return self._memo[type_name]
        inline = el.find(_XS + "complexType")
        return self._complex(inline) if inline is not None else _Node(has_text=True)

    def _complex(self, ct) -> _Node:
        node = _Node()
        self._collect(ct, node)
        return node

    def _collect(self, parent, node: _Node) -> None:
        for child in parent:
            tag = child.tag
            if tag == _XS + "element":
                node.children[child.get("name")] = self._element(child)
            elif tag == _XS + "attribute":
                node.attributes.add(child.get("name"))
            elif tag == _XS + "group" and child.get("ref"):
                self._collect(self.groups[child.get("ref")], node)
            elif tag == _XS + "simpleContent":
                node.has_text = True
                self._collect(child, node)
            elif tag in (_XS + "choice", _XS + "sequence", _XS + "all", _XS + "extension", _XS + "group"):
                self._collect(child, node)


def is_valid(tree) -> bool:
    """True if the tree validates against scene.xsd as it is.  The schema is closed (no `xs:any`,
    no `anyAttribute`, no mixed content), so a valid tree has no unknown element or attribute and
    no stray text: `remove_unknown` would find nothing, and reading can skip its Python walk over
    every element (most of the time of a schema check for 10^5 placements)."""
    return _schema()[0].validate(tree)


def remove_unknown(root, diags: Diagnostics) -> None:
    """Warn about and remove undeclared elements and attributes, and stray text in element-only
    content (such as the `-->` of an unterminated comment, Q9).  The root must be `<scene>`."""
    _, known = _schema()
    _prune(root, known.children[root.tag], diags)


def _prune(el, node: _Node, diags: Diagnostics) -> None:
    unknown = [a for a in el.attrib if a not in node.attributes]
    for name in unknown:
        diags.at(el).warning(f"unknown attribute '{name}' ignored")
        del el.attrib[name]
    if not node.has_text and el.text and not el.text.isspace():
        diags.at(el).warning(f"stray text {_short(el.text)} ignored")
        el.text = None
    for child in list(el):
        if not isinstance(child.tag, str):          # comments and processing instructions
            el.remove(child)
            continue
        sub = node.children.get(child.tag)
        if sub is None:
            diags.at(child).warning(f"unknown element ignored (not allowed inside <{el.tag}>)")
            el.remove(child)
            continue
        if not node.has_text and child.tail and not child.tail.isspace():
            diags.warning(f"stray text {_short(child.tail)} ignored (an unterminated comment?)",
                          _tail_line(child), el.tag)
            child.tail = None
        _prune(child, sub, diags)


def _tail_line(child) -> int:
    """Line where the first non-blank character of an element's tail text is."""
    end = child.sourceline + etree.tostring(child, with_tail=False).count(b"\n")
    return end + child.tail[: len(child.tail) - len(child.tail.lstrip())].count("\n")


def _short(text: str) -> str:
    text = " ".join(text.split())
    return repr(text if len(text) <= 40 else text[:37] + "...")


_PREFIX = re.compile(r"^Element '([^']+)'(?:, attribute '([^']+)')?: ")
_REWRITES = [
    (re.compile(r"\[facet 'enumeration'\] The value '([^']*)' is not an element of the set \{(.*)\}\.?"),
     lambda m: f"'{m.group(1)}' is not one of {m.group(2)}"),
    (re.compile(r"The attribute '([^']+)' is required but missing\.?"),
     lambda m: f"missing required attribute '{m.group(1)}'"),
    (re.compile(r"\[facet 'minLength'\] The value '' has a length of '0'.*"),
     lambda m: "must not be empty"),
    (re.compile(r"This element is not expected\..*"),
     lambda m: "element not allowed here"),
]


def validate(tree, diags: Diagnostics) -> None:
    """Validate against scene.xsd, one error per schema violation, with line and element."""
    xsd, _ = _schema()
    if xsd.validate(tree):
        return
    for entry in xsd.error_log:
        message = entry.message
        element, attribute = None, None
        prefix = _PREFIX.match(message)
        if prefix:
            element, attribute = prefix.groups()
            message = message[prefix.end():]
        for pattern, rewrite in _REWRITES:
            hit = pattern.match(message)
            if hit:
                message = rewrite(hit)
                break
        if attribute:
            message = f"attribute '{attribute}': {message}"
        diags.error(message.rstrip("."), entry.line, element)
