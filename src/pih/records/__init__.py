"""Outputs and provenance: the provenance record of every output, the behaviour hash of the
rollout code and the machine (:mod:`.provenance`), and Parquet, Markdown and figure files written
atomically with units and provenance (:mod:`.outputs`), and Rerun recordings of a rollout or a
planning run (:mod:`.recordings`). May import :mod:`pih.config`, :mod:`pih.whitney` and
:mod:`pih.scene` (the trace it writes); no Drake."""
