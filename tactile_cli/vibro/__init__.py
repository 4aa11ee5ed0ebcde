"""The active-vibration chain of paper 003 (VibroTouch): an ERM shakes one fingertip, an
accelerometer in the other listens, and contact or a touch shows as a change of the chain's
resonances.

- :func:`model_spectra`, :func:`assemble`, :func:`frequency_response`: the lumped model of
  sec. 2.2; :func:`model_file`: the same from a config file, with its figure (``tactile
  vibro-model``);
- :func:`simulate_vibrotouch`: the test bench with ground truth (``tactile simulate
  vibrotouch``);
- :func:`detect_contacts`, :func:`find_band`: the spectral and force triggers of sec. 2.4
  and the band-finder; :func:`detect_contact_file`: both on a file, with the figure
  (``tactile detect-contact``); :func:`follow`, :func:`follow_input`: the same detector on
  a live stream (``--follow``); :func:`write_trial_samples`: a trial as such a stream
  (``--samples-out``).
"""

from .config import DetectorConfig as DetectorConfig
from .config import ModelConfig as ModelConfig
from .config import VibroTouchSceneConfig as VibroTouchSceneConfig
from .config import detector_config as detector_config
from .config import load_detector_config as load_detector_config
from .config import load_model_config as load_model_config
from .config import load_vibrotouch_config as load_vibrotouch_config
from .model import assemble as assemble
from .model import frequency_response as frequency_response
from .model import model_spectra as model_spectra
from .model import natural_frequencies_hz as natural_frequencies_hz
from .pipeline import ContactFileResult as ContactFileResult
from .pipeline import ModelFileResult as ModelFileResult
from .pipeline import detect_contact_file as detect_contact_file
from .pipeline import detect_contacts as detect_contacts
from .pipeline import find_band as find_band
from .pipeline import model_file as model_file
from .pipeline import write_trial_samples as write_trial_samples
from .simulate import simulate_vibrotouch as simulate_vibrotouch
from .stream import follow as follow
from .stream import follow_input as follow_input

__all__ = ["ContactFileResult", "DetectorConfig", "ModelConfig", "ModelFileResult",
           "VibroTouchSceneConfig", "assemble", "detect_contact_file", "detect_contacts",
           "detector_config", "find_band", "follow", "follow_input", "frequency_response",
           "load_detector_config", "load_model_config", "load_vibrotouch_config",
           "model_file", "model_spectra", "natural_frequencies_hz", "simulate_vibrotouch",
           "write_trial_samples"]
