"""Statistics (interval coverage), summary tables (files, Markdown) and the rerun blueprint layout."""


import numpy as np
import pandas as pd
import pytest
from scipy import stats as sps

from studies.recording.blueprint import run_blueprint, send_estimate, send_truth
from studies.recording.reader import export_series
from studies.recording.writer import recording
from studies.engine.stats import bootstrap_interval, describe, proportion_interval, t_interval
from studies.engine.tables import Table, to_markdown, write_tables
from tests.rerun_cli import assert_rrd_verifies, blueprint_views



def test_t_interval_has_its_nominal_coverage():
    rng = np.random.default_rng(11)
    samples = rng.normal(3.0, 2.0, size=(2000, 8))
    hits = 0
    for x in samples:
        iv = t_interval(x, 0.95)
        hits += iv.lo <= 3.0 <= iv.hi
    # binomial(2000, 0.95): sd 0.49%; accept +-3 sd
    assert abs(hits / 2000 - 0.95) < 0.015
    # width is 2 t_{n-1} s / sqrt(n)
    iv = t_interval(samples[0], 0.95)
    assert iv.hi - iv.lo == pytest.approx(2 * sps.t.ppf(0.975, 7) * samples[0].std(ddof=1) / np.sqrt(8), rel=1e-12)


def test_t_interval_degenerate_cases():
    assert np.isnan(t_interval([1.0]).lo) and t_interval([1.0]).estimate == 1.0
    iv = t_interval([2.0, 2.0, 2.0, np.nan])
    assert (iv.lo, iv.estimate, iv.hi) == (2.0, 2.0, 2.0)
    with pytest.raises(ValueError, match="confidence must be in"):
        t_interval([1.0, 2.0], 1.5)


def test_bootstrap_median_interval_covers_the_true_median():
    # exponential(1): median ln 2; BCa of n = 40 covers it about 95% of the time
    rng = np.random.default_rng(5)
    hits = sum(
        (iv := bootstrap_interval(rng.exponential(1.0, 40), np.median, 0.95, rng=rng, n_resamples=999)).lo <= np.log(2) <= iv.hi
        for _ in range(100)
    )
    assert hits >= 85  # binomial(100, 0.95) is below 88 with probability < 1%; BCa undercovers slightly at n = 40
    iv = bootstrap_interval([4.0, 4.0], rng=rng)
    assert (iv.lo, iv.hi) == (4.0, 4.0)


def test_wilson_interval_coverage_and_closed_form():
    # closed form of the Wilson interval for k = 9 of n = 10 at 95%
    z, n, p = sps.norm.ppf(0.975), 10, 0.9
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z / (1 + z * z / n) * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    iv = proportion_interval(9, 10)
    assert (iv.lo, iv.hi) == (pytest.approx(centre - half, rel=1e-9), pytest.approx(centre + half, rel=1e-9))
    # coverage for p = 0.9, n = 50 (Fig. 20-like fractions): near 95% over 4000 binomial draws
    k = np.random.default_rng(3).binomial(50, 0.9, 4000)
    values, counts = np.unique(k, return_counts=True)
    cover = sum(c for v, c in zip(values, counts) if (iv := proportion_interval(int(v), 50)).lo <= 0.9 <= iv.hi) / k.size
    assert 0.92 < cover < 0.98
    with pytest.raises(ValueError, match="0 <= k <= n"):
        proportion_interval(3, 2)


def test_describe_groups_in_order_of_appearance():
    df = pd.DataFrame({"sc": ["b", "a", "b", "a", "b"], "m": [1.0, 10.0, 3.0, 14.0, 5.0]})
    d = describe(df, ["sc"], ["m"], median_of=["m"], rng=np.random.default_rng(0))
    assert d["sc"].tolist() == ["b", "a"] and d["n_runs"].tolist() == [3, 2]
    assert d["m_mean"].tolist() == [3.0, 12.0] and d["m_sd"].iloc[0] == pytest.approx(2.0)
    assert d["m_ci_lo"].iloc[0] < 3.0 < d["m_ci_hi"].iloc[0] and d["m_median"].iloc[0] == 3.0
    with pytest.raises(KeyError, match="not in the runs table"):
        describe(df, ["sc"], ["nope"])


def test_tables_write_parquet_csv_and_markdown(tmp_path):
    frame = pd.DataFrame({"scenario": ["SC1", "SC2"], "err (mm)": [0.0123456, np.nan], "ok": [True, False], "n": [3, 4]})
    t = Table("summary", "Errors", frame, notes="A note.", formats={"err (mm)": ".2f"})
    md = write_tables(tmp_path, [t, Table("extra", "More", frame.head(1))], heading="demo")
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "summary.parquet"), frame)
    assert len(pd.read_csv(tmp_path / "extra.csv")) == 1
    assert (tmp_path / "summary.md").read_text() == md
    lines = to_markdown(t).splitlines()
    assert lines[0] == "### Errors" and lines[2] == "| scenario | err (mm) | ok | n |"
    assert lines[4] == "| SC1 | 0.01 | yes | 3 |" and lines[5] == "| SC2 | – | no | 4 |" and lines[-1] == "A note."
    assert not list(tmp_path.glob(".*tmp"))  # atomic writes leave no temporaries
    with pytest.raises(ValueError, match="unique"):
        write_tables(tmp_path, [t, t])


def test_blueprint_recording_verifies_and_holds_estimates_with_3sigma(tmp_path):
    t = np.arange(0.0, 20.0, 1.0)
    truth = np.column_stack([np.sin(t), np.cos(t), t])
    est = truth + 0.01
    sigma = np.full_like(est, 0.02)
    bp = run_blueprint(quantities=["w_ST_T"], filters=["ekf", "ukf"], gates=True, lightcurve=True, spectrum=True,
                       cameras=True, cloud=True)
    path = tmp_path / "bp.rrd"
    with recording(path, recording_id="bp-test", blueprint=bp) as rec:
        send_truth(rec, "w_ST_T", t, truth)
        send_estimate(rec, "ekf", "w_ST_T", t, est, truth=truth, sigma=sigma)
    assert_rrd_verifies(path)
    # the stored layout: views on truth vs estimate, errors ±3σ, gates, light curve, spectrum, cameras, clouds
    origins, queries = blueprint_views(path)
    assert {"/truth/w_ST_T/**", "/estimate/ekf/w_ST_T/**", "/estimate/ukf/w_ST_T/**", "/cloud/**"} <= queries
    assert {"/estimate/ekf/error/w_ST_T", "/estimate/ukf/error/w_ST_T", "/gate", "/lightcurve", "/spectrum",
            "/camera/left", "/camera/right"} <= origins
    df, _ = export_series(path)
    assert len(df) == len(t)
    np.testing.assert_allclose(df["/estimate/ekf/error/w_ST_T/y/value"], 0.01, rtol=1e-9)
    np.testing.assert_allclose(df["/estimate/ekf/error/w_ST_T/z/plus3sigma"], 0.06, rtol=1e-12)
    np.testing.assert_allclose(df["/estimate/ekf/error/w_ST_T/z/minus3sigma"], -0.06, rtol=1e-12)
    np.testing.assert_allclose(df["/truth/w_ST_T/z"], t)
    with pytest.raises(ValueError, match="nothing to show"):
        run_blueprint()
