"""Pictures of recordings without a display: rerun's own viewer, headless, draws the blueprint to a PNG.

``rerun --headless --screenshot-to`` runs the native viewer offscreen; on a machine
with no GPU it draws with Mesa's software Vulkan driver (Debian ``mesa-vulkan-drivers``,
installed by ``make``). What it shows is what a user sees when they open the file:
the recording's blueprint, styles and time ranges, so a picture checks all three.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import tempfile
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
_ANSI = re.compile(r"\x1b\[[0-9;]*m")
_NO_DRIVER = ("graphics adapter", "render state", "render context")


#: Viewer runs before a picture of existing files that shows the error screen or nothing, with no error in the viewer's
#: log and exit 0, is called an error: on a loaded machine rerun's headless viewer sometimes saves its frame before the
#: files have loaded ("Data source finished without loading a recording"; seen in 1 of 4 full test suites on 2 cores).
#: A file the viewer cannot load logs an ERROR and fails at once.
VIEWER_ATTEMPTS = 3


def rerun_executable() -> Path:
    """The ``rerun`` command installed beside this interpreter (the venv's ``bin/``)."""
    exe = Path(sys.executable).with_name("rerun")
    if not exe.is_file():
        raise ScreenshotUnavailable(f"rerun not found beside {sys.executable}: install rerun-sdk into this environment")
    return exe


def viewer_errors(log: str) -> list[str]:
    """The ERROR records of the viewer's log (its stderr/stdout, colour codes removed), each with its continuation lines.

    ``2026-...Z ERROR re_viewer::app::add_data_source: Failed to load file ...`` followed by lines that start with no
    time stamp (``File path: ...``) give one entry ``"re_viewer::app::add_data_source: Failed to load file ... File path: ..."``.
    """
    records, current = [], None
    for line in _ANSI.sub("", log).splitlines():
        m = re.match(r"^\d{4}-\d\d-\d\dT\S+\s+(\w+)\s+(.*)$", line)
        if m:
            current = [m.group(2)] if m.group(1) == "ERROR" else None
            if current is not None:
                records.append(current)
        elif current is not None and line.strip():
            current.append(line.strip())
    return [" ".join(r) for r in records]


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


def screenshot_recording(rrds, png, *, width_px: int = 1600, height_px: int = 1000, timeout_s: float = 180.0) -> Path:
    """Draw the recording(s) ``rrds`` as the viewer opens them and write ``png`` atomically.

    ``width_px`` × ``height_px`` is the window in logical points (the PNG is
    drawn at the viewer's pixel scale, usually twice that). The viewer listens
    on 127.0.0.1 only, on a free port. Paths are resolved against the current
    folder before the viewer (which runs in a scratch folder) sees them.

    Raises :class:`ScreenshotUnavailable` if this machine cannot draw headless, and :class:`ScreenshotError` if the
    viewer exits with an error, logs an ERROR (a file it cannot load), or the picture fails :func:`check_picture`;
    no ``png`` is written then.
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
    try:
        shot = work / "shot.png"
        cmd = [str(rerun_executable()), "--headless", "--renderer", "vulkan", "--bind", "127.0.0.1", "--port", "auto",
               "--window-size", f"{width_px}x{height_px}", "--screenshot-to", str(shot), *map(str, rrds)]
        env = dict(os.environ, RERUN_ANALYTICS="0")
        what = ", ".join(map(str, rrds))
        for attempt in range(1, VIEWER_ATTEMPTS + 1):
            try:
                res = subprocess.run(cmd, cwd=work, env=env, capture_output=True, text=True, timeout=timeout_s)
            except subprocess.TimeoutExpired as e:
                raise ScreenshotError(f"the headless viewer did not finish within {timeout_s:g} s") from e
            log = res.stderr + res.stdout
            if res.returncode != 0 and any(k in log for k in _NO_DRIVER):
                raise ScreenshotUnavailable(f"cannot draw {what}: no Vulkan driver (Debian: apt-get install mesa-vulkan-drivers)")
            errors = viewer_errors(log)
            if errors:
                raise ScreenshotError(f"the viewer could not show {what}: {errors[0][:400]}")
            if res.returncode != 0 or not shot.is_file():
                raise ScreenshotError(f"could not draw {what}: rerun exited {res.returncode} without a picture")
            try:
                check_picture(shot)
                break
            except ScreenshotError:  # the viewer saved its frame before the files had loaded, and said nothing (see VIEWER_ATTEMPTS)
                if attempt == VIEWER_ATTEMPTS:
                    raise
        os.replace(shot, png)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return png
