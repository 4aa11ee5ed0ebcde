"""The taxel-array chain of paper 004: where did it slip? Object/hand against object/world
slip from dynamic taxel arrays, with the power ratio Gamma and the group square coherence
G2 (computed by :mod:`tactile_cli.spectral`).

- :func:`simulate_taxel_slip`: the scene with ground truth (``tactile simulate taxel-slip``);
- :func:`slip_interface`: naive-Bayes classification with nested best-band search;
  :func:`slip_interface_file`: the same on a file, its JSON and figure written
  (``tactile slip-interface``);
- :func:`write_taxel_features`: Gamma and G2 per window as a stream for ``tactile train``
  (``tactile features spectral``).
"""

from .config import FeatureConfig as FeatureConfig
from .config import TaxelSceneConfig as TaxelSceneConfig
from .config import load_feature_config as load_feature_config
from .config import load_taxel_scene_config as load_taxel_scene_config
from .pipeline import slip_interface as slip_interface
from .pipeline import slip_interface_file as slip_interface_file
from .pipeline import write_taxel_features as write_taxel_features
from .simulate import simulate_taxel_slip as simulate_taxel_slip

__all__ = ["FeatureConfig", "TaxelSceneConfig", "load_feature_config",
           "load_taxel_scene_config", "simulate_taxel_slip", "slip_interface",
           "slip_interface_file", "write_taxel_features"]
