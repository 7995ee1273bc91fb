"""Convolutional terrain classifiers on raw windows, as scikit-learn estimators.

Two networks, both trained with skorch (a well-kept scikit-learn wrapper of PyTorch) and
exposed as plain scikit-learn classifiers (``fit / predict / predict_proba / get_params``)
that take the raw windows of :mod:`features.windows`, ``X`` of shape
``(n_windows, n_channels, n_samples)`` (a 2-D ``X`` is read as one channel):

* :class:`RawCNNClassifier`: a small 1-D CNN over time on the standardised channels.
* :class:`SpectrogramCNNClassifier`: the multichannel-spectrogram CNN of BorealTC
  (LaRocque et al., "Proprioception Is All You Need: Terrain Classification for Boreal
  Forests", IROS 2024) and Vulpi et al. (J. Terramechanics 2021): the short-time spectrum of
  every channel is one image channel of a 2-D CNN.

Low-rate wheel channels. BorealTC computes each sensor's spectrogram at its native rate and
stretches the frequency axis of the low-rate wheel spectrogram (repeating its rows) to the
IMU spectrogram's size. Here every channel is already on the aligned clock
(:func:`terrain.io.align.align_streams`), so all spectra share one time-frequency grid by
construction; bins of a channel above the Nyquist frequency of its native rate
(``band_limits_hz``, e.g. 3.25 Hz for the 6.5 Hz BorealTC wheel stream) hold only
interpolation artefacts and are set to zero after standardisation instead of being filled
with repeated rows. The wheel information (level and slow variations) stays in the low bins,
at the true frequency instead of a stretched one.

Leakage and reproducibility: the per-channel (raw) or per-channel-and-bin (spectrogram)
standardisation is computed in ``fit`` from the training windows only. skorch's default
random validation split is disabled: training runs a fixed epoch budget, or, with
``early_stopping=True``, validates on whole runs held out of the training data given to
``fit`` (``groups`` required), which then take no part in the standardisation or the class
weights either. Weights, shuffling and dropout draw from ``random_state`` in
a forked torch RNG, so CPU training is deterministic for a given torch thread count
(``n_threads``; another count changes the floating-point sums), fits in threads of one
process included (they take turns on torch's global RNG); a CUDA device is used when present
(``device="auto"``) and nothing requires one. skorch is handed the network's class and
arguments, never an instance, so a net trained on a GPU loads and predicts on a CPU-only
machine (skorch maps its ``module_`` to the available device; README, "Model comparison").
"""

from __future__ import annotations

import threading
from contextlib import contextmanager
from typing import Callable, Sequence

import numpy as np
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.utils.multiclass import check_classification_targets
from sklearn.utils.validation import (check_array, check_consistent_length, check_is_fitted,
                                      column_or_1d)

from features.calculators import hann_taper
from terrain.errors import (ConfigError, NonFiniteInputError, ShapeError, config_integer,
                            config_numbers, config_positive, refuse_missing,
                            refuse_mixed_types)
from terrain.models.cv import class_keeping_split, restored_on_failure

#: Floor added to the squared STFT magnitude before the logarithm (signal units^2).
POWER_FLOOR = 1e-10


def as_windows(X) -> np.ndarray:
    """Windows as float32 ``(n_windows, n_channels, n_samples)``; a 2-D array is one channel.

    Parameters
    ----------
    X : array-like
        ``(n_windows, n_channels, n_samples)`` or ``(n_windows, n_samples)``.

    Returns
    -------
    numpy.ndarray
        float32, 3-D.
    """
    X = np.asarray(X, dtype=np.float32)
    return X[:, None, :] if X.ndim == 2 else X


def segment_samples(rate_hz: float, segment_s: float, n_samples: int) -> int:
    """Samples of one STFT segment: ``segment_s`` at ``rate_hz``, clipped to the window.

    Parameters
    ----------
    rate_hz : float
        Sampling rate, Hz.
    segment_s : float
        Segment length, s.
    n_samples : int
        Samples of one window.

    Returns
    -------
    int
        The nearest whole number of samples (Python's ``round``: halfway between two counts,
        the even one, e.g. 0.5 s at 5 Hz is 2 samples), at least 2 and at most ``n_samples``
        (a window of 1 sample is one segment of 1 sample).
    """
    return int(np.clip(round(segment_s * rate_hz), 2, n_samples))


