"""``DamageClassifier``: a scikit-learn style estimator around :class:`learn.models.DamageNet`.

``fit(X, y, groups)`` standardises the features (statistics of the training
part only), holds out a validation part by specimen (``groups``), trains the
network, and fits a temperature on the validation logits (temperature scaling,
Guo et al. 2017) so that ``predict_proba`` is calibrated, and a factor on the size
head's spread so that one standard deviation covers 68 % of the sizes of the validation pairs called damaged.

Targets ``y`` have three columns: damaged (0/1), ``x / L`` of the damage (NaN if
intact) and its size (:func:`learn.features.labels`: a slit's hinge flexibility ``EI / (k_theta L)``, 0 if intact).
"""

from __future__ import annotations

import inspect
import time
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np
import torch
from scipy.special import expit

from learn.features import split_by_specimen
from learn.models import DamageNet, loss_terms
from physics.errors import BeamDamageError

__all__ = ["DamageClassifier", "DamagePrediction", "fit_calibration", "fit_size_std_scale", "lognormal_std",
           "torch_threads"]


@dataclass(frozen=True)
class DamagePrediction:
    """Per-pair outputs of :meth:`DamageClassifier.predict_details` (arrays of shape (n,) unless noted)."""

    probability_damaged: np.ndarray
    location_distribution: np.ndarray      # (n, n_bins) over x/L bins
    x_over_L: np.ndarray                   # mean of the distribution
    x_std_over_L: np.ndarray
    element_probabilities: np.ndarray      # (n, Z) zones (the thesis's 4 elements)
    element: np.ndarray                    # 1..Z, most probable zone
    hinge_flexibility: np.ndarray         # median of the log-normal size estimate
    hinge_flexibility_std: np.ndarray
    logit: np.ndarray                      # calibrated detection logit
    probability_support_change: np.ndarray  # supports changed beyond re-clamping (NaN: a model not trained on it)


#: Bound of the network's raw outputs (far beyond any trained value), so that no exp of them overflows.
RAW_LIMIT = 1e3
#: Bound of the log of the size (hinge flexibility from e^-30 to e^30) and of its log-std (a factor e^5).
LOG_SIZE_LIMIT = 30.0
MAX_SIZE_LOG_STD = 5.0


def lognormal_std(median, log_std):
    """Standard deviation of a log-normal variable from its median and the std of its logarithm."""
    return median * np.sqrt(np.expm1(log_std**2) * np.exp(log_std**2))


def fit_size_std_scale(truth, median, log_std, coverage: float = 0.6827) -> float:
    """Factor ``k`` on the size head's log-std so that ``|truth - median| <= std(k log_std)`` holds for
    ``coverage`` of the pairs (one sigma: 68.3 %); the std grows with ``k``, solved by bisection in log k."""
    truth, median, log_std = (np.asarray(a, float) for a in (truth, median, log_std))

    def covered(log_k):
        with np.errstate(over="ignore", invalid="ignore"):   # an infinite std covers every truth
            return np.mean(np.abs(truth - median) <= lognormal_std(median, np.exp(log_k) * log_std))

    lo, hi = np.log(1e-3), np.log(1e2)
    if covered(hi) < coverage:
        return float(np.exp(hi))
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if covered(mid) < coverage else (lo, mid)
    return float(np.exp(hi))


def _device(name):
    if name is not None:
        return torch.device(name)
    return torch.device("cuda" if torch.cuda.is_available() else "cpu")


