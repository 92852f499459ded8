"""The study around the paper: its configuration and sweep (:mod:`.config`, no Drake), a sweep
point's method keys, seed key and variant (:mod:`.points`), the config schema and its docs
(:mod:`.schema`); and what the study does with a recorded run beyond Algorithm 1: its policy
redeployed (:mod:`.redeployment`, with what its file records, :mod:`.redeployment_record`), its
rollouts replayed at another setting (:mod:`.replay`). May import every subpackage below it:
:mod:`pih.planning`, :mod:`pih.validation`, :mod:`pih.records`, :mod:`pih.scene`,
:mod:`pih.whitney`, :mod:`pih.config`."""
