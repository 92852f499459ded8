"""Whitney's quasi-static insertion theory (§2.3, docs/whitney.md): the benchmark for the
simulated contact forces. Owns :mod:`pih.whitney.theory` (phases, forces, curves),
:mod:`pih.whitney.jamming` (the jamming diagram) and :mod:`pih.whitney.frame` (his signs in the
world). Imports nothing of ``pih`` outside it."""
