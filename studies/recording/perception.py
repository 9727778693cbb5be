"""The stereo-frame recording: both camera images, the depth, and the measured, model and registered clouds.

Entities: ``/camera/left/image``, ``/camera/right/image``, ``/camera/left/depth``
(m), ``/cloud/measured``, ``/cloud/model`` and ``/cloud/registered`` (camera
frame C, m), all at ``sim_time`` 0. The recording carries a viewer layout
(:func:`studies.recording.blueprint.run_blueprint` with the cameras and the clouds).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from studies.recording.blueprint import run_blueprint
from studies.recording.writer import recording, set_sim_time


def write_frame_recording(path: Path, frame, left_u8, right_u8, cloud, model_C, registered_C=None, *,
                          recording_id: str | None = None) -> None:
    """Write one stereo frame's recording to ``path`` atomically (named ``recording_id``, default ``perception-frames-<folder>``)."""
    import rerun as rr

    path = Path(path)
    rid = recording_id or f"perception-frames-{path.parent.name}"
    with recording(path, recording_id=rid, blueprint=run_blueprint(cameras=True, cloud=True)) as rec:
        set_sim_time(rec, 0.0)
        rec.log("/camera/left/image", rr.Image(left_u8))
        rec.log("/camera/right/image", rr.Image(right_u8))
        rec.log("/camera/left/depth", rr.DepthImage(np.nan_to_num(frame.depth_left, nan=0.0).astype(np.float32), meter=1.0))
        rec.log("/cloud/measured", rr.Points3D(cloud.points_C, colors=[(240, 200, 40)], radii=0.03))
        rec.log("/cloud/model", rr.Points3D(model_C, colors=[(120, 120, 120)], radii=0.02))
        if registered_C is not None:
            rec.log("/cloud/registered", rr.Points3D(registered_C, colors=[(40, 160, 240)], radii=0.02))