def log_spectrogram(X: np.ndarray, rate_hz: float, segment_s: float, hop_s: float
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Per-channel log power short-time spectra (periodic Hann window, one-sided).

    Parameters
    ----------
    X : array-like
        ``(n_windows, n_channels, n_samples)`` signals (SI units of each channel).
    rate_hz : float
        Sampling rate, Hz.
    segment_s : float
        STFT segment length, s (:func:`segment_samples`: clipped to the window length, at
        least 2 samples where the window has them; a segment of fewer than 4 samples is
        tapered with a rectangular window, since a Hann window of 2 or 3 samples drops the
        oldest sample and weighs the others nearly alike).
    hop_s : float
        Hop between segments, s (the nearest whole number of samples, at least 1).

    Returns
    -------
    spectra : numpy.ndarray
        ``(n_windows, n_channels, n_freqs, n_frames)`` float32, ``log10(|STFT|^2 + 1e-10)``.
        Frames are aligned to the window's end, ``(n_samples - seg) // hop + 1`` of them
        every hop, the last one ending at the newest sample: the ``(n_samples - seg) % hop``
        oldest samples are in no frame (with the defaults 0.5 s / 0.2 s, the first 0.1 s of a
        2 s window), never the newest ones a live decision is about. The taper is the
        periodic ("DFT-even") Hann window of spectral analysis
        (:func:`features.calculators.hann_taper`, as ``scipy.signal.get_window`` and
        ``scipy.signal.stft`` use it): it weighs a segment's first sample 0 and its last
        sample not, so the newest sample reaches the spectrum (the symmetric
        ``numpy.hanning`` weighed both ends 0).
    freqs_hz : numpy.ndarray
        ``(n_freqs,)`` bin frequencies, Hz.

    Raises
    ------
    ConfigError
        ``rate_hz``, ``segment_s`` or ``hop_s`` not a finite number > 0.
    ShapeError
        Windows of no sample (``n_samples`` 0, or a scalar ``X``).

    References
    ----------
    F. J. Harris, "On the use of windows for harmonic analysis with the discrete Fourier
    transform", Proc. IEEE 66(1), 1978, sec. II-B and IV (DFT-even windows: the periodic
    extension of the window, its last zero dropped, for spectral analysis with the DFT).
    """
    config_positive("log_spectrogram", rate_hz=rate_hz, segment_s=segment_s, hop_s=hop_s)
    X = np.asarray(X)       # (a list: a bare AttributeError on X.shape)
    if X.ndim == 0 or X.shape[-1] == 0:     # (NumPy's "Invalid number of FFT data points")
        raise ShapeError(f"log_spectrogram: windows of shape {X.shape} hold no sample: "
                         "give (n_windows, n_channels, n_samples) with n_samples >= 1")
    seg = segment_samples(rate_hz, segment_s, X.shape[-1])
    hop = max(1, int(round(hop_s * rate_hz)))
    # frames end at the newest sample: the first starts after the (n - seg) % hop oldest
    start = (X.shape[-1] - seg) % hop
    frames = np.lib.stride_tricks.sliding_window_view(X[..., start:], seg, axis=-1)[..., ::hop, :]
    # a Hann taper of 2 or 3 samples drops the oldest sample and leaves one or two at nearly
    # equal weight, no better than none: segments shorter than 4 samples are rectangular
    taper = hann_taper(seg) if seg >= 4 else np.ones(seg)
    spec = np.fft.rfft(frames * taper.astype(np.float32), axis=-1)
    power = np.log10(np.abs(spec) ** 2 + POWER_FLOOR).astype(np.float32)
    return np.swapaxes(power, -1, -2), np.fft.rfftfreq(seg, 1.0 / rate_hz)


def _torch_modules():
    """torch and the network classes (imported lazily: torch is slow to import)."""
    import torch

    from terrain.models.nets import Raw1dNet, Spectrogram2dNet
    return torch, Raw1dNet, Spectrogram2dNet


#: Held by every fit while it seeds and draws from torch's process-wide RNG (weight
#: initialisation and dropout draw from it): fits in threads of one process (joblib's
#: threading backend) drew from one another's seeded stream and moved a seed's
#: probabilities by up to 0.2; under this lock they run one at a time, as sequential fits.
_TORCH_RNG_LOCK = threading.RLock()

#: Held while a fit or prediction runs on a torch thread count of its own, and while one
#: reads the count it puts back. torch keeps the count per thread, but a thread takes the
#: count last set by any thread on its first torch call: a prediction started in a new thread
#: while another ran on 1 thread took 1 for the process's count, put it back last, and every
#: thread started later (a served request, a joblib worker) ran on 1 thread.
_TORCH_THREADS_LOCK = threading.RLock()


@contextmanager
def _torch_threads(torch, count: Callable[[int], int]):
    """Run the block on ``count(current)`` torch threads, the current count put back after.

    The count is read under :data:`_TORCH_THREADS_LOCK`, which is held through the block
    when the count changes (so no other thread starts on the temporary one) and released at
    once otherwise.
    """
    with _TORCH_THREADS_LOCK:
        threads = torch.get_num_threads()
        wanted = count(threads)
        if wanted != threads:
            torch.set_num_threads(wanted)
            try:
                yield
            finally:
                torch.set_num_threads(threads)
            return
    yield


class _WindowCNN(ClassifierMixin, BaseEstimator):
    """Shared training logic of the window CNNs (see the module docstring)."""

    def _inputs(self, X: np.ndarray) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def _module_spec(self, n_inputs: int, n_classes: int
                     ) -> tuple[type, dict]:  # pragma: no cover - abstract
        """The network class and its constructor arguments.

        skorch builds the module from them (``module__<arg>``) instead of being handed an
        instance: a module instance would be pickled with the fitted net as a plain
        parameter, so a net trained on a GPU could not be loaded where CUDA is absent,
        whereas skorch's own ``module_`` is mapped to the available device on loading.
        """
        raise NotImplementedError

    def _standardise(self, Z: np.ndarray) -> np.ndarray:
        Z = (Z - self.mean_) / self.scale_
        if getattr(self, "mask_", None) is not None:
            Z = Z * self.mask_
        return Z.astype(np.float32)

    def _augmented(self, Z: np.ndarray, y_idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Training inputs and labels as the network is fitted on them (here: unchanged)."""
        return Z, y_idx

    def _fit_scaling(self, Z: np.ndarray) -> None:
        # accumulated in float64, then cast: a float32 sum depends on the order in which
        # numpy visits the elements (the memory layout), and 5e-5 on the mean is enough
        # for training to take another path
        axes = (0,) + tuple(range(2 + self._per_bin, Z.ndim))
        self.mean_ = Z.mean(axis=axes, keepdims=True, dtype=np.float64)[0]
        std = Z.std(axis=axes, keepdims=True, dtype=np.float64)[0]
        self.mean_ = self.mean_.astype(np.float32)
        self.scale_ = np.where(std > 1e-8, std, 1.0).astype(np.float32)

    @staticmethod
    def _check_windows(X) -> np.ndarray:
        """Finite C-contiguous float32 windows, 2-D or 3-D, none empty, not booleans
        (ValueError otherwise).

        A non-empty float NumPy array that is finite in float32 is converted directly:
        scikit-learn's ``check_array`` accepts it unchanged and costs 0.06-0.1 ms per call,
        up to a tenth of the single-window budget. Anything else goes through ``check_array``.
        Every path returns a C-contiguous array: the same values laid out otherwise (a
        transposed view from the windowing, a copy, a joblib memmap) then train the same
        network, since float32 reductions depend on the order elements are visited in.
        """
        if type(X) is np.ndarray and X.ndim in (2, 3) and X.dtype.kind == "f" and X.size:
            X32 = np.ascontiguousarray(X, dtype=np.float32)
            if np.isfinite(X32).all():
                return X32
        if np.asarray(X).dtype.kind == "b":     # check_array reads them as 0.0 and 1.0
            raise ValueError("windows hold booleans (a mask?) where signal values are "
                             "expected")
        X = check_array(X, accept_sparse=False, ensure_2d=True, allow_nd=True,
                        dtype=np.float32, order="C")
        if X.ndim > 3:
            raise ValueError(f"expected 2-D or 3-D windows, got {X.ndim}-D")
        if X.ndim == 3 and 0 in X.shape[1:]:    # check_array counts only 2-D features
            raise ValueError(f"empty windows of shape {X.shape[1:]} (channels, samples)")
        return X

    def _device(self) -> str:
        import torch
        if self.device == "auto":
            return "cuda" if torch.cuda.is_available() else "cpu"
        return self.device

    def fit(self, X, y, groups=None, sample_weight=None):
        """Standardise on the training windows and train the network.

        Parameters
        ----------
        X : array-like
            ``(n_windows, n_channels, n_samples)`` raw windows (or 2-D: one channel).
        y : array-like
            ``(n_windows,)`` terrain labels.
        groups : array-like or None
            ``(n_windows,)`` run ids; required with ``early_stopping=True`` (the validation
            runs are held out whole).
        sample_weight : array-like or None
            ``(n_windows,)`` non-negative window weights. Each epoch then draws its
            ``n_windows`` training windows with replacement, with probabilities proportional
            to them (a seeded ``torch.utils.data.WeightedRandomSampler``), instead of
            shuffling every window once; the loss keeps its class weights. ``None``: every
            window once per epoch.

        Returns
        -------
        self

        Raises
        ------
        ConfigError
            ``max_epochs``, ``width`` or ``batch_size`` not an integer >= 1, ``batch_size``
            1 with windows too short for the network to train on one alone (see
            ``batch_size`` of the class), ``lr`` or
            ``weight_decay`` not a finite number >= 0, ``dropout`` not a
            number in [0, 1), ``n_threads`` neither ``None`` nor one, ``random_state`` not an
            integer in [0, 2**32 - 1];
            ``early_stopping=True`` without ``groups``, with ``patience`` not an integer >= 1,
            with ``validation_splits`` not an integer >= 2, above the number of runs or
            above the windows of every class, or with no validation split that leaves a
            training run of every class;
            (spectrogram CNN) ``augment_noise_std``
            not a finite number >= 0, ``band_limits_hz`` not one frequency >= 0 Hz (or
            ``inf``) per channel (a scalar, booleans or text included).
        ValueError
            ``sample_weight`` not numbers (booleans, text), negative or all 0
            (on the training runs: the early-stopping runs are never drawn);
            windows not finite, booleans, not 2-D or 3-D, or empty (0 channels or 0
            samples). A refused fit leaves the model as it was (unfitted, or its previous
            fit whole: :func:`~terrain.models.cv.restored_on_failure`).
        ShapeError
            ``sample_weight`` not of shape ``(n_windows,)`` (a scalar, 2-D, another length).
        NonFiniteInputError
            A label of ``y`` is missing (NaN or None), named by its index; a weight of
            ``sample_weight`` NaN or infinite.
        MixedTypesError
            Values of types that do not sort together (text or booleans beside numbers) in ``y``, or
            ``groups`` with early stopping (:func:`~terrain.models.cv.class_keeping_split`)
            (:func:`terrain.errors.refuse_mixed_types`).
        """
        with restored_on_failure(self):
            return self._fit(X, y, groups, sample_weight)

    def _fit(self, X, y, groups, sample_weight):
        """:meth:`fit` itself (which puts the previous fit back where this raises)."""
        from skorch import NeuralNetClassifier
        from skorch.callbacks import EarlyStopping
        from skorch.dataset import Dataset
        from skorch.helper import predefined_split

        config_integer("max_epochs", self.max_epochs, 1)
        config_integer("width", self.width, 1)
        # torch's and skorch's own refusals came mid-fit (dropout NaN: a RuntimeError);
        # lr=True was taken as a learning rate of 1 (lr=0 keeps the initial weights)
        owner = type(self).__name__
        config_positive(owner, allow_zero=True, lr=self.lr, weight_decay=self.weight_decay)
        config_integer("batch_size", self.batch_size, 1)
        config_numbers(owner, dropout=self.dropout)
        if not 0.0 <= self.dropout < 1.0:
            raise ConfigError(f"{owner}.dropout must be in [0, 1), got {self.dropout!r}")
        # torch.Generator.manual_seed takes Python integers only; numpy's seeds end at 2**32
        config_integer("random_state", self.random_state, 0, 2 ** 32 - 1)
        seed = int(self.random_state)
        if self.n_threads is not None:
            config_integer("n_threads", self.n_threads, 1)
        X = self._check_windows(X)
        y = column_or_1d(y, warn=True)
        check_consistent_length(X, y)
        # (None beside text reached NumPy's bare "'<' not supported" in np.unique)
        refuse_missing(type(self).__name__, "y", y, "label(s)")
        refuse_mixed_types(type(self).__name__, "y", y)
        check_classification_targets(y)
        self.n_features_in_ = X.shape[1]
        self.window_shape_ = as_windows(X).shape[1:]
        self.classes_, y_idx = np.unique(y, return_inverse=True)
        if len(self.classes_) < 2:
            raise ValueError("need at least 2 classes, got 1 class")
        torch, _, _ = _torch_modules()
        Z = self._inputs(as_windows(X))
        fit_idx = val_idx = None
        if self.early_stopping:
            if groups is None:
                raise ConfigError("early_stopping needs the run of every window (groups)")
            # skorch stops when its count of epochs without improvement equals the patience:
            # 0 stopped every fit after its first epoch, -1 or 2.5 never stopped one
            config_integer("patience", self.patience, 1)
            fit_idx, val_idx = class_keeping_split(
                y, groups, self.validation_splits, self.random_state, "early stopping",
                "validation_splits", "early_stopping=False")
        # the normalisation statistics come from the windows the network trains on: the
        # validation runs held out for early stopping take no part in them
        self._fit_scaling(Z if fit_idx is None else Z[fit_idx])
        self.mask_ = self._band_mask(X.shape[-1], Z.shape)
        Z = self._standardise(Z)
        y_idx = y_idx.astype(np.int64)
        if sample_weight is not None:
            kind = np.asarray(sample_weight).dtype.kind
            if kind not in "iuf":   # .astype(float) read a mask as 1 / 0, the text "2" as 2
                raise ValueError(f"sample_weight must hold numbers, got dtype "
                                 f"{np.asarray(sample_weight).dtype} (booleans: a mask?)")
            sample_weight = np.asarray(sample_weight, dtype=float)
            # (scikit-learn's column_or_1d named a scalar or 2-D one "y", its length check
            # named neither: "inconsistent numbers of samples: [12, 3]")
            if sample_weight.shape != y_idx.shape:
                raise ShapeError(f"sample_weight must hold one weight per window, shape "
                                 f"{y_idx.shape}; got shape {sample_weight.shape} "
                                 "(inconsistent numbers of samples)")
            if not np.isfinite(sample_weight).all():
                raise NonFiniteInputError("sample_weight must be finite and >= 0, got "
                                          f"{int((~np.isfinite(sample_weight)).sum())} NaN "
                                          "or infinite weight(s), the first at index "
                                          f"{np.flatnonzero(~np.isfinite(sample_weight))[0]}")
            if not ((sample_weight >= 0).all() and sample_weight.sum() > 0):
                raise ValueError("sample_weight must be finite and >= 0, and the weights not "
                                 "all zero")
        train_split, callbacks = None, []
        self.validation_groups_ = np.asarray([] if groups is None else groups)[:0]
        if fit_idx is None:
            fit_idx = np.arange(len(Z))
        else:
            self.validation_groups_ = np.unique(np.asarray(groups)[val_idx])
            train_split = predefined_split(Dataset(Z[val_idx], y_idx[val_idx]))
            callbacks = [EarlyStopping(patience=self.patience, load_best=True)]
        if sample_weight is not None and not sample_weight[fit_idx].sum() > 0:
            raise ValueError("sample_weight is 0 on every training window (the runs held out "
                             "for early stopping, validation_groups_, are never drawn)")
        # the loss's class weights balance the windows the network trains on: the
        # validation runs held out for early stopping take no part in them
        counts = np.bincount(y_idx[fit_idx], minlength=len(self.classes_)).astype(np.float32)
        weight = counts.sum() / (len(counts) * np.maximum(counts, 1))
        # torch.manual_seed reseeds every CUDA device too: fork their RNGs as well, so a
        # fit leaves the caller's random streams as it found them on a GPU machine too
        cuda = list(range(torch.cuda.device_count())) if torch.cuda.is_available() else []
        with _TORCH_RNG_LOCK, _torch_threads(torch, lambda threads: self.n_threads or threads):
            with torch.random.fork_rng(devices=cuda):
                torch.manual_seed(seed)
                gen = torch.Generator().manual_seed(seed)
                Z_fit, y_fit = self._augmented(Z[fit_idx], y_idx[fit_idx])
                if sample_weight is None:
                    order = {"iterator_train__shuffle": True, "iterator_train__generator": gen}
                else:   # an augmented copy repeats the windows: it repeats their weights
                    w = np.tile(sample_weight[fit_idx], len(y_fit) // len(fit_idx))
                    sampler = torch.utils.data.WeightedRandomSampler(
                        torch.as_tensor(w, dtype=torch.double), len(y_fit), replacement=True,
                        generator=gen)
                    order = {"iterator_train__shuffle": False,
                             "iterator_train__sampler": sampler}
                module, module_args = self._module_spec(Z.shape[1], len(self.classes_))
                order.update(self._lone_window_batch(len(y_fit), Z.shape[1:], module,
                                                     module_args))
                self.net_ = NeuralNetClassifier(
                    module, **{f"module__{k}": v for k, v in module_args.items()},
                    criterion=torch.nn.CrossEntropyLoss,
                    criterion__weight=torch.as_tensor(weight),
                    optimizer=torch.optim.AdamW, lr=self.lr,
                    optimizer__weight_decay=self.weight_decay,
                    max_epochs=self.max_epochs, batch_size=self.batch_size, **order,
                    train_split=train_split, callbacks=callbacks, device=self._device(),
                    verbose=0, classes=np.arange(len(self.classes_)))
                self.net_.fit(Z_fit, y_fit)
                # the sampler (it holds the training weights), the generator and the
                # validation split (it holds the validation windows) only serve training;
                # the fitted model does not carry them (skorch's set_params refuses
                # iterator-only changes on a fitted net, hence setattr)
                for key in ("iterator_train__sampler", "iterator_train__generator",
                            "train_split"):
                    if key in vars(self.net_):
                        setattr(self.net_, key, None)
        self.n_epochs_ = len(self.net_.history)
        return self

    def _lone_window_batch(self, n_train: int, window_shape, module, module_args) -> dict:
        """skorch's training-iterator settings for a last minibatch of one window.

        A window short enough that one of the network's batch normalisations sees a single
        position of it (:func:`~terrain.models.nets.normalises_one_value`) cannot be trained
        on alone: torch refuses one value per channel in training mode. Such a last batch
        (``n_train`` one more than a multiple of ``batch_size``) is left out of the epoch
        (``drop_last``: a different window each epoch, as the order is drawn anew); longer
        windows keep it. ``batch_size`` 1 would leave no batch: it is refused.
        """
        if self.batch_size > 1 and n_train % self.batch_size != 1:
            return {}
        import torch

        from terrain.models.nets import normalises_one_value

        with torch.random.fork_rng(devices=[]):    # the probe draws no weight of the fit
            lone = normalises_one_value(module(**module_args), window_shape)
        if not lone:
            return {}
        if self.batch_size == 1:
            raise ConfigError(f"{type(self).__name__}: batch_size 1 trains on batches of one "
                              f"window, and windows of shape {tuple(self.window_shape_)} "
                              "(channels, samples) leave a batch normalisation of the network "
                              "one value per channel, which torch cannot train on: give "
                              "batch_size >= 2 or longer windows")
        return {"iterator_train__drop_last": True}

    def predict_proba(self, X) -> np.ndarray:
        """Class probabilities.

        Parameters
        ----------
        X : array-like
            ``(n_windows, n_channels, n_samples)`` raw windows, or 2-D ``(n_windows,
            n_samples)`` one-channel windows, in the layout ``fit`` was given:
            ``n_features_in_`` is ``X.shape[1]`` of ``fit`` (the channels of 3-D windows, the
            samples of 2-D ones), so a model fitted on 3-D one-channel windows refuses them
            2-D and one fitted on 2-D windows refuses them 3-D.

        Returns
        -------
        numpy.ndarray
            ``(n_windows, n_classes)``, columns in the order of ``classes_``; float64 rows
            summing to 1 within float64 rounding.

        Raises
        ------
        ValueError
            ``X.shape[1]`` other than ``n_features_in_`` (another number of channels than
            in ``fit``, or another layout, see ``X``); windows not finite, booleans, not
            2-D or 3-D, or empty (0 channels or 0 samples).
        ShapeError
            Windows of another length than in ``fit`` (``window_shape_``; a model saved
            before it was recorded takes any length).
        """
        import torch

        check_is_fitted(self, "net_")
        X = self._check_windows(X)
        if X.shape[1] != self.n_features_in_:
            raise ValueError(f"X has {X.shape[1]} features, but {type(self).__name__} is "
                             f"expecting {self.n_features_in_} features as input (channels)")
        shape = getattr(self, "window_shape_", None)     # None: saved before it was kept
        if shape is not None and X.shape[-1] != shape[-1]:
            raise ShapeError(f"{type(self).__name__} was fitted on windows of shape {shape} "
                             f"(channels, samples) and got {as_windows(X).shape[1:]}: "
                             "windows of another length run through its pooling but are "
                             "off its training distribution; cut them as for training")

        Z = self._standardise(self._inputs(as_windows(X)))
        module = self.net_.module_
        if module.training:      # eval() walks every submodule (~0.1 ms): only when needed
            module.eval()
        device = next(module.parameters()).device
        out = [np.zeros((0, len(self.classes_)), dtype=np.float32)]
        # direct forward (no DataLoader overhead); one thread for small batches, where
        # thread synchronisation costs more than it saves
        with _torch_threads(torch, lambda threads: 1 if len(Z) <= 64
                            else (self.n_threads or threads)), torch.inference_mode():
            for start in range(0, len(Z), 1024):
                logits = module(torch.as_tensor(Z[start:start + 1024], device=device))
                out.append(torch.softmax(logits, dim=1).cpu().numpy())
        # the float32 softmax sums to 1 within ~1e-7 only, outside scikit-learn's float64
        # tolerance (log_loss warned "do not sum to one"): each row is divided by its own
        # float64 sum, which keeps its order (the decisions) and every value in [0, 1]
        proba = np.concatenate(out).astype(np.float64)
        return proba / proba.sum(axis=1, keepdims=True)

    def predict(self, X) -> np.ndarray:
        """Most probable terrain of each window.

        Parameters
        ----------
        X : array-like
            ``(n_windows, n_channels, n_samples)`` raw windows (or 2-D: one channel).

        Returns
        -------
        numpy.ndarray
            ``(n_windows,)`` labels from ``classes_``.
        """
        proba = self.predict_proba(X)
        return self.classes_[proba.argmax(axis=1)]

    def _band_mask(self, n_samples: int, shape) -> np.ndarray | None:
        return None

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.non_deterministic = False
        return tags


class RawCNNClassifier(_WindowCNN):
    """1-D CNN over the raw, per-channel standardised window signals.

    Parameters
    ----------
    max_epochs : int
        Fixed epoch budget (upper bound with ``early_stopping``).
    lr : float
        AdamW learning rate.
    weight_decay : float
        AdamW decoupled weight decay.
    batch_size : int
        Windows per minibatch. Where the windows are so short that a batch normalisation
        sees one position of a window (8 samples or fewer for the raw CNN), a last minibatch
        of one window is left out of each epoch (torch cannot train on it), and 1 is
        refused; otherwise every window is trained on in every epoch.
    width : int
        Filters of the first convolution (later layers use twice as many).
    dropout : float
        Dropout before the linear head, in [0, 1).
    early_stopping : bool
        Stop on the validation loss of whole held-out runs (needs ``groups`` in ``fit``).
    validation_splits : int
        ``1 / validation_splits`` of the training runs are held out for early stopping.
    patience : int
        Epochs without validation improvement before stopping (>= 1).
    random_state : int
        Seed of weights, shuffling, dropout and the validation split, in [0, 2**32 - 1].
    device : str
        ``"auto"`` (CUDA when available, else CPU), ``"cpu"`` or a torch device string.
    n_threads : int or None
        torch CPU threads during ``fit`` (restored afterwards); ``None`` keeps torch's.

    Attributes
    ----------
    classes_ : numpy.ndarray
        Terrain labels, in the order of ``predict_proba``.
    mean_, scale_ : numpy.ndarray
        ``(n_channels, 1)`` training-window mean and standard deviation per channel.
    window_shape_ : tuple of int
        ``(n_channels, n_samples)`` of the training windows; ``predict_proba`` refuses
        another.
    net_ : skorch.NeuralNetClassifier
        The trained network.
    n_epochs_ : int
        Epochs run.
    validation_groups_ : numpy.ndarray
        Runs held out of training for early stopping (validated on, never trained on;
        the first split that leaves every class a training run); empty without it.
    """

    _per_bin = 0

    def __init__(self, max_epochs: int = 30, lr: float = 3e-3, weight_decay: float = 1e-2,
                 batch_size: int = 64, width: int = 32, dropout: float = 0.3,
                 early_stopping: bool = False, validation_splits: int = 5, patience: int = 5,
                 random_state: int = 0, device: str = "auto", n_threads: int | None = None
                 ) -> None:
        self.max_epochs = max_epochs
        self.lr = lr
        self.weight_decay = weight_decay
        self.batch_size = batch_size
        self.width = width
        self.dropout = dropout
        self.early_stopping = early_stopping
        self.validation_splits = validation_splits
        self.patience = patience
        self.random_state = random_state
        self.device = device
        self.n_threads = n_threads

    def _inputs(self, X: np.ndarray) -> np.ndarray:
        return X

    def _module_spec(self, n_inputs: int, n_classes: int) -> tuple[type, dict]:
        _, Raw1dNet, _ = _torch_modules()
        return Raw1dNet, {"n_channels": n_inputs, "n_classes": n_classes,
                          "width": self.width, "dropout": self.dropout}


class SpectrogramCNNClassifier(_WindowCNN):
    """2-D CNN on per-channel log short-time spectra stacked as image channels (BorealTC).

    Parameters
    ----------
    rate_hz : float
        Sampling rate of the windows, Hz.
    segment_s : float
        STFT segment length, s.
    hop_s : float
        STFT hop, s.
    band_limits_hz : tuple of float or None
        ``(n_channels,)`` highest meaningful frequency of each channel, Hz (the Nyquist
        frequency of its native sensor rate; ``inf`` for channels sampled at ``rate_hz``).
        Bins above it are zeroed after standardisation. ``None``: no limit. NaN or a
        negative limit is refused (``ConfigError`` in ``fit``).
    max_epochs : int
        Fixed epoch budget (upper bound with ``early_stopping``).
    lr : float
        AdamW learning rate.
    weight_decay : float
        AdamW decoupled weight decay.
    batch_size : int
        Windows per minibatch. Where the windows are so short that a batch normalisation
        sees one position of a window (8 samples or fewer for the raw CNN), a last minibatch
        of one window is left out of each epoch (torch cannot train on it), and 1 is
        refused; otherwise every window is trained on in every epoch.
    width : int
        Filters of the first convolution (later layers use twice as many).
    dropout : float
        Dropout before the linear head, in [0, 1).
    early_stopping : bool
        Stop on the validation loss of whole held-out runs (needs ``groups`` in ``fit``).
    validation_splits : int
        ``1 / validation_splits`` of the training runs are held out for early stopping.
    patience : int
        Epochs without validation improvement before stopping (>= 1).
    random_state : int
        Seed of weights, shuffling, dropout and the validation split, in [0, 2**32 - 1].
    device : str
        ``"auto"`` (CUDA when available, else CPU), ``"cpu"`` or a torch device string.
    n_threads : int or None
        torch CPU threads during ``fit`` (restored afterwards); ``None`` keeps torch's.
    augment_noise_std : float
        When > 0, the network is fitted on every training window's standardised log
        spectra plus one copy perturbed by white noise of this standard deviation per bin
        (in units of the training standard deviation; the band mask applied after it), drawn
        from ``random_state``. 0: no copy (the default). On BorealTC run-grouped, 0.3 lifts
        the SVM + spectrogram-CNN vote by about a point with non-overlapping training
        windows, and does nothing on the held-out streams with overlapping ones
        (docs/model_comparison.md, "More members"; docs/streaming.md).

    Attributes
    ----------
    classes_ : numpy.ndarray
        Terrain labels, in the order of ``predict_proba``.
    mean_, scale_ : numpy.ndarray
        ``(n_channels, n_freqs, 1)`` training mean and standard deviation of every
        channel's log power per frequency bin.
    freqs_hz_ : numpy.ndarray
        ``(n_freqs,)`` bin frequencies, Hz.
    window_shape_ : tuple of int
        ``(n_channels, n_samples)`` of the training windows; ``predict_proba`` refuses
        another.
    net_ : skorch.NeuralNetClassifier
        The trained network.
    n_epochs_ : int
        Epochs run.
    validation_groups_ : numpy.ndarray
        Runs held out of training for early stopping (validated on, never trained on;
        the first split that leaves every class a training run); empty without it.
    """

    _per_bin = 1
    #: models pickled before the parameter existed unpickle with no noise copy
    augment_noise_std = 0.0

    def __init__(self, rate_hz: float = 100.0, segment_s: float = 0.5, hop_s: float = 0.2,
                 band_limits_hz: Sequence[float] | None = None, max_epochs: int = 30,
                 lr: float = 3e-3, weight_decay: float = 1e-2, batch_size: int = 64,
                 width: int = 16, dropout: float = 0.3, early_stopping: bool = False,
                 validation_splits: int = 5, patience: int = 5, random_state: int = 0,
                 device: str = "auto", n_threads: int | None = None,
                 augment_noise_std: float = 0.0) -> None:
        self.rate_hz = rate_hz
        self.segment_s = segment_s
        self.hop_s = hop_s
        self.band_limits_hz = band_limits_hz
        self.max_epochs = max_epochs
        self.lr = lr
        self.weight_decay = weight_decay
        self.batch_size = batch_size
        self.width = width
        self.dropout = dropout
        self.early_stopping = early_stopping
        self.validation_splits = validation_splits
        self.patience = patience
        self.random_state = random_state
        self.device = device
        self.n_threads = n_threads
        self.augment_noise_std = augment_noise_std

    def _inputs(self, X: np.ndarray) -> np.ndarray:
        return log_spectrogram(X, self.rate_hz, self.segment_s, self.hop_s)[0]

    def _augmented(self, Z: np.ndarray, y_idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The standardised spectra and one noise-perturbed copy (``augment_noise_std``)."""
        config_positive(type(self).__name__, allow_zero=True,
                        augment_noise_std=self.augment_noise_std)
        if self.augment_noise_std == 0:
            return Z, y_idx
        rng = np.random.default_rng(self.random_state)
        copy = Z + rng.normal(0.0, self.augment_noise_std, Z.shape).astype(np.float32)
        if self.mask_ is not None:     # set by ``fit`` before it calls this
            copy = copy * self.mask_
        return np.concatenate([Z, copy]), np.concatenate([y_idx, y_idx])

    def _band_mask(self, n_samples: int, shape) -> np.ndarray | None:
        seg = segment_samples(self.rate_hz, self.segment_s, n_samples)
        self.freqs_hz_ = np.fft.rfftfreq(seg, 1.0 / self.rate_hz)
        if self.band_limits_hz is None:
            return None
        given = np.asarray(self.band_limits_hz)
        if given.dtype.kind not in "iuf":   # (True,) and ("3",) were limits of 1 and 3 Hz
            raise ConfigError(f"band_limits_hz must hold numbers (Hz), got dtype {given.dtype}")
        limits = given.astype(float)
        if limits.shape != (shape[1],):
            raise ConfigError(f"band_limits_hz must give one frequency per channel, a "
                              f"sequence of {shape[1]}; got shape {limits.shape}")
        if not (limits >= 0).all():     # NaN or < 0: no bin is kept, the channel drops out
            raise ConfigError(f"band_limits_hz must be frequencies >= 0 Hz (inf: no limit), "
                              f"got {tuple(limits.tolist())}")
        return (self.freqs_hz_[None, :] <= limits[:, None]).astype(np.float32)[..., None]

    def _module_spec(self, n_inputs: int, n_classes: int) -> tuple[type, dict]:
        _, _, Spectrogram2dNet = _torch_modules()
        return Spectrogram2dNet, {"n_channels": n_inputs, "n_classes": n_classes,
                                  "width": self.width, "dropout": self.dropout}
