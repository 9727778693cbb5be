"""``lcnav run``: one filter on one scenario, with or without a spin prior; metrics, states, recording.

Per run ``i`` (seed ``seed + i``): the scenario's truth (:mod:`studies.sim.truth`),
simulated pose measurements at ``1/τ_s`` (:mod:`perception.simulated_pose`,
or a measurement file), the initial guess of §6 of Renis et al. (``q_TS = 1``,
``ω = r = v = 0``, ``k`` from the true inertia scaled by ``U(0.7, 1.3)`` per
axis), optionally the prior as initial condition and/or proxy, then the filter.
Writes, after everything has run (nothing is written on an error):

* ``metrics.json`` — convergence time and steady-state RMSE per group of the
  first run (state based in ``components``, filter based in
  ``filter_components``), their means over the runs, the fraction of steps
  (from the fixed settling time :data:`studies.sim.metrics.SETTLING_S`, 60 s) whose run-averaged NEES lies in its 95 %
  band, the same for each source's NIS (3 dof), gate rejection rates;
* ``states.parquet`` — per step of the first run: truth, estimate, 3-σ of
  each error state, NIS and gate decisions;

With ``--measurements FILE`` the simulated scenario only gives the filter's time
grid and the servicer's state: its truth is not the file's, so nothing is scored
against it. Without ``--truth-file`` no truth-based figure is written or printed
(no ``true_*`` columns, no NEES, RMSE or convergence time; NIS and gate rates only);
``--truth-file truth.parquet`` (as ``lcnav simulate`` writes it, holding every
filter time) is the truth to score against.
* ``run.rrd`` — the same on the ``sim_time`` timeline in the layout of
  :mod:`studies.recording.blueprint` (``/truth/...``, ``/estimate/<filter>/...`` with
  errors and ±3σ, ``/measurement/<source>/...``, ``/gate/<filter>/<source>/e2``
  with its bounds and a log of rejections), with the viewer layout.
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Optional

import numpy as np
import typer

from studies.cli.choices import (DEFAULT_TUNINGS, FILTERS, NOISE_MODELS, POSE_NOISE_MODEL, POSE_SIGMA_Q_RAD, POSE_SIGMA_R_M, PRIOR_USES,
                                 PROXY_MODES, TRUTH_PHYSICS, TUNINGS)
from studies.engine import validate as v

if TYPE_CHECKING:  # annotations only
    import pandas as pd

    from estimators.navigation import NavigationRun
    from estimators.prior import BodyRatePrior
    from studies.sim.navigation import NavigationSetup
    from studies.sim.truth import Truth

# The libraries (estimators, perception, studies.sim, the recording, pandas) are imported in the functions that use them:
# at module level they made ``lcnav run --help`` and a misspelt option wait ~8 s (issue 30); the help's names and
# defaults come from :mod:`studies.cli.choices`.

ERROR_NAMES = ["dq_x_rad", "dq_y_rad", "dq_z_rad", "w_x_rad_s", "w_y_rad_s", "w_z_rad_s", "r_x_m", "r_y_m", "r_z_m",
               "v_x_m_s", "v_y_m_s", "v_z_m_s", "k1", "k2"]
MEASUREMENT_COLUMNS = ["t_s", "q_TS_0", "q_TS_1", "q_TS_2", "q_TS_3", "r_ST_T_x_m", "r_ST_T_y_m", "r_ST_T_z_m"]


#: Most filter steps per run (duration / dt) and most Monte-Carlo runs: a bound on the work one command may ask for.
MAX_STEPS = 10**5
MAX_RUNS = 1000
#: Largest prior rate magnitude, deg/s (a tumbling body spins far slower than 1 turn/s).
MAX_RATE_DEG_S = 360.0
#: Largest --prior-json, bytes.
MAX_PRIOR_BYTES = 2**20


def _floats(text: str, n: int, flag: str, max_abs: float = 1e12) -> np.ndarray:
    return v.check_floats(flag, text, n, max_abs=max_abs)


def _read_measurements(path: Path, t_span: tuple[float, float]):
    """Pose measurements from a Parquet/CSV file: every row finite, unit quaternions, strictly increasing times in the run."""
    import pandas as pd

    v.check_in_file("--measurements", path, (".parquet", ".csv"))
    where = f"--measurements {str(path)!r}"
    try:
        if path.suffix.lower() == ".parquet":
            df = pd.read_parquet(path)
        else:
            v.check_no_nul(where, path.read_bytes())
            df = pd.read_csv(path)
    except (ValueError, OSError, ImportError) as e:  # pyarrow/pandas parse errors are ValueErrors
        raise v.InputError(f"{where}: not a readable {path.suffix[1:]} table ({e}): expected columns {', '.join(MEASUREMENT_COLUMNS)}") from None
    missing = [c for c in MEASUREMENT_COLUMNS if c not in df.columns]
    if missing:
        raise v.InputError(f"{where} lacks columns {missing}: expected {', '.join(MEASUREMENT_COLUMNS)}")
    if len(df) < 2:
        raise v.InputError(f"{where} holds {len(df)} row(s): expected at least 2 measurements")
    for c in MEASUREMENT_COLUMNS:
        col = df[c]
        if col.dtype.kind not in "fiu":
            bad = next((x for x in col if not (isinstance(x, int | float) or (isinstance(x, str) and v.DECIMAL.match(x)))), col.iloc[0])
            raise v.InputError(f"{where}: column {c} holds {v.plain(bad)}: expected decimal numbers")
    a = df[MEASUREMENT_COLUMNS].to_numpy(dtype=float)
    bad = np.flatnonzero(~np.all(np.isfinite(a), axis=1))
    if bad.size:
        raise v.InputError(f"{where}: row {int(bad[0])} has a NaN, Inf or empty cell: expected finite measurements")
    t = a[:, 0]
    if np.any(np.diff(t) <= 0):
        k = int(np.flatnonzero(np.diff(t) <= 0)[0])
        raise v.InputError(f"{where}: t_s {t[k + 1]:g} (row {k + 1}) follows {t[k]:g}: expected strictly increasing times")
    if not np.any((t >= t_span[0]) & (t <= t_span[1])):
        raise v.InputError(f"{where}: t_s from {t[0]:g} to {t[-1]:g} s: expected measurements within the run, {t_span[0]:g} to {t_span[1]:g} s")
    q = a[:, 1:5]
    if np.any(np.abs(np.linalg.norm(q, axis=1) - 1.0) > 1e-6):
        raise v.InputError(f"{where}: q_TS of norm {np.linalg.norm(q, axis=1)[0]:g}...: expected unit quaternions")
    if np.any(np.abs(a[:, 5:8]) > 1e7):
        raise v.InputError(f"{where}: a position beyond 1e7 m: expected relative positions within 10000 km")
    return t, q, a[:, 5:8]


def _read_truth_file(path: Path, t: np.ndarray, scenario: str) -> np.ndarray:
    """The relative state ``(len(t), 15)`` of a ``lcnav simulate`` truth table at the filter's times ``t`` (s).

    The file must hold a row within 1 µs of every filter time (it may be sampled more finely)
    and, when it records its scenario, be of ``scenario``.
    """
    import pandas as pd

    from studies.sim.truth import RELATIVE_COLUMNS

    v.check_in_file("--truth-file", path, (".parquet",))
    where = f"--truth-file {str(path)!r}"
    try:
        df = pd.read_parquet(path)
    except (ValueError, OSError, ImportError) as e:
        raise v.InputError(f"{where}: not a readable parquet table ({e}); expected the truth.parquet of `lcnav simulate`") from None
    columns = ["t_s", *RELATIVE_COLUMNS]
    missing = [c for c in columns if c not in df.columns]
    if missing:
        raise v.InputError(f"{where} lacks columns {missing[:4]}; expected the truth.parquet of `lcnav simulate` (t_s and the relative state)")
    recorded = df.attrs.get("scenario")
    if recorded is not None and recorded != scenario:
        v.fail(where + ": scenario", recorded, f"the run's --scenario {scenario}")
    a = df[columns].to_numpy(dtype=float)
    if len(a) < 2 or not np.all(np.isfinite(a)) or np.any(np.diff(a[:, 0]) <= 0):
        v.fail(where, f"{len(a)} rows", "at least 2 rows of finite numbers at strictly increasing t_s")
    t_file = a[:, 0]
    i = np.clip(np.searchsorted(t_file, t), 1, len(t_file) - 1)
    i = np.where(np.abs(t_file[i - 1] - t) < np.abs(t_file[i] - t), i - 1, i)
    if np.any(np.abs(t_file[i] - t) > 1e-6):
        dt = float(t[1] - t[0])
        v.fail(f"{where}: t_s", f"{t_file[0]:g} to {t_file[-1]:g} s every {np.median(np.diff(t_file)):g} s",
               f"a row at every filter time 0, {dt:g}, ..., {t[-1]:g} s (lcnav simulate with --duration {t[-1]:g} and a --dt dividing {dt:g})")
    return a[i, 1:]


def _read_prior_json(path: Path, axis: str):
    """A prior from ``lcnav lightcurve prior --json``: a JSON object with numbers ``rate_rad_s`` and ``rate_sigma_rad_s``."""
    from estimators.prior import BodyRatePrior

    v.check_in_file("--prior-json", path, max_bytes=MAX_PRIOR_BYTES)
    where = f"--prior-json {str(path)!r}"
    data = path.read_bytes()
    v.check_no_nul(where, data)
    try:
        d = json.loads(data)
    except (ValueError, RecursionError) as e:  # JSONDecodeError, UnicodeDecodeError; nesting too deep
        raise v.InputError(f"{where}: not JSON ({type(e).__name__}: {str(e)[:120]}): expected an object from `lcnav lightcurve prior --json`") from None
    if not isinstance(d, dict):
        raise v.InputError(f"{where} holds a JSON {type(d).__name__}: expected an object with rate_rad_s and rate_sigma_rad_s")
    if d.get("rate_rad_s") is None:
        raise v.InputError(f"prior without a rate: {where} has no rate_rad_s (no significant period in the light curve)")
    max_rate = np.radians(MAX_RATE_DEG_S)
    rate = v.check_number(f"{where}: rate_rad_s", d["rate_rad_s"], 0.0, max_rate, unit="rad/s")
    sigma = v.check_number(f"{where}: rate_sigma_rad_s", d.get("rate_sigma_rad_s"), 0.0, max_rate, lo_open=True, unit="rad/s")
    return BodyRatePrior.from_rate(rate, sigma, _floats(axis, 3, "--prior-axis"), source=str(path))


def _metrics_dict(m) -> dict:
    return {g: {"convergence_time_s": _num(c.convergence_time_s), "steady_state_rmse": _num(c.steady_state_rmse)} for g, c in m.items()}


def _num(v: float):
    return None if not np.isfinite(v) else float(v)


def _states_table(tr: Truth, run: NavigationRun, scored: bool) -> pd.DataFrame:
    import pandas as pd

    from estimators.navigation import SOURCES
    from studies.sim.truth import RELATIVE_COLUMNS

    cols = {"t_s": tr.t}
    if scored:
        cols.update({f"true_{c}": v for c, v in zip(RELATIVE_COLUMNS, tr.x.T)})
    cols.update({f"est_{c}": v for c, v in zip(RELATIVE_COLUMNS, run.x.T)})
    sig = 3.0 * np.sqrt(np.diagonal(run.P, axis1=1, axis2=2))
    cols.update({f"sigma3_{c}": v for c, v in zip(ERROR_NAMES, sig.T)})
    for s in SOURCES:
        cols[f"nis_{s}"] = run.nis[s]
        cols[f"accepted_{s}"] = run.accepted[s]
    cols["proxy_used"] = run.proxy_used
    return pd.DataFrame(cols)


def run(
    scenario: str = typer.Option("SC3", help="Scenario name (SC1-SC4).", callback=v.text()),
    filter_: str = typer.Option("ekf", "--filter", help=f"Filter: {'|'.join(FILTERS)}.", callback=v.text(FILTERS)),
    duration: float = typer.Option(300.0, help="Simulated time, s (at most 1e5 filter steps).", callback=v.number(0, 1e6, lo_open=True, unit="s")),
    dt: float = typer.Option(1.0, help="Sampling time tau_s of the filter and the pose estimator, s.", callback=v.number(0, 600, lo_open=True, unit="s")),
    prior: str = typer.Option("none", help="Spin prior use: none|init|proxy (proxy also initialises).", callback=v.text(PRIOR_USES)),
    prior_error: float = typer.Option(0.05, help="Prior rate error as a fraction of the true rate (Renis et al. §5.3).",
                                      callback=v.number(0, 10, lo_open=True)),
    prior_rate_deg_s: Optional[str] = typer.Option(None, help="Prior rate 'wx,wy,wz' in deg/s (target frame); default: truth x (1 + prior-error).",
                                                   callback=v.text()),
    prior_json: Optional[Path] = typer.Option(None, help="Prior from `lcnav lightcurve prior --json` (rate_rad_s, rate_sigma_rad_s) about --prior-axis.",
                                              callback=v.path_text()),
    prior_axis: str = typer.Option("0,0,1", help="Spin axis 'x,y,z' in the target frame for --prior-json (a light curve gives no axis).", callback=v.text()),
    proxy_mode: str = typer.Option("always", help=f"When the proxy is pushed: {'|'.join(PROXY_MODES)}.", callback=v.text(PROXY_MODES)),
    tuning: Optional[str] = typer.Option(None, help=f"Named tuning ({', '.join(TUNINGS)}); default per --truth: "
                                         f"{', '.join(f'{k}: {n!r}' for k, n in DEFAULT_TUNINGS.items())} (real time: a 60-s window re-fitted "
                                         "every 10 s; in orbit the gravity-gradient torque modelled and the process noise matched to what the "
                                         "model leaves out; with or without a prior, the prior enters as the initial condition). "
                                         "What a spin prior selects in the demo and the chain study: sc1-conservative ... sc4-conservative "
                                         "(the paper's scenario tunings with a settling phase); sc1-paper ... sc4-paper as the paper has them "
                                         "(sc3-paper over-confident from the default P_0).", callback=v.text(TUNINGS)),
    p0_diag: Optional[str] = typer.Option(None, help="Override P_0: 14 comma-separated variances (error states).", callback=v.text()),
    fault: Optional[str] = typer.Option(None, help="Fault window 'START,LENGTH' in s (heavy measurement noise).", callback=v.text()),
    runs: int = typer.Option(1, help=f"Monte-Carlo runs (seeds seed..seed+runs-1), at most {MAX_RUNS}.", callback=v.count(1, MAX_RUNS)),
    seed: int = typer.Option(1, help="Seed of the first run.", callback=v.seed(v.MAX_SEED - MAX_RUNS)),
    noise: str = typer.Option(POSE_NOISE_MODEL, help=f"Pose noise model: {'|'.join(NOISE_MODELS)} (the measurements' and the filter's R_d).",
                              callback=v.text(NOISE_MODELS)),
    sigma_q_rad: float = typer.Option(POSE_SIGMA_Q_RAD, help="Pose attitude noise amplitude, rad (the measurements' and the filter's R_d).",
                                      callback=v.number(0, 3.15, lo_open=True, unit="rad")),
    sigma_r_m: float = typer.Option(POSE_SIGMA_R_M, help="Pose position noise amplitude, m (the measurements' and the filter's R_d).",
                                    callback=v.number(0, 1e3, lo_open=True, unit="m")),
    gate_confidence: float = typer.Option(0.99, help="Gate confidence per source (0 disables the gates).", callback=v.number(0, 1, hi_open=True)),
    gate_start: float = typer.Option(10.0, help="Gates test measurements from this time on, s (acquisition before).", callback=v.number(0, 1e6, unit="s")),
    reacquire_window: int = typer.Option(5, help="Re-acquire a source after this many rejections in a row that lie on a line (0: never; the paper's filters).",
                                         callback=v.count(0, 10**4)),
    measurements: Optional[Path] = typer.Option(None,
                                                help=f"Use these measurements (Parquet/CSV with {', '.join(MEASUREMENT_COLUMNS)}) instead of simulating; "
                                                "scored against --truth-file only (else NIS and gate rates only).",
                                                callback=v.path_text()),
    truth_file: Optional[Path] = typer.Option(None, help="With --measurements: the truth to score against (truth.parquet of `lcnav simulate`, "
                                              "a row at every filter time).", callback=v.path_text()),
    truth: str = typer.Option("torque-free", help="Truth physics: torque-free (what the filters model) or perturbed (gravity gradient, "
                              "J2, drag, nutation damping; recorded in metrics.json).", callback=v.choice(TRUTH_PHYSICS)),
    out: Path = typer.Option(..., help="Output folder for metrics.json, states.parquet, run.rrd.", callback=v.out_dir()),
) -> None:
    """Run a filter on a scenario; write metrics.json, states.parquet and run.rrd."""
    from studies.engine.io import output_folder, write_json, write_table
    from studies.recording.navigation import record_navigation

    setup = _setup(scenario=scenario, filter_=filter_, duration=duration, dt=dt, prior=prior, prior_error=prior_error,
                   prior_rate_deg_s=prior_rate_deg_s, prior_json=prior_json, prior_axis=prior_axis, proxy_mode=proxy_mode, tuning=tuning,
                   p0_diag=p0_diag, fault=fault, runs=runs, seed=seed, noise=noise, sigma_q_rad=sigma_q_rad, sigma_r_m=sigma_r_m,
                   gate_confidence=gate_confidence, gate_start=gate_start, reacquire_window=reacquire_window, measurements=measurements,
                   truth_file=truth_file, truth=truth)
    results = _monte_carlo(setup)
    metrics = _run_metrics(setup, results)
    metrics["prior_contradicted_s"] = list(results[0][0].prior_contradicted)
    _warn_prior_contradicted(results)
    # ---- write (into a staging folder under the --out lock; moved into --out once all three are whole)
    first, meas0, _ = results[0]
    tr = setup.truth
    with output_folder(out, "run") as stage:
        write_table(stage / "states.parquet", _states_table(tr, first, setup.scored))
        record_navigation(stage / "run.rrd", tr, first, meas0, recording_id=f"run-{tr.scenario.name}-{filter_}-seed{seed}", with_truth=setup.scored)
        write_json(stage / "metrics.json", metrics)
    for line in summary_lines(metrics):
        typer.echo(line)
    typer.echo(f"wrote {out / 'metrics.json'}, {out / 'states.parquet'} and {out / 'run.rrd'}")


@dataclass(frozen=True)
class RunSetup:
    """What ``lcnav run`` runs, validated: the truth, one run's navigation set-up, the measurements, the Monte-Carlo runs."""

    truth: Truth  #: the filter's times and servicer state; its ``x`` is what the run is scored against when ``scored``
    nav: NavigationSetup  #: the filter and its tuning, the prior, the measurements' noise and faults, the gates
    meas: object  #: measurements read from --measurements, or None to simulate them
    runs: int
    seed: int
    config: dict  #: the options as metrics.json records them
    scored: bool = True  #: whether ``truth.x`` is the truth of the measurements (simulated, or from --truth-file)


