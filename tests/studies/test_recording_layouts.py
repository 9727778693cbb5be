"""Every recording lcnav writes carries its viewer layout and holds what the layout shows.

The light curve as relative flux (up = brighter) and magnitudes, spectra as bar charts over mHz;
the truth rates and range; a stereo frame's images and clouds.
"""

from types import SimpleNamespace

import numpy as np

from estimators.state import R_ST_T, W_ST_T
from lightcurves.prior import extract_spin_prior
from studies.recording.reader import _open_store, export_series
from studies.recording.lightcurve import SPECTRUM_LEVEL, spectrum_top_hz, write_lightcurve_recording
from studies.recording.perception import write_frame_recording
from studies.sim.scenarios import get_scenario
from studies.sim.truth import simulate_truth
from studies.recording.truth import record_truth
from tests.lightcurves.test_lc_io_cli import make_lc
from tests.rerun_cli import assert_rrd_verifies, blueprint_views


def test_lightcurve_recording_carries_its_layout_and_the_curve_as_flux(tmp_path):
    lc = make_lc()
    prior = extract_spin_prior(lc.t_s, lc.mag, lc.mag_err)
    path = tmp_path / "lc.rrd"
    write_lightcurve_recording(path, lc, prior)
    assert_rrd_verifies(path)
    assert {"/lightcurve/relative_flux", "/lightcurve", "/lightcurve/geometry", "/spectrum/dirty", "/spectrum/clean",
            "/spectrum/residual", "/spectrum/window", "/spectrum/summary"} <= blueprint_views(path)[0]
    df, skipped = export_series(path)
    np.testing.assert_allclose(df["sim_time_s"], lc.t_s, atol=1e-9)
    np.testing.assert_allclose(df["/lightcurve/mag"], lc.mag)
    # brighter is up: relative flux is 10^(-0.4 (m - median m)), 1 at the median magnitude
    flux = df["/lightcurve/relative_flux"].to_numpy()
    np.testing.assert_allclose(flux, 10 ** (-0.4 * (lc.mag - np.median(lc.mag))), rtol=1e-12)
    assert np.argmax(flux) == np.argmin(lc.mag)
    # the spectra are static bar charts whose abscissa is the spectrum's frequency in mHz
    _, _, store = _open_store(path)
    table = store.reader(None, contents={"/spectrum/clean": ["BarChart:abscissa", "BarChart:values"]}).to_arrow_table()
    abscissa = np.asarray(table.column("/spectrum/clean:BarChart:abscissa").to_pylist()[0][0]["buffer"])
    values = np.asarray(table.column("/spectrum/clean:BarChart:values").to_pylist()[0][0]["buffer"])
    # up to where the power is (spectrum_top_hz), not the whole search band
    band = prior.spectrum.frequency_hz <= spectrum_top_hz(prior.spectrum, prior.frequency_hz)
    assert 0 < band.sum() < band.size
    np.testing.assert_allclose(abscissa, 1e3 * prior.spectrum.frequency_hz[band], rtol=1e-12)
    np.testing.assert_allclose(values, 2 * np.abs(prior.spectrum.clean)[band], rtol=1e-12)
    amp = np.abs(prior.spectrum.clean)
    assert np.all(amp[~band] < SPECTRUM_LEVEL * amp.max())  # what is left out holds no clean component above 5 % of the peak
    # the extracted rotation frequency is where the clean spectrum peaks (within one bin)
    assert abs(abscissa[np.argmax(values)] - 1e3 * prior.frequency_hz * prior.maxima_per_rotation) <= abscissa[1] - abscissa[0]
    # and a marker bar stands at it, as tall as the clean peak, in the clean spectrum's view
    marker = store.reader(None, contents={"/spectrum/rotation_frequency": ["BarChart:abscissa", "BarChart:values"]}).to_arrow_table()
    at = np.asarray(marker.column("/spectrum/rotation_frequency:BarChart:abscissa").to_pylist()[0][0]["buffer"])
    height = np.asarray(marker.column("/spectrum/rotation_frequency:BarChart:values").to_pylist()[0][0]["buffer"])
    np.testing.assert_allclose(at, [1e3 * prior.frequency_hz], rtol=1e-12)
    np.testing.assert_allclose(height, [values.max()], rtol=1e-12)
    assert "/spectrum/rotation_frequency" in blueprint_views(path)[1]


def test_truth_recording_carries_its_layout_and_the_scenario_rates(tmp_path):
    truth = simulate_truth(get_scenario("SC3"), 20.0, 1.0)
    path = tmp_path / "truth.rrd"
    record_truth(truth, path, seed=1)
    assert_rrd_verifies(path)
    _, queries = blueprint_views(path)
    assert {"/truth/w_ST_T/**", "/truth/w_T_T/**", "/truth/range_m/**", "/truth/**"} <= queries
    df, _ = export_series(path, ["/truth/**"])
    np.testing.assert_allclose(df[[f"/truth/w_ST_T/{a}" for a in "xyz"]], truth.x[:, W_ST_T], rtol=1e-12)
    np.testing.assert_allclose(df["/truth/range_m"], np.linalg.norm(truth.x[:, R_ST_T], axis=1), rtol=1e-12)


def test_frame_recording_carries_cameras_and_clouds(tmp_path):
    rng = np.random.default_rng(3)
    left, right = (rng.integers(0, 255, (24, 32), dtype=np.uint8) for _ in range(2))
    frame = SimpleNamespace(depth_left=np.where(rng.uniform(size=(24, 32)) < 0.5, np.nan, 40.0))
    cloud = SimpleNamespace(points_C=rng.normal(size=(50, 3)) + [0, 0, 40])
    path = tmp_path / "run" / "frames.rrd"
    path.parent.mkdir()
    write_frame_recording(path, frame, left, right, cloud, model_C=rng.normal(size=(80, 3)))
    assert_rrd_verifies(path)
    origins, queries = blueprint_views(path)
    assert {"/camera/left", "/camera/right"} <= origins and "/cloud/**" in queries
    _, _, store = _open_store(path)
    table = store.reader("sim_time", contents={"/cloud/measured": ["Points3D:positions"]}).to_arrow_table()
    np.testing.assert_allclose(np.asarray(table.column("/cloud/measured:Points3D:positions").to_pylist()[0]),
                               cloud.points_C, rtol=1e-6)
