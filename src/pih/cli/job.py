"""``pih job TARGET``: a workflow script run in this process, outside Snakemake."""

from __future__ import annotations

import sys
from pathlib import Path

from pih.cli.common import first_line

running_script = False
"""True while ``pih job`` runs a workflow script: its errors keep their tracebacks."""


def job(target: str, configfiles: list[str] | None) -> int:
    """Run the rule's script with the ``snakemake`` object Snakemake would give it."""
    import runpy

    from pih.study.config import load_config_file
    from pih.workflow.jobs import mock_snakemake

    global running_script
    try:
        if not Path("Snakefile").is_file():
            raise ValueError(f"no Snakefile in {Path.cwd()}; run it in the workflow's directory")
        for path in configfiles or []:
            load_config_file(path)  # one line naming a missing, empty or malformed file
        smk, script = mock_snakemake(target, configfiles)
    except ValueError as error:  # a ConfigError too
        print(f"pih job: {first_line(error)}", file=sys.stderr)
        return 1
    except Exception as error:  # noqa: BLE001 - Snakemake's errors: one line
        print(f"pih job: {first_line(error)} ({type(error).__name__})", file=sys.stderr)
        return 1
    missing = [str(path) for path in smk.input if not Path(path).exists()]
    if missing:
        more = f" and {len(missing) - 3} more" if len(missing) > 3 else ""
        print(
            f"pih job: {target}: {len(missing)} input(s) missing ({', '.join(missing[:3])}{more});"
            f" make them first with snakemake (pih job runs one script, not its upstream jobs)",
            file=sys.stderr,
        )
        return 1
    print(f"pih job: {script.name} for {target} (log: {smk.log[0] if smk.log else 'none'})")
    running_script = True
    try:
        runpy.run_path(str(script), init_globals={"snakemake": smk}, run_name="__main__")
    finally:
        running_script = False
    return 0
