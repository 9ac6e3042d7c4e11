"""``DamageClassifier``: a scikit-learn style estimator around :class:`learn.network.models.DamageNet`.

``fit(X, y, groups)`` standardises the features (statistics of the training part only), holds out a validation part
by specimen (``groups``), trains the network, and fits a logit scale and bias on the validation logits (Guo et al.'s
2017 "temperature scaling" with Platt's bias) so that ``predict_proba`` is calibrated, a factor on the size head's
spread per level so that its 68 % and 95 % intervals cover as they say on the validation pairs called damaged
(:mod:`learn.network.size`), and the location's sharpness per level and spread (:mod:`learn.network.intervals`). Targets
``y`` have three columns: damaged (0/1), ``x / L`` of the damage (NaN if intact) and its size
(:func:`learn.network.features.labels`: the size of the data's damage kind, 0 if intact), learned through the kind's
:class:`learn.network.size.SizeTransform`.

Missing modes
-------------
Given ``feature_modes`` (the mode of each feature column, the modal and frequency inputs), the network answers
on any subset of the modes with at least ``min_modes`` present. A missing mode's features are NaN in ``X``; the
network reads the standardised features with those of missing modes set to 0 (the training mean) and one
presence indicator per mode. During training each mode of each pair in each batch is missing with probability
``missing_mode_probability`` (never fewer than ``min_modes`` present: the ``min_modes`` modes of largest draw are
kept), so every subset is trained on and about half the pairs a batch holds are complete. The detection threshold
is set per number of missing modes on the validation intact pairs with that many modes drawn missing. The
Mahalanobis distance of a pair with missing modes is the marginal one of its present features (the inverse of
the training covariance's sub-block of those features: the distance of the training distribution's marginal),
and its training percentile is taken among training pairs with the same features removed
(:meth:`DamageClassifier.training_percentile`).
"""

from __future__ import annotations

import inspect
import time
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np
from scipy.special import expit

from learn.network.features import split_by_specimen
from learn.network.forward import check_weights, forward
from learn.network.intervals import LEVELS, Z_OF_LEVEL, fit_curves, level_distributions, level_intervals, read_curves
from learn.network.size import LOG_SIZE_LIMIT, MAX_SIZE_LOG_STD, SizeTransform, fit_size_scales, read_size_scales
from physics.errors import BeamDamageError

__all__ = ["DamageClassifier", "DamagePrediction", "fit_calibration", "torch_threads"]


@dataclass(frozen=True)
class DamagePrediction:
    """Per-pair outputs of :meth:`DamageClassifier.predict_details` (arrays of shape (n,) unless noted)."""

    probability_damaged: np.ndarray
    location_distribution: np.ndarray      # (n, n_bins) over x/L bins
    x_over_L: np.ndarray                   # mean of the distribution
    x_std_over_L: np.ndarray
    element_probabilities: np.ndarray      # (n, Z) zones (the thesis's 4 elements)
    element: np.ndarray                    # 1..Z, most probable zone
    size: np.ndarray                      # median of the size estimate (signed for a signed kind)
    size_std: np.ndarray
    logit: np.ndarray                      # calibrated detection logit
    probability_support_change: np.ndarray  # supports changed beyond re-clamping (NaN: a model not trained on it)
    threshold: np.ndarray                  # the verdict's detection threshold of each pair (its missing modes')
    modes_present: np.ndarray              # (n, n_modes) bool, the modes each pair was answered on ((n, 0): no modes)
    intervals: dict                        # "x_over_L_68", "x_over_L_95", "size_68", "size_95": (n, 2) each
    level_distributions: dict              # "68", "95": (n, n_bins), the distribution each interval is read from


#: Bound of the network's raw outputs (far beyond any trained value), so that no exp of them overflows.
RAW_LIMIT = 1e3
#: Training rows kept (in training standard deviations) as the reference of the Mahalanobis distances of pairs
#: with missing modes: 5000 rows put the 99.9th percentile between the 5th and 6th largest.
REFERENCE_ROWS = 5000
#: Copies of the validation intact pairs, each with its own missing modes, that set a threshold per number of
#: missing modes.
THRESHOLD_COPIES = 4


def _device(name):
    import torch  # torch: training

    if name is not None:
        return torch.device(name)
    return torch.device("cuda" if torch.cuda.is_available() else "cpu")