def _parse_prior(prior_json, prior_rate_deg_s, prior_axis, prior_error) -> BodyRatePrior | None:
    from estimators.prior import BodyRatePrior

    if prior_json is not None and prior_rate_deg_s is not None:
        raise v.InputError("--prior-json and --prior-rate-deg-s: both given: expected the prior as one of them")
    if prior_json is not None:
        return _read_prior_json(prior_json, prior_axis)
    if prior_rate_deg_s is None:
        return None
    if not prior_rate_deg_s.strip():
        raise v.InputError("prior without a rate: --prior-rate-deg-s '': expected 'wx,wy,wz' in deg/s")
    w = np.radians(_floats(prior_rate_deg_s, 3, "--prior-rate-deg-s (prior rate)", max_abs=MAX_RATE_DEG_S))
    return BodyRatePrior(w, np.full(3, prior_error * max(float(np.linalg.norm(w)), 1e-6)), source="--prior-rate-deg-s")


def _parse_faults(fault: str | None) -> tuple:
    from perception.simulated_pose import parse_faults

    if not fault:
        return ()
    start, length = _floats(fault, 2, "--fault", max_abs=1e6)
    if start < 0 or length <= 0:
        v.fail("--fault", fault, "'START,LENGTH' in s with START >= 0 and LENGTH > 0")
    return parse_faults([(start, length)])


