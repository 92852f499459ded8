"""The study around the paper, as defined before anything runs: its configuration and sweep
(:mod:`.config`, no Drake), a sweep point's method keys, seed key and variant (:mod:`.points`),
the config schema and its docs (:mod:`.schema`), and a recorded run's redeployment under model
error (:mod:`.redeployment`). May import every subpackage below it: :mod:`pih.planning`,
:mod:`pih.validation`, :mod:`pih.records`, :mod:`pih.scene`, :mod:`pih.whitney`,
:mod:`pih.config`."""
