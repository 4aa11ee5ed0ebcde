"""The tactile HDF5 store: schema spec, atomic writer, validator and the one trial reader
(:class:`TactileFile` hands out :class:`Trial` objects; nothing outside ``store/`` imports
h5py)."""

from .reader import FileSummary as FileSummary
from .reader import read_events as read_events
from .reader import read_events_window as read_events_window
from .reader import read_signal as read_signal
from .reader import summarize as summarize
from .reader import trial_names as trial_names
from .spec import load_spec as load_spec
from .trials import Annotation as Annotation
from .trials import EventWindow as EventWindow
from .trials import Frames as Frames
from .trials import Sensor as Sensor
from .trials import Signal as Signal
from .trials import TactileFile as TactileFile
from .trials import Trial as Trial
from .trials import TrialEvents as TrialEvents
from .trials import open_file as open_file
from .validate import ValidationReport as ValidationReport
from .validate import Violation as Violation
from .validate import validate_file as validate_file
from .writer import Compression as Compression
from .writer import EventAppender as EventAppender
from .writer import FrameAppender as FrameAppender
from .writer import StoreWriter as StoreWriter
from .writer import TrialWriter as TrialWriter
from .writer import safe_name as safe_name
