"""``pih compare OLD NEW``: did NEW reproduce OLD (:mod:`pih.publishing.compare`)."""

from __future__ import annotations

import sys
from pathlib import Path

from pih.cli.common import first_line


def compare(old: Path, new: Path, rtol: float, r_tolerance: float) -> int:
    """Print both levels of the comparison; 0 when the conclusions reproduce, 1 when not."""
    from pih.publishing.compare import compare

    try:
        result = compare(old, new, rtol, r_tolerance)
    except (OSError, ValueError) as error:
        print(f"pih compare: {first_line(error)}", file=sys.stderr)
        return 1
    failed = [check for check in result.checks if not check.holds]
    verdict = "reproduced" if result.conclusions_hold else "NOT reproduced"
    causes = f"; likely causes: {'; '.join(result.causes)}" if result.causes else ""
    # The answer first, in one line: the details below can run to hundreds of lines.
    print(
        f"pih compare: {new} {verdict} {old}: {len(result.checks) - len(failed)} of "
        f"{len(result.checks)} conclusions hold, {result.differing_items()} of {result.items} "
        f"data items differ{causes}"
    )
    if result.scope:
        print(f"scope: {result.scope}")
    for difference in result.differences:
        print(difference)
    within = "bit-identical" if rtol == 0 else f"within --rtol {rtol:g}"
    data = "the same" if result.data_identical else "NOT the same"
    print(f"data: {result.differing_items()} of {result.items} items differ: {data} ({within})")
    if result.causes:
        print(f"data: likely causes, from the provenance: {'; '.join(result.causes)}")
    for check in failed:
        print(check)
    print(
        f"conclusions: {len(result.checks) - len(failed)} of {len(result.checks)} hold "
        f"(deployment success inside the 95 % intervals, paired signs, validation r within "
        f"{r_tolerance:g}): {new} {verdict} {old}"
    )
    return 0 if result.conclusions_hold else 1
