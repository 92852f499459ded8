"""What the Rerun recordings keep (the ``recordings`` config section): sized for a person
watching. No Drake, no Rerun."""

from __future__ import annotations

from dataclasses import dataclass, replace

from pih.config import described, require_positive


@dataclass(frozen=True)
class RecordingsConfig:
    """The Rerun recordings (``.rrd``): sized for a person watching, not for analysis (the
    Parquet beside each keeps what the analysis reads; docs/workflow.md, "Outputs")."""

    series_rate_hz: float = described(
        100.0,
        "force and depth series of an insertion recording: each 1/rate s keeps its lowest and "
        "highest sample, so every peak survives (a 0.5 ms step logs 2000 samples a second)",
    )
    frame_rate_hz: float = described(
        50.0, "scene frames (peg, robot frame, spring, contact force, paths) per simulated second"
    )
    validation_frame_rate_hz: float = described(
        10.0,
        "scene frames of a validation run's recording per simulated second, in place of "
        "frame_rate_hz: its 0.2 mm/s descent moves 0.02 mm between frames at 10 Hz",
    )
    full_rate_tail_s: float = described(
        1.0, "the last seconds of every insertion recording (series and frames) at every step"
    )

    def validate(self, prefix: str = "") -> None:
        require_positive(
            self, ("series_rate_hz", "frame_rate_hz", "validation_frame_rate_hz"), prefix
        )
        require_positive(self, ("full_rate_tail_s",), prefix, allow_zero=True)

    def for_validation(self) -> RecordingsConfig:
        """The rates of a validation run's recording."""
        return replace(self, frame_rate_hz=self.validation_frame_rate_hz)