@contextmanager
def torch_threads(n):
    """Run the block with ``n`` torch CPU threads (``None``: leave torch's setting), then restore it."""
    import torch  # torch: training

    before = torch.get_num_threads()
    if n is not None:
        torch.set_num_threads(int(n))
    try:
        yield
    finally:
        torch.set_num_threads(before)


def fit_calibration(logits, y) -> tuple[float, float]:
    """Temperature ``T`` and bias ``b`` minimising the log-loss of ``sigmoid(logit / T + b)``.

    Temperature scaling (Guo et al. 2017) with a bias term (Platt scaling): the
    bias absorbs a shift of the validation class balance. ``T`` is kept in
    [0.25, 20] so a perfectly separated validation split cannot drive it to 0.
    """
    from scipy.optimize import minimize

    z = np.asarray(logits, float)
    y = np.asarray(y, float)

    def nll(p):
        s = z / np.exp(p[0]) + p[1]
        return np.mean(np.logaddexp(0.0, s) - y * s)

    res = minimize(nll, np.zeros(2), method="L-BFGS-B", bounds=[(np.log(0.25), np.log(20.0)), (-10.0, 10.0)])
    return float(np.exp(res.x[0])), float(res.x[1])


class DamageClassifier:
    """Detect, localise and size damage from pair features.

    A scikit-learn estimator (``get_params``, ``set_params``, ``clone``, its tags and checks) that does not import
    scikit-learn: that import (about 1 s) would be paid by every ``classify``.

    Parameters
    ----------
    n_bins : int
        Location bins over ``x / L``.
    hidden, depth, dropout : network size (:class:`learn.network.models.DamageNet`)
    epochs, batch_size, lr, weight_decay : optimisation (AdamW, cosine schedule)
    loc_sigma_bins : float
        Standard deviation (in bins) of the Gaussian soft location target.
    val_fraction : float
        Share of specimens held out for calibration and the decision threshold.
    false_alarm_target : float
        The verdict "damaged" needs a probability above the ``1 - false_alarm_target``
        quantile of the validation intact pairs' probabilities (and above 0.5):
        the probabilities stay calibrated, the verdict controls false alarms.
    random_state : int
    device : str or None
        ``None`` picks CUDA when present, else CPU.
    n_threads : int or None
        torch CPU threads for ``fit`` (``None``: torch's own setting, usually one per core); one trains this
        small network fastest, and on a shared machine more were up to ten times slower.
    verbose : bool
        Show a tqdm bar over epochs.
    zone_edges : sequence of float or None
        Edges of the location zones over ``x / L`` (``0 ... 1``); None: the thesis's 4 elements. A zone's
        probability is the sum over the bins whose centre lies in it.
    size_transform : str
        What the size head learns (:class:`SizeTransform`): ``"log"`` (a slit's positive hinge flexibility) or
        ``"asinh:<scale>"`` (a signed size: a mass change); the damage kind's ``size_transform``.
    feature_modes : sequence of int or None
        The 0-based mode of each feature column: the network then answers pairs with missing modes (NaN
        features; module docstring). None: every feature always present (the FRF inputs).
    missing_mode_probability : float
        Probability that a mode of a training pair is missing in a batch (with ``feature_modes``).
    min_modes : int
        Fewest modes present the network answers on (with ``feature_modes``).
    mirrored : bool
        The network reads a symmetric beam's frequencies alone: its place is known up to ``x <-> L - x``, and
        the location's sharpness is fitted on the distributions folded onto ``x <= L / 2``
        (:mod:`learn.explanations.mirror`).
    """

    def __init__(self, n_bins=80, hidden=128, depth=3, dropout=0.05, epochs=60, batch_size=256, lr=2e-3,
                 weight_decay=1e-4, loc_sigma_bins=1.0, val_fraction=0.15, false_alarm_target=0.005, random_state=0,
                 device=None, n_threads=1, verbose=False, zone_edges=None, size_transform="log", feature_modes=None,
                 missing_mode_probability=0.15, min_modes=2, mirrored=False):
        self.n_bins, self.mirrored = n_bins, mirrored
        self.size_transform = size_transform
        self.zone_edges = zone_edges
        self.feature_modes = feature_modes
        self.missing_mode_probability = missing_mode_probability
        self.min_modes = min_modes
        self.hidden = hidden
        self.depth = depth
        self.dropout = dropout
        self.epochs = epochs
        self.batch_size = batch_size
        self.lr = lr
        self.weight_decay = weight_decay
        self.loc_sigma_bins = loc_sigma_bins
        self.val_fraction = val_fraction
        self.false_alarm_target = false_alarm_target
        self.random_state = random_state
        self.device = device
        self.n_threads = n_threads
        self.verbose = verbose

    # ------------------------------------------------------------------ scikit-learn's estimator protocol
    @classmethod
    def _get_param_names(cls) -> list[str]:
        return sorted(p for p in inspect.signature(cls.__init__).parameters if p != "self")

    def get_params(self, deep=True) -> dict:
        """The constructor's parameters (no nested estimators: ``deep`` changes nothing)."""
        return {name: getattr(self, name) for name in self._get_param_names()}

    def set_params(self, **params) -> "DamageClassifier":
        names = self._get_param_names()
        for name, value in params.items():
            if name not in names:
                raise ValueError(f"Invalid parameter {name!r} for estimator {type(self).__name__}. Valid parameters "
                                 f"are: {names!r}.")
            setattr(self, name, value)
        return self

    def __repr__(self) -> str:
        defaults = {n: p.default for n, p in inspect.signature(type(self).__init__).parameters.items()}
        changed = [f"{k}={v!r}" for k, v in self.get_params().items() if repr(v) != repr(defaults[k])]
        return f"{type(self).__name__}({', '.join(changed)})"

    def __sklearn_tags__(self):
        from sklearn.utils import ClassifierTags, Tags, TargetTags  # sklearn: asked only by scikit-learn itself

        return Tags(estimator_type="classifier", target_tags=TargetTags(required=True), transformer_tags=None,
                    regressor_tags=None, classifier_tags=ClassifierTags())

    # ------------------------------------------------------------------ helpers
    def _targets(self, y):
        y = np.asarray(y, float)
        if y.ndim != 2 or y.shape[1] not in (3, 4):
            raise BeamDamageError(f"y must have shape (n, 3) [damaged, x/L, size] or (n, 4) [..., "
                                  f"support changed], got {y.shape}")
        damaged = y[:, 0] > 0.5
        centres = (np.arange(self.n_bins) + 0.5) / self.n_bins
        sig = self.loc_sigma_bins / self.n_bins
        x = np.nan_to_num(y[:, 1], nan=0.5)
        soft = np.exp(-0.5 * ((centres[None] - x[:, None]) / sig) ** 2)
        soft /= soft.sum(axis=1, keepdims=True)
        tf = SizeTransform.parse(self.size_transform)
        log_size = np.where(damaged, tf.forward(np.where(damaged, y[:, 2], 1.0)), tf.forward(1.0))
        support = (y[:, 3] > 0.5) if y.shape[1] == 4 else np.zeros(len(y), bool)
        return (damaged.astype(np.float32), soft.astype(np.float32), log_size.astype(np.float32),
                support.astype(np.float32))

    @property
    def answers_missing_modes(self) -> bool:
        """Whether the network answers pairs with missing modes (``feature_modes`` given)."""
        return self.feature_modes is not None

    def _check_X(self, X) -> tuple[np.ndarray, np.ndarray]:
        """Fitted, and ``X`` an (n, n_features_in_) matrix (scikit-learn's conventions), else a BeamDamageError;
        returns ``X`` and the modes each row holds, (n, n_modes_) bool (a mode is missing where any of its
        features is NaN; (n, 0) for a network without ``feature_modes``)."""
        if not hasattr(self, "model_"):
            from sklearn.exceptions import NotFittedError  # sklearn: its error, raised only before fit

            raise NotFittedError(f"This {type(self).__name__} instance is not fitted yet. Call 'fit' with "
                                 "appropriate arguments before using this estimator.")
        X = np.asarray(X, float)
        if X.ndim != 2 or X.shape[1] != self.n_features_in_:
            raise BeamDamageError(f"X has {X.shape[-1] if X.ndim else 0} features (shape {X.shape}), but "
                                  f"DamageClassifier is expecting {self.n_features_in_} features as input")
        nan = np.isnan(X)
        if np.isinf(X).any() or (nan.any() and not self.answers_missing_modes):
            raise BeamDamageError("X must be finite (no NaN or inf)" if not self.answers_missing_modes else
                                  "X must be finite or NaN (a missing mode's features), not inf")
        if not self.answers_missing_modes:
            return X, np.ones((X.shape[0], 0), bool)
        cm = np.asarray(self.feature_modes, int)
        present = np.stack([~nan[:, cm == r].any(axis=1) for r in range(self.n_modes_)], axis=1)
        need = min(self.min_modes, self.n_modes_)                        # a model of fewer modes: all of them
        few = np.flatnonzero(present.sum(axis=1) < need)
        if few.size:
            raise BeamDamageError(f"row {few[0]} of X holds {int(present[few[0]].sum())} of {self.n_modes_} modes; "
                                  f"the network answers on {need} or more")
        return X, present

    def _standardised(self, X) -> tuple[np.ndarray, np.ndarray]:
        """Rows in training standard deviations (0 for a missing mode's features) and the modes they hold."""
        X, present = self._check_X(X)
        Z = (X - self.mean_) / self.scale_
        if self.answers_missing_modes:
            Z = np.where(present[:, self.feature_modes], Z, 0.0)
        return Z, present

    def _inputs(self, Z, present) -> np.ndarray:
        """The network's input: the standardised features, then one presence indicator per mode."""
        return np.concatenate([Z, present.astype(float)], axis=1) if self.answers_missing_modes else Z

    def _forward(self, A, batch=8192) -> dict:
        if self.model_ is None:              # a loaded model: its weights in NumPy (learn.network.forward)
            if not len(A):
                return {}
            return {k: np.clip(np.nan_to_num(v, nan=0.0), -RAW_LIMIT, RAW_LIMIT)
                    for k, v in forward(self.weights_, A).items()}
        import torch  # torch: the network being trained

        T = torch.as_tensor(A, dtype=torch.float32, device=self.device_)
        self.model_.eval()
        outs = []
        with torch.no_grad(), torch_threads(self.n_threads):
            for i in range(0, T.shape[0], batch):
                outs.append({k: v.cpu().numpy() for k, v in self.model_(T[i:i + batch]).items()})
        if not outs:
            return {}
        # float64, and finite: inputs far outside the training data can drive float32 outputs to +-inf
        return {k: np.clip(np.nan_to_num(np.concatenate([o[k] for o in outs]).astype(float), nan=0.0),
                           -RAW_LIMIT, RAW_LIMIT) for k in outs[0]}

    def _raw(self, X) -> tuple[dict, np.ndarray]:
        Z, present = self._standardised(X)
        return self._forward(self._inputs(Z, present)), present

    def _missing(self, present) -> np.ndarray:
        """The number of missing modes of each row (n,)."""
        return self.n_modes_ - present.sum(axis=1) if present.shape[1] else np.zeros(present.shape[0], int)

    def _thresholds_of(self, present) -> np.ndarray:
        """The detection threshold of each row: that of its number of missing modes."""
        return np.asarray(self.thresholds_, float)[self._missing(present)]

    # ------------------------------------------------------------------ fit
    def fit(self, X, y, groups=None):
        """Train on features ``X`` (n, d) and targets ``y`` (n, 3); ``groups`` = specimen keys (default: rows)."""
        with torch_threads(self.n_threads):
            return self._fit(X, y, groups)

    def _fit(self, X, y, groups):
        import torch  # torch: training

        from learn.network.models import DamageNet, loss_terms  # torch: the network

        X = np.asarray(X, float)
        if X.ndim != 2 or not np.all(np.isfinite(X)):
            raise BeamDamageError("X must be a finite 2-D feature matrix")
        if self.zone_edges is None and self.n_bins % 4:
            raise BeamDamageError(f"n_bins must be a multiple of 4 (the thesis's elements), got {self.n_bins}")
        self.n_modes_ = 0
        if self.answers_missing_modes:
            cm = np.asarray(self.feature_modes, int)
            if cm.shape != (X.shape[1],) or cm.min() < 0:
                raise BeamDamageError(f"feature_modes must give a 0-based mode for each of the {X.shape[1]} features")
            if not 0.0 <= self.missing_mode_probability < 1.0 or self.min_modes < 1:
                raise BeamDamageError("missing_mode_probability must lie in [0, 1) and min_modes be >= 1, got "
                                      f"{self.missing_mode_probability} and {self.min_modes}")
            self.n_modes_ = int(cm.max()) + 1
        t0 = time.perf_counter()
        rng = np.random.default_rng(self.random_state)
        groups = np.arange(X.shape[0]) if groups is None else np.asarray(groups)
        tr, va, _ = split_by_specimen(groups, (1 - self.val_fraction, self.val_fraction, 0.0), seed=self.random_state)
        self.mean_ = X[tr].mean(axis=0)
        self.scale_ = X[tr].std(axis=0) + 1e-8
        Z = (X[tr] - self.mean_) / self.scale_
        self.covariance_ = np.atleast_2d(np.cov(Z, rowvar=False)) + 1e-3 * np.eye(X.shape[1])
        self.precision_ = np.linalg.pinv(self.covariance_)
        self.reference_distances_ = np.sort(self._distances(Z))
        self.reference_features_ = (Z[np.sort(rng.choice(len(Z), min(REFERENCE_ROWS, len(Z)), replace=False))]
                                    .astype(np.float32) if self.answers_missing_modes else None)
        self.n_features_in_ = X.shape[1]
        self.classes_ = np.array([0, 1])
        self.device_ = _device(self.device)
        torch.manual_seed(self.random_state)
        gen = torch.Generator().manual_seed(self.random_state)
        self.model_ = DamageNet(X.shape[1] + self.n_modes_, self.n_bins, self.hidden, self.depth,
                                self.dropout).to(self.device_)
        d, soft, ls, sup = self._targets(y)
        self.support_trained_ = bool(sup[tr].any())
        Xt = torch.as_tensor(Z, dtype=torch.float32, device=self.device_)
        tgt = [torch.as_tensor(a[tr], device=self.device_) for a in (d, soft, ls)]
        if self.support_trained_:
            tgt.append(torch.as_tensor(sup[tr], device=self.device_))
        opt = torch.optim.AdamW(self.model_.parameters(), lr=self.lr, weight_decay=self.weight_decay)
        steps = self.epochs * int(np.ceil(len(tr) / self.batch_size))
        sched = torch.optim.lr_scheduler.OneCycleLR(opt, max_lr=self.lr, total_steps=max(steps, 1))
        cols = torch.as_tensor(np.asarray(self.feature_modes if self.answers_missing_modes else [], int),
                               device=self.device_)
        history = []
        epochs = range(self.epochs)
        if self.verbose:
            from tqdm.auto import tqdm
            epochs = tqdm(epochs, desc="train", unit="epoch", disable=None)     # None: only on a terminal
        for _ in epochs:
            self.model_.train()
            perm = torch.randperm(len(tr), generator=gen).to(self.device_)
            if self.answers_missing_modes:   # each pair's modes drawn missing anew every epoch
                present = torch.as_tensor(self._draw_present(len(tr), rng), dtype=torch.float32, device=self.device_)
            tot = 0.0
            for i in range(0, len(tr), self.batch_size):
                b = perm[i:i + self.batch_size]
                xb = Xt[b]
                if self.answers_missing_modes:
                    pb = present[b]
                    xb = torch.cat([xb * pb[:, cols], pb], dim=1)
                terms = loss_terms(self.model_(xb), *(t[b] for t in tgt))
                loss = terms["detect"] + terms["locate"] + 0.5 * terms["size"] + terms["support"]
                opt.zero_grad()
                loss.backward()
                opt.step()
                sched.step()
                tot += float(loss.detach()) * len(b)
            history.append(tot / len(tr))
        self.loss_history_ = history
        self.logit_scale_, self.bias_, self.size_std_scale_ = 1.0, 0.0, read_size_scales(1.0)
        self.location_sharpness_ = read_curves(1.0)
        self.thresholds_ = [0.5] * (1 + max(self.n_modes_ - self.min_modes, 0) * self.answers_missing_modes)
        if len(va):
            self._calibrate(X[va], d[va], ls[va], rng, np.asarray(y, float)[va, 1])
        self.threshold_ = self.thresholds_[0]
        self.train_seconds_ = time.perf_counter() - t0
        self.n_train_, self.n_val_ = len(tr), len(va)
        return self

    def _draw_present(self, n: int, rng, missing: int | None = None) -> np.ndarray:
        """Modes present in ``n`` rows, (n, n_modes_) bool: each missing with ``missing_mode_probability`` and
        the ``min_modes`` of largest draw always present; or exactly ``missing`` modes missing per row."""
        u = rng.random((n, self.n_modes_))
        rank = np.argsort(np.argsort(-u, axis=1), axis=1)               # 0 = the largest draw
        if missing is not None:
            return rank < self.n_modes_ - missing
        return (u >= self.missing_mode_probability) | (rank < self.min_modes)

    def _calibrate(self, Xv, dv, lsv, rng, xv) -> None:
        """Logit scale and bias (modes drawn missing as in training), then per number ``k`` of missing modes (all
        pairs, or ``THRESHOLD_COPIES`` copies with ``k`` drawn missing): the detection threshold on the intact pairs,
        and on the damaged pairs called damaged the size spread's factors and the location's sharpness curves
        (``xv``: their x / L), as classify answers a pair holding that many modes."""
        Zv = (Xv - self.mean_) / self.scale_

        def raw(rows, P):
            return self._forward(self._inputs(np.where(P[:, self.feature_modes], Zv[rows], 0.0)
                                              if self.answers_missing_modes else Zv[rows], P))

        every = np.arange(len(Zv))
        n_modes = self.n_modes_ if self.answers_missing_modes else 0
        mixed = raw(every, self._draw_present(len(Zv), rng) if n_modes else np.ones((len(Zv), 0), bool))
        self.logit_scale_, self.bias_ = fit_calibration(mixed["detect"], dv)
        (scales,), (curves,) = read_size_scales(1.0), read_curves(1.0)      # where too few pairs: the previous count's
        self.size_std_scale_, self.location_sharpness_ = [], []
        for k in range(len(self.thresholds_)):
            rows = np.tile(every, THRESHOLD_COPIES) if k else every
            r = raw(rows, self._draw_present(len(rows), rng, missing=k) if k else np.ones((len(rows), n_modes), bool))
            p = expit(r["detect"] / self.logit_scale_ + self.bias_)
            if (dv[rows] < 0.5).any():
                self.thresholds_[k] = float(max(0.5, np.quantile(p[dv[rows] < 0.5], 1 - self.false_alarm_target)))
            called = (dv[rows] > 0.5) & (p >= self.thresholds_[k])          # intervals are reported for these
            if called.sum() >= 10:
                t_std = np.exp(np.minimum(r["size_log_std"][called], LOG_SIZE_LIMIT))
                scales = fit_size_scales(lsv[rows][called], r["size_mean"][called], t_std)
                curves = fit_curves(r["locate"][called], xv[rows][called], self.mirrored)
            self.size_std_scale_.append(scales)
            self.location_sharpness_.append(curves)

    # ------------------------------------------------------------------ predict
    def _marginal(self, present_row) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The features a row with the modes ``present_row`` holds, (d,) bool; the marginal precision of those
        features (the inverse of the training covariance's sub-block); and the training pairs' sorted distances
        under it."""
        if not present_row.size or present_row.all():
            return np.ones(self.n_features_in_, bool), self.precision_, self.reference_distances_
        key = present_row.tobytes()
        cache = self.__dict__.setdefault("_marginals", {})
        if key not in cache:
            cols = present_row[np.asarray(self.feature_modes, int)]
            P = np.linalg.pinv(self.covariance_[np.ix_(cols, cols)])
            R = self.reference_features_[:, cols].astype(float)
            cache[key] = cols, P, np.sort(np.sqrt(np.maximum(np.einsum("ni,ij,nj->n", R, P, R), 0.0)))
        return cache[key]

    def _by_pattern(self, present):
        """``(rows, marginal)`` for each distinct set of present modes among the rows."""
        if not present.shape[1]:
            yield np.arange(present.shape[0]), self._marginal(np.ones(0, bool))
            return
        patterns, inverse = np.unique(present, axis=0, return_inverse=True)
        for k, pattern in enumerate(patterns):
            yield np.flatnonzero(inverse.reshape(-1) == k), self._marginal(pattern)

    def training_percentile(self, X) -> tuple[np.ndarray, np.ndarray]:
        """Mahalanobis distance of each row to the training features and the percentage of training pairs at or
        below it, shapes (n,). A row with missing modes is measured on its present features with the marginal
        precision of the training features, against the training pairs' distances on the same features."""
        Z, present = self._standardised(X)
        dist, pct = np.empty(len(Z)), np.empty(len(Z))
        for rows, (cols, P, ref) in self._by_pattern(present):
            Zc = Z[np.ix_(rows, cols)]
            dist[rows] = np.sqrt(np.maximum(np.einsum("ni,ij,nj->n", Zc, P, Zc), 0.0))
            pct[rows] = np.searchsorted(ref, dist[rows], side="right") / ref.size * 100
        return dist, pct

    def mahalanobis(self, X):
        """Mahalanobis distance of feature rows to the training features (out-of-distribution score; on the present
        features of a row with missing modes, :meth:`training_percentile`)."""
        return self.training_percentile(X)[0]

    def distance_terms(self, X):
        """Each feature's term of the squared Mahalanobis distance, ``z_i (P z)_i`` with ``z`` the row in training
        standard deviations and ``P`` the training features' precision (the marginal precision of the present
        features of a row with missing modes): shape (n, p), each row summing to the squared distance of
        :meth:`mahalanobis` (a term may be negative where correlated features offset); NaN, in both returned
        arrays, for a missing mode's features."""
        Z, present = self._standardised(X)
        terms = np.full(Z.shape, np.nan)
        for rows, (cols, P, _) in self._by_pattern(present):
            Zc = Z[np.ix_(rows, cols)]
            terms[np.ix_(rows, cols)] = Zc * (Zc @ P)
        return terms, np.where(np.isnan(terms), np.nan, Z)

    def _distances(self, Z):
        return np.sqrt(np.maximum(np.einsum("ni,ij,nj->n", Z, self.precision_, Z), 0.0))

    def decision_function(self, X):
        return self._raw(X)[0]["detect"] / self.logit_scale_ + self.bias_

    def predict_proba(self, X):
        p = expit(self.decision_function(X))
        return np.stack([1 - p, p], axis=1)

    def predict(self, X):
        d = self.predict_details(X)
        return (d.probability_damaged >= d.threshold).astype(int)

    def score(self, X, y, sample_weight=None) -> float:
        """Accuracy of the damaged / intact verdict; ``y`` is the (n, 3) target of :meth:`fit` or its first column."""
        y = np.asarray(y, float)
        damaged = (y[:, 0] if y.ndim == 2 else y) > 0.5
        return float(np.average(self.predict(X) == damaged, weights=sample_weight))

    def predict_details(self, X) -> DamagePrediction:
        raw, present = self._raw(X)
        z = raw["detect"] / self.logit_scale_ + self.bias_
        missing = np.minimum(self._missing(present), len(self.location_sharpness_) - 1)
        dists = level_distributions(self.location_sharpness_, raw["locate"], self.mirrored, missing)
        p = dists["68"]
        c = (np.arange(self.n_bins) + 0.5) / self.n_bins
        mean = p @ c
        std = np.sqrt(np.maximum(p @ c**2 - mean**2, 0.0) + 1.0 / (12 * self.n_bins**2))
        if self.zone_edges is None:
            el = p.reshape(len(p), 4, -1).sum(axis=2)
        else:
            edges = np.asarray(self.zone_edges, float)
            zone = np.clip(np.searchsorted(edges, c, side="right") - 1, 0, edges.size - 2)
            el = p @ (zone[:, None] == np.arange(edges.size - 1)[None]).astype(float)
        tf = SizeTransform.parse(self.size_transform)
        med = tf.inverse(raw["size_mean"])
        head = np.exp(np.minimum(raw["size_log_std"], LOG_SIZE_LIMIT))
        t_std = {k: np.minimum([self.size_std_scale_[m][k] for m in missing] * head, MAX_SIZE_LOG_STD) for k in LEVELS}
        sd = tf.std(raw["size_mean"], t_std["68"])
        sup = expit(raw["support"]) if self.support_trained_ else np.full(len(z), np.nan)
        iv = {**{f"x_over_L_{k}": v for k, v in level_intervals(dists).items()},
              **{f"size_{k}": np.stack([tf.inverse(raw["size_mean"] + s * Z_OF_LEVEL[k] * t_std[k])
                                        for s in (-1, 1)], axis=1) for k in LEVELS}}
        return DamagePrediction(expit(z), p, mean, std, el, np.argmax(el, axis=1) + 1, med, sd, z, sup,
                                self._thresholds_of(present), present, iv, dists)

    # ------------------------------------------------------------------ persistence (no pickle)
    def get_state(self) -> tuple[dict, dict]:
        """``(arrays, meta)``: the network's state dict, the input normalisation and the out-of-distribution
        statistics as NumPy arrays (``net.*``, ``norm.*``, ``ood.*``), and JSON-ready metadata."""
        net = (self.weights_ if self.model_ is None
               else {k: v.detach().cpu().numpy() for k, v in self.model_.state_dict().items()})
        arrays = {f"net.{k}": np.asarray(v) for k, v in net.items()}
        arrays.update({"norm.mean": self.mean_, "norm.scale": self.scale_, "ood.precision": self.precision_,
                       "ood.reference": self.reference_distances_, "ood.covariance": self.covariance_})
        if self.answers_missing_modes:
            arrays["ood.reference_features"] = self.reference_features_
        meta = {"params": self.get_params(), "logit_scale": self.logit_scale_, "bias": self.bias_,
                "threshold": self.threshold_, "thresholds": list(self.thresholds_),
                "size_std_scale": self.size_std_scale_, "location_sharpness": self.location_sharpness_,
                "n_features": int(self.n_features_in_), "support_trained": self.support_trained_,
                "train_seconds": self.train_seconds_, "loss_history": self.loss_history_,
                "n_train": int(self.n_train_), "n_val": int(self.n_val_)}
        return arrays, meta

    @classmethod
    def from_state(cls, arrays: dict, meta: dict, device=None) -> "DamageClassifier":
        """The estimator of :meth:`get_state`'s ``(arrays, meta)`` (or an older file's CPU tensors), answering with
        the NumPy forward pass (:mod:`learn.network.forward`); ``KeyError`` / ``ValueError`` where they do not match."""
        arrays = {k: np.asarray(v) for k, v in arrays.items()}
        params = dict(meta["params"])
        params["device"] = device
        est = cls(**params)
        est.device_ = device
        est.mean_ = arrays["norm.mean"].astype(float)
        est.scale_ = arrays["norm.scale"].astype(float)
        est.n_features_in_ = int(meta["n_features"])
        est.precision_ = arrays["ood.precision"].astype(float)
        est.reference_distances_ = arrays["ood.reference"].astype(float)
        est.covariance_ = (arrays["ood.covariance"].astype(float) if "ood.covariance" in arrays
                           else np.linalg.pinv(est.precision_))
        est.reference_features_ = arrays["ood.reference_features"] if est.answers_missing_modes else None
        est.n_modes_ = int(max(est.feature_modes)) + 1 if est.answers_missing_modes else 0
        est.classes_ = np.array([0, 1])
        est.support_trained_ = bool(meta.get("support_trained", False))
        est.weights_ = {k[4:]: v for k, v in arrays.items() if k.startswith("net.")}
        if not est.support_trained_:   # a support head never trained is never read
            est.weights_ = {k: v for k, v in est.weights_.items() if not k.startswith("support.")}
        check_weights(est.weights_, est.n_features_in_ + est.n_modes_, est.n_bins, est.hidden, est.depth)
        est.model_ = None
        est.logit_scale_ = float(meta["logit_scale"] if "logit_scale" in meta else meta["temperature"])
        est.bias_ = float(meta.get("bias", 0.0))
        est.threshold_ = float(meta.get("threshold", 0.5))
        est.thresholds_ = [float(v) for v in meta.get("thresholds", [est.threshold_])]
        est.size_std_scale_ = read_size_scales(meta.get("size_std_scale", 1.0))
        est.location_sharpness_ = read_curves(meta.get("location_sharpness", 1.0))
        est.train_seconds_ = float(meta.get("train_seconds", float("nan")))
        est.loss_history_ = list(meta.get("loss_history", []))
        est.n_train_, est.n_val_ = int(meta.get("n_train", 0)), int(meta.get("n_val", 0))
        return est
