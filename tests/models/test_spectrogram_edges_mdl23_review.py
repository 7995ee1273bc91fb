"""The spectrogram's edges: the window's last samples, the band limit, rounded sample counts
(review mdl23)."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.models.cnn import SpectrogramCNNClassifier, log_spectrogram, segment_samples

RATE_HZ = 100.0


def _tail_changed(n_samples: int, rate_hz: float, segment_s: float, hop_s: float,
                  n_tail: int) -> bool:
    """Whether changing the last ``n_tail`` samples of a window changes its spectra."""
    return _changed(n_samples, rate_hz, segment_s, hop_s, slice(n_samples - n_tail, None))


def _head_changed(n_samples: int, rate_hz: float, segment_s: float, hop_s: float,
                  n_head: int) -> bool:
    """Whether changing the first ``n_head`` samples of a window changes its spectra."""
    return _changed(n_samples, rate_hz, segment_s, hop_s, slice(0, n_head))


def _changed(n_samples: int, rate_hz: float, segment_s: float, hop_s: float,
             part: slice) -> bool:
    X = np.random.default_rng(0).normal(size=(1, 1, n_samples)).astype(np.float32)
    Y = X.copy()
    Y[..., part] += 5.0
    return not np.array_equal(log_spectrogram(X, rate_hz, segment_s, hop_s)[0],
                              log_spectrogram(Y, rate_hz, segment_s, hop_s)[0])


@pytest.mark.parametrize("n_samples, seg, hop, unseen", [
    (200, 50, 20, 10),      # the default 0.5 s / 0.2 s at 100 Hz (BorealTC), 2 s windows
    (100, 25, 10, 5),       # the same at 50 Hz (Vulpi), 2 s windows
    (85, 25, 10, 0),        # the papers' 1.7 s windows at 50 Hz: a frame starts at the first
    (100, 100, 20, 0),      # one segment of the whole window
])
def test_frames_end_at_the_last_sample_and_the_samples_before_the_first_full_segment_are_unseen(
        n_samples, seg, hop, unseen):
    # documented: frames are aligned to the window's end, the last ending at the newest
    # sample; the (n_samples - seg) mod hop oldest samples are in no frame, and the first
    # sample of the first segment has weight 0 in its periodic Hann taper (a DFT-even window
    # is 0 at its first sample only). This test pinned the frames starting at the first
    # sample (the newest samples unseen) until review mdl23's fix.
    assert (n_samples - seg) % hop == unseen
    assert not _head_changed(n_samples, RATE_HZ, seg / RATE_HZ, hop / RATE_HZ, unseen + 1)
    assert _head_changed(n_samples, RATE_HZ, seg / RATE_HZ, hop / RATE_HZ, unseen + 2)
    assert _tail_changed(n_samples, RATE_HZ, seg / RATE_HZ, hop / RATE_HZ, 1)


@pytest.mark.parametrize("n_samples, rate_hz", [(200, 100.0), (100, 50.0), (85, 50.0),
                                                (100, 100.0), (400, 100.0)])
def test_the_newest_sample_of_a_default_window_reaches_the_spectrogram(n_samples, rate_hz):
    # the frames started at the window's first sample and the taper was the symmetric
    # np.hanning: the newest 0.1 s of a default window was in no frame and a last frame's
    # last sample weighed 0, so the served spectrogram CNN never saw the latest samples
    assert _tail_changed(n_samples, rate_hz, 0.5, 0.2, 1)


@pytest.mark.parametrize("limit_hz, kept", [(3.0, True), (np.nextafter(3.0, 0.0), False),
                                            (np.nextafter(3.0, 4.0), True)])
def test_a_bin_exactly_at_its_band_limit_is_kept(limit_hz, kept):
    # documented: bins *above* the limit are zeroed; 1 s segments at 10 Hz: bins 0-5 Hz
    model = SpectrogramCNNClassifier(rate_hz=10.0, segment_s=1.0, hop_s=0.5,
                                     band_limits_hz=(limit_hz, np.inf))
    mask = model._band_mask(20, (1, 2, 6, 3))
    assert mask[0, :, 0].tolist() == [1.0, 1.0, 1.0, float(kept), 0.0, 0.0]
    assert mask[1, :, 0].tolist() == [1.0] * 6


@pytest.mark.parametrize("samples, expected", [(2.5, 2), (3.5, 4), (12.5, 12), (2.4, 2),
                                               (2.6, 3)])
def test_a_segment_halfway_between_two_sample_counts_rounds_to_the_even_one(
        samples, expected):
    # documented: Python's round, a tie to the even count (0.5 s at 5 Hz: 2 samples)
    assert segment_samples(1.0, samples, 100) == expected


@pytest.mark.parametrize("seg", [2, 3, 4, 5])
def test_a_short_segment_tells_a_constant_from_an_alternating_signal(seg):
    # np.hanning(3) is [0, 1, 0]: a Hann-tapered 3-sample segment was its middle sample
    # alone, every bin that sample's power, so a constant and a sign-alternating signal gave
    # one spectrum (0.5 s segments at 6.5 Hz are 3 samples); like 2 samples (np.hanning(2)
    # is [0, 0]), 3 are tapered with a rectangular window
    constant = np.ones((1, 1, 12), np.float32)
    alternating = np.tile([1.0, -1.0], 6)[None, None].astype(np.float32)
    a, freqs = log_spectrogram(constant, 1.0, float(seg), 1.0)
    b, _ = log_spectrogram(alternating, 1.0, float(seg), 1.0)
    assert len(freqs) == seg // 2 + 1
    assert a[0, 0, 0, 0] > b[0, 0, 0, 0] + 0.5         # the constant's power is at 0 Hz
    assert b[0, 0, -1, 0] > a[0, 0, -1, 0] + 0.5       # the alternation's at the top bin


def test_a_three_sample_segment_is_rectangular():
    # 0.5 s at 6.5 Hz (the BorealTC wheel rate) is 3.25 samples: 3
    x = np.array([[[1.0, 2.0, 4.0]]], dtype=np.float32)
    spec, _ = log_spectrogram(x, 6.5, 0.5, 0.2)
    assert segment_samples(6.5, 0.5, 3) == 3
    np.testing.assert_allclose(spec[0, 0, :, 0], np.log10(np.abs(np.fft.rfft(x[0, 0])) ** 2
                                                          + 1e-10), rtol=1e-6)
