"""Event accumulation and action segmentation (paper 000, sec. 4.2, Fig. 10).

Events of one trial are counted per polarity in fixed bins (20 ms by default), the net
count is smoothed with a centred moving average, and a trial of approach, press, slip and
release is segmented into those four regions. ``tactile accumulate`` is the command;
:mod:`tactile_cli.events.figure` draws a trial like the paper's Fig. 10 (matplotlib, not
imported here).
"""

from .accumulate import CHANNELS as CHANNELS
from .accumulate import EventCounts as EventCounts
from .accumulate import bin_events as bin_events
from .accumulate import centred_moving_average as centred_moving_average
from .accumulate import counts_to_labels as counts_to_labels
from .accumulate import trial_counts as trial_counts
from .recording import FileAccumulation as FileAccumulation
from .recording import TrialAccumulation as TrialAccumulation
from .recording import accumulate_file as accumulate_file
from .recording import write_bins_csv as write_bins_csv
from .recording import write_counts as write_counts
from .segment import Segmentation as Segmentation
from .segment import SegmentationScore as SegmentationScore
from .segment import SegmentOptions as SegmentOptions
from .segment import segment_actions as segment_actions
from .segment import segmentation_accuracy as segmentation_accuracy