def _parse_p0(p0_diag: str | None) -> np.ndarray | None:
    if p0_diag is None:
        return None
    d = _floats(p0_diag, 14, "--p0-diag")
    if np.any(d <= 0):
        v.fail("--p0-diag", p0_diag, "14 variances > 0 (P_0 positive definite)")
    return np.diag(d)


def _setup(*, scenario, filter_, duration, dt, prior, prior_error, prior_rate_deg_s, prior_json, prior_axis, proxy_mode, tuning, p0_diag,
           fault, runs, seed, noise, sigma_q_rad, sigma_r_m, gate_confidence, gate_start, reacquire_window, measurements, truth_file,
           truth) -> RunSetup:
    """Validate every option (single options are bounded by their callbacks) before any work or output; simulate the truth."""
    from estimators.measurement import PoseNoise
    from estimators.perturbations import get_truth_physics
    from estimators.prior import BodyRatePrior
    from estimators.state import W_B
    from estimators.tuning import get_tuning
    from studies.sim.navigation import NavigationSetup, considered_states
    from studies.sim.scenarios import get_scenario
    from studies.sim.truth import simulate_truth

    sc = get_scenario(scenario)
    if dt > duration or duration / dt > MAX_STEPS:
        v.fail("--duration/--dt", f"{duration:g}/{dt:g}", f"--dt <= --duration and at most {MAX_STEPS} filter steps")
    if reacquire_window != 0 and reacquire_window < 3:
        v.fail("--reacquire-window", reacquire_window, "0 (off) or at least 3 measurements")
    pose_noise = PoseNoise(sigma_q_rad, sigma_r_m, noise)
    spin = _parse_prior(prior_json, prior_rate_deg_s, prior_axis, prior_error)
    faults = _parse_faults(fault)
    P0 = _parse_p0(p0_diag)
    meas = _read_measurements(measurements, (0.0, duration)) if measurements is not None else None
    if truth_file is not None and meas is None:
        v.fail("--truth-file", str(truth_file), "it with --measurements (a simulated run is scored against its own truth)")
    if meas is not None and spin is None and prior != "none":
        v.fail("--prior", prior, "with --measurements, the prior's rate from --prior-json or --prior-rate-deg-s (the simulated truth is not the file's)")
    physics = get_truth_physics(truth)
    tr = simulate_truth(sc, duration, dt, physics)
    if truth_file is not None:
        tr = dataclasses.replace(tr, x=_read_truth_file(truth_file, tr.t, sc.name))
    if spin is None and prior != "none":
        spin = BodyRatePrior.from_truth(tr.target[0, W_B], prior_error)
    tuning_name = tuning or DEFAULT_TUNINGS[physics.name]
    tun = get_tuning(tuning_name)
    consider = considered_states(sc, physics)
    config = {"duration_s": duration, "dt_s": dt, "prior": prior, "prior_error": prior_error, "proxy_mode": proxy_mode if prior == "proxy" else None,
              "tuning": tuning_name, "fault": [list(f) for f in faults], "runs": runs, "seed": seed, "noise": noise, "sigma_q_rad": sigma_q_rad,
              "sigma_r_m": sigma_r_m, "gate_confidence": gate_confidence or None, "gate_start_s": gate_start, "k_estimated": not consider,
              "reacquire_window": reacquire_window or None, "prior_w_T_T_rad_s": None if spin is None else spin.w_T_T_rad_s.tolist(),
              "truth": physics.name, "truth_physics": physics.as_dict(),
              "scored_against": "simulated" if meas is None else (None if truth_file is None else str(truth_file))}
    nav = NavigationSetup(filter_, tun, P0=P0, prior=spin, prior_use=prior, proxy_mode=proxy_mode, faults=faults, pose_noise=pose_noise,
                          gate_confidence=gate_confidence or None, gate_start_s=gate_start, consider=consider, reacquire_window=reacquire_window or None)
    return RunSetup(tr, nav, meas, runs, seed, config, scored=meas is None or truth_file is not None)


