"""``pih publish [RESULTS]``: a finished study copied into ``published/``, its results block
(in README, or in the study's docs page) remade."""

from __future__ import annotations

import sys
from pathlib import Path

from pih.cli.common import first_line


def publish(results: Path, name: str) -> int:
    """Copy ``results`` into ``published/<name>`` and regenerate the study's results block."""
    from pih.publishing.pages import write_results
    from pih.publishing.published import PUBLISHED_STUDIES, publish, publish_part

    study = PUBLISHED_STUDIES[name]
    page = Path(study.page)
    if not _page_ready(page, study.markers[0]):
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
    write_results(study)
    print(f"{study.directory}: {copied}; {page}'s results for it")
    return 0


def redeploy_published(name: str, limit: int | None, workers: int) -> int:
    """Make the published study's missing redeployments, at most ``limit``; once all are in,
    its tables are re-made and its results block regenerated."""
    from pih.publishing.pages import write_results
    from pih.publishing.published import PUBLISHED_STUDIES
    from pih.publishing.redeploy import redeploy_published

    study = PUBLISHED_STUDIES[name]
    if not _page_ready(Path(study.page), study.markers[0]):
        return 1
    if (limit is not None and limit < 1) or workers < 1:
        print("pih publish: --limit and --workers: expected at least 1", file=sys.stderr)
        return 1
    try:
        done = redeploy_published(study, workers=workers, limit=limit)
    except (OSError, ValueError) as error:
        print(f"pih publish: {first_line(error)}", file=sys.stderr)
        return 1
    if done.tables:
        write_results(study)
    tables = "its tables re-made" if done.tables else "the tables once all are in"
    print(f"{study.directory}: {done.made} redeployments made, {done.left} still to make; {tables}")
    return 0


def replay_published(name: str, step_s: float, limit: int | None, workers: int) -> int:
    """Replay the published study's deployment trials at ``step_s``, at most ``limit`` runs;
    once all are in, its tables are re-made and its results block regenerated."""
    from pih.publishing.pages import write_results
    from pih.publishing.published import PUBLISHED_STUDIES
    from pih.publishing.reference_step import replay_published

    study = PUBLISHED_STUDIES[name]
    if not _page_ready(Path(study.page), study.markers[0]):
        return 1
    if (limit is not None and limit < 1) or workers < 1:
        print("pih publish: --limit and --workers: expected at least 1", file=sys.stderr)
        return 1
    if not 0 < step_s <= 2e-3:
        print(
            f"pih publish: --replay-step {step_s:g}: expected a step in (0, 0.002] s",
            file=sys.stderr,
        )
        return 1
    try:
        done = replay_published(study, step_s, workers=workers, limit=limit)
    except (OSError, ValueError) as error:
        print(f"pih publish: {first_line(error)}", file=sys.stderr)
        return 1
    if done.tables:
        write_results(study)
    tables = "its tables re-made" if done.tables else "the tables once all are in"
    print(
        f"{study.directory}: {done.made} runs replayed at {step_s:g} s, {done.left} still to go; "
        f"{tables}"
    )
    return 0


def _page_ready(page: Path, marker: str) -> bool:
    """Whether the study's results page is here (the repository's root) and has its block."""
    if not page.is_file():
        print(f"pih publish: run it from the repository's root (no {page} here)", file=sys.stderr)
        return False
    if marker not in page.read_text():
        print(f"pih publish: {page} has no {marker} line", file=sys.stderr)
        return False
    return True
