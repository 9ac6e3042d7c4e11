"""Models of the normal variation of a series' features (log natural frequencies) learnt on the baseline period: a
regression on measured conditions, or a latent-variable model (PCA with factors removed, factor analysis, a
Gaussian mixture); each gives a test's novelty index, a squared Mahalanobis distance of its residual."""

from __future__ import annotations

import numpy as np

__all__ = ["DEFAULT_LATENT", "FactorRemoval", "Mixture", "NORMAL_MODELS", "PCA_EXPLAINED", "PCARemoval",
           "Regression"]

#: The latent-variable model used without measured conditions (chosen in docs/monitoring.md).
DEFAULT_LATENT = "pca"
#: Share of the baseline's variance the components :class:`PCARemoval` removes explain (its ``k=None``).
PCA_EXPLAINED = 0.95




def _impute(X, mean, cov):
    """``X`` with each row's NaN entries replaced by their conditional mean given the row's finite entries under
    ``N(mean, cov)`` (``mean`` (n, p) or (p,)); rows without a finite entry get the mean."""
    X = np.array(X, float)
    mean = np.broadcast_to(mean, X.shape)
    miss = ~np.isfinite(X)
    for pattern in {tuple(r) for r in miss[miss.any(axis=1)]}:
        mk = np.asarray(pattern)
        rows = np.flatnonzero((miss == mk).all(axis=1))
        o = ~mk
        if not o.any():
            X[np.ix_(rows, mk)] = mean[np.ix_(rows, mk)]
            continue
        gain = cov[np.ix_(mk, o)] @ np.linalg.pinv(cov[np.ix_(o, o)])                       # (miss, obs)
        X[np.ix_(rows, mk)] = mean[np.ix_(rows, mk)] + (X[np.ix_(rows, o)] - mean[np.ix_(rows, o)]) @ gain.T
    return X


def _start(X):
    """NaN entries replaced by their column's median (the first pass of a fit)."""
    X = np.array(X, float)
    med = np.nanmedian(X, axis=0)
    miss = ~np.isfinite(X)
    X[miss] = np.take(med, np.nonzero(miss)[1])
    return X


def _filled(X, passes: int = 2):
    """``(X filled, mean, cov)``: the missing entries at their column median, then ``passes`` times at their
    conditional mean under the Gaussian of the filled rows (:func:`_impute`)."""
    X0 = _start(X)
    for _ in range(passes):
        X0 = _impute(X, X0.mean(axis=0), _cov(X0))
    return X0, X0.mean(axis=0), _cov(X0)


def _cov(X):
    return np.cov(X, rowvar=False).reshape(X.shape[1], X.shape[1])


def _mahalanobis(R, cov):
    P = np.linalg.pinv(cov)
    return np.einsum("ij,jk,ik->i", R, P, R)


class Regression:
    """Linear regression of every feature on the measured conditions, the residuals' covariance; the index is the
    residual's squared Mahalanobis distance (``p`` degrees of freedom)."""

    name = "regression"

    def fit(self, X, C):
        C = np.asarray(C, float)
        self.n_conditions = C.shape[1]
        A = np.c_[np.ones(len(C)), C]
        X0 = _start(X)
        for _ in range(2):                                  # missing entries: conditional mean, refitted once
            self.coef_ = np.linalg.lstsq(A, X0, rcond=None)[0]
            R = X0 - A @ self.coef_
            self.cov_ = R.T @ R / max(len(X0) - A.shape[1], 1)
            X0 = _impute(X, A @ self.coef_, self.cov_)
        tot = np.var(X0, axis=0)
        self.r2_ = 1 - np.var(X0 - A @ self.coef_, axis=0) / np.where(tot > 0, tot, np.nan)
        self.dof_ = X0.shape[1]
        return self

    def with_choices(self):
        return Regression()

    def expected(self, X, C):
        """The features the normal variation predicts for each test (its conditions' prediction), (n, p)."""
        return np.c_[np.ones(len(C)), np.asarray(C, float)] @ self.coef_

    def novelty(self, X, C):
        mean = self.expected(X, C)
        return _mahalanobis(_impute(X, mean, self.cov_) - mean, self.cov_)

    def describe(self, names) -> dict:
        return {"model": self.name, "conditions": list(names), "r2": self.r2_.tolist(),
                "slope_per_condition": self.coef_[1:].T.tolist(), "intercept": self.coef_[0].tolist()}


class PCARemoval:
    """PCA of the baseline features with the ``k`` leading components (the environment's factors) removed (Yan et
    al. 2005); the index is the squared Mahalanobis distance in the remaining ``p - k`` components.

    ``k=None``: the fewest leading components that explain :data:`PCA_EXPLAINED` of the baseline's variance, leaving
    at least two (one with two features): the environment's factors dominate a baseline period's variation, the
    identification noise and what is left are the rest, and a change is told from them by its pattern over at least
    two remaining directions (docs/monitoring.md: on the output-only series one direction left found 1 of 31
    damaged tests, two 10)."""

    name = "pca"

    def __init__(self, k: int | None = None):
        self.k = k

    def fit(self, X, C=None):
        X0, self.mean_, self.cov_ = _filled(X)
        lam, V = np.linalg.eigh(self.cov_)
        order = np.argsort(lam)[::-1]
        self.var_, self.components_ = lam[order], V[:, order]
        k, p = self.k, X0.shape[1]
        if k is None:
            share = np.cumsum(self.var_) / max(self.var_.sum(), 1e-300)
            k = min(int(np.searchsorted(share, PCA_EXPLAINED) + 1), p - 2 if p >= 3 else p - 1)
        self.k_ = min(k, p - 1)
        self.dof_ = X0.shape[1] - self.k_
        return self

    def with_choices(self):
        """An unfitted copy keeping the number of components chosen here."""
        return PCARemoval(self.k_)

    def expected(self, X, C=None):
        """The mean plus the removed components' part of each test: what the environment's factors explain."""
        U = self.components_[:, :self.k_]
        return self.mean_ + (_impute(X, self.mean_, self.cov_) - self.mean_) @ U @ U.T

    def novelty(self, X, C=None):
        scores = (_impute(X, self.mean_, self.cov_) - self.mean_) @ self.components_[:, self.k_:]
        return np.sum(scores**2 / np.maximum(self.var_[self.k_:], 1e-300), axis=1)

    def describe(self, names=()) -> dict:
        total = self.var_.sum()
        return {"model": self.name, "factors_removed": self.k_,
                "explained_variance_ratio": (self.var_ / total).tolist() if total > 0 else None,
                "removed_components": self.components_[:, :self.k_].T.tolist()}


