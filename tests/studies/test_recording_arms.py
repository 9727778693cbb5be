"""The two arms of a paired study record under names that say what differs (issue 30: both under ``/estimate/ekf/``)."""

from studies.catalog import init_study
from studies.engine.config import default_config_path, load_config
from studies.engine.sweep import RunSpec
from tests.rerun_cli import blueprint_views


def test_init_arms_are_named_by_the_prior(tmp_path):
    config = load_config(default_config_path("init"), "init", init_study.FIELDS, quick=True)
    ekf = [s for s in init_study.expand(config) if s.params["filter"] == "ekf" and s.params["seed_index"] == 0]
    assert sorted(s.params["prior"] for s in ekf) == [False, True]  # the paired arms of one seed
    origins = {}
    for spec in ekf:
        short = RunSpec(spec.run_id, spec.seed, {**spec.params, "duration_s": 20.0})  # the names, not the physics, are tested
        workdir = tmp_path / spec.run_id
        workdir.mkdir()
        init_study.execute(short, workdir)
        origins[spec.params["prior"]], _ = blueprint_views(workdir / "run.rrd")
    assert "/estimate/ekf_prior/error/w_ST_T" in origins[True] and "/estimate/ekf_no_prior/error/w_ST_T" in origins[False]
    assert not any(o.startswith("/estimate/ekf/") for o in origins[True] | origins[False])
