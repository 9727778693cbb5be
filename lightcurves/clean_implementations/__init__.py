"""Ways of computing the dirty spectrum and the spectral window of WindowCLEAN.

Each implementation returns the one-sided transforms on the grid
``ν_j = j Δν``: the dirty spectrum ``D(ν) = (1/N) Σ_r y_r e^{−2πiνt_r}`` for
``j = 0 … n_freq−1`` and the window ``W(ν) = (1/N) Σ_r e^{−2πiνt_r}`` for
``j = 0 … 2 n_freq − 2`` (the CLEAN shifts need twice the range); eqs 2–3 of
Roberts, Lehár & Dreher (1987, AJ 93, 968). Negative frequencies follow from
``D(−ν) = D(ν)*`` for real data.

* ``direct`` — the sums evaluated term by term (exact; O(N·n_freq)).
* ``fast`` — Press & Rybicki (1989) extirpolation onto a regular grid and an
  FFT, via astropy's ``trig_sum`` (O(N + n_freq log n_freq)).
"""

from lightcurves.clean_implementations.direct import dirty_and_window as direct
from lightcurves.clean_implementations.fast import dirty_and_window as fast

METHODS = {"direct": direct, "fast": fast}

__all__ = ["METHODS", "direct", "fast"]
