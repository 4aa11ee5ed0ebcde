"""Spectral methods any multichannel stream can enter: STFT settings and spectrograms,
Welch band power, spectral centroid and the anti-alias resampling of bandwidth studies
(first needed by the accelerometer fingertips of paper 001, :mod:`tactile_cli.accel`);
sliding spectra with band tracking (peak amplitude and frequency in a band, offline or as
samples arrive; the active-vibration chain of paper 003); Welch cross-spectra, the power
ratio Gamma and the group square coherence G2, per bin and per band, of one array or
across arrays (:mod:`._coherence`, :mod:`._array_features`; the taxel chain of paper 004).

Arrays in, arrays out (numpy and scipy only), except :mod:`.stream_features`, the
file-level verb that writes those features of any stream of a tactile file as a new stream
(``tactile features spectral --stream``).
"""

from ._array_features import ArrayFeatures as ArrayFeatures
from ._array_features import array_features as array_features
from ._array_features import band_centre_width_hz as band_centre_width_hz
from ._array_features import band_grid as band_grid
from ._array_features import finger_ensembles as finger_ensembles
from ._array_features import masked_g2 as masked_g2
from ._array_features import multi_finger_g2 as multi_finger_g2
from ._band_power import band_power as band_power
from ._band_power import spectral_centroid as spectral_centroid
from ._band_power import welch_psd as welch_psd
from ._coherence import band_sums as band_sums
from ._coherence import coherence_matrix as coherence_matrix
from ._coherence import cross_spectral_matrix as cross_spectral_matrix
from ._coherence import g2_noise_floor as g2_noise_floor
from ._coherence import group_square_coherence as group_square_coherence
from ._coherence import group_square_coherence_bins as group_square_coherence_bins
from ._coherence import group_square_coherence_windows as group_square_coherence_windows
from ._coherence import local_ensemble_power as local_ensemble_power
from ._coherence import power_ratio as power_ratio
from ._coherence import segment_spectra as segment_spectra
from ._coherence import welch_segment_count as welch_segment_count
from ._resample import bandwidth_steps as bandwidth_steps
from ._resample import limit_bandwidth as limit_bandwidth
from ._resample import lowest_cutoff_hz as lowest_cutoff_hz
from ._stft import STFT_LENGTHS as STFT_LENGTHS
from ._stft import spectrogram as spectrogram
from ._stft import stft_hop as stft_hop
from ._stft import stft_lengths as stft_lengths
from ._tracking import FrameSettings as FrameSettings
from ._tracking import FrameSpectra as FrameSpectra
from ._tracking import SpectrumTracker as SpectrumTracker
from ._tracking import band_peak as band_peak
from ._tracking import causal_moving_average as causal_moving_average
from ._tracking import frame_spectra as frame_spectra

__all__ = ["STFT_LENGTHS", "FrameSettings", "FrameSpectra", "SpectrumTracker", "band_peak",
           "frame_spectra", "causal_moving_average", "band_power", "bandwidth_steps",
           "limit_bandwidth", "lowest_cutoff_hz", "spectral_centroid", "spectrogram", "stft_hop",
           "stft_lengths", "welch_psd"]
__all__ += ["band_sums", "coherence_matrix", "cross_spectral_matrix", "g2_noise_floor",
            "group_square_coherence", "group_square_coherence_bins",
            "group_square_coherence_windows", "local_ensemble_power",
            "power_ratio", "segment_spectra", "welch_segment_count",  # paper 004
            "ArrayFeatures", "array_features", "band_centre_width_hz", "band_grid",
            "finger_ensembles", "masked_g2", "multi_finger_g2"]
