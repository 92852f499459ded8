"""What every subcommand shares: one-line errors, output paths that must exist."""

from __future__ import annotations

import sys
from pathlib import Path


def first_line(error: Exception) -> str:
    """An error's first line (its type's name when it has no message)."""
    return str(error).splitlines()[0] if str(error) else type(error).__name__


def missing_parent(command: str, option: str, output: Path | None) -> bool:
    """Whether ``output``'s directory is missing (said on stderr): a CLI writes only into an
    existing directory."""
    if output is None or output.parent.is_dir():
        return False
    print(f"pih {command}: {option} {output}: no directory {output.parent}", file=sys.stderr)
    return True
