"""Snakemake logger plugin ``pih`` (``--logger pih``; profiles/default/config.yaml sets it): one
console line per job. The code is :mod:`pih.workflow.console`; Snakemake finds logger plugins by this
package name (``snakemake_logger_plugin_<name>``)."""

from pih.workflow.console import LogHandler, LogHandlerSettings

__all__ = ["LogHandler", "LogHandlerSettings"]