def _warn_prior_contradicted(results: list) -> None:
    """One ``lcnav: warning:`` line if a run's full-information fits passed only without the spin prior's rate (the prior disagrees with the data)."""
    hit = [(i, r.prior_contradicted) for i, (r, _, _) in enumerate(results) if r.prior_contradicted]
    if hit:
        i, times = hit[0]
        typer.echo(f"lcnav: warning: the spin prior contradicts the measurements in {len(hit)} of {len(results)} run(s): the filter's "
                   f"full-information fit passed its chi-square test only with the prior's rate left free ({len(times)} time(s) from "
                   f"t = {times[0]:g} s in run {i}); the estimate follows the measurements, not the prior (check --prior-json and --prior-axis)",
                   err=True)


def _monte_carlo(setup: RunSetup) -> list:
    """``(run, measurements, metrics)`` of each run ``i``, drawn from seed ``seed + i`` (a progress bar when stderr is a terminal)."""
    from tqdm import tqdm

    from studies.sim.metrics import evaluate
    from studies.sim.navigation import navigate

    results = []
    tr = setup.truth
    with tqdm(total=setup.runs, desc="lcnav run", unit="run", leave=False, disable=None) as bar:
        for i in range(setup.runs):
            rng = np.random.default_rng(setup.seed + i)
            run_i, meas_i = navigate(tr, setup.nav, rng, meas=setup.meas)
            results.append((run_i, meas_i, evaluate(tr.t, run_i.x, run_i.P, tr.x) if setup.scored else None))
            bar.update(1)
    return results


