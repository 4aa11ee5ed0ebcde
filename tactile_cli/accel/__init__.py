"""The accelerometer-fingertip chain of paper 001: slip, texture and speed from vibration.

- :func:`simulate_vibro_slip`: the slip-slide rig as the paper's CSV tree (``tactile
  simulate vibro-slip``), ingested by ``tactile ingest --format accel-tree``;
- :func:`prepare_file`: recording segments as trials (label ``segment``), the per-sample
  ``speed_cm_s`` target and an optional bandwidth limit (``tactile accel-prepare``);
- :data:`CHANNEL_CONFIGS` and :func:`with_channels`: the 8 accelerometer channel sets;
- :func:`detection_delay`: samples and inference time to detect slippage (sec. 6.5,
  ``tactile detect-delay``).
"""

from .channels import CHANNEL_CONFIGS as CHANNEL_CONFIGS
from .channels import channel_config as channel_config
from .channels import with_channels as with_channels
from .config import VibroSceneConfig as VibroSceneConfig
from .config import load_vibro_config as load_vibro_config
from .simulate import simulate_vibro_slip as simulate_vibro_slip

__all__ = ["CHANNEL_CONFIGS", "VibroSceneConfig", "channel_config", "load_vibro_config",
           "simulate_vibro_slip", "with_channels"]
