"""Whitney's frame for a planar insertion (docs/whitney.md): which world x direction his +u
(lateral error) points along, so that simulated forces and tilts read in his signs."""

from __future__ import annotations

__all__ = ["error_side"]


def error_side(start_x_m: float, hole_x_m: float) -> float:
    """+1 or −1: the world x direction of Whitney's +u, toward the side the peg starts on."""
    return -1.0 if start_x_m < hole_x_m else 1.0
