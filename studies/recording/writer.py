"""Rerun recordings: one place that opens, fills and atomically saves ``.rrd`` files.

Entity paths follow DESIGN.md (``/truth/...``, ``/estimate/<filter>/...``,
``/measurement/...``, ...); the timeline is ``sim_time`` in seconds. Series
are sent as columns (``rr.send_columns``), which is much faster than one
``log`` call per step.
"""

from __future__ import annotations

import contextlib
import os
import uuid
from pathlib import Path

import numpy as np

from studies.engine.io import atomic_path

os.environ.setdefault("RERUN_ANALYTICS", "0")

import rerun as rr  # noqa: E402  (after the analytics switch)

TIMELINE = "sim_time"


@contextlib.contextmanager
def recording(path, *, recording_id: str | None = None, application_id: str = "lcnav", blueprint=None):
    """Yield a :class:`rerun.RecordingStream` that is saved atomically to ``path`` on exit.

    The recording is named after ``recording_id`` (or the file's stem), so several
    recordings opened together are told apart in the viewer (not "<unknown>").
    It is kept in memory (``memory_recording``) and written by this thread with
    :func:`studies.engine.io.atomic_path` at the end: rerun's own file sink writes
    from a background thread, which on a full disk only logs ``ERROR
    re_log_encoding...`` lines and fails later with "File-writer thread shut down
    prematurely"; here the write's own ``OSError`` (a full disk, a permission)
    reaches the caller, and nothing is written if the block raises. With rerun switched off in the environment
    (``RERUN=off``, rerun's own kill switch) the stream would drop everything: a ``ValueError`` says so before
    anything is logged.
    """
    path = Path(path)
    rec = rr.RecordingStream(application_id, recording_id=recording_id or str(uuid.uuid4()), send_properties=False)
    if not rec.is_enabled():
        raise ValueError(f"{path.name}: rerun is switched off in this environment (RERUN={os.environ.get('RERUN', '')!r}), so no recording "
                         "can be written: expected RERUN unset (or on)")
    memory = rec.memory_recording()
    try:
        if blueprint is not None:
            rec.send_blueprint(blueprint, make_active=False, make_default=True)
        rec.send_recording_name(recording_id or path.stem)
        yield rec
        rec.flush()
        data = memory.drain_as_bytes()
    finally:
        rec.disconnect()
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)


def time_column(t_s) -> rr.TimeColumn:
    """The ``sim_time`` index column for ``t_s`` seconds."""
    # rounded to whole nanoseconds: rerun truncates float seconds, which can split
    # one epoch (e.g. 3.0303… s) from the same epoch logged with set_time (rounded)
    ns = np.round(np.asarray(t_s, dtype=float) * 1e9).astype(np.int64)
    return rr.TimeColumn(TIMELINE, duration=ns.astype("timedelta64[ns]"))


def set_sim_time(rec, t_s: float) -> None:
    """Set ``sim_time`` for the next ``log`` calls, stamped exactly as :func:`time_column` stamps it."""
    rec.set_time(TIMELINE, duration=np.timedelta64(int(np.round(float(t_s) * 1e9)), "ns"))


def send_scalars(rec, entity: str, t_s, values, names=None) -> None:
    """Send one scalar series per column of ``values`` (``(N,)`` or ``(N, k)``).

    With ``names`` each column goes to ``entity/<name>``; a 1-D series goes to ``entity``.
    """
    values = np.asarray(values, dtype=float)
    if values.ndim == 1:
        rr.send_columns(entity, indexes=[time_column(t_s)], columns=rr.Scalars.columns(scalars=values), recording=rec)
        return
    names = names or [str(i) for i in range(values.shape[1])]
    for name, col in zip(names, values.T):
        rr.send_columns(f"{entity}/{name}", indexes=[time_column(t_s)], columns=rr.Scalars.columns(scalars=col), recording=rec)


def send_poses(rec, entity: str, t_s, translation, quat_wxyz) -> None:
    """Send a time series of rigid transforms (parent <- entity) of ``entity``."""
    q = np.asarray(quat_wxyz, dtype=float)
    xyzw = np.concatenate([q[:, 1:], q[:, :1]], axis=1)
    rr.send_columns(
        entity,
        indexes=[time_column(t_s)],
        columns=rr.Transform3D.columns(translation=np.asarray(translation, dtype=float), quaternion=xyzw),
        recording=rec,
    )
