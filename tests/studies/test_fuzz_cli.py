"""Fuzzing every ``lcnav`` command and option type in-process (``studies.cli.main``), with hypothesis.

Each example starts from a cheap valid command line and replaces one option by
a value drawn from malformed and extreme inputs (NaN, inf, 1e308, hex, empty,
NUL bytes, huge integers, long text, paths that are files, unwritable places),
or feeds a malformed file (CSV, ECSV, JSON, TOML, RRD, measurement table).
Properties:

* the exit status is 0 or 2 — never 1 (the safety net of ``main`` for bugs);
* on 2, stderr is exactly one line ``lcnav: error: ...``;
* on 2, no file appeared or changed anywhere in the example's folder.

The expensive computation behind each command is replaced by a sentinel that
records its arguments and stops the command (:class:`Reached`, a
``BaseException`` the CLI does not catch): reaching it means validation
passed, and the test checks that what reached the computation is finite and
within the documented bounds — and that nothing was written before it.
"""

import contextlib
import importlib
import io
import json
import math
import os
import pkgutil
import tempfile
from pathlib import Path
from unittest import mock

import numpy as np
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from studies.cli import main

SETTINGS = settings(max_examples=50, deadline=None, suppress_health_check=[HealthCheck.too_slow], derandomize=True)


def _import_everything(*packages) -> None:
    """Import every module of ``packages`` now, so that their ``from x import y`` bind the real functions: a module first
    imported while a sentinel is patched in (a command's lazy import) would keep the sentinel for the rest of the worker's
    tests (seen: ``studies.catalog.demo.simulate_truth`` raised :class:`Reached` in ``test_demo``)."""
    for package in packages:
        module = importlib.import_module(package)
        for info in pkgutil.walk_packages(module.__path__, package + "."):
            if not info.name.endswith("__main__"):
                importlib.import_module(info.name)


_import_everything("studies", "lightcurves")


class Reached(BaseException):
    """Raised by a sentinel in place of a command's computation: validation has passed."""

    def __init__(self, name, args, kwargs):
        super().__init__(name)
        self.name, self.args_, self.kwargs = name, args, kwargs


def sentinel(name):
    def stop(*args, **kwargs):
        raise Reached(name, args, kwargs)

    return stop


SENTINELS = {
    "studies.cli.simulate.simulate_truth": "truth",
    "studies.sim.truth.simulate_truth": "run-truth",  # lcnav run imports it when it runs (studies.cli.simulate has its own name)
    "studies.sim.combina.run_combina": "combina",  # lcnav combina imports it when it runs
    "lightcurves.render.UnresolvedRenderer": "renderer",
    "studies.cli.perception.frame_pipeline": "frames",
    "studies.cli.perception.bench_registration": "bench",
    "studies.engine.registry.run_sweep": "sweep",
    "studies.catalog.demo.render_prior": "demo",
}


def snapshot(root: Path) -> dict:
    """Every path under ``root``: files with their size and modification time, folders by name."""
    out = {}
    for dirpath, dirnames, filenames in os.walk(root):
        out.update({str(Path(dirpath) / n): "folder" for n in dirnames})
        for n in filenames:
            st_ = (Path(dirpath) / n).lstat()
            out[str(Path(dirpath) / n)] = (st_.st_size, st_.st_mtime_ns)
    return out


def run_cli(argv: list[str], root: Path) -> tuple[int | None, str, Reached | None]:
    """``main(argv)`` with sentinels; returns ``(exit status or None if a sentinel stopped it, stderr, reached)``."""
    before = snapshot(root)
    err = io.StringIO()
    reached = None
    code = None
    with contextlib.ExitStack() as stack:
        for target, name in SENTINELS.items():
            stack.enter_context(mock.patch(target, sentinel(name)))
        stack.enter_context(contextlib.redirect_stdout(io.StringIO()))
        stack.enter_context(contextlib.redirect_stderr(err))
        try:
            code = main(argv)
        except Reached as r:
            reached = r
    text = err.getvalue()
    event(f"{argv[0]}: " + ("reached" if reached is not None else f"exit {code}"))
    assert "Traceback" not in text, text
    if reached is not None:
        assert snapshot(root) == before, f"{argv}: files written before the computation"
        return None, text, reached
    assert code in (0, 2), f"{argv} -> exit {code}: {text}"
    if code == 2:
        lines = text.strip().splitlines()
        errors = [ln for ln in lines if ln.startswith("lcnav: error:")]
        assert len(errors) == 1 and lines[-1] == errors[0] and all(ln.startswith("lcnav: ") for ln in lines), f"{argv}: {lines}"
        assert snapshot(root) == before, f"{argv}: files left after a failure"
    return code, text, None


