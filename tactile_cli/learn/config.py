"""The YAML training config of ``tactile train``: data, model, optimiser and seed.

One typed model validated as a whole before any data are read. Every level forbids
unknown keys, and :func:`load_config` turns any problem into one
:class:`~tactile_cli.errors.InputError` naming the config file, the line and the key
(``configs/train_lstm_actions.yaml`` documents every key)::

    version: 1
    seed: 0
    data:
      stream: event_counts        # /trials/{trial}/signals/{stream}
      channels: [net]             # by name (the sensor's channel_names)
      window: 25                  # samples per window
      stride: 1                   # samples between window starts (overlap = window - stride)
      pad: zero                   # none | zero | edge: left padding so early samples get windows
      transform: signed_log1p     # none | signed_log1p, before normalisation
      label_rule: last            # last | majority
      label_delay: 0              # target sample = window end - label_delay (with `last`)
      targets:
        - {name: action}                                   # sample label, classification
        - {name: force_level, source: trial, kind: regression, weight: 0.5}
      split: {mode: auto, val_fraction: 0.2, test_fraction: 0.0}
    model: {family: lstm, hidden: 64, layers: 1}
    optim: {lr: 0.003, batch_size: 256, epochs: 30, patience: 5}

Absurd sizes are refused before any work, with their key and line. Every number must be
finite, and the sizes have generous upper bounds, far above any real use: ``data.window``,
``data.stride``, ``optim.batch_size`` and the spectrogram's ``n_fft``/``hop`` at most
10^7; a layer width (``hidden``, ``channels``, ``head_hidden``) at most 10^5; ``layers`` and
list lengths at most 1000 (``data.channels`` at most 3 x 4096 x 4096, the pixel values of
the largest image-sequence input); ``optim.threads`` at most 1024; ``optim.epochs`` at most 10^6.
Then the memory a training step needs is estimated from the config alone (the weights with
their gradients and Adam state, 16 bytes per parameter; the activations of one batch; the
batch itself) and a config that needs more than this machine's physical memory is refused,
naming the key that dominates, the estimate and the machine's memory.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, Literal

import yaml
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    field_validator,
    model_validator,
)

from ..config_file import check_fits_in_memory, key_line, read_yaml
from ..errors import InputError
from ..vocabulary import BIN_S, CHANNEL_SETS

#: Summary features of the MLP family, in the order they are computed (per channel).
SUMMARY_FEATURES: tuple[str, ...] = ("mean", "std", "min", "max", "last", "slope")
#: Summary features that do not read the window's level (issue 34): ``range`` (max - min),
#: ``diff_std`` (standard deviation of the sample-to-sample differences), ``skew`` and
#: ``kurtosis`` (excess; both 0 for a window without spread). With ``std`` and ``slope``
#: they are unchanged by an offset added to the channel.
LEVEL_FREE_FEATURES: tuple[str, ...] = ("range", "diff_std", "skew", "kurtosis")
#: Every name ``model.features`` accepts.
FEATURE_NAMES: tuple[str, ...] = SUMMARY_FEATURES + LEVEL_FREE_FEATURES
#: Model families that are not networks (issue 34, item 3): scikit-learn estimators on
#: window features or raw vectors, stored and exported as ONNX (:mod:`.classic`).
CLASSIC_FAMILIES: tuple[str, ...] = ("logistic", "random_forest", "hist_gb", "svm")
#: Model families of the registry (``model.family``): the networks, then the classic ones.
FAMILIES: tuple[str, ...] = ("lstm", "cnn1d", "cnn2d_spectrogram", "fnn", "mlp",
                             "cnn2d_layout", "cnn2d_frames", *CLASSIC_FAMILIES)
#: The stream name that reads a trial's image frames (``/trials/{trial}/frames``) as an
#: image-sequence input (issue 35; :mod:`.frames`).
FRAMES_STREAM = "frames"


#: Upper bounds of sizes (see the module docstring): far above any real use, low enough
#: that a typo (an extra six zeros) is an error and not an allocation that never ends.
_MAX_SAMPLES = 10_000_000
_MAX_WIDTH = 100_000
_MAX_LIST = 1000
#: ``data.channels``: the pixel values of the largest frame input (3 planes of 4096 x 4096).
_MAX_CHANNELS = 3 * 4096 * 4096
_MAX_SEED = 2**63 - 1
_Width = Annotated[int, Field(ge=1, le=_MAX_WIDTH)]


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class TargetConfig(_Model):
    """One output head: what it predicts and how much its loss counts."""

    name: str = Field(min_length=1)
    """Sample-label name (``signals/{stream}/sample_labels/{name}``) or trial-label name
    (``/trials/{trial}/labels`` attribute) when ``source: trial``."""
    kind: Literal["classification", "regression"] = "classification"
    source: Literal["sample", "trial"] = "sample"
    weight: float = Field(default=1.0, gt=0, le=1e6)
    """Factor of this head's loss in the total (paper 001, eq. 3 uses 1 for every head)."""


