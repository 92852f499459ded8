"""``pih verify [STUDY_DIR ...]``: today's code computes what made the published runs
(:mod:`pih.publishing.verification`)."""

from __future__ import annotations

import signal
import sys
import time
from pathlib import Path

from pih.cli.common import first_line


def stop_on_signals() -> dict[int, object]:
    """Make SIGTERM and SIGHUP end ``pih verify`` cleanly: every child still running (each
    version's ``snakemake``, with its jobs) is ended and the stack unwinds, which removes the
    scratch directory. Returns the handlers it replaced."""
    from pih.publishing.verification import end_children

    def stop(number: int, frame: object) -> None:
        end_children(number)
        raise SystemExit(128 + number)

    return {number: signal.signal(number, stop) for number in (signal.SIGTERM, signal.SIGHUP)}


def verify(directories: list[Path], stop_at_difference: bool = False) -> int:
    """Print one line per suite item; 0 when the published runs are current or were verified
    (a row added to the equivalence record), 1 when an output differs or the input is bad."""
    from pih.publishing.equivalence import RECORD, REPOSITORY
    from pih.publishing.published import PUBLISHED_STUDIES
    from pih.publishing.verification import Study
    from pih.publishing.verification import verify as run

    started = time.monotonic()
    published = [
        Study(REPOSITORY / s.directory, s.config_files)
        for s in PUBLISHED_STUDIES.values()
        if (REPOSITORY / s.directory).is_dir()
    ]
    studies = []
    for directory in directories or [study.directory for study in published]:
        study = PUBLISHED_STUDIES.get(Path(directory).resolve().name)
        if study is None or not Path(directory).is_dir():
            names = ", ".join(f"published/{name}" for name in PUBLISHED_STUDIES)
            print(f"pih verify: {directory}: not a published study ({names})", file=sys.stderr)
            return 1
        studies.append(Study(Path(directory).resolve(), study.config_files))
    replaced = stop_on_signals()
    try:
        # The suite is every published study's: a row makes every run at its hash current.
        verifications = run(
            studies,
            REPOSITORY,
            RECORD,
            lambda line: print(line, flush=True),
            published,
            stop_at_difference,
        )
    except (OSError, ValueError, LookupError, RuntimeError) as error:
        print(f"pih verify: {first_line(error)}", file=sys.stderr)
        return 1
    finally:
        for number, handler in replaced.items():
            signal.signal(number, handler)
    minutes = (time.monotonic() - started) / 60
    differences = [d for v in verifications for d in v.differences]
    if differences:
        print(f"pih verify: NOT equivalent, nothing recorded: {differences[0]}", file=sys.stderr)
        return 1
    for v in verifications:
        print(
            f"verified: {v.from_hash[:12]} ({v.from_commit}) -> {v.to_hash[:12]}, recorded in {RECORD.name}"
        )
    print(f"pih verify: {minutes:.1f} min")
    return 0
