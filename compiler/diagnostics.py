"""Diagnostics: every message the compiler gives about its input, with file, line and element.

A `Diagnostic` formats the way compilers do, so editors can jump to it::

    scenes/eggs.xml:42: error: <radius>: expected 1 number, got 'abc'

`Diagnostics` collects them while the scene is read and written; the first error does not stop
the reader, so one run reports every problem it can.  `CompileError` carries the collected list
out of the public API when at least one of them is an error.
"""
from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import Iterator, Optional


class Severity(enum.Enum):
    WARNING = "warning"
    ERROR = "error"


@dataclass(frozen=True)
class Diagnostic:
    """One message about the input.  `line` is 1-based (None when the message concerns the file as
    a whole); `element` is the XML element's tag (None for file-level messages)."""

    severity: Severity
    message: str
    file: str
    line: Optional[int] = None
    element: Optional[str] = None

    @property
    def is_error(self) -> bool:
        return self.severity is Severity.ERROR

    def __str__(self) -> str:
        where = self.file if self.line is None else f"{self.file}:{self.line}"
        what = f"<{self.element}>: " if self.element else ""
        return f"{where}: {self.severity.value}: {what}{self.message}"


class CompileError(Exception):
    """The input cannot be compiled; `diagnostics` holds every message (errors and warnings)."""

    def __init__(self, diagnostics: list[Diagnostic]):
        self.diagnostics = list(diagnostics)
        super().__init__("\n".join(str(d) for d in self.diagnostics if d.is_error))


class Diagnostics:
    """An ordered collection of diagnostics for one input file."""

    def __init__(self, file: str):
        self.file = file
        self._items: list[Diagnostic] = []

    def warning(self, message: str, line: Optional[int] = None, element: Optional[str] = None) -> None:
        self._items.append(Diagnostic(Severity.WARNING, message, self.file, line, element))

    def error(self, message: str, line: Optional[int] = None, element: Optional[str] = None) -> None:
        self._items.append(Diagnostic(Severity.ERROR, message, self.file, line, element))

    def at(self, node) -> "_At":
        """Helper bound to an lxml element: ``diags.at(el).error("...")``."""
        return _At(self, node.sourceline, _local_name(node.tag))

    @property
    def has_errors(self) -> bool:
        return any(d.is_error for d in self._items)

    def raise_if_errors(self) -> None:
        if self.has_errors:
            raise CompileError(self._items)

    def __iter__(self) -> Iterator[Diagnostic]:
        return iter(self._items)

    def __len__(self) -> int:
        return len(self._items)

    def as_list(self) -> list[Diagnostic]:
        return list(self._items)


@dataclass(frozen=True)
class _At:
    diags: Diagnostics
    line: Optional[int]
    element: str

    def warning(self, message: str) -> None:
        self.diags.warning(message, self.line, self.element)

    def error(self, message: str) -> None:
        self.diags.error(message, self.line, self.element)


def _local_name(tag) -> str:
    return tag.rsplit("}", 1)[-1] if isinstance(tag, str) else str(tag)
