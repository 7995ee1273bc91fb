"""PyTorch networks of the window CNNs (:mod:`terrain.models.cnn`).

Module-level classes so the fitted classifiers pickle (MLflow serving stores them with
joblib).
"""

from __future__ import annotations

import torch
from torch import nn


def normalises_one_value(module: nn.Module, window_shape) -> bool:
    """Whether one window alone gives a batch normalisation of ``module`` one value per
    channel (training on a batch of that one window then fails in torch).

    A batch normalisation in training mode averages each channel over the windows of the
    batch and the positions the layers before it leave; a short window can leave one.

    Parameters
    ----------
    module : torch.nn.Module
        The network (its mode and weights are left as they are; it runs on its device).
    window_shape : tuple of int
        Shape of one input window without the batch axis: ``(n_channels, n_samples)`` for
        :class:`Raw1dNet`, ``(n_channels, n_freqs, n_frames)`` for
        :class:`Spectrogram2dNet`.

    Returns
    -------
    bool
        True when a batch normalisation sees one position of one window.
    """
    positions = []
    norms = [m for m in module.modules() if isinstance(m, (nn.BatchNorm1d, nn.BatchNorm2d))]
    hooks = [m.register_forward_pre_hook(
        lambda _, args: positions.append(args[0][0, 0].numel())) for m in norms]
    was_training = module.training
    device = next(module.parameters()).device
    try:
        with torch.no_grad():
            module.eval()(torch.zeros((1, *window_shape), device=device))
    finally:
        for hook in hooks:
            hook.remove()
        module.train(was_training)
    return min(positions, default=2) < 2


class Raw1dNet(nn.Module):
    """Conv1d(k7, stride 2)-BN-ReLU-pool, Conv1d(k5)-BN-ReLU-pool, Conv1d(k3)-BN-ReLU,
    global average, dropout, linear.

    Input ``(batch, n_channels, n_samples)`` standardised windows (any length of 1 sample
    or more: the global average takes what the strides and pools leave; in training mode a
    batch of one window needs 9 samples or more, since the last batch normalisation sees
    ``ceil(n_samples / 8)`` positions, see :func:`normalises_one_value`).

    Parameters
    ----------
    n_channels : int
        Input channels (window channels).
    n_classes : int
        Output logits.
    width : int
        Filters of the first convolution (later layers: twice as many).
    dropout : float
        Dropout before the linear head.
    """

    def __init__(self, n_channels: int = 1, n_classes: int = 2, width: int = 32,
                 dropout: float = 0.3) -> None:
        super().__init__()

        def block(cin, cout, k, stride, pool):
            layers = [nn.Conv1d(cin, cout, k, stride=stride, padding=k // 2),
                      nn.BatchNorm1d(cout), nn.ReLU()]
            return layers + ([nn.MaxPool1d(2, ceil_mode=True)] if pool else [])

        self.body = nn.Sequential(*block(n_channels, width, 7, 2, True),
                                  *block(width, width, 5, 1, True),
                                  *block(width, 2 * width, 3, 1, False),
                                  nn.AdaptiveAvgPool1d(1), nn.Flatten(), nn.Dropout(dropout))
        self.head = nn.Linear(2 * width, n_classes)

    def forward(self, X):
        """Class logits of a batch.

        Parameters
        ----------
        X : torch.Tensor
            Input batch (see the class docstring for its shape).

        Returns
        -------
        torch.Tensor
            ``(batch, n_classes)`` logits.
        """
        return self.head(self.body(X))


class Spectrogram2dNet(nn.Module):
    """Conv2d(3x3)-BN-ReLU-pool, Conv2d(3x3)-BN-ReLU, average over time and into
    ``n_bands`` frequency bands (frequency position is the information), dropout, linear.

    Input ``(batch, n_channels, n_freqs, n_frames)`` log spectra.

    Parameters
    ----------
    n_channels : int
        Input channels (window channels).
    n_classes : int
        Output logits.
    width : int
        Filters of the first convolution (later layers: twice as many).
    dropout : float
        Dropout before the linear head.
    n_bands : int
        Frequency bands kept by the final pooling.
    """

    def __init__(self, n_channels: int = 1, n_classes: int = 2, width: int = 32,
                 dropout: float = 0.3, n_bands: int = 8) -> None:
        super().__init__()
        self.body = nn.Sequential(
            nn.Conv2d(n_channels, width, 3, padding=1), nn.BatchNorm2d(width), nn.ReLU(),
            nn.MaxPool2d(2, ceil_mode=True),
            nn.Conv2d(width, 2 * width, 3, padding=1), nn.BatchNorm2d(2 * width),
            nn.ReLU(), nn.AdaptiveAvgPool2d((n_bands, 1)), nn.Flatten(),
            nn.Dropout(dropout))
        self.head = nn.Linear(2 * width * n_bands, n_classes)

    def forward(self, X):
        """Class logits of a batch.

        Parameters
        ----------
        X : torch.Tensor
            Input batch (see the class docstring for its shape).

        Returns
        -------
        torch.Tensor
            ``(batch, n_classes)`` logits.
        """
        return self.head(self.body(X))
