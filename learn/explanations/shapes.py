"""Mode shapes as the features, the sensitivities and the explanations compare them: real, unit-norm, each
current shape's sign following its baseline's, and their changes between two tests."""

from __future__ import annotations

import numpy as np

__all__ = ["real_shapes", "shape_changes", "sign_aligned"]


def real_shapes(eigenvectors):
    """Real, unit-norm mode shapes from complex ones (batched).

    Each column is rotated so that its largest entry is real and positive, its
    real part kept and scaled to unit Euclidean norm.

    Parameters
    ----------
    eigenvectors : ndarray, complex, shape (..., n_dofs, m)

    Returns
    -------
    ndarray, shape (..., n_dofs, m)
    """
    psi = np.asarray(eigenvectors, complex)
    big = np.take_along_axis(psi, np.argmax(np.abs(psi), axis=-2)[..., None, :], axis=-2)
    u = (psi * np.exp(-1j * np.angle(big))).real
    return u / np.linalg.norm(u, axis=-2, keepdims=True)


def sign_aligned(shapes, reference):
    """``shapes`` (..., S, m) with each mode's sign following ``reference``'s (the sign of their dot product, MAC
    sign; a mode orthogonal to its reference keeps its sign): what a shape change between two tests compares."""
    sign = np.sign(np.sum(shapes * reference, axis=-2, keepdims=True))
    return shapes * np.where(sign == 0, 1.0, sign)


def shape_changes(eigenvectors) -> np.ndarray:
    """Changes of the real unit-norm shapes between the two tests of pairs, the current shape's sign following the
    baseline's (:func:`sign_aligned`, as the modal features take them): ``eigenvectors`` (n, 2, S, m) complex ->
    (n, S m), sensor-major as :attr:`learn.explanations.sensitivity.Sensitivity.shape`."""
    u = real_shapes(np.asarray(eigenvectors, complex))                   # (n, 2, S, m)
    return (sign_aligned(u[:, 1], u[:, 0]) - u[:, 0]).reshape(u.shape[0], -1)
