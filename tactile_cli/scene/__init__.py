"""The marker-event scene of ``tactile simulate marker-events`` (paper 000, secs. 3-4).

Raw event recordings of a neuromorphic marker sensor (640 x 480 events for trials of
approach, press at one of 12 force levels, slip and release) with their ground truth:
eq. 16/17 event counts per 20 ms bin, positive and negative polarities, Poisson and
background noise, big-force saturation, and marker-strip ROIs whose event-weighted
centroid moves with the slip speed (eq. 15).
"""

from .config import MarkerSceneConfig as MarkerSceneConfig
from .config import load_marker_scene_config as load_marker_scene_config
from .events import EVENT_DTYPE as EVENT_DTYPE
from .events import SimulatedEvents as SimulatedEvents
from .events import strip_offset_px as strip_offset_px
from .events import trial_events as trial_events
from .layout import SceneLayout as SceneLayout
from .layout import scene_layout as scene_layout
from .layout import slip_px_per_m as slip_px_per_m
from .marker_events import SceneResult as SceneResult
from .marker_events import SimulatedTrial as SimulatedTrial
from .marker_events import simulate_marker_events as simulate_marker_events
from .trials import SceneTrial as SceneTrial
from .trials import TrialRates as TrialRates
from .trials import draw_trial as draw_trial
from .trials import expected_rates as expected_rates
from .trials import plan_trials as plan_trials
from .trials import trial_name as trial_name
from .trials import trial_rng as trial_rng

__all__ = ["EVENT_DTYPE", "MarkerSceneConfig", "SceneLayout", "SceneResult", "SceneTrial",
           "SimulatedEvents", "SimulatedTrial", "TrialRates", "draw_trial", "expected_rates",
           "load_marker_scene_config", "plan_trials", "scene_layout", "simulate_marker_events",
           "slip_px_per_m", "strip_offset_px", "trial_events", "trial_name", "trial_rng"]
