"""The network: a small multi-head MLP on standardised pair features.

Heads
-----
``detect``   one logit of "damaged" (calibrated afterwards by a logit scale and bias,
             :func:`learn.network.estimator.fit_calibration`).
``locate``   logits over ``n_bins`` equal bins of ``x / L`` (a distribution along the beam).
``support``  one logit of "the supports changed beyond re-clamping" (an intact specimen, datasets with
             ``specimen.support_change_fraction`` > 0; untrained otherwise).
``size``     mean and log standard deviation of the damage size through its kind's ``size_transform``
             (:class:`learn.network.size.SizeTransform`, :func:`learn.network.features.labels`)
             (the mean by least squares, the spread by the Gaussian negative log-likelihood of the mean's
             residuals; damaged pairs only).
"""

from __future__ import annotations

import math

import torch
from torch import nn

from learn.network.forward import LOG_STD_MAX, LOG_STD_MIN

__all__ = ["DamageNet", "LOG_STD_MAX", "LOG_STD_MIN", "SIZE_MEAN_WEIGHT", "loss_terms"]


class DamageNet(nn.Module):
    """Shared trunk and four heads.

    Parameters
    ----------
    n_features : int
    n_bins : int
        Location bins over ``x / L`` (a multiple of 4 so the thesis's elements are unions of bins).
    hidden : int
    depth : int
        Hidden layers of the trunk.
    dropout : float
    """

    def __init__(self, n_features: int, n_bins: int = 80, hidden: int = 128, depth: int = 3, dropout: float = 0.05):
        super().__init__()
        layers, d = [], n_features
        for _ in range(depth):
            layers += [nn.Linear(d, hidden), nn.GELU(), nn.Dropout(dropout)]
            d = hidden
        self.trunk = nn.Sequential(*layers)
        self.detect = nn.Linear(hidden, 1)
        self.locate = nn.Linear(hidden, n_bins)
        self.size = nn.Linear(hidden, 2)
        self.support = nn.Linear(hidden, 1)

    def forward(self, x: torch.Tensor) -> dict:
        h = self.trunk(x)
        s = self.size(h)
        spread = self.size(h.detach())[:, 1]   # the spread reads the features; it does not shape them
        return {"detect": self.detect(h)[:, 0], "support": self.support(h)[:, 0], "locate": self.locate(h),
                "size_mean": s[:, 0],
                "size_log_std": LOG_STD_MIN + (LOG_STD_MAX - LOG_STD_MIN) * torch.sigmoid(spread)}


#: Weight of the size mean's squared ``ln`` error. The mean is fitted by least squares with this fixed weight and
#: the spread by the Gaussian negative log-likelihood of the (detached) residuals, so that a small spread does not
#: turn the size into the loss that shapes the shared features (``exp(-2)``: the weight at the spread ``e``).
SIZE_MEAN_WEIGHT = math.exp(-2.0)


def loss_terms(out: dict, damaged: torch.Tensor, loc_target: torch.Tensor, log_size: torch.Tensor,
               support: torch.Tensor | None = None) -> dict:
    """Losses of one batch.

    Parameters
    ----------
    damaged : (B,) float 0/1
    support : (B,) float 0/1, optional   supports changed beyond re-clamping (no ``support`` term without it)
    loc_target : (B, n_bins) soft target distribution (rows of intact pairs are ignored)
    log_size : (B,) the transformed size (ignored where intact)
    """
    det = nn.functional.binary_cross_entropy_with_logits(out["detect"], damaged)
    m = damaged > 0.5
    if m.any():
        logp = torch.log_softmax(out["locate"][m], dim=1)
        loc = -(loc_target[m] * logp).sum(dim=1).mean()
        ls = out["size_log_std"][m]
        r = log_size[m] - out["size_mean"][m]
        size = (SIZE_MEAN_WEIGHT * 0.5 * r ** 2 + 0.5 * (r.detach() / ls.exp()) ** 2 + ls).mean()
    else:
        loc = size = out["detect"].sum() * 0.0
    sup = (out["detect"].sum() * 0.0 if support is None
           else nn.functional.binary_cross_entropy_with_logits(out["support"], support))
    return {"detect": det, "locate": loc, "size": size, "support": sup}