class SplitConfig(_Model):
    """How trials (never windows) are divided into train, val and test, and into the folds
    of ``tactile train --cv`` (see :mod:`.splits`)."""

    mode: Literal["auto", "attribute", "random", "stratified", "group", "blocked"] = "auto"
    """``attribute``: each trial's ``split`` attribute (train/val/test; ``tactile ingest
    --trial-labels`` column ``split`` or ``tactile train --split-from CSV`` sets it);
    ``random``: seeded by trial with the fractions below; ``stratified``: the same, per
    class of the label ``by``, so that every class is in every split where it has enough
    trials; ``group``: whole groups of trials sharing the value of label ``by`` (a day, an
    object, a session) go to one side; ``blocked``: trials in recording order (the order
    of label ``by``: a sample number, a session, or ``time_origin_unix_s``, the trial's
    start time) cut into contiguous blocks, the latest blocks to test and the ones before
    them to val, so that no held-out trial lies between two training trials (the split
    that predicts accuracy on later recordings; see :mod:`.splits`); ``auto``: the
    attribute when every trial has one, random when none has."""
    by: str | None = Field(default=None, min_length=1)
    """Label that ``stratified`` and ``group`` use: a trial label, or a per-sample label
    (a trial's class is then the set of classes its samples hold, e.g. ``no_slip`` or
    ``no_slip+slip``). Default for ``stratified``: the first classification target. For
    ``blocked``: the label whose natural order is the recording order (numbers by value),
    or ``time_origin_unix_s`` (a trial label of that name, else the trial attribute the
    mapped-CSV ingest writes)."""
    within: str | None = Field(default=None, min_length=1)
    """``blocked`` only: cut the blocks inside each value of this label (a class, a
    material), so that every fold holds the same stretch of every class's recordings
    (e.g. ``by: time_origin_unix_s, within: material`` when materials were recorded one
    after another)."""
    val_fraction: float = Field(default=0.2, ge=0, lt=1)
    test_fraction: float = Field(default=0.0, ge=0, lt=1)
    seed: int | None = Field(default=None, ge=0, le=_MAX_SEED)
    """Seed of the random split; default the run's ``seed``."""

    @model_validator(mode="after")
    def _fractions(self) -> SplitConfig:
        if self.val_fraction + self.test_fraction >= 1:
            raise ValueError(
                f"val_fraction + test_fraction (={self.val_fraction + self.test_fraction}) "
                "must be < 1: some trials must remain for training"
            )
        if self.mode == "group" and self.by is None:
            raise ValueError("`mode: group` needs `by`: the label whose trials stay together")
        if self.mode == "blocked" and self.by is None:
            raise ValueError("`mode: blocked` needs `by`: the label that gives the recording "
                             "order (a sample number, or time_origin_unix_s)")
        if self.within is not None and self.mode != "blocked":
            raise ValueError("`within` goes with `mode: blocked` only")
        return self


class BaselineConfig(_Model):
    """Per-trial baseline removal (:func:`.preprocess.remove_baseline`): every channel of a
    trial minus its resting level, as BioTac and taxel users subtract resting electrode and
    pressure values, so that a model sees changes, not a session's absolute level."""

    mode: Literal["none", "start", "median"] = "none"
    """``start``: the mean of the trial's first ``duration_ms`` (the resting level before
    contact when the recording starts before it; causal); ``median``: the trial's median
    (needs the whole trial: offline evaluation only); ``none``: nothing removed."""
    duration_ms: float = Field(default=100.0, gt=0, le=3.6e6)
    """``start``: how much of the trial's beginning is the resting level (at least its
    first sample)."""


class AugmentConfig(_Model):
    """Augmentation of the training windows (:func:`.preprocess.augment_windows`), drawn
    per window and channel from a generator seeded by the run's ``seed``; all 0: none."""

    offset_sd: float = Field(default=0.0, ge=0, le=100)
    """Standard deviation of a level offset added to each channel of each window, in
    training standard deviations (the normalised unit)."""
    gain_sd: float = Field(default=0.0, ge=0, le=10)
    """Standard deviation of the log of a gain applied to each channel's variation about its
    window mean (0.1: gains of about 0.9 to 1.1)."""
    time_stretch: float = Field(default=0.0, ge=0, lt=1)
    """Largest relative time stretch of a window (0.05: factors 0.95 to 1.05, uniform)."""
    channel_dropout: float = Field(default=0.0, ge=0, lt=1)
    """Probability that a channel of a window is set to 0 (the training mean)."""

    @property
    def active(self) -> bool:
        return any(v > 0 for v in (self.offset_sd, self.gain_sd, self.time_stretch,
                                   self.channel_dropout))


