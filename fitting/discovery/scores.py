"""Linear algebra of the score tests shared by both discovery bases (`ranking`,
`cycle_workflow`): the base columns' basis, the efficient part of a candidate's columns,
and the cosine of the smallest principal angle between two column spaces."""

from __future__ import annotations

import numpy as np

__all__ = ["base_basis", "principal_cosine", "project_out"]


def base_basis(Jb: np.ndarray) -> np.ndarray:
    """Orthonormal basis of the base columns (each scaled to unit norm first: their
    sizes differ by orders of magnitude)."""
    scale = np.linalg.norm(Jb, axis=0)
    scale[scale == 0] = 1.0
    return np.linalg.qr(Jb / scale)[0]


def project_out(Q: np.ndarray, Jc: np.ndarray) -> np.ndarray:
    """The candidate columns Jc with the span of the orthonormal Q removed (what the base
    parameters cannot absorb: the efficient score's columns)."""
    return Jc - Q @ (Q.T @ Jc)


def principal_cosine(A: np.ndarray, B: np.ndarray) -> float:
    """Largest |cosine| between the column spaces of A and B (smallest principal angle):
    near 1, the two change the traces in the same way."""
    qa, _ = np.linalg.qr(A)
    qb, _ = np.linalg.qr(B)
    return float(np.linalg.svd(qa.T @ qb, compute_uv=False)[0])
