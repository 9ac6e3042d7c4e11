"""Classical damage detection on the same pairs the network sees.

Every method takes the measured modal data of the pairs and the FE
sensitivities of the nominal beam (:mod:`learn.explanations.sensitivity`) and returns a
:class:`MethodOutput`:

* :func:`cawley_adams` - frequency-shift ratios (Cawley & Adams 1979): the
  candidate element whose predicted ratios ``df_i / df_j`` best match the
  measured ones (ratios in the bounded form ``df_i / (|df_i| + |df_j|)``).
* :func:`dlac` - damage location assurance criterion (Messina et al. 1996):
  ``DLAC_e = (df . s_e)^2 / ((df . df)(s_e . s_e))``, largest wins.
* :func:`mdlac` - multiple-damage LAC: the best combination of at most two elements
  with sizes of one sign (all pairs, vectorised; one element on fewer than 4 modes), the larger share locates.
* :func:`sensitivity_updating` - regularised least squares on frequency shifts
  and shape changes for the size of a damage in every element of the grid;
  reports the element of the largest change.
* :class:`GradientBoosting` - scikit-learn's HistGradientBoosting on the
  network's own features.

Detection scores: the largest relative frequency change of either sign (frequency
methods), the largest element change of either sign (updating): a rise is a change too
(a mass lost, a stiffness gained), and the sizes are signed (negative: the frequencies
rise). Each method's threshold is the 99.5th percentile of its score on the intact
training pairs (0.5 % false alarms, as the network's).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from learn.explanations.shapes import shape_changes
from learn.explanations.sensitivity import Sensitivity
from learn.network.size import SizeTransform

__all__ = ["GradientBoosting", "FREQUENCY_METHODS", "MethodOutput", "cawley_adams", "change_score", "dlac",
           "false_alarm_threshold",
           "frequency_shifts", "mdlac", "run_classical", "sensitivity_updating"]


@dataclass(frozen=True)
class MethodOutput:
    """Answers of one method for ``n`` pairs.

    score : higher = more likely damaged (for ROC); probability : in [0, 1] when calibrated, else None
    damaged : bool verdict; x_over_L, size : estimates (meaningful where damaged; the size of the model's damage kind,
    signed: negative where the frequencies rise)
    """

    name: str
    score: np.ndarray
    damaged: np.ndarray
    x_over_L: np.ndarray
    size: np.ndarray
    probability: np.ndarray | None = None
    x_std_over_L: np.ndarray | None = None
    size_std: np.ndarray | None = None
    detectable: np.ndarray | None = None


def frequency_shifts(eigenvalues):
    """Relative natural-frequency changes ``f_cur / f_base - 1`` of pairs, shape (n, m)."""
    f = np.abs(np.asarray(eigenvalues, complex))
    return f[:, 1] / f[:, 0] - 1


def _single_amplitude(df, sens: Sensitivity):
    """Least-squares signed size of a single damage in each element: (n, E) (negative: a change that raises the
    frequencies, a stiffness gained or a mass lost)."""
    S = sens.frequency[: df.shape[1]]
    return df @ S / np.sum(S**2, axis=0)


def change_score(df):
    """Detection score of the frequency methods: the largest relative frequency change of either sign (a rise is
    a change too: a mass lost, a stiffness gained), shape (n,)."""
    return np.abs(df).max(axis=1)


def _pack(name, score, threshold, e, size, sens):
    return MethodOutput(name, score, score >= threshold, sens.x_over_L[e], size)


def cawley_adams(df, sens: Sensitivity, threshold: float) -> MethodOutput:
    """Cawley-Adams location by frequency-shift ratios; ``df`` (n, m) relative shifts."""
    S = sens.frequency[: df.shape[1]]
    i, j = np.triu_indices(df.shape[1], 1)
    rm = df[:, i] / (np.abs(df[:, i]) + np.abs(df[:, j]) + 1e-15)                 # (n, P)
    rp = S[i] / (np.abs(S[i]) + np.abs(S[j]) + 1e-30)                            # (P, E)
    err = np.sum((rm[:, :, None] - rp[None]) ** 2, axis=1)                        # (n, E)
    e = np.argmin(err, axis=1)
    amp = _single_amplitude(df, sens)[np.arange(len(df)), e]
    return _pack("Cawley-Adams", change_score(df), threshold, e, amp, sens)


def dlac(df, sens: Sensitivity, threshold: float) -> MethodOutput:
    """DLAC location (largest correlation of measured and predicted shift vectors)."""
    S = sens.frequency[: df.shape[1]]
    num = (df @ S) ** 2
    den = np.sum(df**2, axis=1, keepdims=True) * np.sum(S**2, axis=0)[None] + 1e-300
    e = np.argmax(num / den, axis=1)
    amp = _single_amplitude(df, sens)[np.arange(len(df)), e]
    return _pack("DLAC", change_score(df), threshold, e, amp, sens)


def mdlac(df, sens: Sensitivity, threshold: float) -> MethodOutput:
    """MDLAC with up to two damaged elements: best pair fit of sizes of one sign (both losses or both gains), the
    larger member locates; the size is signed.

    On 3 modes or fewer (a test missing some of modes 1-4) a pair of elements, two places and two sizes, fits
    nearly any shift vector: the single-element fit alone answers."""
    S = sens.frequency[: df.shape[1]]                       # (m, E)
    E = S.shape[1]
    a, b = np.triu_indices(E, 1)
    A = np.stack([S[:, a], S[:, b]], axis=-1)               # (m, P, 2)
    G = np.einsum("mpi,mpj->pij", A, A)                     # (P, 2, 2)
    Ginv = np.linalg.pinv(G)
    rhs = np.einsum("mpi,nm->npi", A, df)                   # (n, P, 2)
    d = np.einsum("pij,npj->npi", Ginv, rhs)
    d1 = _single_amplitude(df, sens)                        # fallbacks: one element only
    one_sign = (d >= 0).all(-1) | (d <= 0).all(-1)
    da = np.where(one_sign[..., None], d, 0.0)
    fit = np.einsum("mpi,npi->npm", A, da)                  # (n, P, m)
    res2 = np.sum((df[:, None, :] - fit) ** 2, axis=-1)
    res1 = np.sum((df[:, None, :] - d1[:, :, None] * S.T[None]) ** 2, axis=-1)   # (n, E)
    use_pair = one_sign & (df.shape[1] >= 4)              # on 3 modes or fewer two damages fit any shifts
    res2 = np.where(use_pair, res2, np.inf)
    bp, b1 = np.argmin(res2, axis=1), np.argmin(res1, axis=1)
    n = np.arange(len(df))
    pair_better = res2[n, bp] < res1[n, b1] * 0.999
    dp = da[n, bp]
    e = np.where(pair_better, np.where(np.abs(dp[:, 0]) >= np.abs(dp[:, 1]), a[bp], b[bp]), b1)
    amp = np.where(pair_better, dp.sum(axis=1), d1[n, b1])
    return _pack("MDLAC", change_score(df), threshold, e, amp, sens)


def sensitivity_updating(df, du, sens: Sensitivity, threshold: float, sigma_f: float = 5e-4,
                         sigma_shape: float = 5e-3, regularisation: float = 1e-3) -> MethodOutput:
    """Tikhonov-regularised least squares for element damage sizes from frequencies and shapes.

    Minimises ``||W (J d - y)||^2 + mu ||d||^2`` over the damage size ``d`` of every element, with
    ``y = [df; du]``, ``J`` the FE sensitivities and ``W`` the inverse noise levels; ``mu`` is
    ``regularisation`` times the mean diagonal of ``J^T W^2 J``. Reports the element of the largest change of
    either sign (a negative size: a stiffness gained or a mass lost), its size summed with its neighbours' of the
    same sign.
    """
    m = df.shape[1]
    J = np.concatenate([sens.frequency[:m], sens.shape[: du.shape[1]]], axis=0)
    w = np.concatenate([np.full(m, 1 / sigma_f), np.full(du.shape[1], 1 / sigma_shape)])
    Jw = J * w[:, None]
    H = Jw.T @ Jw
    mu = regularisation * np.mean(np.diag(H))
    P = np.linalg.solve(H + mu * np.eye(H.shape[0]), Jw.T)   # (E, m + s)
    d = (np.concatenate([df, du], axis=1) * w) @ P.T             # (n, E)
    rows = np.arange(len(d))
    e = np.argmax(np.abs(d), axis=1)
    dmax = d[rows, e]
    # a damage's estimate spreads over neighbouring elements: sum the peak and its neighbours of its sign
    E = d.shape[1]
    size = sum(np.where(np.sign(d[rows, np.clip(e + k, 0, E - 1)]) == np.sign(dmax),
                        d[rows, np.clip(e + k, 0, E - 1)], 0.0) * (0 <= e + k) * (e + k < E) for k in (-1, 0, 1))
    return _pack("sensitivity updating", np.abs(dmax), threshold, e, size, sens)


def false_alarm_threshold(score, damaged, target: float = 0.005) -> float:
    """Detection threshold: the ``1 - target`` quantile of the scores of intact pairs (the network's rule)."""
    s = np.asarray(score, float)
    return float(np.quantile(s[~np.asarray(damaged, bool)], 1 - target))


class GradientBoosting:
    """HistGradientBoosting on the pair features: detection, ``x / L`` and the size through ``size_transform``
    (:class:`learn.network.size.SizeTransform`: ``ln`` of a positive size, ``asinh`` of a signed one)."""

    def __init__(self, random_state: int = 0, max_iter: int = 300, size_transform: str = "log"):
        self.random_state = random_state
        self.max_iter = max_iter
        self.size_transform = size_transform

    def fit(self, X, y):
        from sklearn.ensemble import HistGradientBoostingClassifier, HistGradientBoostingRegressor

        y = np.asarray(y, float)
        dam = y[:, 0] > 0.5
        kw = dict(random_state=self.random_state, max_iter=self.max_iter, early_stopping=True)
        self.detect_ = HistGradientBoostingClassifier(**kw).fit(X, dam)
        self.threshold_ = max(0.5, false_alarm_threshold(self.detect_.predict_proba(X)[:, 1], dam))
        self.locate_ = HistGradientBoostingRegressor(**kw).fit(X[dam], y[dam, 1])
        self.size_ = HistGradientBoostingRegressor(**kw).fit(X[dam], self._transform.forward(y[dam, 2]))
        return self

    def predict(self, X) -> MethodOutput:
        p = self.detect_.predict_proba(X)[:, 1]
        return MethodOutput("gradient boosting", p, p >= self.threshold_, np.clip(self.locate_.predict(X), 0, 1),
                            self._transform.inverse(self.size_.predict(X)), probability=p)

    @property
    def _transform(self):
        return SizeTransform.parse(self.size_transform)


FREQUENCY_METHODS = {"Cawley-Adams": cawley_adams, "DLAC": dlac, "MDLAC": mdlac}


def run_classical(eigenvalues, eigenvectors, sens: Sensitivity, thresholds: dict | None = None,
                  damaged=None) -> tuple[list, dict]:
    """All classical methods on pairs; thresholds fitted on ``damaged`` labels when not given.

    Returns
    -------
    outputs : list of MethodOutput
    thresholds : dict name -> detection threshold used
    """
    df = frequency_shifts(eigenvalues)[:, :4]
    du = shape_changes(np.asarray(eigenvectors)[..., :4])
    scores = {"freq": change_score(df)}
    up = sensitivity_updating(df, du, sens, np.inf)
    scores["upd"] = up.score
    if thresholds is None:
        if damaged is None:
            raise ValueError("either thresholds or damaged labels are needed")
        thresholds = {k: false_alarm_threshold(v, damaged) for k, v in scores.items()}
    outs = [f(df, sens, thresholds["freq"]) for f in FREQUENCY_METHODS.values()]
    outs.append(replace(up, damaged=up.score >= thresholds["upd"]))
    return outs, thresholds
