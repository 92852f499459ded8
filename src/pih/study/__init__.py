"""The study around the paper: its configuration, sweep points and seeds (:mod:`.config`, no
Drake), redeployments (:mod:`.redeployment`), aggregation over runs (:mod:`.aggregate`,
:mod:`.pooling`), tables, figures and recordings (:mod:`.summary`, :mod:`.planning_summary`,
:mod:`.plots`, :mod:`.recordings`), and the published studies (:mod:`.published`,
:mod:`.compare`). May import every subpackage below it: :mod:`pih.planning`,
:mod:`pih.validation`, :mod:`pih.records`, :mod:`pih.scene`, :mod:`pih.whitney`,
:mod:`pih.config`."""
