"""The visuotactile chain of paper 002 (DIGIT, GelSight): surface normals from colour,
height maps, tactile meshes, the slip signal and the slip-avoidance monitor.

Public names are re-exported below as the modules land (one line per name).
"""

from .avoidance import simulate_digit_avoidance as simulate_digit_avoidance
from .calibrate import find_contact_circle as find_contact_circle
from .calibrate import normal_rmse as normal_rmse
from .calibrate import write_normal_labels as write_normal_labels
from .heightmap import HeightMapper as HeightMapper
from .heightmap import heightmap_file as heightmap_file
from .mesh import MESH_SIZES as MESH_SIZES
from .monitor import MonitorManager as MonitorManager
from .monitor import SlipMonitor as SlipMonitor
from .monitor import replay as replay
from .monitor_replay import monitor_file as monitor_file
from .normals import NormalModel as NormalModel
from .poisson import PoissonSolver as PoissonSolver
from .poisson import gradients_from_normals as gradients_from_normals
from .render import GelOptics as GelOptics
from .render import render_rgb as render_rgb
from .render import surface_normals as surface_normals
from .simulate import simulate_digit_press as simulate_digit_press
from .slip import adaptive_threshold as adaptive_threshold
from .slip import detect_slip as detect_slip
from .slip import slip_signal as slip_signal
from .slip import slip_signal_file as slip_signal_file
from .stability import run_stability as run_stability

__all__: list[str] = [
    "MonitorManager", "SlipMonitor", "monitor_file", "replay", "run_stability",
    "simulate_digit_avoidance",
    "GelOptics", "find_contact_circle", "normal_rmse", "render_rgb", "simulate_digit_press",
    "surface_normals", "write_normal_labels",
    "MESH_SIZES", "HeightMapper", "NormalModel", "PoissonSolver", "adaptive_threshold",
    "detect_slip", "gradients_from_normals", "heightmap_file", "slip_signal",
    "slip_signal_file",
]