class FramesConfig(_Model):
    """An image-sequence input (``data.stream: frames``; :mod:`.frames`): every frame of a
    trial as its difference from a reference frame, area-averaged down to ``width`` x
    ``height`` pixels, grey or in colour. Each pixel of each plane is one channel of the
    window (plane-major: all of plane 0's rows, then plane 1's), named
    ``<plane>_r<row>_c<col>`` (planes ``grey``, or ``r``, ``g``, ``b``), in levels of the
    8-bit camera (a difference: -255 to 255)."""

    width: int = Field(default=32, ge=1, le=4096)
    """Pixels across after downsampling (at most the camera's width)."""
    height: int = Field(default=24, ge=1, le=4096)
    """Pixels down after downsampling (at most the camera's height)."""
    colour: bool = False
    """Keep the red, green and blue planes (3 values a pixel); else one grey plane (the
    ITU-R BT.601 luma of the difference)."""
    reference: Literal["stored", "first"] = "stored"
    """The frame subtracted: the trial's stored no-contact frame (``frames/reference``;
    ``tactile ingest --reference first`` stores each folder's first frame), or the trial's
    own first frame."""
    change: Literal["reference", "previous", "flow"] = "reference"
    """What each frame is a difference from: the reference (the change since no contact),
    or the kept frame before it (``previous``: the motion between samples, the first
    kept frame still minus the reference). ``flow``: not a difference of levels but the
    gel's motion since the kept frame before it (the first since the reference), measured
    in ``height`` x ``width`` blocks of the grey camera frame by phase correlation
    (:mod:`.frame_flow`): planes ``dy`` and ``dx`` in camera px; for marker skins and
    textured gels, whose pattern area-averaging blurs away."""
    step: int = Field(default=1, ge=1, le=1000)
    """Keep every ``step``-th frame of a trial (frames 0, step, 2 step, ...; the sample
    period grows by ``step``): a 25 fps video of 450 frames becomes 90 samples at 5 fps
    with ``step: 5``. The reference is unchanged."""

    @model_validator(mode="after")
    def _flow_is_grey(self) -> FramesConfig:
        if self.change == "flow" and self.colour:
            raise ValueError("`change: flow` measures the motion of the grey frame; set "
                             "`colour: false`")
        return self

    @property
    def planes(self) -> tuple[str, ...]:
        if self.change == "flow":
            return ("dy", "dx")
        return ("r", "g", "b") if self.colour else ("grey",)

    @property
    def unit(self) -> str:
        """The unit of every channel: levels of the 8-bit camera, or px of motion."""
        return "px" if self.change == "flow" else "levels"

    @property
    def n_values(self) -> int:
        """Values per frame: planes x height x width."""
        return len(self.planes) * self.height * self.width


class DataConfig(_Model):
    """Which stream and channels, how they are cut into windows, and what to predict."""

    stream: str = Field(min_length=1)
    """Signal stream of every trial. ``event_counts`` is also computed on the fly from a
    trial's events (bins of ``bin_s``) when the trial has no such stream."""
    channels: list[str] = Field(min_length=1, max_length=_MAX_CHANNELS)
    """Channel names of the stream's sensor, in the order the model sees them. A name with
    ``*``, ``?`` or ``[`` is a glob pattern (``ele*``, ``txl?_z``) matched against the
    sensor's channel names in their stored order; ``tactile train`` writes the matched names
    into the run's resolved config. A single string naming one of paper 001's accelerometer
    channel configurations (``channels: LxRx``; :data:`tactile_cli.vocabulary.CHANNEL_SETS`)
    stands for its channels."""
    window: int = Field(ge=1, le=_MAX_SAMPLES)
    """Samples per window."""

    @field_validator("channels", mode="before")
    @classmethod
    def _named_set(cls, value: Any) -> Any:
        if isinstance(value, str):
            if value in CHANNEL_SETS:
                return list(CHANNEL_SETS[value])
            raise ValueError(f"{value!r} is not a channel configuration "
                             f"({', '.join(CHANNEL_SETS)}); give a list of channel names")
        return value
    stride: int = Field(default=1, ge=1, le=_MAX_SAMPLES)
    """Samples between the ends of consecutive windows."""
    align: Literal["start", "end"] = "start"
    """Where the windows of a trial are laid: every ``stride`` samples from the first sample
    that ends a full window (``start``), or back from the trial's last sample (``end``: the
    last window always ends at the last sample; with ``pad`` a trial shorter than the window
    still gives that one window), which a decision per trial over recordings of different
    lengths needs."""
    pad: Literal["none", "zero", "edge"] = "none"
    """Left padding of each trial by ``window - 1`` samples so that every sample can end a
    window: ``zero`` pads with 0 in raw units (no events before the trial starts), ``edge``
    repeats the first sample; ``none`` starts at the first full window."""
    label_rule: Literal["last", "majority"] = "last"
    """Per-window target of a sample label: the label of the window's last sample (minus
    ``label_delay``), what a real-time user gets; or the most frequent label in the window
    (ties go to the lower class index). Regression sample labels: the last value or the
    window mean."""
    label_delay: int = Field(default=0, ge=0, le=_MAX_SAMPLES)
    """With ``last``: the target is the label ``label_delay`` samples before the window's
    end, so the decision for a sample is made after that many later samples (a latency of
    ``label_delay`` samples that lets the model see a transition's first samples)."""
    targets: list[TargetConfig] = Field(min_length=1, max_length=_MAX_LIST)
    bin_s: float = Field(default=BIN_S, ge=1e-6, le=3600)
    """Bin width (s) of event counts computed on the fly from events: a whole number of
    microseconds."""
    transform: Literal["none", "signed_log1p"] = "none"
    """Applied to every sample before normalisation: ``signed_log1p`` is
    ``sign(x) log(1 + |x|)``, which keeps both tens and thousands of events per bin
    visible (event counts span three decades within one trial)."""
    normalise: bool = True
    """Per-channel standardisation with statistics from the training split only."""
    window_norm: Literal["none", "center_scale", "center", "zscore"] = "none"
    """Applied to every window after ``normalise``: ``center_scale`` removes each channel's
    mean over the window and divides by its largest absolute value, so every channel of
    every window spans [-1, 1] (paper 001, sec. 4: the network sees the shape of a
    vibration, not its amplitude; a channel that is constant over the window becomes 0);
    ``center`` only removes the window's mean (the level goes, the amplitude stays);
    ``zscore`` also divides by the window's standard deviation (see
    :mod:`.preprocess`)."""
    class_weights: bool = True
    """Weight each classification loss by inverse class frequency in the training split."""
    decide_by: str | None = Field(default=None, min_length=1, max_length=200)
    """A trial label whose trials are decided together: evaluation also pools the windows of
    every trial that shares its value into one decision per value (majority vote and mean
    probability, as per trial), for trial-level targets. ``experiment`` for the two cameras
    of one grasp, recorded as two trials. Keep such trials on one side of every split
    (split ``by`` the same label or a coarser one)."""
    split: SplitConfig = SplitConfig()
    boundary_margin: int = Field(default=1, ge=0, le=_MAX_SAMPLES)
    """Evaluation also reports accuracy without the windows whose target sample is within
    this many samples of a change of its sample label."""
    baseline: BaselineConfig = BaselineConfig()
    """Per-trial baseline removal before ``transform`` and normalisation (default none)."""
    augment: AugmentConfig = AugmentConfig()
    """Augmentation of the training windows (default none); evaluation never augments."""
    frames: FramesConfig | None = None
    """With ``stream: frames``: the image-sequence input (default :class:`FramesConfig`);
    ``channels: ["*"]`` then selects every pixel value of it."""

    @model_validator(mode="before")
    @classmethod
    def _default_frames(cls, value: Any) -> Any:
        if isinstance(value, dict) and value.get("stream") == FRAMES_STREAM \
                and value.get("frames") is None:
            return {**value, "frames": {}}
        return value

    @model_validator(mode="after")
    def _check(self) -> DataConfig:
        if len(set(self.channels)) != len(self.channels):
            raise ValueError(f"`channels` has duplicates: {self.channels}")
        names = [t.name for t in self.targets]
        if len(set(names)) != len(names):
            raise ValueError(f"`targets` names repeat: {names}")
        if abs(round(self.bin_s * 1e6) - self.bin_s * 1e6) > 1e-6 * self.bin_s * 1e6:
            raise ValueError(f"`bin_s` (={self.bin_s}) must be a whole number of microseconds")
        if self.frames is not None and self.stream != FRAMES_STREAM:
            raise ValueError(f"`frames` goes with `stream: {FRAMES_STREAM}` (the image "
                             f"frames of each trial); this config reads stream {self.stream!r}")
        if self.decide_by is not None and not any(t.source == "trial" for t in self.targets):
            raise ValueError(f"`decide_by` (={self.decide_by!r}) pools trial-level decisions: "
                             "give a target with `source: trial`")
        if self.label_rule == "majority" and self.label_delay:
            raise ValueError("`label_delay` applies to `label_rule: last` only")
        if self.label_delay >= self.window:
            raise ValueError(
                f"`label_delay` (={self.label_delay}) must be < `window` (={self.window}): "
                "the target sample lies inside the window"
            )
        return self


