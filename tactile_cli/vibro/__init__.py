"""The active-vibration chain of paper 003 (VibroTouch): an ERM shakes one fingertip, an
accelerometer in the other listens, and contact or a touch shows as a change of the chain's
resonances.

- :func:`model_spectra`, :func:`assemble`, :func:`frequency_response`: the lumped model of
  sec. 2.2 (``tactile vibro-model``);
- :func:`simulate_vibrotouch`: the test bench with ground truth (``tactile simulate
  vibrotouch``);
- :func:`detect_contacts`, :func:`find_band`: the spectral and force triggers of sec. 2.4
  and the band-finder (``tactile detect-contact``); :func:`follow`: the same detector on a
  live stream (``--follow``).
"""

from .config import DetectorConfig as DetectorConfig
from .config import ModelConfig as ModelConfig
from .config import SceneConfig as SceneConfig
from .config import load_detector_config as load_detector_config
from .config import load_model_config as load_model_config
from .config import load_scene_config as load_scene_config
from .model import assemble as assemble
from .model import frequency_response as frequency_response
from .model import model_spectra as model_spectra
from .model import natural_frequencies_hz as natural_frequencies_hz
from .pipeline import detect_contacts as detect_contacts
from .pipeline import find_band as find_band
from .simulate import simulate_vibrotouch as simulate_vibrotouch
from .stream import follow as follow

__all__ = ["DetectorConfig", "ModelConfig", "SceneConfig", "assemble", "detect_contacts",
           "find_band", "follow", "frequency_response", "load_detector_config",
           "load_model_config", "load_scene_config", "model_spectra",
           "natural_frequencies_hz", "simulate_vibrotouch"]
