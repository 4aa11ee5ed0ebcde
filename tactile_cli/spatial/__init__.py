"""The spatial chain of the event-based marker sensor (paper 000, secs. 3.2-3.3, 4.3, 5.2).

Event frames (Fig. 13), rectangular ROIs and their event-weighted centroids (eqs. 18-19),
slip velocity, displacement and speed (eqs. 20-21, Fig. 23), and the optics that turn
pixels into metres (eqs. 3, 15).
"""

from .config import CentroidOptions as CentroidOptions
from .config import SlipOptions as SlipOptions
from .config import SpatialConfig as SpatialConfig
from .config import config_from_mapping as config_from_mapping
from .config import load_config as load_config
from .frames import EventFrames as EventFrames
from .frames import accumulate_frames as accumulate_frames
from .frames import iter_trial_frames as iter_trial_frames
from .frames import median_filter_frames as median_filter_frames
from .optics import PAPER_FOCAL_LENGTH_M as PAPER_FOCAL_LENGTH_M
from .optics import PAPER_PIXEL_PITCH_M as PAPER_PIXEL_PITCH_M
from .optics import StripOptics as StripOptics
from .pipeline import FramesResult as FramesResult
from .pipeline import SlipRateReport as SlipRateReport
from .pipeline import slip_rate_report as slip_rate_report
from .pipeline import write_frames as write_frames
from .roi import Roi as Roi
from .roi import RoiCentroids as RoiCentroids
from .roi import centroids_from_sums as centroids_from_sums
from .roi import check_rois_on_sensor as check_rois_on_sensor
from .roi import event_density as event_density
from .roi import propose_rois as propose_rois
from .roi import roi_centroid_series as roi_centroid_series
from .roi import roi_weight_sums as roi_weight_sums
from .roi import trial_roi_centroids as trial_roi_centroids
from .slip_rate import SlipRate as SlipRate
from .slip_rate import SlipRateEstimate as SlipRateEstimate
from .slip_rate import SlipTrace as SlipTrace
from .slip_rate import SlopeFit as SlopeFit
from .slip_rate import centroid_velocity as centroid_velocity
from .slip_rate import estimate_slip_rate as estimate_slip_rate
from .slip_rate import estimate_slip_rates as estimate_slip_rates
from .slip_rate import fit_common_slope as fit_common_slope
from .slip_rate import integrate_displacement as integrate_displacement
from .slip_rate import slip_rate_from_centroids as slip_rate_from_centroids
from .trial_events import event_trial_names as event_trial_names
from .trial_events import spatial_events as spatial_events
