"""Whitney's quasi-static insertion theory (§2.3, docs/whitney.md): the benchmark for the
simulated contact forces. Owns :mod:`pih.whitney.theory` (phases, forces, curves) and
:mod:`pih.whitney.jamming` (the jamming diagram). Imports nothing of ``pih`` outside it."""
