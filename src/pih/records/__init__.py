"""Outputs and provenance: the provenance record of every output, the behaviour hash of the
rollout code and the machine (:mod:`.provenance`), and Parquet, Markdown and figure files written
atomically with units and provenance (:mod:`.outputs`). May import :mod:`pih.config` and
:mod:`pih.scene` (the trace it writes); no Drake."""
