"""The planner (§3, Algorithm 1, Appendix B): the DMP (:mod:`.dmp`), the optimizers
(:mod:`.optimizers`), the planner's configuration (:mod:`.config`, no Drake), the inner cost
(:mod:`.costs`), bilevel's outer level (:mod:`.outer`), the run record (:mod:`.run_record`, no
Drake) and Algorithm 1 itself (:mod:`.planner`). May import :mod:`pih.config`, :mod:`pih.scene`
and :mod:`pih.records`."""
