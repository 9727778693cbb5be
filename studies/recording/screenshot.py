"""Pictures of recordings without a display: rerun's own viewer, headless, draws the blueprint to a PNG.

``rerun --headless`` runs the native viewer offscreen; on a machine with no GPU it draws with
Mesa's software Vulkan driver (Debian ``mesa-vulkan-drivers``, installed by ``make``). What it
shows is what a user sees when they open the file: the recording's blueprint, styles and time
ranges, so a picture checks all three.

The viewer is driven through its control API (``rerun.experimental.ViewerClient``, rerun 0.41): the
files are opened, the viewer is asked until it has nothing left to load, and pictures are taken until
two in a row are the same (:func:`_settled_picture`). ``rerun --headless --screenshot-to`` took its picture after a fixed number of frames instead, and
on a loaded machine that was sometimes before the files had loaded: a picture of the viewer's chrome
with no plot (2 of 8 pictures with two busy processes on 2 cores, 2026-11-30; all 6 attempts of one
test in one full test suite), which no check of the picture alone can tell from an empty recording.
"""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path


class ScreenshotError(RuntimeError):
    """The headless viewer did not draw the recording: it could not load it, reported an error, or drew an error screen."""


class ScreenshotUnavailable(ScreenshotError):
    """This machine cannot draw headless at all: no ``rerun`` beside the interpreter, or no Vulkan driver."""


#: Background of the viewer's "Failed to load File: ...: Data source finished without loading a recording" banner,
#: 8-bit sRGB (rerun 0.2x dark theme; measured on the screens of a missing, a garbage and an empty ``.rrd``: ~26 000
#: pixels of a 1800x1200 picture; none in a picture of a recording).
ERROR_BANNER_RGB = (56, 10, 25)
#: More pixels of :data:`ERROR_BANNER_RGB` than this make a picture an error screen (the banner is ~20x larger).
MAX_ERROR_BANNER_PX = 1000
#: A picture whose most common colour covers more than this fraction of it is blank (a failed draw); the viewer's
#: own chrome alone (panels, menus, time bar) covers ~25 %.
MAX_BACKGROUND_FRACTION = 0.98
_NO_DRIVER = ("graphics adapter", "render state", "render context")
#: Seconds between two questions to the viewer while it starts or loads.
POLL_S = 0.1
#: Seconds between two pictures that must be the same for the view to count as drawn (:func:`_settled_picture`).
SETTLE_S = 0.5


def rerun_executable() -> Path:
    """The ``rerun`` command installed beside this interpreter (the venv's ``bin/``)."""
    exe = Path(sys.executable).with_name("rerun")
    if not exe.is_file():
        raise ScreenshotUnavailable(f"rerun not found beside {sys.executable}: install rerun-sdk into this environment")
    return exe


def check_picture(png) -> None:
    """ScreenshotError unless ``png`` shows content: not blank (one colour over :data:`MAX_BACKGROUND_FRACTION` of it)
    and not the viewer's load-error screen (its banner, :data:`ERROR_BANNER_RGB`, on over :data:`MAX_ERROR_BANNER_PX` pixels)."""
    import matplotlib.image as mpimg
    import numpy as np

    try:
        rgb = np.round(mpimg.imread(png)[..., :3] * 255.0).astype(np.uint8).reshape(-1, 3)
    except (OSError, ValueError, SyntaxError) as e:  # PIL's truncated/garbled image errors
        raise ScreenshotError(f"{png}: not a readable PNG ({e})") from None
    _, counts = np.unique(rgb, axis=0, return_counts=True)
    if counts.max() > MAX_BACKGROUND_FRACTION * len(rgb):
        raise ScreenshotError(f"{png}: blank picture ({100 * counts.max() / len(rgb):.1f} % of it one colour): the viewer drew nothing")
    banner = int(np.all(rgb == np.array(ERROR_BANNER_RGB, dtype=np.uint8), axis=1).sum())
    if banner > MAX_ERROR_BANNER_PX:
        raise ScreenshotError(f"{png}: the viewer's load-error screen ({banner} pixels of its error banner)")


