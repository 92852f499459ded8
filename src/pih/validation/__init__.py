"""The validation against Whitney (§2.4): the straight-down insertion experiment's configuration
and deeper-hole scene (:mod:`.config`, no Drake) and the experiment, its alignment, Pearson r and
Table 2 errors (:mod:`.experiment`). May import :mod:`pih.config`, :mod:`pih.whitney`,
:mod:`pih.scene` and :mod:`pih.records`."""
