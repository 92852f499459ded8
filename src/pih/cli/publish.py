"""``pih publish [RESULTS]``: a finished study copied into ``published/``, README's results remade."""

from __future__ import annotations

import sys
from pathlib import Path

from pih.cli.common import first_line


def publish(results: Path, name: str) -> int:
    """Copy ``results`` into ``published/<name>`` and regenerate README's block for it."""
    from pih.study.published import PUBLISHED_STUDIES, publish, readme_with_results, results_block

    study, readme = PUBLISHED_STUDIES[name], Path("README.md")
    if not readme.is_file():
        print("pih publish: run it from the repository's root (no README.md here)", file=sys.stderr)
        return 1
    if study.markers[0] not in readme.read_text():
        print(f"pih publish: README.md has no {study.markers[0]} line", file=sys.stderr)
        return 1
    try:
        copied = publish(results, study)
    except (OSError, ValueError) as error:
        print(f"pih publish: {first_line(error)}", file=sys.stderr)
        return 1
    block = results_block(study.directory, study)
    readme.write_text(readme_with_results(readme.read_text(), block, study))
    print(f"{study.directory}: {copied} files from {results}; README.md's results for it")
    return 0
