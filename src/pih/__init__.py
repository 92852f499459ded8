"""pih: planar peg-in-hole insertion planning with Drake's hydroelastic contact model.

Reproduces and extends Yang et al., "A Planning Framework for Robotic Insertion Tasks via
Hydroelastic Contact Model", Machines 11(7):741, 2023.
"""

__version__ = "0.5.0.dev0"