class _Family(_Model):
    dropout: float = Field(default=0.0, ge=0, lt=1)
    head_hidden: list[_Width] = Field(default=[], max_length=_MAX_LIST)
    """Hidden fully connected layers of each head before its output layer (paper 001 uses
    two per task); empty: the trunk's features go straight to one linear output layer."""


def _odd_kernel(value: int) -> int:
    if value % 2 == 0:
        raise ValueError(f"kernel (={value}) must be odd: 'same' padding centres an odd kernel")
    return value


class LstmConfig(_Family):
    """LSTM over the window; the last hidden state feeds the heads (paper 000, Table I:
    one LSTM layer, a fully connected layer, softmax)."""

    family: Literal["lstm"]
    hidden: int = Field(default=64, ge=1, le=_MAX_WIDTH)
    layers: int = Field(default=1, ge=1, le=_MAX_LIST)


class Cnn1dConfig(_Family):
    """1-D convolutions over time (channels as input channels), flattened into the heads."""

    family: Literal["cnn1d"]
    channels: list[_Width] = Field(default=[32, 32], min_length=1, max_length=_MAX_LIST)
    kernel: int = Field(default=5, ge=1, le=_MAX_SAMPLES)
    """Samples; odd, so that 'same' padding centres it."""
    pool: int = Field(default=2, ge=1, le=_MAX_SAMPLES)
    """Max-pool factor after each convolution (skipped when the sequence is too short)."""

    _odd = field_validator("kernel")(_odd_kernel)


class Cnn2dSpectrogramConfig(_Family):
    """2-D convolutions over the log-magnitude spectrogram of each channel (torch.stft),
    channels as image channels (paper 001, sec. 5.3)."""

    family: Literal["cnn2d_spectrogram"]
    n_fft: int = Field(default=16, ge=2, le=_MAX_SAMPLES)
    hop: int = Field(default=4, ge=1, le=_MAX_SAMPLES)
    channels: list[_Width] = Field(default=[16, 32], min_length=1, max_length=_MAX_LIST)
    kernel: int = Field(default=3, ge=1, le=_MAX_WIDTH)
    """Odd, so that 'same' padding centres it."""

    _odd = field_validator("kernel")(_odd_kernel)


class FnnConfig(_Family):
    """Fully connected network on the flattened window (paper 001, sec. 5.1)."""

    family: Literal["fnn"]
    hidden: list[_Width] = Field(default=[128, 64], min_length=1, max_length=_MAX_LIST)


