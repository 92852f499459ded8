"""The peg-in-hole scene and its simulation (§2): the scene's configuration and geometry
(:mod:`.config`, no Drake), the frames P, P1, P2 and the spring (:mod:`.frames`), a rollout's
records (:mod:`.trace`, no Drake) and Drake's hydroelastic simulation (:mod:`.simulation`).
May import :mod:`pih.config` and :mod:`pih.whitney`."""