@contextmanager
def torch_threads(n):
    """Run the block with ``n`` torch CPU threads (``None``: leave torch's setting), then restore it."""
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
    hidden, depth, dropout : network size (:class:`learn.models.DamageNet`)
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
        torch CPU threads for ``fit`` and the predictions (``None``: torch's own setting, usually
        one per core). One is the default: this small network trains fastest on one thread, and
        on a machine shared with other jobs more threads were up to ten times slower.
    verbose : bool
        Show a tqdm bar over epochs.
    zone_edges : sequence of float or None
        Edges of the location zones over ``x / L`` (``0 ... 1``); None: the thesis's 4 elements. A zone's
        probability is the sum over the bins whose centre lies in it.
    """

    def __init__(self, n_bins=80, hidden=128, depth=3, dropout=0.05, epochs=60, batch_size=256, lr=2e-3,
                 weight_decay=1e-4, loc_sigma_bins=1.0, val_fraction=0.15, false_alarm_target=0.005, random_state=0,
                 device=None, n_threads=1, verbose=False, zone_edges=None):
        self.n_bins = n_bins
        self.zone_edges = zone_edges
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
            raise BeamDamageError(f"y must have shape (n, 3) [damaged, x/L, hinge flexibility] or (n, 4) [..., "
                                  f"support changed], got {y.shape}")
        damaged = y[:, 0] > 0.5
        centres = (np.arange(self.n_bins) + 0.5) / self.n_bins
        sig = self.loc_sigma_bins / self.n_bins
        x = np.nan_to_num(y[:, 1], nan=0.5)
        soft = np.exp(-0.5 * ((centres[None] - x[:, None]) / sig) ** 2)
        soft /= soft.sum(axis=1, keepdims=True)
        log_size = np.log(np.where(damaged, np.maximum(y[:, 2], 1e-9), 1.0))
        support = (y[:, 3] > 0.5) if y.shape[1] == 4 else np.zeros(len(y), bool)
        return (damaged.astype(np.float32), soft.astype(np.float32), log_size.astype(np.float32),
                support.astype(np.float32))

    def _check_X(self, X) -> np.ndarray:
        """Fitted, and ``X`` a finite (n, n_features_in_) matrix (scikit-learn's conventions), else a ValueError."""
        if not hasattr(self, "model_"):
            from sklearn.exceptions import NotFittedError  # sklearn: its error, raised only before fit

            raise NotFittedError(f"This {type(self).__name__} instance is not fitted yet. Call 'fit' with "
                                 "appropriate arguments before using this estimator.")
        X = np.asarray(X, float)
        if X.ndim != 2 or X.shape[1] != self.n_features_in_:
            raise BeamDamageError(f"X has {X.shape[-1] if X.ndim else 0} features (shape {X.shape}), but "
                                  f"DamageClassifier is expecting {self.n_features_in_} features as input")
        if not np.all(np.isfinite(X)):
            raise BeamDamageError("X must be finite (no NaN or inf)")
        return X

    def _tensor(self, X):
        Z = (self._check_X(X) - self.mean_) / self.scale_
        return torch.as_tensor(Z, dtype=torch.float32, device=self.device_)

    def _raw(self, X, batch=8192) -> dict:
        T = self._tensor(X)
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

    # ------------------------------------------------------------------ fit
    def fit(self, X, y, groups=None):
        """Train on features ``X`` (n, d) and targets ``y`` (n, 3); ``groups`` = specimen keys (default: rows)."""
        with torch_threads(self.n_threads):
            return self._fit(X, y, groups)

    def _fit(self, X, y, groups):
        X = np.asarray(X, float)
        if X.ndim != 2 or not np.all(np.isfinite(X)):
            raise BeamDamageError("X must be a finite 2-D feature matrix")
        if self.zone_edges is None and self.n_bins % 4:
            raise BeamDamageError(f"n_bins must be a multiple of 4 (the thesis's elements), got {self.n_bins}")
        t0 = time.perf_counter()
        groups = np.arange(X.shape[0]) if groups is None else np.asarray(groups)
        tr, va, _ = split_by_specimen(groups, (1 - self.val_fraction, self.val_fraction, 0.0), seed=self.random_state)
        self.mean_ = X[tr].mean(axis=0)
        self.scale_ = X[tr].std(axis=0) + 1e-8
        Z = (X[tr] - self.mean_) / self.scale_
        self.precision_ = np.linalg.pinv(np.cov(Z, rowvar=False) + 1e-3 * np.eye(X.shape[1]))
        self.reference_distances_ = np.sort(self._distances(Z))
        self.n_features_in_ = X.shape[1]
        self.classes_ = np.array([0, 1])
        self.device_ = _device(self.device)
        torch.manual_seed(self.random_state)
        gen = torch.Generator().manual_seed(self.random_state)
        self.model_ = DamageNet(X.shape[1], self.n_bins, self.hidden, self.depth, self.dropout).to(self.device_)
        d, soft, ls, sup = self._targets(y)
        self.support_trained_ = bool(sup[tr].any())
        Xt = self._tensor(X[tr])
        tgt = [torch.as_tensor(a[tr], device=self.device_) for a in (d, soft, ls)]
        if self.support_trained_:
            tgt.append(torch.as_tensor(sup[tr], device=self.device_))
        opt = torch.optim.AdamW(self.model_.parameters(), lr=self.lr, weight_decay=self.weight_decay)
        steps = self.epochs * int(np.ceil(len(tr) / self.batch_size))
        sched = torch.optim.lr_scheduler.OneCycleLR(opt, max_lr=self.lr, total_steps=max(steps, 1))
        history = []
        epochs = range(self.epochs)
        if self.verbose:
            from tqdm.auto import tqdm
            epochs = tqdm(epochs, desc="train", unit="epoch")
        for _ in epochs:
            self.model_.train()
            perm = torch.randperm(len(tr), generator=gen).to(self.device_)
            tot = 0.0
            for i in range(0, len(tr), self.batch_size):
                b = perm[i:i + self.batch_size]
                terms = loss_terms(self.model_(Xt[b]), *(t[b] for t in tgt))
                loss = terms["detect"] + terms["locate"] + 0.5 * terms["size"] + terms["support"]
                opt.zero_grad()
                loss.backward()
                opt.step()
                sched.step()
                tot += float(loss.detach()) * len(b)
            history.append(tot / len(tr))
        self.loss_history_ = history
        self.temperature_, self.bias_, self.threshold_, self.size_std_scale_ = 1.0, 0.0, 0.5, 1.0
        if len(va):
            raw = self._raw(X[va])
            self.temperature_, self.bias_ = fit_calibration(raw["detect"], d[va])
            p = expit(raw["detect"] / self.temperature_ + self.bias_)
            if (d[va] < 0.5).any():
                self.threshold_ = float(max(0.5, np.quantile(p[d[va] < 0.5], 1 - self.false_alarm_target)))
            # sizes are reported for pairs called damaged: the spread is scaled on those
            dmg = (d[va] > 0.5) & (p >= self.threshold_)
            if dmg.sum() >= 10:
                self.size_std_scale_ = fit_size_std_scale(np.exp(ls[va][dmg]), np.exp(raw["size_mean"][dmg]),
                                                          np.exp(raw["size_log_std"][dmg]))
        self.train_seconds_ = time.perf_counter() - t0
        self.n_train_, self.n_val_ = len(tr), len(va)
        return self

    # ------------------------------------------------------------------ predict
    def mahalanobis(self, X):
        """Mahalanobis distance of feature rows to the training features (out-of-distribution score)."""
        return self._distances((self._check_X(X) - self.mean_) / self.scale_)

    def distance_terms(self, X):
        """Each feature's term of the squared Mahalanobis distance, ``z_i (P z)_i`` with ``z`` the row in training
        standard deviations and ``P`` the training features' precision: shape (n, p), each row summing to the
        squared distance of :meth:`mahalanobis` (a term may be negative where correlated features offset)."""
        Z = (self._check_X(X) - self.mean_) / self.scale_
        return Z * (Z @ self.precision_), Z

    def _distances(self, Z):
        return np.sqrt(np.maximum(np.einsum("ni,ij,nj->n", Z, self.precision_, Z), 0.0))

    def decision_function(self, X):
        return self._raw(X)["detect"] / self.temperature_ + self.bias_

    def predict_proba(self, X):
        p = expit(self.decision_function(X))
        return np.stack([1 - p, p], axis=1)

    def predict(self, X):
        return (self.predict_proba(X)[:, 1] >= self.threshold_).astype(int)

    def score(self, X, y, sample_weight=None) -> float:
        """Accuracy of the damaged / intact verdict; ``y`` is the (n, 3) target of :meth:`fit` or its first column."""
        y = np.asarray(y, float)
        damaged = (y[:, 0] if y.ndim == 2 else y) > 0.5
        return float(np.average(self.predict(X) == damaged, weights=sample_weight))

    def predict_details(self, X) -> DamagePrediction:
        raw = self._raw(X)
        z = raw["detect"] / self.temperature_ + self.bias_
        logits = raw["locate"]
        p = np.exp(logits - logits.max(axis=1, keepdims=True))
        p /= p.sum(axis=1, keepdims=True)
        c = (np.arange(self.n_bins) + 0.5) / self.n_bins
        mean = p @ c
        std = np.sqrt(np.maximum(p @ c**2 - mean**2, 0.0) + 1.0 / (12 * self.n_bins**2))
        if self.zone_edges is None:
            el = p.reshape(len(p), 4, -1).sum(axis=2)
        else:
            edges = np.asarray(self.zone_edges, float)
            zone = np.clip(np.searchsorted(edges, c, side="right") - 1, 0, edges.size - 2)
            el = p @ (zone[:, None] == np.arange(edges.size - 1)[None]).astype(float)
        med = np.exp(np.clip(raw["size_mean"], -LOG_SIZE_LIMIT, LOG_SIZE_LIMIT))
        log_std = np.minimum(self.size_std_scale_ * np.exp(np.minimum(raw["size_log_std"], LOG_SIZE_LIMIT)),
                             MAX_SIZE_LOG_STD)
        sd = lognormal_std(med, log_std)
        sup = expit(raw["support"]) if self.support_trained_ else np.full(len(z), np.nan)
        return DamagePrediction(expit(z), p, mean, std, el, np.argmax(el, axis=1) + 1, med, sd, z, sup)

    # ------------------------------------------------------------------ persistence (no pickle)
    def get_state(self) -> tuple[dict, dict]:
        """``(tensors, meta)``: a state dict for ``torch.save`` and JSON-ready metadata."""
        tensors = {f"net.{k}": v.detach().cpu() for k, v in self.model_.state_dict().items()}
        tensors["norm.mean"] = torch.as_tensor(self.mean_)
        tensors["norm.scale"] = torch.as_tensor(self.scale_)
        tensors["ood.precision"] = torch.as_tensor(self.precision_)
        tensors["ood.reference"] = torch.as_tensor(self.reference_distances_)
        meta = {"params": self.get_params(), "temperature": self.temperature_, "bias": self.bias_,
                "threshold": self.threshold_, "size_std_scale": self.size_std_scale_,
                "n_features": int(self.n_features_in_), "support_trained": self.support_trained_,
                "train_seconds": self.train_seconds_, "loss_history": self.loss_history_,
                "n_train": int(self.n_train_), "n_val": int(self.n_val_)}
        return tensors, meta

    @classmethod
    def from_state(cls, tensors: dict, meta: dict, device=None) -> "DamageClassifier":
        params = dict(meta["params"])
        params["device"] = device
        est = cls(**params)
        est.device_ = _device(device)
        est.mean_ = tensors["norm.mean"].numpy().astype(float)
        est.scale_ = tensors["norm.scale"].numpy().astype(float)
        est.n_features_in_ = int(meta["n_features"])
        est.precision_ = tensors["ood.precision"].numpy().astype(float)
        est.reference_distances_ = tensors["ood.reference"].numpy().astype(float)
        est.classes_ = np.array([0, 1])
        est.model_ = DamageNet(est.n_features_in_, est.n_bins, est.hidden, est.depth, est.dropout).to(est.device_)
        est.support_trained_ = bool(meta.get("support_trained", False))
        net = {k[4:]: v for k, v in tensors.items() if k.startswith("net.")}
        if not est.support_trained_:   # tensors without a support head: it keeps its initial weights, never read
            net = {**{k: v for k, v in est.model_.state_dict().items() if k.startswith("support.")}, **net}
        est.model_.load_state_dict(net)
        est.temperature_ = float(meta["temperature"])
        est.bias_ = float(meta.get("bias", 0.0))
        est.threshold_ = float(meta.get("threshold", 0.5))
        est.size_std_scale_ = float(meta.get("size_std_scale", 1.0))
        est.train_seconds_ = float(meta.get("train_seconds", float("nan")))
        est.loss_history_ = list(meta.get("loss_history", []))
        est.n_train_, est.n_val_ = int(meta.get("n_train", 0)), int(meta.get("n_val", 0))
        return est