class MlpConfig(_Family):
    """Fully connected network on summary features of the window (per channel)."""

    family: Literal["mlp"]
    hidden: list[_Width] = Field(default=[64, 64], min_length=1, max_length=_MAX_LIST)
    features: list[Literal["mean", "std", "min", "max", "last", "slope", "range", "diff_std",
                           "skew", "kurtosis"]] = Field(
        default=list(SUMMARY_FEATURES), min_length=1
    )
    """Per-channel summary features (:data:`SUMMARY_FEATURES`, and the level-free
    :data:`LEVEL_FREE_FEATURES`); default the six of :data:`SUMMARY_FEATURES`."""


class Cnn2dLayoutConfig(_Family):
    """2-D convolutions over the channels laid out as an image at their places on the sensor
    (:mod:`.layout_cnn`, :mod:`.layouts`; the electrode image of arXiv 1809.05551)."""

    family: Literal["cnn2d_layout"]
    layout: str = "biotac_sp"
    """A named electrode layout (:data:`.layouts.LAYOUTS`); ``data.channels`` lists whole
    sensors of it, each in the layout's electrode order."""
    cell_mm: float = Field(default=1.5, gt=0, le=1000)
    """Size of one image cell on the sensor (mm); every electrode must get its own cell."""
    fill: Literal["zero", "nearest"] = "nearest"
    """Cells without an electrode: 0, or the value of the nearest electrode."""
    channels: list[_Width] = Field(default=[16, 32], min_length=1, max_length=_MAX_LIST)
    kernel: int = Field(default=3, ge=1, le=_MAX_WIDTH)
    """Odd, so that 'same' padding centres it."""

    _odd = field_validator("kernel")(_odd_kernel)

    @model_validator(mode="after")
    def _grid(self) -> Cnn2dLayoutConfig:
        from .layouts import layout_grid  # numpy only

        layout_grid(self.layout, cell_mm=self.cell_mm, fill=self.fill)  # ValueError: the key
        return self


class Cnn2dFramesConfig(_Family):
    """Image sequences (``data.stream: frames``): each frame of the window encoded by 2-D
    convolutions into ``embed`` features, then aggregated over time by an LSTM (its last
    hidden state: a causal decision at the window's last frame) or by temporal convolutions
    averaged over the window (:mod:`.frame_cnn`; the CNN-LSTM of slip detection on GelSight
    lifts, Li et al., ICRA 2018)."""

    family: Literal["cnn2d_frames"]
    channels: list[_Width] = Field(default=[8, 16], min_length=1, max_length=_MAX_LIST)
    """Output channels of each 2-D convolution of the frame encoder (each followed by ReLU
    and a 2 x 2 max-pool while the image is at least 2 x 2)."""
    kernel: int = Field(default=3, ge=1, le=_MAX_WIDTH)
    """Pixels; odd, so that 'same' padding centres it."""
    embed: int = Field(default=32, ge=1, le=_MAX_WIDTH)
    """Features per frame (a dense layer with ReLU on the flattened convolution output)."""
    temporal: Literal["lstm", "conv"] = "lstm"
    """How frames are aggregated: ``lstm`` (last hidden state) or ``conv`` (1-D 'same'
    convolutions over the frames with ReLU, then the mean over the window)."""
    hidden: int = Field(default=32, ge=1, le=_MAX_WIDTH)
    """LSTM hidden size, or output channels of each temporal convolution."""
    temporal_layers: int = Field(default=1, ge=1, le=_MAX_LIST)
    temporal_kernel: int = Field(default=3, ge=1, le=_MAX_SAMPLES)
    """``conv`` only: frames per temporal kernel; odd."""

    _odd = field_validator("kernel", "temporal_kernel")(_odd_kernel)


class _Classic(_Model):
    """Keys every classic family shares (:mod:`.classic`): what a window becomes."""

    input: Literal["features", "raw"] = "features"
    """``features``: the window's summary features per channel (as the MLP's, feature-major);
    ``raw``: the window's samples flattened (window x channels values, sample-major)."""
    features: list[Literal["mean", "std", "min", "max", "last", "slope"]] = Field(
        default=list(SUMMARY_FEATURES), min_length=1, max_length=len(SUMMARY_FEATURES))
    """With ``input: features``: which summary features, in this order."""
    standardise: bool = True
    """Scale each input value to zero mean and unit variance over the training windows
    (inside the stored model)."""

    @model_validator(mode="after")
    def _inputs(self) -> _Classic:
        if len(set(self.features)) != len(self.features):
            raise ValueError(f"`features` has duplicates: {self.features}")
        if self.input == "raw" and list(self.features) != list(SUMMARY_FEATURES):
            raise ValueError("`features` applies to `input: features`; `input: raw` feeds "
                             "the window's samples")
        return self


class LogisticConfig(_Classic):
    """Multinomial logistic regression (L2, lbfgs)."""

    family: Literal["logistic"]
    c: float = Field(default=1.0, gt=0, le=1e12)
    """Inverse regularisation strength (scikit-learn's ``C``)."""
    max_iter: int = Field(default=1000, ge=1, le=1_000_000)


