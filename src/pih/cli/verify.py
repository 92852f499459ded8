"""``pih verify [STUDY_DIR ...]``: today's code computes what made the published runs
(:mod:`pih.publishing.verification`)."""

from __future__ import annotations

import sys
import time
from pathlib import Path

from pih.cli.common import first_line


def verify(directories: list[Path]) -> int:
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
    try:
        # The suite is every published study's: a row makes every run at its hash current.
        verifications = run(
            studies, REPOSITORY, RECORD, lambda line: print(line, flush=True), published
        )
    except (OSError, ValueError, LookupError, RuntimeError) as error:
        print(f"pih verify: {first_line(error)}", file=sys.stderr)
        return 1
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
