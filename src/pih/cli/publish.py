"""``pih publish [RESULTS]``: a finished study copied into ``published/``, its results block
(in README, or in the study's docs page) remade."""

from __future__ import annotations

import sys
from pathlib import Path

from pih.cli.common import first_line


def publish(results: Path, name: str) -> int:
    """Copy ``results`` into ``published/<name>`` and regenerate the study's results block."""
    from pih.publishing.published import (
        PUBLISHED_STUDIES,
        publish,
        publish_part,
        readme_with_results,
        results_block,
    )

    study = PUBLISHED_STUDIES[name]
    page = Path(study.page)
    if not page.is_file():
        print(f"pih publish: run it from the repository's root (no {page} here)", file=sys.stderr)
        return 1
    if study.markers[0] not in page.read_text():
        print(f"pih publish: {page} has no {study.markers[0]} line", file=sys.stderr)
        return 1
    try:
        if study.in_parts:
            part = publish_part(results, study)
            copied = (
                f"{part.added} runs added from {results} ({part.unfinished} left out, their "
                f"redeployments unfinished), {part.missing} still to come"
            )
        else:
            copied = f"{publish(results, study)} files from {results}"
    except (OSError, ValueError) as error:
        print(f"pih publish: {first_line(error)}", file=sys.stderr)
        return 1
    block = results_block(study.directory, study)
    page.write_text(readme_with_results(page.read_text(), block, study))
    print(f"{study.directory}: {copied}; {page}'s results for it")
    return 0
