"""Distances between the distributions of uqdrive: Kullback-Leibler divergence and 2-Wasserstein
distances of normals and uniforms (thesis 5.27-5.33, with the corrections of the seeds' errata).
"""

from __future__ import annotations

import numpy as np

__all__ = ["kl_divergence_normal", "wasserstein2_normal", "wasserstein2_uniform"]


def kl_divergence_normal(mean_p, std_p, mean_q, std_q):
    """D_KL(P || Q) for P = N(mean_p, std_p^2), Q = N(mean_q, std_q^2), thesis (5.27) corrected.

    ln(s_q / s_p) + (s_p^2 + (m_p - m_q)^2) / (2 s_q^2) - 1/2, elementwise; NaN where either
    standard deviation is zero (the divergence of degenerate distributions is undefined).
    """
    mean_p, std_p, mean_q, std_q = (np.asarray(a, float) for a in (mean_p, std_p, mean_q, std_q))
    with np.errstate(divide="ignore", invalid="ignore"):
        kl = np.log(std_q / std_p) + (std_p**2 + (mean_p - mean_q) ** 2) / (2.0 * std_q**2) - 0.5
    return np.where((std_p > 0) & (std_q > 0), kl, np.nan)


def wasserstein2_normal(mean_1, std_1, mean_2, std_2):
    """2-Wasserstein distance of two normals, thesis (5.30): sqrt((m1 - m2)^2 + (s1 - s2)^2)."""
    return np.hypot(np.asarray(mean_1, float) - mean_2, np.asarray(std_1, float) - std_2)


def wasserstein2_uniform(low_1, high_1, low_2, high_2):
    """2-Wasserstein distance of U(a1, b1) and U(a2, b2), thesis (5.31) corrected.

    With da = a1 - a2 and dw = (b1 - a1) - (b2 - a2): W2^2 = da^2 + da dw + dw^2 / 3, the
    integral of the squared quantile difference (the printed formula halves the cross term).
    """
    da = np.asarray(low_1, float) - low_2
    dw = (np.asarray(high_1, float) - low_1) - (np.asarray(high_2, float) - low_2)
    return np.sqrt(da**2 + da * dw + dw**2 / 3.0)
