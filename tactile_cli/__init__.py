"""tactile-cli: tactile-sensing research from raw recordings to trained, evaluated models.

The library API (importable in a notebook without the CLI)::

    import tactile_cli as tc
    tc.ingest(["rec.aedat4"], "rec.h5")
    tc.validate_file("rec.h5").ok
    tc.summarize("rec.h5").trials
"""

from ._version import __version__ as __version__
from .errors import InputError as InputError
from .errors import SchemaError as SchemaError
from .errors import TactileError as TactileError
from .ingest import IngestOptions as IngestOptions
from .ingest import ingest as ingest
from .store import StoreWriter as StoreWriter
from .store import read_events as read_events
from .store import read_events_window as read_events_window
from .store import read_signal as read_signal
from .store import summarize as summarize
from .store import validate_file as validate_file
