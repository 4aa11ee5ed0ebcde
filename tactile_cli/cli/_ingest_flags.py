"""The flags of the format options, shared by `tactile ingest` (which sets them) and
`tactile info` (whose notes on a raw recording name them)."""

from __future__ import annotations

#: The format options that have a flag of their own (the others go through --option).
OPTION_FLAGS: dict[str, str] = {
    "mapping": "--mapping",
    "width_px": "--width",
    "height_px": "--height",
    "sensor_name": "--sensor",
    "frame_rate_hz": "--fps",
    "reference": "--reference",
    "px_per_mm": "--px-per-mm",
    "skip_unknown": "--skip-unknown",
    "trials_from": "--trials-from",
    "sort_stamps": "--sort-stamps",
}

__all__ = ["OPTION_FLAGS"]
