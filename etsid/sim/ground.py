"""Ground effect: thrust ratio T_IGE/T_OGE of a rotor at height z above flat ground.

* Cheeseman & Bennett (1955), single rotor, method of images:
  T_IGE/T_OGE = 1 / (1 − (R/4z)²)
* Sanchez-Cuevas, Heredia & Ollero (2017), multirotor: each other rotor j at hub distance
  d_j adds an image term and the body (at distance b from the hub) a lift term,
  T_IGE/T_OGE = 1 / (1 − (R/4z)² − Σ_j (R²/2) z/(d_j² + 4z²)^{3/2} − 2 K_b R² z/(b² + 4z²)^{3/2}).
  For a quadrotor (two neighbours at d, one at √2 d) this is the paper's formula exactly.

Near the ground both are clipped: z is taken ≥ ``min_height_ratio``·R and the ratio
≤ ``max_ratio``. There is no cut-off above: every term decays like (R/z)², so the ratio
falls continuously towards 1 (a cut-off at 5 R made the Tarot's thrust jump by 3.3 %).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

CHEESEMAN_BENNETT = 0
SANCHEZ_CUEVAS = 1


@njit(cache=True)
def ground_ratio(
    z: float, radius: float, model: int, dists: np.ndarray, b: float, k_body: float,
    min_height_ratio: float, max_ratio: float
) -> float:
    """Thrust ratio T_IGE/T_OGE (≥ 1) of one rotor whose hub is ``z`` m above the ground.

    Parameters
    ----------
    z : float
        Hub height above ground, m.
    radius : float
        Rotor radius R, m.
    model : int
        ``CHEESEMAN_BENNETT`` (0) or ``SANCHEZ_CUEVAS`` (1).
    dists : ndarray
        Distances from this hub to every other hub, m (used by the multirotor model).
    b : float
        Horizontal distance from the hub to the body centre, m.
    k_body : float
        Empirical body-lift coefficient K_b of the multirotor model.
    min_height_ratio, max_ratio : float
        Clips: z ≥ min_height_ratio·R and ratio ≤ max_ratio.
    """
    zc = z if z > min_height_ratio * radius else min_height_ratio * radius
    x = radius / (4.0 * zc)
    d = 1.0 - x * x
    if model == SANCHEZ_CUEVAS:
        r2 = radius * radius
        for j in range(dists.size):
            dj = dists[j]
            if dj > 0.0:
                s = dj * dj + 4.0 * zc * zc
                d -= 0.5 * r2 * zc / (s * math.sqrt(s))
        s = b * b + 4.0 * zc * zc
        d -= 2.0 * k_body * r2 * zc / (s * math.sqrt(s))
    lim = 1.0 / max_ratio
    if d < lim:
        d = lim
    return 1.0 / d


def cheeseman_bennett(z_over_r: np.ndarray) -> np.ndarray:
    """Unclipped Cheeseman–Bennett ratio 1/(1 − (1/(4 z/R))²) for an array of z/R (> 0.25)."""
    zr = np.asarray(z_over_r, dtype=float)
    return 1.0 / (1.0 - (1.0 / (4.0 * zr)) ** 2)
