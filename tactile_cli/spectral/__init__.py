"""Spectral methods any multichannel stream can enter: STFT settings and spectrograms,
Welch band power, spectral centroid and the anti-alias resampling of bandwidth studies.

Arrays in, arrays out (numpy and scipy only); first needed by the accelerometer
fingertips of paper 001 (:mod:`tactile_cli.accel`).
"""

from ._band_power import band_power as band_power
from ._band_power import spectral_centroid as spectral_centroid
from ._band_power import welch_psd as welch_psd
from ._resample import bandwidth_steps as bandwidth_steps
from ._resample import limit_bandwidth as limit_bandwidth
from ._stft import STFT_LENGTHS as STFT_LENGTHS
from ._stft import spectrogram as spectrogram
from ._stft import stft_hop as stft_hop
from ._stft import stft_lengths as stft_lengths

__all__ = ["STFT_LENGTHS", "band_power", "bandwidth_steps", "limit_bandwidth",
           "spectral_centroid", "spectrogram", "stft_hop", "stft_lengths", "welch_psd"]