def _mean_over_runs(results, g: str, key: str):
    values = [getattr(r[2]["state"][g], key) for r in results]
    return _num(float(np.nanmean(values)) if any(np.isfinite(values)) else float("nan"))


#: metrics.json keys that score against a truth: absent when ``lcnav run --measurements`` has no ``--truth-file``.
TRUTH_KEYS = ("components", "nees_fraction_in_95", "filter_components", "components_mean_over_runs", "nees")


def _truth_metrics(setup: RunSetup, results: list, sel: np.ndarray) -> dict:
    """The truth-based part of metrics.json: §6 metrics of the first run and their means over the runs, NEES in band."""
    from estimators.state import DK, N_ERROR
    from studies.sim.metrics import GROUPS, SETTLING_S, block_nees_per_dof, chi_square_band, nees

    tr = setup.truth
    states = np.arange(DK.start) if setup.nav.consider else np.arange(N_ERROR)
    E = np.array([nees(r.x, r.P, tr.x, states) for r, _, _ in results])
    lo, hi = chi_square_band(len(states), setup.runs, 0.95)
    avg = E[:, sel].mean(axis=0)
    m0 = results[0][2]
    blocks = [block_nees_per_dof(r.x[sel], r.P[sel], tr.x[sel], states) for r, _, _ in results] if sel.any() else []
    per_dof = {"per_dof": _num(float(avg.mean()) / len(states)),
               "per_dof_alone": {g: _num(float(np.mean([b[0][g] for b in blocks]))) for g in blocks[0][0]},
               "per_dof_given_rest": {g: _num(float(np.mean([b[1][g] for b in blocks]))) for g in blocks[0][1]}} if blocks else {}
    return {
        "components": _metrics_dict(m0["state"]),
        "nees_fraction_in_95": _num(float(np.mean((avg >= lo) & (avg <= hi))) if avg.size else float("nan")),
        "filter_components": _metrics_dict(m0["filter"]),
        "components_mean_over_runs": {g: {k: _mean_over_runs(results, g, k) for k in ("convergence_time_s", "steady_state_rmse")} for g in GROUPS},
        "nees": {"dof": int(len(states)), "from_s": float(SETTLING_S), "band_95": [lo, hi], "runs": setup.runs, **per_dof},
    }