# ---------------------------------------------------------------- values

NASTY_NUMBERS = ["nan", "-nan", "inf", "-inf", "1e308", "-1e308", "1e400", "0", "-0", "-1", "1e-320", "0x10", "1_0", "", " ",
                 "abc", "1e", "1,2", "\x00", "1\x00", "１", "9" * 400, str(2**63), str(-(2**63)), str(2**64)]
numbers = st.one_of(st.sampled_from(NASTY_NUMBERS),
                    st.floats(allow_nan=True, allow_infinity=True).map(repr),
                    st.integers(-(2**80), 2**80).map(str),
                    st.floats(-1e3, 1e3).map(lambda x: f"{x:g}"))
texts = st.one_of(st.sampled_from(["", "\x00", "a\x00b", "x" * 2000, "../..", "SC3\n", "ekf ", "0,0,0", "1,2", "nan,0,1", "inf,1,1",
                                   "1e308,0,0", "0x10,0,1", ",,", "tcp://localhost:99999", "tcp://h:1"]),
                  st.text(max_size=40))


def paths(root: Path):
    """Nasty paths under ``root``: files as folders, names with NUL, too long, under a file, unwritable."""
    blocker = root / "a-file"
    locked = root / "locked"
    return st.sampled_from([
        "", str(root / "x\x00y"), str(root / ("n" * 300)), str(blocker), str(blocker / "sub"), str(locked / "sub"),
        str(root / "new" / "deep" / "folder"), str(root / "ok.ecsv"), str(root / "ok.rrd"), str(root / "ok.parquet"), str(root),
    ])


def prepare_root(root: Path) -> None:
    (root / "a-file").write_text("not a folder\n")
    (root / "locked").mkdir()
    os.chmod(root / "locked", 0o500)


COMMANDS = {
    # command: (valid cheap argv, {option: kind})
    "simulate": (["simulate", "--duration", "20", "--dt", "1", "--out", "{out}"],
                 {"--scenario": "text", "--duration": "number", "--dt": "number", "--seed": "number", "--truth": "text", "--out": "path"}),
    "run": (["run", "--duration", "30", "--dt", "1", "--out", "{out}"],
            {"--scenario": "text", "--filter": "text", "--duration": "number", "--dt": "number", "--prior": "text", "--prior-error": "number",
             "--prior-rate-deg-s": "text", "--prior-axis": "text", "--proxy-mode": "text", "--tuning": "text", "--p0-diag": "text",
             "--fault": "text", "--runs": "number", "--seed": "number", "--noise": "text", "--sigma-q-rad": "number", "--sigma-r-m": "number",
             "--gate-confidence": "number", "--gate-start": "number", "--reacquire-window": "number", "--out": "path",
             "--measurements": "path", "--prior-json": "path", "--truth": "text"}),
    "combina": (["combina", "--duration-tu", "0.1", "--out", "{out}"],
                {"--target": "text", "--pose-source": "text", "--duration-tu": "number", "--rate-hz": "number", "--seed": "number",
                 "--prior": "text", "--prior-error": "number", "--axis-frame": "text", "--out": "path"}),
    "render": (["lightcurve", "render", "--duration", "40", "--cadence", "1", "--out", "{root}/lc.ecsv"],
               {"--target": "text", "--axis": "text", "--rate-deg-s": "number", "--duration": "number", "--cadence": "number", "--seed": "number",
                "--out": "path", "--record": "path", "--pole-ra-dec": "text", "--variant": "text", "--resolution": "number", "--spp": "number"}),
    "frames": (["perception", "frames", "--out", "{out}"],
               {"--target": "text", "--range": "number", "--seed": "number", "--out": "path", "--resolution": "number", "--spp": "number",
                "--estimate-error-deg": "number", "--estimate-error-m": "number"}),
    "bench": (["perception", "bench"], {"--poses": "number", "--seed": "number", "--method": "text"}),
    "study": (["study", "truth", "--quick", "--out", "{out}"], {"--config": "path", "--out": "path", "--scheduler": "text", "--workers": "number"}),
    "demo": (["demo", "--quick", "--out", "{out}"], {"--out": "path"}),
    "prior": (["lightcurve", "prior", "{root}/lc.csv"], {"--false-alarm-level": "number", "--maxima-per-rotation": "number", "--record": "path"}),
    "inspect": (["inspect", "{root}/missing.rrd"], {"--export": "path", "--contents": "text"}),
}


