"""What a study's runs say, read from their files: per-run tables (:mod:`.run_summary`), runs
pooled across studies (:mod:`.pooling`), rates, intervals and sign tests over runs
(:mod:`.statistics`, :mod:`.aggregate`), deployment success at two time steps
(:mod:`.time_step`), the planner's and the validation's summaries (:mod:`.planning_summary`,
:mod:`.summary`) and figures (:mod:`.plots`). No Drake. May import :mod:`pih.study` and
everything below it."""
