"""The eight accelerometer channel configurations of paper 001 (sec. 4) by name.

L and R are the left and right fingertips, x/y/z their axes; the names are the paper's::

    L3R3  all six    L3  left x, y, z    LxRx  both x    Lx  left x
    LyRy  both y     Ly  left y          LzRz  both z    Lz  left z
"""

from __future__ import annotations

from typing import Any

from ..errors import InputError
from ..vocabulary import CHANNEL_SETS

#: Configuration name -> channel names of the ``accel`` stream, in stored order (the
#: table lives in :mod:`tactile_cli.vocabulary` so training configs can name a set).
CHANNEL_CONFIGS: dict[str, tuple[str, ...]] = CHANNEL_SETS


def channel_config(name: str) -> tuple[str, ...]:
    """The channels of configuration ``name`` (``"LxRx"`` -> ``("L_x", "R_x")``)."""
    try:
        return CHANNEL_CONFIGS[name]
    except KeyError:
        raise InputError(f"unknown channel configuration {name!r}; use one of "
                         f"{', '.join(CHANNEL_CONFIGS)}") from None


def with_channels(config: Any, name: str) -> Any:
    """A copy of a training config (:class:`tactile_cli.learn.config.TrainConfig`) whose
    ``data.channels`` are those of configuration ``name``, validated."""
    raw = config.model_dump(mode="json")
    raw["data"]["channels"] = list(channel_config(name))
    return type(config).model_validate(raw)
