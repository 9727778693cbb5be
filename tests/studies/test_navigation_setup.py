"""``NavigationSetup``: one run's set-up is checked field by field before any drawing or filtering."""

import numpy as np
import pytest

from estimators.measurement import PoseNoise
from estimators.prior import BodyRatePrior
from estimators.state import K_STATES, N_ERROR
from estimators.tuning import get_tuning
from studies.sim.navigation import NavigationSetup

PRIOR = BodyRatePrior.from_truth([0.0, 0.0, 0.05], 0.05)


def test_defaults_normalise_the_containers():
    s = NavigationSetup("ukf", get_tuning("sc1-paper"), prior=PRIOR, prior_use="proxy", faults=[[60, 120]], consider=list(K_STATES),
                        inertia_range=[0.8, 1.2], P0=np.eye(N_ERROR).tolist())
    assert s.faults == ((60.0, 120.0),) and s.consider == K_STATES and s.inertia_range == (0.8, 1.2)
    assert isinstance(s.P0, np.ndarray) and s.P0.shape == (N_ERROR, N_ERROR)
    assert s.pose_noise == PoseNoise() and s.filter_noise is None and s.proxy_mode == "always"


@pytest.mark.parametrize("field, value, message", [
    ("filter_name", "kf", "filter_name must be one of"),
    ("tuning", "sc1-paper", "tuning must be a Tuning"),
    ("prior_use", "both", "prior_use must be one of"),
    ("prior", None, "prior must be a BodyRatePrior when prior_use is 'init'"),
    ("proxy_mode", "sometimes", "proxy_mode must be one of"),
    ("pose_noise", None, "pose_noise must be a PoseNoise"),
    ("R_w", 0.0, "R_w must be a finite number in (0, inf)"),
    ("gate_confidence", 1.0, "gate_confidence must be a finite number in (0, 1) or None"),
    ("gate_start_s", -1.0, "gate_start_s must be a finite number in [0, inf)"),
    ("fault_sigma_r_m", float("nan"), "fault_sigma_r_m must be a finite number"),
    ("P0_w_prior", -1e-3, "P0_w_prior must be a finite number in (0, inf) or None"),
    ("reacquire_window", 0, "reacquire_window must be a positive whole number"),
    ("reacquire_window", 2.5, "reacquire_window must be a positive whole number"),
    ("faults", [(10.0, -5.0)], "fault window needs start >= 0 and length > 0"),
    ("consider", (12, 14), "consider must hold error-state indices 0..13"),
    ("inertia_range", (1.3, 0.7), "inertia_range must be (lo, hi) with 0 < lo <= hi"),
    ("P0", np.eye(15), "P0 must be a finite 14x14 covariance"),
])
def test_bad_field_is_named(field, value, message):
    kwargs = {"filter_name": "ekf", "tuning": get_tuning("sc1-paper"), "prior": PRIOR, "prior_use": "init", field: value}
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)").replace("[", r"\[")):
        NavigationSetup(**kwargs)