def good_lightcurve_csv(path: Path) -> None:
    t = np.arange(60) * 2.0
    path.write_text("time,mag,mag_err\n" + "".join(f"{a:g},{9 + 0.5 * np.cos(0.4 * a):.4f},0.02\n" for a in t))


def check_reached(r: Reached) -> None:
    """What passed validation is finite and within the documented bounds."""
    a, k = r.args_, r.kwargs
    if r.name in ("truth", "run-truth"):
        duration, dt = float(a[1]), float(a[2])
        assert math.isfinite(duration) and math.isfinite(dt) and 0 < dt <= duration
        assert duration / dt <= (1e6 if r.name == "truth" else 1e5)
    elif r.name == "combina":
        cfg = a[0]
        assert 0 < cfg.rate_hz <= 10 and 0 < cfg.duration_tu <= 100 and cfg.effective_duration_s * cfg.rate_hz <= 1e5
    elif r.name == "renderer":
        assert 4 <= k["resolution"] <= 1024 and k["spp"] in (1, 4, 16, 64, 256)
    elif r.name == "frames":
        assert 5 <= a[1] <= 1000 and 64 <= k["resolution"] <= 4096 and 1 <= k["spp"] <= 1024
        assert 0 <= k["estimate_error_deg"] <= 180 and 0 <= k["estimate_error_m"] <= 100
    elif r.name == "bench":
        assert 1 <= a[0] <= 100000 and 0 <= a[1] < 2**63
    elif r.name == "sweep":
        assert 1 <= len(a[0]) <= 10**5
    elif r.name == "demo":
        pass
    else:  # pragma: no cover
        raise AssertionError(r.name)


@settings(SETTINGS, max_examples=300)
@given(data=st.data())
def test_every_option_one_line_or_valid(data):
    command = data.draw(st.sampled_from(sorted(COMMANDS)), label="command")
    base, options = COMMANDS[command]
    option = data.draw(st.sampled_from(sorted(options)), label="option")
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        prepare_root(root)
        good_lightcurve_csv(root / "lc.csv")
        kind = options[option]
        value = data.draw(numbers if kind == "number" else texts if kind == "text" else paths(root), label=option)
        argv = [s.format(out=root / "out", root=root) for s in base]
        if option in argv:
            argv[argv.index(option) + 1] = value
        else:
            argv += [option, value]
        try:
            code, err, reached = run_cli(argv, root)
        finally:
            os.chmod(root / "locked", 0o700)
        if reached is not None:
            check_reached(reached)


# ---------------------------------------------------------------- malformed files

cells = st.one_of(st.sampled_from(["", " ", "nan", "inf", "-inf", "0x10", "1_0", "1e999", "1e", "--", "abc", "2024-03-21T20:00:00", "\x00", '"1"']),
                  st.floats(-1e6, 1e6).map(lambda x: f"{x:.6g}"), st.integers(-100, 10**6).map(str))


@st.composite
def csv_texts(draw):
    header = draw(st.sampled_from(["time,mag", "time,mag,mag_err", "TIME , Mag", "time,mag,mag", "t,m", "time", "time,mag,extra", ""]))
    n = draw(st.integers(0, 40))
    width = max(1, header.count(",") + 1)
    rows = [",".join(draw(cells) for _ in range(draw(st.sampled_from([width, width, width, width - 1, width + 1])))) for _ in range(n)]
    return header + "\n" + "\n".join(rows) + ("\n" if draw(st.booleans()) else "")


@SETTINGS
@given(text=csv_texts())
def test_lightcurve_prior_on_malformed_csv(text):
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        path = root / "lc.csv"
        path.write_bytes(text.encode("utf-8", "surrogatepass"))
        run_cli(["lightcurve", "prior", str(path)], root)


@SETTINGS
@given(data=st.binary(max_size=400), suffix=st.sampled_from([".csv", ".ecsv"]))
def test_lightcurve_prior_on_random_bytes(data, suffix):
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        path = root / f"lc{suffix}"
        path.write_bytes(data)
        run_cli(["lightcurve", "prior", str(path), "--record", str(root / "p.rrd")], root)


json_values = st.recursive(st.none() | st.booleans() | st.floats() | st.integers(-(2**70), 2**70) | st.text(max_size=10),
                           lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=8), inner, max_size=3), max_leaves=8)


