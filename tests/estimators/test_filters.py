"""Both filters on the relative-navigation model: unit quaternion, NaN/Inf refusal, bad input."""

import numpy as np
import pytest

from estimators.error_state import boxplus
from estimators.filter import NonFiniteError
from estimators.measurement import PoseNoise
from estimators.navigation import make_filter
from estimators.process_model import RelativeProcessModel
from estimators.state import Q_TS
from estimators.tuning import get_tuning
from perception.simulated_pose import simulate_pose_measurements

FILTERS = ["ekf", "ukf"]


def _setup(truth, name, rng, duration=40.0):
    tr = truth("SC3", duration)
    tun = get_tuning("sc3-paper")
    model = RelativeProcessModel(tr.J_S_diag)
    x0 = boxplus(tr.x[0], rng.normal(size=14) * np.sqrt(np.diag(tun.P_0)) * 0.3)
    f = make_filter(name, model, x0, tun.P_0, tun.Q_d(1.0), gate_confidence=0.99)
    return tr, tun, f


@pytest.mark.parametrize("name", FILTERS)
def test_quaternion_stays_unit_after_every_step(truth, rng, name):
    tr, _, f = _setup(truth, name, rng)
    m = simulate_pose_measurements(tr.t, tr.x, rng, tau_s=1.0)
    att, pos = PoseNoise(model="isotropic").sources()
    norms = []
    for k in range(1, len(tr.t)):
        f.predict(tr.servicer[k - 1], 1.0)
        norms.append(np.linalg.norm(f.x[Q_TS]))
        parts = [(att, m.q_TS[k - 1])] if k % 2 else [(att, m.q_TS[k - 1]), (pos, m.r_ST_T[k - 1])]
        f.update(parts, t=tr.t[k])
        norms.append(np.linalg.norm(f.x[Q_TS]))
        assert np.all(np.isfinite(f.x)) and np.all(np.isfinite(f.P))
    assert np.max(np.abs(np.array(norms) - 1.0)) < 1e-12
    assert f.P.shape == (14, 14) and np.all(np.linalg.eigvalsh(f.P) > 0)
    # the last innovation and its covariance are exposed, per source and stacked
    assert set(f.innovations) <= {"attitude", "position"} and f.S.shape == (len(f.y), len(f.y))


@pytest.mark.parametrize("name", FILTERS)
def test_nan_measurement_is_refused_and_state_kept(truth, rng, name):
    tr, _, f = _setup(truth, name, rng)
    f.predict(tr.servicer[0], 1.0)
    x, P = f.x.copy(), f.P.copy()
    att, pos = PoseNoise(model="isotropic").sources()
    with pytest.raises(ValueError, match="NaN or Inf"):
        f.update([(att, tr.x[1, Q_TS]), (pos, np.array([1.0, np.nan, 2.0]))], t=1.0)
    with pytest.raises(ValueError, match="unit quaternion"):
        f.update([(att, 2.0 * tr.x[1, Q_TS])], t=1.0)
    np.testing.assert_array_equal(f.x, x)
    np.testing.assert_array_equal(f.P, P)


@pytest.mark.parametrize("name", FILTERS)
def test_step_that_would_produce_nan_is_refused(truth, rng, name):
    tr, _, f = _setup(truth, name, rng)
    x, P = f.x.copy(), f.P.copy()
    bad = tr.servicer[0].copy()
    bad[0] = np.inf  # a servicer AODS state at infinity
    with np.errstate(all="ignore"), pytest.raises(NonFiniteError, match="NaN or Inf.*refused"):
        f.predict(bad, 1.0)
    np.testing.assert_array_equal(f.x, x)
    np.testing.assert_array_equal(f.P, P)


def test_bad_filter_input(truth, rng):
    tr = truth("SC3", 40.0)
    model = RelativeProcessModel(tr.J_S_diag)
    tun = get_tuning("sc3-paper")
    with pytest.raises(ValueError, match="unknown filter 'kf'"):
        make_filter("kf", model, tr.x[0], tun.P_0, tun.Q_d(1.0))
    notpd = np.eye(14)
    notpd[0, 0] = -1.0
    with pytest.raises(ValueError, match="P_0 must be positive definite"):
        make_filter("ekf", model, tr.x[0], notpd, tun.Q_d(1.0))
    with pytest.raises(ValueError, match="P_0 must be symmetric"):
        make_filter("ukf", model, tr.x[0], np.eye(14) + np.triu(np.ones((14, 14)), 1) * 0.1, tun.Q_d(1.0))
    with pytest.raises(ValueError, match="x0 must be 15 finite numbers"):
        make_filter("ekf", model, np.full(15, np.nan), tun.P_0, tun.Q_d(1.0))
    with pytest.raises(ValueError, match="unknown tuning"):
        get_tuning("nope")
    with pytest.raises(ValueError, match="'sc3' is now called 'sc3-paper'"):
        get_tuning("sc3")
