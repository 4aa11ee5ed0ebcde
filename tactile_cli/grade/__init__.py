"""Pressing-force grading with a Mamdani fuzzy classifier (paper 000, sec. 4.4 and 5.3).

The area of net pressing events in a trial's press region (:mod:`.features`) is graded
into six force extents (light, small, small medium, medium, small big, big) by the rules of
Table III: a vectorised Mamdani system (:mod:`.fuzzy`) whose membership functions come
from a YAML config (:mod:`.config`) and can be fitted to labelled recordings of another
sensor (:mod:`.calibrate`).
"""

from importlib import resources
from pathlib import Path

from .calibrate import AreaCalibrator as AreaCalibrator
from .config import GraderConfig as GraderConfig
from .config import config_from_dict as config_from_dict
from .config import load_config as load_config
from .config import normalise_grade as normalise_grade
from .config import save_config as save_config
from .features import TrialArea as TrialArea
from .features import load_areas as load_areas
from .features import press_area as press_area
from .features import read_area_csv as read_area_csv
from .fuzzy import Inference as Inference
from .fuzzy import MamdaniSystem as MamdaniSystem
from .fuzzy import MembershipFunction as MembershipFunction
from .fuzzy import gaussmf as gaussmf
from .fuzzy import infer as infer
from .fuzzy import trapmf as trapmf
from .fuzzy import trimf as trimf
from .grading import FuzzyGrader as FuzzyGrader
from .grading import GradedTrial as GradedTrial
from .grading import GradeReport as GradeReport
from .grading import GradeSummary as GradeSummary
from .grading import grade_trials as grade_trials
from .grading import true_grade_index as true_grade_index
from .pipeline import Calibration as Calibration
from .pipeline import GradeRun as GradeRun
from .pipeline import calibrate_config as calibrate_config
from .pipeline import grade_files as grade_files

#: File name of the default (marker-sensor) config shipped inside the package; the same
#: file is configs/grade_marker.yaml in the repository.
DEFAULT_CONFIG = "grade_marker.yaml"


def default_config_path() -> Path:
    """Path of the packaged default config (the marker sensor of paper 000)."""
    return Path(str(resources.files(__package__).joinpath(DEFAULT_CONFIG)))
