"""Exit statuses of the `rtc` commands, and the one way a command fails with a message.

0 success, 1 warnings with --strict, 2 bad input or options (nothing written), 130 interrupted (the
image so far is written)."""
from __future__ import annotations

import sys

import click

EXIT_OK, EXIT_WARNINGS, EXIT_ERROR, EXIT_INTERRUPTED = 0, 1, 2, 130


def fail(message: str, code: int = EXIT_ERROR):
    """Print `rtc: error: MESSAGE` on stderr and exit with `code`."""
    click.echo(f'rtc: error: {message}', err=True)
    sys.exit(code)
