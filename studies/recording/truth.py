"""The truth recording: the target posed in the servicer frame, the rates and the range, with a viewer layout.

``/truth/target`` carries the target as a box of the same principal-inertia
ratios, posed by ``q_ST`` and ``r_TS_S`` (the target seen from the servicer);
``/truth/servicer`` is a 1 m box at the origin; ``/truth/w_ST_T/{x,y,z}`` and
``/truth/w_T_T/{x,y,z}`` are the relative and the target's own rates (rad/s);
``/truth/range_m`` the range (m). :func:`truth_blueprint` opens on the rates and
the range, with the 3-D scene in a second tab.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import rerun.blueprint as rrb

from estimators.attitude import quat_conjugate, quat_to_dcm
from estimators.state import Q_TS, R_ST_T, W_B, W_ST_T
from studies.recording.blueprint import run_blueprint
from studies.recording.writer import recording, send_poses, send_scalars
from studies.sim.truth import Truth


def truth_blueprint() -> rrb.Blueprint:
    """Rates and range of the truth over the whole run, and the posed target in 3-D."""
    return run_blueprint(quantities=["w_ST_T", "w_T_T", "range_m"], cloud=True)


def equivalent_box_half_sizes(J_diag, longest_half_m: float = 6.0) -> np.ndarray:
    """Half sizes of the uniform box with the same principal-inertia ratios as ``J_diag``.

    For a box, ``I_x ∝ b² + c²`` etc., so ``a² ∝ (I_y + I_z − I_x)/2``; scaled
    so the longest half size is ``longest_half_m``. Used to draw the target.
    """
    I = np.asarray(J_diag, dtype=float)
    sq = 0.5 * (I.sum() - 2.0 * I)
    if np.any(sq <= 0):
        raise ValueError(f"inertia {I.tolist()} violates the triangle inequality of a rigid body")
    h = np.sqrt(sq)
    return h * (longest_half_m / h.max())


def record_truth(truth: Truth, path: Path, seed: int) -> None:
    """``truth.rrd``: the target as a box posed in the servicer frame, rates as scalars.

    ``/truth/target`` carries ``q_ST`` and ``r_TS_S = −R_ST r_ST_T`` (the target
    seen from the servicer); ``/truth/w_ST_T/{x,y,z}`` and ``/truth/w_T_T/...``
    the relative and the target's own rates (rad/s); ``/truth/range_m`` the range.
    """
    with recording(path, recording_id=f"truth-{truth.scenario.name}-seed{seed}", blueprint=truth_blueprint()) as rec:
        log_truth(rec, truth)


def log_truth(rec, truth: Truth) -> None:
    """Log the truth entities of :func:`record_truth` into the open recording ``rec``."""
    import rerun as rr

    q_ST = quat_conjugate(truth.x[:, Q_TS])
    r_TS_S = -np.einsum("nij,nj->ni", quat_to_dcm(q_ST), truth.x[:, R_ST_T])
    rec.log("/truth/target", rr.Boxes3D(half_sizes=[equivalent_box_half_sizes(truth.J_T_diag)], colors=[[200, 160, 60]]), static=True)
    rec.log("/truth/servicer", rr.Boxes3D(half_sizes=[[1.0, 1.0, 1.0]], colors=[[90, 140, 220]]), static=True)
    send_poses(rec, "/truth/target", truth.t, r_TS_S, q_ST)
    send_scalars(rec, "/truth/w_ST_T", truth.t, truth.x[:, W_ST_T], ["x", "y", "z"])
    send_scalars(rec, "/truth/w_T_T", truth.t, truth.target[:, W_B], ["x", "y", "z"])
    send_scalars(rec, "/truth/range_m", truth.t, np.linalg.norm(truth.x[:, R_ST_T], axis=1))