def _free_port() -> int:
    """A TCP port free on 127.0.0.1 now (the viewer binds it a moment later; :func:`_start_viewer` retries if it was taken)."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def _start_viewer(cmd: list[str], work: Path, deadline: float, attempts: int = 3):
    """(process, client): ``rerun --headless`` started in ``work`` on a free port, and a ``ViewerClient`` that it answered.

    Raises :class:`ScreenshotUnavailable` when the viewer finds no Vulkan driver, :class:`ScreenshotError` when it exits
    otherwise or does not answer before ``deadline`` (``time.monotonic()``)."""
    from rerun.experimental import ViewerClient

    env = dict(os.environ, RERUN_ANALYTICS="0")
    log_path = work / "viewer.log"
    for _ in range(attempts):
        port = _free_port()
        with open(log_path, "w") as log:  # its own session: _stop ends the launcher and the viewer it starts together
            proc = subprocess.Popen([*cmd, "--port", str(port)], cwd=work, env=env, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
        while time.monotonic() < deadline:
            if proc.poll() is not None:
                break
            try:
                client = ViewerClient(f"rerun+http://127.0.0.1:{port}/proxy")
                client.get_state()
                return proc, client
            except Exception:  # noqa: BLE001 - not listening yet (the bindings raise their own error types)
                time.sleep(POLL_S)
        else:
            _stop(proc)
            raise ScreenshotError("the headless viewer did not answer in time")
        log = log_path.read_text(errors="replace")
        if any(k in log for k in _NO_DRIVER):
            raise ScreenshotUnavailable("no Vulkan driver (Debian: apt-get install mesa-vulkan-drivers)")
        if "in use" not in log:  # any other exit than a port taken between _free_port and the viewer
            raise ScreenshotError(f"the headless viewer exited {proc.returncode}: {log.strip()[-400:]}")
    raise ScreenshotError(f"the headless viewer found no free port in {attempts} tries")


def _stop(proc: subprocess.Popen, grace_s: float = 10.0) -> None:
    """End the viewer's process group (SIGTERM, SIGKILL after ``grace_s``): the ``rerun`` beside the interpreter is a Python
    launcher that runs the viewer as its child, and ending the launcher alone left the viewer running (78 of them after a
    day of trying screenshots, 10 GB)."""
    try:
        os.killpg(proc.pid, signal.SIGTERM)
    except ProcessLookupError:
        proc.wait()
        return
    deadline = time.monotonic() + grace_s
    while time.monotonic() < deadline:
        proc.poll()  # reap the launcher: a zombie would keep the group alive
        try:
            os.killpg(proc.pid, 0)
        except ProcessLookupError:
            return
        time.sleep(POLL_S)
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    proc.wait()


def _loaded(client, paths: list[Path], what: str, deadline: float) -> None:
    """Open ``paths`` in the viewer and wait until it has nothing left to load; :class:`ScreenshotError` if it logs an ERROR
    (a file it cannot read), opens no recording, or is still loading at ``deadline``."""
    opened = client.open([str(p) for p in paths])
    errors = [e.message.replace("\n", " ") for e in client.get_logs() if e.level == "ERROR"]
    if errors:
        raise ScreenshotError(f"the viewer could not show {what}: {errors[0][:400]}")
    if not opened.store_ids:
        raise ScreenshotError(f"the viewer opened no recording from {what}")
    while client.get_state().loading:
        if time.monotonic() > deadline:
            raise ScreenshotError(f"the viewer was still loading {what} after the time allowed")
        time.sleep(POLL_S)


def _settled_picture(client, what: str, deadline: float) -> bytes:
    """The viewer's picture (PNG bytes) once two taken :data:`SETTLE_S` apart are the same: the view has drawn what it loaded.

    A loaded recording is not yet a drawn one: the first picture after the load showed the time-series views' axes and
    streams but no line in 7 of 8 tries with two busy processes on 2 cores (2026-11-30); the next one had them in 8 of 8."""
    previous = client.take_screenshot()
    while time.monotonic() < deadline:
        time.sleep(SETTLE_S)
        picture = client.take_screenshot()
        if picture == previous:
            return picture
        previous = picture
    raise ScreenshotError(f"the viewer's picture of {what} did not settle in the time allowed")


def screenshot_recording(rrds, png, *, width_px: int = 1600, height_px: int = 1000, timeout_s: float = 180.0) -> Path:
    """Draw the recording(s) ``rrds`` as the viewer opens them and write ``png`` atomically.

    ``width_px`` × ``height_px`` is the window in logical points (the PNG is drawn at the viewer's pixel scale: one
    pixel per point headless). The viewer listens on 127.0.0.1 only, on a free port; the picture is taken once it has
    loaded every file and its picture stopped changing (module docstring). Paths are resolved against the current folder before the viewer (which runs
    in a scratch folder) sees them.

    Raises :class:`ScreenshotUnavailable` if this machine cannot draw headless, and :class:`ScreenshotError` if the
    viewer exits, logs an ERROR (a file it cannot load), opens no recording, does not finish within ``timeout_s``, or the
    picture fails :func:`check_picture`; no ``png`` is written then.
    """
    rrds = [Path(p).resolve() for p in ([rrds] if isinstance(rrds, (str, os.PathLike)) else rrds)]
    missing = [str(p) for p in rrds if not p.is_file()]
    if not rrds or missing:
        raise FileNotFoundError(f"no recording to draw: {', '.join(missing) or 'none given'}")
    if not (100 <= width_px <= 8000 and 100 <= height_px <= 8000):
        raise ValueError(f"screenshot size must be 100..8000 points a side, got {width_px}x{height_px}")
    png = Path(png).resolve()
    if png.suffix.lower() != ".png":
        raise ValueError(f"screenshot file must end in .png, got {png.name!r}")
    png.parent.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(prefix=f".{png.name}.", dir=png.parent))
    what = ", ".join(map(str, rrds))
    deadline = time.monotonic() + timeout_s
    proc = None
    try:
        cmd = [str(rerun_executable()), "--headless", "--renderer", "vulkan", "--bind", "127.0.0.1", "--window-size", f"{width_px}x{height_px}"]
        proc, client = _start_viewer(cmd, work, deadline)
        shot = work / "shot.png"
        try:
            _loaded(client, rrds, what, deadline)
            shot.write_bytes(_settled_picture(client, what, deadline))
        except ScreenshotError:
            raise
        except Exception as e:  # noqa: BLE001 - the control API's own errors: a viewer that died or stopped answering
            raise ScreenshotError(f"the headless viewer stopped answering while drawing {what}: {e}") from e
        check_picture(shot)
        os.replace(shot, png)
    finally:
        if proc is not None:
            _stop(proc)
        shutil.rmtree(work, ignore_errors=True)
    return png