class RandomForestConfig(_Classic):
    """A random forest of ``trees`` trees (bootstrap, Gini)."""

    family: Literal["random_forest"]
    trees: int = Field(default=200, ge=1, le=100_000)
    max_depth: int | None = Field(default=None, ge=1, le=1000)
    min_samples_leaf: int = Field(default=1, ge=1, le=_MAX_SAMPLES)
    max_features: Literal["sqrt", "log2", "all"] = "sqrt"
    """Features tried per split."""


class HistGbConfig(_Classic):
    """Histogram gradient boosting (scikit-learn's HistGradientBoostingClassifier), no early
    stopping: ``max_iter`` rounds."""

    family: Literal["hist_gb"]
    max_iter: int = Field(default=200, ge=1, le=100_000)
    learning_rate: float = Field(default=0.1, gt=0, le=10)
    max_leaf_nodes: int = Field(default=31, ge=2, le=100_000)
    max_depth: int | None = Field(default=None, ge=1, le=1000)
    min_samples_leaf: int = Field(default=20, ge=1, le=_MAX_SAMPLES)
    l2_regularization: float = Field(default=0.0, ge=0, le=1e12)


class SvmConfig(_Classic):
    """A support-vector classifier (one-against-one), its decision values calibrated to
    probabilities by Platt's sigmoid over ``calibration_folds`` folds of the training
    windows (scikit-learn's CalibratedClassifierCV, ``ensemble=False``)."""

    family: Literal["svm"]
    kernel: Literal["linear", "rbf"] = "rbf"
    c: float = Field(default=1.0, gt=0, le=1e12)
    """Scikit-learn's ``C``."""
    gamma: Literal["scale", "auto"] | Annotated[float, Field(gt=0, le=1e12)] = "scale"
    """RBF width: a number, or scikit-learn's ``scale`` / ``auto``."""
    calibration_folds: int = Field(default=5, ge=2, le=100)


ModelConfig = Annotated[
    LstmConfig | Cnn1dConfig | Cnn2dSpectrogramConfig | FnnConfig | MlpConfig
    | Cnn2dLayoutConfig | Cnn2dFramesConfig | LogisticConfig | RandomForestConfig
    | HistGbConfig | SvmConfig,
    Field(discriminator="family"),
]
#: The config classes of the classic families.
CLASSIC_CONFIGS = (LogisticConfig, RandomForestConfig, HistGbConfig, SvmConfig)


class OptimConfig(_Model):
    """Optimiser, batches, epochs and early stopping."""

    optimizer: Literal["adam", "sgd"] = "adam"
    lr: float = Field(default=1e-3, gt=0)
    momentum: float = Field(default=0.9, ge=0, lt=1)
    """SGD only."""
    weight_decay: float = Field(default=0.0, ge=0)
    lr_schedule: Literal["constant", "cosine"] = "constant"
    """``cosine``: the learning rate falls from ``lr`` to 0 over ``epochs`` (cosine
    annealing, stepped per epoch), which settles the weights for precise boundaries."""
    batch_size: int = Field(default=256, ge=1, le=_MAX_SAMPLES)
    epochs: int = Field(default=30, ge=1, le=1_000_000)
    patience: int = Field(default=5, ge=0, le=1_000_000)
    """Stop after this many epochs without improvement of ``monitor`` on the validation
    split and keep the best epoch's weights; 0 trains every epoch (and keeps the best)."""
    monitor: Literal["val_loss", "val_accuracy"] = "val_loss"
    grad_clip: float = Field(default=0.0, ge=0)
    """Clip the gradient's global norm to this value before each step; 0: no clipping."""
    threads: int = Field(default=1, ge=1, le=1024)
    """torch CPU threads during training. One is fastest for the small networks here (an
    LSTM step of batch 256 took 26 ms on 1 thread and 64 ms on 2 of this machine's busy 2
    cores) and keeps results independent of the machine's core count; raise it for large
    convolutional networks."""


class TrainConfig(_Model):
    """A whole ``tactile train`` config."""

    version: Literal[1] = 1
    seed: int = Field(default=0, ge=0, le=_MAX_SEED)
    data: DataConfig
    model: ModelConfig
    optim: OptimConfig = OptimConfig()

    @model_validator(mode="after")
    def _check(self) -> TrainConfig:
        m = self.model
        if isinstance(m, Cnn2dSpectrogramConfig) and m.n_fft > self.data.window:
            raise ValueError(
                f"model.n_fft (={m.n_fft}) must be <= data.window (={self.data.window})"
            )
        if isinstance(m, Cnn2dFramesConfig) and self.data.frames is None:
            raise ValueError(f"model.family cnn2d_frames reads image sequences: set "
                             f"data.stream: {FRAMES_STREAM} (data.stream is "
                             f"{self.data.stream!r})")
        if isinstance(m, CLASSIC_CONFIGS):
            kinds = [t.kind for t in self.data.targets]
            if kinds != ["classification"]:
                raise ValueError(
                    f"model.family {m.family} predicts one classification target; "
                    f"data.targets has {len(kinds)} ({', '.join(kinds)}): use a network "
                    "family for regression or several heads")
        return self

    def with_overrides(self, *, seed: int | None = None, epochs: int | None = None
                       ) -> TrainConfig:
        """A copy with the command-line ``--seed`` / ``--epochs`` applied (validated)."""
        raw = self.model_dump(mode="json")
        if seed is not None:
            raw["seed"] = seed
        if epochs is not None:
            raw["optim"]["epochs"] = epochs
        return TrainConfig.model_validate(raw)

    def as_yaml(self) -> str:
        return yaml.safe_dump(self.model_dump(mode="json"), sort_keys=False)