@st.composite
def prior_jsons(draw):
    kind = draw(st.sampled_from(["object", "any", "deep", "bytes"]))
    if kind == "object":
        d = {"rate_rad_s": draw(json_values), "rate_sigma_rad_s": draw(json_values)}
        return json.dumps(d).encode()
    if kind == "any":
        return json.dumps(draw(json_values)).encode()
    if kind == "deep":
        return b"[" * 100000 + b"]" * 100000
    return draw(st.binary(max_size=200))


@SETTINGS
@given(data=prior_jsons())
def test_run_prior_json(data):
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        path = root / "prior.json"
        path.write_bytes(data)
        code, _, reached = run_cli(["run", "--duration", "30", "--dt", "1", "--prior", "init", "--prior-json", str(path), "--out", str(root / "out")], root)
        if reached is not None:  # a prior that passed holds finite numbers within bounds
            d = json.loads(data)
            assert 0 <= d["rate_rad_s"] <= np.radians(360) and 0 < d["rate_sigma_rad_s"] <= np.radians(360)


MEASUREMENT_HEADER = "t_s,q_TS_0,q_TS_1,q_TS_2,q_TS_3,r_ST_T_x_m,r_ST_T_y_m,r_ST_T_z_m"


@st.composite
def measurement_csvs(draw):
    n = draw(st.integers(0, 6))
    rows = []
    for i in range(n):
        good = [f"{i * 2.0:g}", "1", "0", "0", "0", "1", "2", "-40"]
        j = draw(st.integers(0, 8))
        if j < 8:
            good[j] = draw(cells)
        rows.append(",".join(good))
    header = draw(st.sampled_from([MEASUREMENT_HEADER, MEASUREMENT_HEADER.replace("t_s", "t"), ""]))
    return (header + "\n" + "\n".join(rows) + "\n").encode("utf-8", "surrogatepass")


@SETTINGS
@given(data=st.one_of(measurement_csvs(), st.binary(max_size=200)), suffix=st.sampled_from([".csv", ".parquet"]))
def test_run_measurements(data, suffix):
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        path = root / f"m{suffix}"
        path.write_bytes(data)
        run_cli(["run", "--duration", "30", "--dt", "1", "--measurements", str(path), "--out", str(root / "out")], root)


def toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf") if math.isinf(v) else repr(v)
    if isinstance(v, int):
        return str(v)
    if isinstance(v, str):
        return json.dumps(v)
    return "[" + ", ".join(toml_value(x) for x in v) + "]"


toml_values = st.one_of(st.integers(-(2**63), 2**63 - 1), st.floats(), st.booleans(), st.text(max_size=12),
                        st.lists(st.one_of(st.integers(-(2**63), 2**63 - 1), st.floats(), st.text(max_size=5)), max_size=4),
                        st.sampled_from([10**12, 10**6, 100001, 1e12, 1e300, -1, 0, 0.0, 1e-300]))
TRUTH_FIELDS = ["seed", "scenarios", "n_seeds", "duration_s", "dt_s", "rk4_dt_s", "rk4_tolerance_m", "position_jitter_m", "confidence", "speed"]


@SETTINGS
@given(field=st.sampled_from(TRUTH_FIELDS), value=toml_values, quick=st.booleans(), garbage=st.one_of(st.none(), st.binary(max_size=200)))
def test_study_config_toml(field, value, quick, garbage):
    from studies.engine.config import default_config_path

    text = default_config_path("truth").read_text()
    lines = [ln for ln in text.splitlines() if not ln.startswith(f"{field} =")]
    k = lines.index("[quick]") if "[quick]" in lines else len(lines)
    lines.insert(k, f"{field} = {toml_value(value)}")
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        cfg = root / "c.toml"
        cfg.write_bytes(garbage if garbage is not None else "\n".join(lines).encode("utf-8", "surrogatepass"))
        argv = ["study", "truth", "--config", str(cfg), "--out", str(root / "out")] + (["--quick"] if quick else [])
        code, _, reached = run_cli(argv, root)
        if reached is not None:
            check_reached(reached)


@SETTINGS
@given(data=st.binary(max_size=300), prefix=st.sampled_from([b"", b"RRF2", b"RRF2\x00\x00\x00\x00"]))
def test_inspect_random_rrd(data, prefix):
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        path = root / "r.rrd"
        path.write_bytes(prefix + data)
        run_cli(["inspect", str(path), "--export", str(root / "x.parquet")], root)
