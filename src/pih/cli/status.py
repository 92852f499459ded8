"""``pih status [DIR]``: a study's progress and the time left."""

from __future__ import annotations

import sys
from pathlib import Path

from pih.cli.show import did_you_mean


def status(study: Path, configfiles: list[str], jobs: int | None) -> int:
    """One progress line per kind of run of the study in ``study`` (:mod:`pih.workflow.status`). Its
    config: ``config/config.yaml`` (here, else in ``study``, else in pih's checkout) with
    ``configfiles`` merged on; without ``configfiles``, those of the latest Snakemake run in
    ``study`` (its log in ``.snakemake/log/``), else the default config alone."""
    from pih.workflow.status import logged_configfiles, study_status

    if not study.is_dir():
        print(f"pih status: no such directory: {study}{did_you_mean(study)}", file=sys.stderr)
        return 1
    # Without --configfile: the config files of the latest Snakemake run there. A study run in
    # its own directory (snakemake -s REPO/Snakefile) has the default config in pih's checkout.
    files = None if configfiles else logged_configfiles(study)
    if files is None:
        checkout = Path(__file__).resolve().parents[3]
        places = [Path("config"), study / "config", checkout / "config"]
        default = next((p / "config.yaml" for p in places if (p / "config.yaml").is_file()), None)
        if default is None:
            raise FileNotFoundError(
                "no config/config.yaml here, in the study directory or in pih's checkout; run "
                "pih status in the workflow's directory (pih status STUDY_DIR --configfile ...)"
            )
        files = [str(default), *configfiles]
    for line in study_status(study, files, jobs):
        print(line)
    return 0