# -- loading ----------------------------------------------------------------------------------
def load_config(path: str | Path) -> TrainConfig:
    """Read and validate a training config; any problem is one :class:`InputError` line
    naming the file, the line and the key."""
    path = Path(path)
    text, raw = read_yaml(path)
    return parse_config(raw, path=path, text=text)


def parse_config(raw: Any, *, path: str | Path | None = None, text: str | None = None
                 ) -> TrainConfig:
    """Validate an already-parsed config (a dict); errors as :func:`load_config`."""
    if not isinstance(raw, dict):
        raise InputError("a training config is a YAML mapping with keys data, model (and "
                         "optionally version, seed, optim); see configs/train_lstm_actions.yaml",
                         path=path)
    try:
        config = TrainConfig.model_validate(raw)
    except ValidationError as exc:
        errors = exc.errors()
        # an unknown key first: a misspelt key also makes the intended one "missing"
        err = max(errors, key=lambda e: (e["type"] == "extra_forbidden", len(e["loc"])))
        keys = _keys_in_file(tuple(err["loc"]), raw, missing=err["type"] == "missing")
        line = key_line(text, keys) if text and keys else None
        raise InputError(_describe(err, keys), path=path,
                         where=None if line is None else f"line {line}") from None
    needed, key, purpose, keys = memory_estimate(config)
    check_fits_in_memory(needed, key, purpose, path=path, text=text, keys=keys)
    return config


def _widest(candidates: list[tuple[tuple[Any, ...], int]]) -> tuple[tuple[Any, ...], int]:
    return max(candidates, key=lambda c: c[1])