def _run_metrics(setup: RunSetup, results: list) -> dict:
    """metrics.json: with a truth its :data:`TRUTH_KEYS` (:func:`_truth_metrics`); NIS in band from ``SETTLING_S``, gate rates."""
    from estimators.navigation import SOURCES
    from studies.sim.metrics import SETTLING_S, fraction_in_band

    tr = setup.truth
    sel = (tr.t - tr.t[0]) >= SETTLING_S
    first = results[0][0]
    return {
        "filter": setup.nav.filter_name,
        "scenario": tr.scenario.name,
        **(_truth_metrics(setup, results, sel) if setup.scored else {}),
        "nis_fraction_in_95": {s: _num(fraction_in_band(np.array([r.nis[s][sel] for r, _, _ in results]), 3)) for s in SOURCES},
        "reacquisitions": [[t_re, source] for t_re, source in first.reacquisitions],
        "gate_rejection_rate": {s: _num(float(np.mean([np.mean(~r.accepted[s][np.isfinite(r.nis[s])]) for r, _, _ in results]))) for s in SOURCES},
        "config": setup.config,
    }


def summary_lines(metrics: dict) -> list[str]:
    """What ``lcnav run`` prints of ``metrics.json``: per group t_conv and RMSE (mean over the runs), consistency, gates."""
    from studies.sim.metrics import SETTLING_S, UNITS

    cfg = metrics["config"]

    def pct(x, digits=0):
        return "–" if x is None else f"{100 * x:.{digits}f} %"

    truth = cfg.get("truth", "torque-free")  # metrics.json written before the perturbed truth existed: torque-free
    lines = [f"lcnav run: {metrics['filter'].upper()} on {metrics['scenario']}{'' if truth == 'torque-free' else f' ({truth} truth)'}, "
             f"tuning {cfg['tuning']!r}, {cfg['runs']} run(s) of "
             f"{cfg['duration_s']:g} s at {cfg['dt_s']:g} s (mean over the runs; '–': did not converge)"]
    nis, gate = metrics["nis_fraction_in_95"], metrics["gate_rejection_rate"]
    nis_text = f"NIS in band {', '.join(f'{s} {pct(v)}' for s, v in nis.items())}"
    if "nees" in metrics:
        lines.append(f"  {'group':6s}{'t_conv (s)':>12s}{'RMSE':>14s}")
        for g, c in metrics["components_mean_over_runs"].items():
            t_conv, rmse = c["convergence_time_s"], c["steady_state_rmse"]
            lines.append(f"  {g:6s}{'–' if t_conv is None else f'{t_conv:.1f}':>12s}{'–' if rmse is None else f'{rmse:.3g}':>14s} {UNITS[g]}")
        n = metrics["nees"]
        lines.append(f"  from t >= {n['from_s']:g} s: NEES in its 95 % band on {pct(metrics['nees_fraction_in_95'])} of the steps "
                     f"({n['dof']} dof); {nis_text}")
        if n.get("per_dof_alone"):  # metrics.json written before 2026-12-03 has no per-block figures

            def fig(v):
                return "–" if v is None else f"{v:.2f}"

            lines.append(f"  NEES/dof {fig(n['per_dof'])}; each block alone {', '.join(f'{g} {fig(v)}' for g, v in n['per_dof_alone'].items())}; "
                         f"given the other blocks {', '.join(f'{g} {fig(v)}' for g, v in n['per_dof_given_rest'].items())}")
    else:
        lines.append(f"  no truth to score against (--measurements without --truth-file); from t >= {SETTLING_S:g} s {nis_text}")
    lines.append(f"  gates (confidence {cfg['gate_confidence']}): rejected {', '.join(f'{s} {pct(v, 1)}' for s, v in gate.items())}"
                 + (f"; {len(metrics['reacquisitions'])} re-acquisition(s)" if metrics["reacquisitions"] else ""))
    return lines


def register(app: typer.Typer) -> None:
    app.command("run")(run)
