"""Every time-series plot of every recording lcnav writes names its unit (issue 30: "panels have no units").

Read back from the blueprint stored in the ``.rrd`` (:func:`studies.recording.reader.blueprint_views`): the title of
each ``TimeSeries`` view ends in ``(<unit>)`` or ``(<unit>; <note>)``, the unit one of SI's (or ``1``, ``mag``, ``σ``),
and each error plot's unit is the one its quantity's error has.
"""

import re

import pytest

from studies.recording.blueprint import UNITS, lightcurve_blueprint, run_blueprint
from studies.recording.inversion import inversion_blueprint
from studies.recording.navigation import QUANTITIES
from studies.recording.reader import blueprint_views
from studies.recording.truth import truth_blueprint
from studies.recording.writer import recording
from studies.sim.combina import FILTER_COMPONENTS

#: What a title may give as its unit: SI units and ratios of them, 1 (dimensionless), magnitudes, noise sigmas.
UNIT = re.compile(r"\((?P<unit>rad/s|rad|m/s|m|km|deg|s|1|mag|σ)(; [^()]*)?\)$")

#: The layouts of lcnav's recordings (navigation run, truth, truth study, CoMBiNa, light curve, inversion).
LAYOUTS = {
    "run": lambda: run_blueprint(quantities=["q_TS", *QUANTITIES], filters=["ekf"], gates=True),
    "truth": truth_blueprint,
    "truth study": lambda: run_blueprint(quantities=["w_ST_T", "r_ST_T", "range_m"], filters=["rk4"]),
    "combina": lambda: run_blueprint(quantities=[c for comps in FILTER_COMPONENTS.values() for c in comps], filters=list(FILTER_COMPONENTS),
                                     gates=True),
    "lightcurve": lightcurve_blueprint,
    "inversion": lambda: inversion_blueprint(2),
}


def stored_time_series(tmp_path, name: str) -> list:
    path = tmp_path / f"{name.replace(' ', '_')}.rrd"
    with recording(path, recording_id=f"units-{name}", blueprint=LAYOUTS[name]()):
        pass
    return [view for view in blueprint_views(path) if view.kind == "TimeSeries"]


@pytest.mark.parametrize("name", LAYOUTS)
def test_every_time_series_title_names_its_unit(tmp_path, name):
    views = stored_time_series(tmp_path, name)
    assert views, name
    for view in views:
        assert UNIT.search(view.name), (name, view.name)


def test_error_plots_carry_their_errors_unit_and_the_attitude_error_is_in_radians(tmp_path):
    views = stored_time_series(tmp_path, "run")
    errors = {v.origin.rsplit("/", 1)[-1]: UNIT.search(v.name)["unit"] for v in views if "/error/" in v.origin}
    assert errors == {q: UNITS[q][1] for q in ["q_TS", *QUANTITIES]}
    assert errors["q_TS"] == "rad" and errors["w_ST_T"] == "rad/s" and errors["r_ST_T"] == "m" and errors["k"] == "1"
    states = {v.name for v in views if v.origin == "/"}
    assert states == {"q_TS (1)", "w_ST_T (rad/s)", "r_ST_T (m)", "v_ST_T (m/s)", "k (1)"}


def test_a_quantity_without_a_unit_is_refused():
    with pytest.raises(ValueError, match=r"quantities \['speed'\]: no unit: expected"):
        run_blueprint(quantities=["speed"])
    run_blueprint(quantities=["speed"], units={"speed": ("m/s", "m/s")})