def memory_estimate(cfg: TrainConfig) -> tuple[float, str, str, tuple[Any, ...]]:
    """``(bytes, key, purpose, keys)``: a lower estimate of the memory one training step of
    ``cfg`` needs (weights with gradients and Adam state at 16 bytes per parameter, one
    batch's activations and the batch); the key that dominates it, with its value
    (``"`model.hidden` (=64)"``), what the largest part is for, and the key's location."""
    d, m, o = cfg.data, cfg.model, cfg.optim
    c, w, b = len(d.channels), d.window, o.batch_size
    if d.frames is not None:  # every pixel value is a channel
        c = max(c, d.frames.n_values)
    sizes: list[tuple[tuple[Any, ...], int]] = [(("data", "window"), w)]
    if isinstance(m, CLASSIC_CONFIGS):  # no batches: the windows' inputs, as float64
        return (8.0 * w * c * b, f"`data.window` (={w})",
                f"for the inputs of {b} windows of {w} samples x {c} channels",
                ("data", "window"))
    if isinstance(m, LstmConfig):
        h = m.hidden
        params = 4 * (c * h + h * h + 2 * h) + (m.layers - 1) * 4 * (2 * h * h + 2 * h)
        acts = 6 * b * w * h * m.layers
        sizes += [(("model", "hidden"), h), (("model", "layers"), m.layers)]
        out = h
    elif isinstance(m, FnnConfig | MlpConfig):
        widths = [w * c if isinstance(m, FnnConfig) else len(m.features) * c, *m.hidden]
        params = sum(a * b_ for a, b_ in zip(widths, widths[1:], strict=False))
        acts = 2 * b * sum(m.hidden)
        sizes += [(("model", "hidden", i), v) for i, v in enumerate(m.hidden)]
        out = m.hidden[-1]
    elif isinstance(m, Cnn1dConfig):
        chans = [c, *m.channels]
        params = sum(a * b_ * m.kernel for a, b_ in zip(chans, chans[1:], strict=False))
        acts = 2 * b * w * sum(m.channels)
        sizes += [(("model", "channels", i), v) for i, v in enumerate(m.channels)]
        sizes.append((("model", "kernel"), m.kernel))
        out = m.channels[-1] * max(1, w // m.pool ** len(m.channels))
    elif isinstance(m, Cnn2dLayoutConfig):
        from .layouts import layout_grid

        rows, cols = layout_grid(m.layout, cell_mm=m.cell_mm, fill=m.fill).shape
        chans = [w * max(1, c // layout_grid(m.layout).n_electrodes), *m.channels]
        params = sum(a * b_ * m.kernel ** 2 for a, b_ in zip(chans, chans[1:], strict=False))
        acts = 2 * b * rows * cols * sum(m.channels)
        sizes += [(("model", "channels", i), v) for i, v in enumerate(m.channels)]
        sizes.append((("model", "kernel"), m.kernel))
        out = m.channels[-1] * rows * cols
    elif isinstance(m, Cnn2dFramesConfig):
        fr = d.frames or FramesConfig()
        chans = [len(fr.planes), *m.channels]
        params = sum(a * b_ * m.kernel ** 2 for a, b_ in zip(chans, chans[1:], strict=False))
        cells = fr.height * fr.width
        params += m.channels[-1] * cells * m.embed + 4 * m.temporal_layers * (
            (m.embed + m.hidden) * m.hidden + 2 * m.hidden)
        acts = 2 * b * w * cells * sum(m.channels)
        sizes += [(("model", "channels", i), v) for i, v in enumerate(m.channels)]
        sizes += [(("model", "embed"), m.embed), (("model", "hidden"), m.hidden)]
        out = m.hidden
    else:  # the spectrogram CNN
        cells = (m.n_fft // 2 + 1) * (w // m.hop + 1)
        chans = [c, *m.channels]
        params = sum(a * b_ * m.kernel ** 2 for a, b_ in zip(chans, chans[1:], strict=False))
        acts = 2 * b * cells * sum(m.channels)
        sizes += [(("model", "channels", i), v) for i, v in enumerate(m.channels)]
        sizes += [(("model", "kernel"), m.kernel), (("model", "n_fft"), m.n_fft)]
        out = m.channels[-1] * cells
    head = [out, *m.head_hidden, 1]
    params += len(d.targets) * sum(a * b_ for a, b_ in zip(head, head[1:], strict=False))
    sizes += [(("model", "head_hidden", i), v) for i, v in enumerate(m.head_hidden)]
    terms = [
        (16.0 * params, f"for the model's {params:.3g} weights (with their gradients and "
         "optimiser state)", sizes),
        (4.0 * acts, f"for the activations of a batch of {b} windows",
         [*sizes, (("optim", "batch_size"), b)]),
        (4.0 * b * w * c, f"for a batch of {b} windows of {w} samples x {c} channels",
         [(("data", "window"), w), (("optim", "batch_size"), b)]),
    ]
    needed = sum(t[0] for t in terms)
    _, purpose, candidates = max(terms, key=lambda t: t[0])
    keys, value = _widest(candidates)
    return needed, f"`{_key_path(keys)}` (={value})", purpose, keys


def _keys_in_file(loc: tuple[Any, ...], raw: Any, *, missing: bool) -> tuple[Any, ...]:
    """The parts of a pydantic ``loc`` that are keys or list indexes of the document (the
    union member tags that pydantic inserts, such as ``lstm``, are dropped)."""
    out: list[Any] = []
    node = raw
    for i, part in enumerate(loc):
        last = i == len(loc) - 1
        if isinstance(part, int):
            if isinstance(node, list) and part < len(node):
                out.append(part)
                node = node[part]
            continue
        if isinstance(node, dict) and part in node:
            out.append(part)
            node = node[part]
        elif last and missing and isinstance(node, dict):
            out.append(part)
    return tuple(out)


def _key_path(keys: tuple[Any, ...]) -> str:
    out = ""
    for part in keys:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out


_ALLOWED: dict[tuple[str, ...], type[BaseModel]] = {
    (): TrainConfig, ("data",): DataConfig, ("optim",): OptimConfig,
    ("data", "baseline"): BaselineConfig, ("data", "augment"): AugmentConfig,
    ("data", "split"): SplitConfig, ("data", "targets"): TargetConfig,
    ("data", "frames"): FramesConfig,
}
_FAMILY_MODELS: dict[str, type[BaseModel]] = {
    "lstm": LstmConfig, "cnn1d": Cnn1dConfig, "cnn2d_spectrogram": Cnn2dSpectrogramConfig,
    "fnn": FnnConfig, "mlp": MlpConfig, "cnn2d_layout": Cnn2dLayoutConfig,
    "cnn2d_frames": Cnn2dFramesConfig, "logistic": LogisticConfig,
    "random_forest": RandomForestConfig, "hist_gb": HistGbConfig,
    "svm": SvmConfig,
}


def _describe(err: dict[str, Any], keys: tuple[Any, ...]) -> str:
    key = _key_path(keys)
    msg = str(err["msg"]).removeprefix("Value error, ")
    if err["type"] == "extra_forbidden":
        parents = tuple(k for k in keys[:-1] if not isinstance(k, int))
        model = _ALLOWED.get(parents)
        if parents == ("model",) and len(err["loc"]) > 1:
            model = _FAMILY_MODELS.get(str(err["loc"][1]))
        hint = ""
        if model is not None:
            hint = f" (allowed here: {', '.join(model.model_fields)})"
        return f"unknown key `{key}`{hint}"
    if err["type"] == "missing":
        return f"missing key `{key}`"
    if err["type"] == "union_tag_invalid" or err["type"] == "union_tag_not_found":
        return f"`{key}`: model.family must be one of {', '.join(FAMILIES)}"
    if not keys:
        return msg
    value = err.get("input")
    shown = ""
    if not (isinstance(value, dict | list) or value is None or repr(value) in msg):
        shown = f" (got {value!r})"
    return f"`{key}`: {msg}{shown}"


__all__ = ["CLASSIC_CONFIGS", "CLASSIC_FAMILIES", "FAMILIES", "FEATURE_NAMES", "FRAMES_STREAM",
           "LEVEL_FREE_FEATURES", "SUMMARY_FEATURES", "AugmentConfig", "BaselineConfig",
           "Cnn1dConfig", "Cnn2dFramesConfig", "Cnn2dLayoutConfig", "Cnn2dSpectrogramConfig",
           "DataConfig", "FramesConfig",
           "FnnConfig", "HistGbConfig", "LogisticConfig", "LstmConfig", "MlpConfig",
           "ModelConfig", "OptimConfig", "RandomForestConfig", "SplitConfig", "SvmConfig",
           "TargetConfig", "TrainConfig", "load_config", "parse_config"]