class FactorRemoval:
    """Factor analysis with ``k`` factors; the index is the residual left after the factors' expected contribution,
    squared and weighted by the specific (noise) variances, ``sum_j e_j^2 / psi_j`` (the residual's full
    Mahalanobis distance would be the features' own: removing the factors' posterior mean is an invertible linear
    map)."""

    name = "factor"

    def __init__(self, k: int = 1, seed: int = 0):
        self.k, self.seed = k, seed

    def fit(self, X, C=None):
        from sklearn.decomposition import FactorAnalysis

        X0, self.mean_, self.cov_ = _filled(X)
        self.scale_ = np.where(X0.std(axis=0) > 0, X0.std(axis=0), 1.0)
        self.fa_ = FactorAnalysis(n_components=min(self.k, X0.shape[1] - 1), random_state=self.seed)
        self.fa_.fit((X0 - self.mean_) / self.scale_)
        self.dof_ = X0.shape[1] - int(self.fa_.n_components)
        return self

    def with_choices(self):
        return FactorRemoval(self.k, self.seed)

    def expected(self, X, C=None):
        """The mean plus the factors' expected contribution to each test."""
        Y = (_impute(X, self.mean_, self.cov_) - self.mean_) / self.scale_
        return self.mean_ + self.fa_.transform(Y) @ self.fa_.components_ * self.scale_

    def novelty(self, X, C=None):
        Y = (_impute(X, self.mean_, self.cov_) - self.mean_) / self.scale_
        R = Y - self.fa_.transform(Y) @ self.fa_.components_
        return np.sum(R**2 / np.maximum(self.fa_.noise_variance_, 1e-12), axis=1)

    def describe(self, names=()) -> dict:
        return {"model": self.name, "factors": int(self.fa_.n_components),
                "loadings": (self.fa_.components_ * self.scale_).tolist(),
                "noise_variance": (self.fa_.noise_variance_ * self.scale_**2).tolist()}


class Mixture:
    """A Gaussian mixture of the features (1 to ``max_components`` components by BIC); the index is the squared
    Mahalanobis distance to the component most responsible for the test."""

    name = "mixture"

    def __init__(self, max_components: int = 3, seed: int = 0, n_components: int | None = None):
        self.max_components, self.seed, self.n_components = max_components, seed, n_components

    def with_choices(self):
        """An unfitted copy keeping the number of components chosen here."""
        return Mixture(self.max_components, self.seed, int(self.gm_.n_components))

    def fit(self, X, C=None):
        from sklearn.mixture import GaussianMixture

        X0, self.mean_, self.cov_ = _filled(X)
        best = None
        for c in ([self.n_components] if self.n_components else range(1, self.max_components + 1)):
            if c > 1 and len(X0) < 3 * c * (X0.shape[1] + 1):
                break
            g = GaussianMixture(c, covariance_type="full", random_state=self.seed, reg_covar=1e-10, n_init=2)
            g.fit(X0)
            bic = g.bic(X0)
            if best is None or bic < best[0]:
                best = (bic, g)
        self.gm_ = best[1]
        self.dof_ = X0.shape[1]
        return self

    def expected(self, X, C=None):
        """The mean of the component most responsible for each test."""
        return self.gm_.means_[self.gm_.predict(_impute(X, self.mean_, self.cov_))]

    def novelty(self, X, C=None):
        X0 = _impute(X, self.mean_, self.cov_)
        g = self.gm_
        d = np.stack([_mahalanobis(X0 - g.means_[j], g.covariances_[j]) for j in range(g.n_components)], axis=1)
        return d[np.arange(len(X0)), np.argmax(g.predict_proba(X0), axis=1)]

    def describe(self, names=()) -> dict:
        return {"model": self.name, "components": int(self.gm_.n_components), "weights": self.gm_.weights_.tolist()}


#: Normal-variation models by name: a factory ``(n_features, n_conditions) -> estimator`` (``fit(X, C)``,
#: ``novelty(X, C)``, ``expected(X, C)``, ``describe(names)``, ``with_choices()``: an unfitted copy keeping what
#: the fit chose from the data, so that every held-out fit is the same model).
NORMAL_MODELS = {
    "regression": lambda p, q: Regression(),
    "pca": lambda p, q: PCARemoval(None),
    "pca0": lambda p, q: PCARemoval(0),
    "pca1": lambda p, q: PCARemoval(1),
    "pca2": lambda p, q: PCARemoval(2),
    "factor": lambda p, q: FactorRemoval(1),
    "mixture": lambda p, q: Mixture(),
}
