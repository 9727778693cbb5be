"""Pictures of recordings without a display: rerun's own viewer, headless, draws the blueprint to a PNG.

``rerun --headless --screenshot-to`` runs the native viewer offscreen; on a machine
with no GPU it draws with Mesa's software Vulkan driver (Debian ``mesa-vulkan-drivers``,
installed by ``make``). What it shows is what a user sees when they open the file:
the recording's blueprint, styles and time ranges, so a picture checks all three.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path


class ScreenshotError(RuntimeError):
    """The headless viewer could not draw the recording (no Vulkan driver, a bad file, a time-out)."""


def rerun_executable() -> Path:
    """The ``rerun`` command installed beside this interpreter (the venv's ``bin/``)."""
    exe = Path(sys.executable).with_name("rerun")
    if not exe.is_file():
        raise ScreenshotError(f"rerun not found beside {sys.executable}: install rerun-sdk into this environment")
    return exe


def screenshot_recording(rrds, png, *, width_px: int = 1600, height_px: int = 1000, timeout_s: float = 180.0) -> Path:
    """Draw the recording(s) ``rrds`` as the viewer opens them and write ``png`` atomically.

    ``width_px`` × ``height_px`` is the window in logical points (the PNG is
    drawn at the viewer's pixel scale, usually twice that). The viewer listens
    on 127.0.0.1 only, on a free port.
    """
    rrds = [Path(p) for p in ([rrds] if isinstance(rrds, (str, os.PathLike)) else rrds)]
    missing = [str(p) for p in rrds if not p.is_file()]
    if not rrds or missing:
        raise FileNotFoundError(f"no recording to draw: {', '.join(missing) or 'none given'}")
    if not (100 <= width_px <= 8000 and 100 <= height_px <= 8000):
        raise ValueError(f"screenshot size must be 100..8000 points a side, got {width_px}x{height_px}")
    png = Path(png)
    if png.suffix.lower() != ".png":
        raise ValueError(f"screenshot file must end in .png, got {png.name!r}")
    png.parent.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(prefix=f".{png.name}.", dir=png.parent))
    try:
        shot = work / "shot.png"
        cmd = [str(rerun_executable()), "--headless", "--renderer", "vulkan", "--bind", "127.0.0.1", "--port", "auto",
               "--window-size", f"{width_px}x{height_px}", "--screenshot-to", str(shot), *map(str, rrds)]
        env = dict(os.environ, RERUN_ANALYTICS="0")
        try:
            res = subprocess.run(cmd, cwd=work, env=env, capture_output=True, text=True, timeout=timeout_s)
        except subprocess.TimeoutExpired as e:
            raise ScreenshotError(f"the headless viewer did not finish within {timeout_s:g} s") from e
        if res.returncode != 0 or not shot.is_file():
            reason = "no Vulkan driver? (Debian: apt-get install mesa-vulkan-drivers)" if "render context" in res.stderr + res.stdout else \
                f"rerun exited {res.returncode}"
            raise ScreenshotError(f"could not draw {', '.join(map(str, rrds))}: {reason}")
        os.replace(shot, png)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return png
