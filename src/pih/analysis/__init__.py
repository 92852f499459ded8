"""What a study's runs say, read from their files: per-run tables (:mod:`.run_summary`), runs
pooled across studies (:mod:`.pooling`), rates, intervals and sign tests over runs
(:mod:`.statistics`, :mod:`.aggregate`), deployment success at two time steps
(:mod:`.time_step`) and the planner's simulator against reality (:mod:`.training_model`). No
Drake; it writes no file (:mod:`pih.reporting` does). May import :mod:`pih.study` and everything
below it."""
