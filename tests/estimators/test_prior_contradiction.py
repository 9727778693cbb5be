"""A prior that contradicts the data: the full-information fit must say so, never pass a fit that explains nothing.

On a linear constant-velocity model (one Gauss–Newton step is the exact
posterior) with a prior held to 1e-4 (m, m/s), so tight that the fit moves less
than one of its σ (the per-component 5-σ test cannot fire):

* 10 m off, every measurement (σ 0.2 m) disagrees by 50 σ, the fit's screen
  leaves out all of them, and the refit "passes" with cost 0 of 0 degrees of
  freedom (it used to, as χ²(1)): it must not be usable;
* a fit that keeps only a minority of the measurements the gates accepted has
  explained those that happen to agree with its start: not usable either;
* 0.5 m off (2.5 σ of each measurement, 5000 σ of the prior), the fit fails its
  chi-square test; with the position named ``suspect`` it is redone with that
  prior flat (σ 0.1 m), passes, and follows the data.
"""

import numpy as np
from scipy.stats import chi2

from estimators.batch import SCREEN_MIN_KEPT, MeasurementHistory, posterior
from tests.estimators.test_batch import CAMERA, CV, _linear_history

X_TRUE0 = np.array([0.0, 0.1, 0.0])
P0_TIGHT = np.diag([1e-8, 1e-8, 1e-8])


def test_a_fit_whose_screen_keeps_nothing_is_not_usable(rng):
    h, _ = _linear_history(rng, X_TRUE0, 40)
    post = posterior(CV, [None] * 40, h, X_TRUE0 + [10.0, 0.0, 0.0], P0_TIGHT, 40, 1.0)
    assert post.dof == 0 and post.cost < 1e-12  # every residual was ~50 σ: screened out
    assert not post.usable


def test_a_fit_that_keeps_a_minority_of_the_accepted_measurements_is_not_usable(rng):
    # the first 15 measurements agree with the (tight, right) prior, the last 25 are offset by 10 m (50 σ)
    h = MeasurementHistory()
    x = X_TRUE0.copy()
    for k in range(1, 41):
        x = CV.propagate(x, None, 1.0)
        h.add(k, CAMERA, CAMERA.H @ x + rng.normal(0.0, 0.2, 1) + (10.0 if k > 15 else 0.0))
    post = posterior(CV, [None] * 40, h, X_TRUE0, P0_TIGHT, 40, 1.0)
    assert post.dof == 15 < SCREEN_MIN_KEPT * 40
    assert post.cost <= chi2.ppf(0.999, post.dof)  # the 15 it kept fit: that alone is no pass
    assert not post.usable


def test_a_suspect_prior_that_contradicts_the_data_is_left_flat(rng):
    h, x_true = _linear_history(rng, X_TRUE0, 40)
    wrong = X_TRUE0 + [0.5, 0.0, 0.0]
    plain = posterior(CV, [None] * 40, h, wrong, P0_TIGHT, 40, 1.0)
    assert not plain.usable and plain.prior_flattened == ()  # the chi-square test fails, nothing beyond 5 σ
    post = posterior(CV, [None] * 40, h, wrong, P0_TIGHT, 40, 1.0, suspect=(0,))
    assert post.usable and post.dof >= 39 and post.prior_flattened == (0,)
    # the data decide the position: the flat prior's σ 0.1 m against 40 measurements of σ 0.2 m moves it ≥ 90 % of the way
    assert abs(post.x[0] - x_true[0]) < 0.1 * 0.5 and abs(plain.x[0] - x_true[0]) > 0.49
    # a prior that agrees with the data is kept (no refit, nothing flattened)
    right = posterior(CV, [None] * 40, h, X_TRUE0, np.diag([1.0, 0.25, 0.09]), 40, 1.0, suspect=(0,))
    assert right.usable and right.prior_flattened == ()
