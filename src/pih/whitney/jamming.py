"""Whitney's jamming diagram (10-41), docs/whitney.md §6: which support loads a peg in two-point
contact can hold, as a parallelogram in the plane of normalized force and moment."""

from __future__ import annotations

import math

from pih.whitney.theory import WhitneyInvalidError

__all__ = ["jamming_diagram"]


def jamming_diagram(depth_m: float, friction: float, peg_diameter_m: float) -> dict:
    """Jamming parallelogram (10-41), docs/whitney.md §6.2, in X = F_x/F_z, Y = M/(r F_z).

    With lambda = l/(mu d): two-point lines Y = +-lambda - mu (1 + lambda) X, one-point edges
    X = +-1/mu. Returns lambda, ``slope`` of both lines, their Y intercepts (+-lambda), the
    X intercepts (+-lambda/((lambda+1) mu)), ``x_edge`` = 1/mu, the four ``vertices`` in polygon
    order and ``wedged`` (lambda < 1, §6.1: every load can be held).
    """
    if not (math.isfinite(friction) and friction > 0.0):
        raise WhitneyInvalidError(f"friction={friction!r} must be finite and > 0")
    if not (math.isfinite(peg_diameter_m) and peg_diameter_m > 0.0):
        raise WhitneyInvalidError(f"peg_diameter_m={peg_diameter_m!r} must be finite and > 0")
    if not (math.isfinite(depth_m) and depth_m >= 0.0):
        raise WhitneyInvalidError(f"depth_m={depth_m!r} must be finite and >= 0")
    lam = depth_m / (friction * peg_diameter_m)
    edge = 1.0 / friction
    return {
        "lambda": lam,
        "slope": -friction * (1.0 + lam),
        "upper_y_intercept": lam,
        "lower_y_intercept": -lam,
        "upper_x_intercept": lam / ((lam + 1.0) * friction),
        "lower_x_intercept": -lam / ((lam + 1.0) * friction),
        "x_edge": edge,
        "vertices": (
            (-edge, 2.0 * lam + 1.0),
            (edge, -1.0),
            (edge, -(2.0 * lam + 1.0)),
            (-edge, 1.0),
        ),
        "wedged": lam < 1.0,
    }
