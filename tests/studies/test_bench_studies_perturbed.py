"""The perturbed-truth study benchmark's config and paired table (benchmarks/bench_studies_perturbed.py)."""

import tomllib

import numpy as np
import pandas as pd
import pytest

from benchmarks import bench_studies_perturbed as B
from estimators.tuning import default_tuning
from studies.engine.registry import get_study


@pytest.mark.parametrize("name", list(B.STUDIES))
def test_the_config_is_the_catalog_s_in_the_perturbed_world(name, tmp_path):
    """Only the benchmark's keys change (the quick table and every other key as in the catalog), and the study accepts it."""
    catalog = tomllib.loads((B.CONFIGS / f"{name}.toml").read_text())
    path = tmp_path / f"{name}.toml"
    path.write_text(B.perturbed_config(name, 7))
    ours = tomllib.loads(path.read_text())
    changed = B.changed_keys(name, 7)
    world = "q_base_tuning" if name == "tuning" else "tuning"
    assert (ours["truth"], ours[world], ours["record"], ours["n_seeds"]) == ("perturbed", default_tuning("perturbed"), False, 7)
    assert {k: v for k, v in ours.items() if k not in changed} == {k: v for k, v in catalog.items() if k not in changed}
    config = get_study(name).load(path, quick=False)
    assert config["truth"] == "perturbed" and config["n_seeds"] == 7
    if name == "tuning":  # the default itself is the grid's last point, so the choice can be compared with it
        assert config["base_point"] and len(get_study(name).expand(config)) == 2 * 2 * (3 ** 2 + 1) * 7


def test_the_tuning_choice_is_made_on_half_the_seeds_and_compared_on_the_other():
    """Seeds 0–1 choose (point 1 has the lower C_t and E_SS there), seeds 2–3 compare it with the base (point 2) seed by
    seed: on them point 1 is worse, and the table says so, against the base's own figures."""
    rows = []
    for seed in range(4):
        for q, (ct, ess) in enumerate([(50.0, 2.0), (10.0, 1.0) if seed < 2 else (40.0, 3.0), (30.0, 1.5)]):
            rows.append({"filter": "ekf", "scenario": "SC3", "q_index": q, "q_exp_w_ST_T": [-12.0, -10.0, np.nan][q], "seed_index": seed,
                         "C_t_s": ct + seed, "E_SS": ess, "nees_per_dof": 1.0, "diverged": False, "converged_all": True})
    config = {"q_blocks": ["w_ST_T"], "score_weight": 0.5, "q_base_tuning": "fixed-lag"}
    lines, held = B.tuning_comparison(pd.DataFrame(rows), config)
    assert lines == ["- EKF SC3: chosen on seeds 0–1: w_ST_T 1e-10 (point 1, G 0; the default's G 0.5)"]
    assert sorted(held["seed_index"].unique()) == [2, 3] and set(held["q_index"]) == {1, 2}
    (row,) = B.paired_rows(held, "chosen", [("C_t_s", "C_t (s)", 1.0)])
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells[:4] == ["EKF SC3", "C_t (s)", "32.5", "42.5"] and cells[5].startswith("+10 [")


def test_a_config_without_the_key_is_refused(monkeypatch, tmp_path):
    (tmp_path / "init.toml").write_text('study = "init"\nn_seeds = 3\n')
    monkeypatch.setattr(B, "CONFIGS", tmp_path)
    with pytest.raises(RuntimeError, match="truth"):
        B.perturbed_config("init", 3)


def test_the_paired_change_is_the_mean_per_seed_difference():
    """with − without per seed: +1, +2, +3 (mean 2, t interval 2 ± 4.30·0.577); a never-converged seed is left out of the
    mean and counted in the finite columns."""
    runs = pd.DataFrame({"filter": ["ekf"] * 8, "prior": [False] * 4 + [True] * 4, "seed_index": [0, 1, 2, 3] * 2,
                         "ct_w_s": [10.0, 20.0, 30.0, np.inf, 11.0, 22.0, 33.0, 5.0]})
    (row,) = B.paired_rows(runs, "prior", [("ct_w_s", "convergence time w (s)", 1.0)])
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells[:5] == ["EKF", "convergence time w (s)", "25", "16.5", "3 / 4"]
    assert cells[5] == "+2 [-0.484, +4.48]" and cells[6:] == ["3", "0"]


def test_the_studies_run_are_chosen_by_name(monkeypatch):
    monkeypatch.delenv(B.ONLY_ENV, raising=False)
    assert B.chosen_studies() == list(B.STUDIES)
    monkeypatch.setenv(B.ONLY_ENV, " init ")
    assert B.chosen_studies() == ["init"]
    for bad in ("init,chain", ","):
        monkeypatch.setenv(B.ONLY_ENV, bad)
        with pytest.raises(SystemExit, match=B.ONLY_ENV):
            B.chosen_studies()


def test_the_prior_line_reports_the_first_run_with_a_prior():
    """The prior's score columns of the study (one campaign shared by every run) in one line; none when no run had one."""
    base = {"prior_pole_err_deg": 0.12, "prior_period_err_pct": -1.4e-4, "prior_sense_right": True, "prior_sense_probability": 1.0,
            "prior_n_modes": 1, "prior_w_err_rad_s": 0.0492, "prior_axis_err_deg": 19.6, "prior_w_mahalanobis2": 2.05}
    runs = pd.DataFrame([{**base, "prior_n_modes": 0}, base])
    line = B.prior_line(runs)
    assert "pole 0.12° off" in line and "sense right (probability 1.00), 1 mode(s)" in line and "49.2 mrad/s off" in line
    assert B.prior_line(runs.iloc[:1]) == "" and B.prior_line(pd.DataFrame({"x": [1]})) == ""


def test_a_run_of_some_studies_keeps_the_others_last_results_with_their_date():
    """Run with ``$LCNAV_BENCH_STUDIES_ONLY=proxy``, the section must still hold the init study's last table, headed by the
    date line of the run that measured it (a proxy-only run on 2026-12-01 had replaced it whole)."""
    text = ("<!-- bench:other -->\nx\n<!-- /bench:other -->\n<!-- bench:studies_perturbed -->\n_Measured 2026-11-29 on M._\n\n"
            "## Init and proxy\n\nintro\n\n### `init` (40 runs, 856 s wall)\n\n| a |\n|---|\n| 1 |\n\n### `proxy` (40 runs)\n\n| b |\n"
            "<!-- /bench:studies_perturbed -->\n")
    kept = B.earlier_subsections(["proxy"], text)
    assert kept == ["", "### `init` (40 runs, 856 s wall)\n\n_Measured 2026-11-29 on M._\n\n| a |\n|---|\n| 1 |"]
    assert B.earlier_subsections(["proxy"], "\n".join(["", *kept])) == []  # no section: nothing to keep
    dated = text.replace("### `init` (40 runs, 856 s wall)\n\n", "### `init` (40 runs, 856 s wall)\n\n_Measured 2026-11-28._\n\n")
    again = B.earlier_subsections(["proxy"], dated)
    assert again[1].count("_Measured") == 1 and "2026-11-28" in again[1]  # a kept subsection keeps its own date
    assert B.earlier_subsections(list(B.STUDIES), text) == []
