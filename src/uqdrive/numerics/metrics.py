"""Distances between the distributions of uqdrive: Kullback-Leibler divergence and 2-Wasserstein
distances of normals and uniforms (thesis 5.27-5.33, with the corrections of the seeds' errata).
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "kl_divergence_normal",
    "wasserstein2_normal",
    "wasserstein2_uniform",
    "wasserstein2_uniform_thesis",
    "normalised_w2_normal",
    "normalised_w2_uniform",
]


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


def wasserstein2_uniform_thesis(low_1, high_1, low_2, high_2):
    """The thesis' printed (5.31), with the factor 1/2 on the cross term (FACTS: an erratum).

    Kept only to compare with the thesis' W2 figures: W2(U(0,1), U(-1,2)) = 1.15 here, 0.577 by
    the correct :func:`wasserstein2_uniform`.
    """
    da = np.asarray(low_1, float) - low_2
    dw = (np.asarray(high_1, float) - low_1) - (np.asarray(high_2, float) - low_2)
    return np.sqrt(dw**2 / 3.0 + 0.5 * dw * da + da**2)


def normalised_w2_normal(mean, std, ref_mean, ref_std):
    """Normalised 2-Wasserstein distance (5.30), (5.32): map onto N(0, 1) by the reference."""
    return wasserstein2_normal((np.asarray(mean, float) - ref_mean) / ref_std, np.abs(std) / ref_std, 0.0, 1.0)


def normalised_w2_uniform(low, high, ref_low, ref_high, thesis_formula: bool = False):
    """Normalised 2-Wasserstein distance (5.31), (5.33): map onto U(-1, 1) by the reference.

    ``thesis_formula`` selects the printed (erroneous) (5.31) for comparison with the thesis.
    """
    span = ref_high - ref_low
    a = 2.0 * (np.asarray(low, float) - ref_low) / span - 1.0
    b = 2.0 * (np.asarray(high, float) - ref_low) / span - 1.0
    f = wasserstein2_uniform_thesis if thesis_formula else wasserstein2_uniform
    return f(a, b, -1.0, 1.0)
