"""The published studies under ``published/``: which runs are current and publishing new ones
(:mod:`.published`), their results on README and the docs pages (:mod:`.pages`), redeployments and reference-step replays made beside published runs
(:mod:`.redeploy`, :mod:`.reference_step`), comparing a tree of results with another
(:mod:`.compare`), and the record of rollout-code equivalence with ``pih verify``, which adds to
it (:mod:`.equivalence`, :mod:`.verification`). May import :mod:`pih.analysis`, :mod:`pih.study`
and everything below them."""
