"""The paper reproduction's common ground: the paper's printed numbers, the filter outputs, the resolution.

:data:`PAPER` holds the printed numbers (the paper's; listed in docs/user-guide/paper.md);
:class:`ReproduceSettings` the resolution of a full and of a
quick run.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["PAPER", "FILTERS", "BANDS", "ReproduceSettings"]

#: Printed numbers of the paper (docs/user-guide/paper.md).
PAPER = {
    "q_at_3arcmin": 187.0,
    "afc_fit_rms_arcsec": 4.0,
    "sensitivity_arcmin_per_pct": {"f0": 2.65, "k1": 1.05e-2, "k2": 1.9e-2, "k3": 1.0e-2, "k4": 2e-3, "k5": 1.7e-2},
    "mismatch_optimum_measured": 0.002,
    "mismatch_optimum_calculated": 0.0025,
    "residual_rms_at_optimum_arcsec": 0.7,
    "eliminator_ring_period_ms": 2.0,
    "impact_vibration_hz": 1600.0,
    "dc_gain_paper_form": 0.99058,
    "k1": 1.75e-4,
    "k2": 1.05e-3,
    "fig1_dt_s": 0.139e-3,
    "f0_hz": 386.0,
    "dither_arcmin": 3.0,
    "motion_arcmin": 1.0,
}

FILTERS = ("raw", "eliminator", "correcting", "correcting_paper", "pickoff")
BANDS = {"80-1000": (80.0, 1000.0), "80-2000": (80.0, 2000.0), "80-3000": (80.0, 3000.0)}


@dataclass(frozen=True)
class ReproduceSettings:
    """Resolution of the reproduction (``full()`` and ``quick()`` are the two used)."""

    n_fig5: int = 25
    fig5_settle_s: float = 1.5
    fig5_measure_s: float = 0.5
    fig5_top_hz: float = 3580.0
    n_mismatch: int = 49
    mismatch_min: float = -0.002
    mismatch_max: float = 0.01
    fig6_settle_s: float = 1.2
    fig6_measure_s: float = 0.3
    afc_truth_settle_s: float = 1.0
    afc_settle_s: float = 0.3
    afc_max_nfev: int = 60
    afc_noise_arcsec: float = 2.0
    decay_s: float = 1.2
    abel_samples: int = 10
    impact_settle_s: float = 1.2
    quick: bool = False

    @classmethod
    def full(cls) -> "ReproduceSettings":
        return cls()

    @classmethod
    def quick_(cls) -> "ReproduceSettings":
        return cls(n_fig5=10, fig5_settle_s=1.0, fig5_measure_s=0.3, n_mismatch=25, fig6_settle_s=1.0,
                   fig6_measure_s=0.2, afc_truth_settle_s=0.6, afc_settle_s=0.15, afc_max_nfev=21,
                   decay_s=1.0, quick=True)
