"""Point clouds from a stereo pair: ROI, features, matching along rows, eq. 1 of Maestrini et al.

§III.A of Maestrini et al.: the region of interest is the set of pixels above a
brightness threshold (black background); features are detected in it and
should cover the whole target rather than be few and strong. The paper picked
SURF, which is not in OpenCV's free build; AKAZE is not in the OpenCV 5.0
wheel either, so :func:`feature_cover` compares ORB, SIFT and Shi-Tomasi
corners (GFTT) by the fraction of the ROI's 8-px cells holding a feature. ORB
— the default — covered best on lcnav's targets (0.88–0.95 against 0.55–0.80
for SIFT and 0.66–0.88 for GFTT at 30–50 m, ``benchmarks/RESULTS.md``). For
parallel cameras the match of a left feature lies on the same row of the right
image with positive disparity ``α = u_left − u_right``: each feature is
matched by normalised cross-correlation of a patch along that row (a sparse
block matcher: the disparity map queried at the features, as in the paper),
with a uniqueness test and a parabolic sub-pixel peak, and becomes a 3-D point
in the chaser frame by eq. 1:
``p^C = [(b/α)(r − r0), (b/α)(u − u0), −f d b/α]`` (``r`` the image row,
i.e. eq. 1 with ``v − v0 = r0 − r``; frame C of :mod:`perception.render`).

Pixel coordinates follow :mod:`perception.render`: pixel ``i`` spans
``[i, i + 1)``; OpenCV's keypoint coordinates put pixel centres at integers,
so ``u = x_cv + 0.5``.

References
----------
.. [1] Maestrini, De Luca, Di Lizia, *Relative Navigation Strategy About Unknown and Uncooperative
   Targets*, Journal of Guidance, Control, and Dynamics, 2023.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from perception.render import StereoCamera

__all__ = ["DETECTORS", "PointCloud", "luminance", "tone_map", "roi_mask", "detect", "feature_cover", "stereo_cloud", "triangulate"]

DETECTORS = ("orb", "sift", "gftt")


@dataclass(frozen=True)
class PointCloud:
    """Stereo point cloud of one frame.

    ``points_C``: (M, 3) points in the chaser frame C, m (eq. 1).
    ``pixels``: (M, 2) left-image ``(u, r)`` pixel coordinates of the features.
    ``disparity_px``: (M,) refined disparities.
    ``detector``; ``n_features``: features found in the left ROI (before matching);
    ``roi``: ``(r0, r1, c0, c1)`` bounding box of the left ROI (empty: all 0).
    """

    points_C: np.ndarray
    pixels: np.ndarray
    disparity_px: np.ndarray
    detector: str
    n_features: int
    roi: tuple[int, int, int, int]


def tone_map(lum: np.ndarray, white: float, gamma: float = 2.2) -> np.ndarray:
    """8-bit image ``255 (L / white)^(1/γ)``, clipped: lifts dark panels out of the noise floor."""
    x = np.clip(np.asarray(lum, dtype=float) / white, 0.0, 1.0)
    return np.round(255.0 * x ** (1.0 / gamma)).astype(np.uint8)


def luminance(rgb: np.ndarray) -> np.ndarray:
    """Relative luminance (Rec. 709 weights) of linear RGB ``(..., 3)``."""
    return np.asarray(rgb, dtype=float) @ np.array([0.2126, 0.7152, 0.0722])


def roi_mask(gray: np.ndarray, threshold: int = 6, dilate_px: int = 4) -> np.ndarray:
    """Pixels brighter than ``threshold`` (the target on a black sky), dilated by ``dilate_px``."""
    m = (gray > threshold).astype(np.uint8)
    if dilate_px > 0:
        m = cv2.dilate(m, np.ones((2 * dilate_px + 1, 2 * dilate_px + 1), np.uint8))
    return m


def _detector(name: str, n_features: int):
    if name == "sift":
        return cv2.SIFT_create(nfeatures=n_features, contrastThreshold=0.005, edgeThreshold=20)
    if name == "orb":
        return cv2.ORB_create(nfeatures=n_features, scaleFactor=1.2, nlevels=4, edgeThreshold=8, patchSize=15, fastThreshold=5)
    if name == "gftt":
        return cv2.GFTTDetector_create(maxCorners=n_features, qualityLevel=0.005, minDistance=3, blockSize=5)
    raise ValueError(f"detector must be one of {DETECTORS}, got {name!r}")


def detect(gray: np.ndarray, mask: np.ndarray, detector: str = "orb", n_features: int = 4000) -> np.ndarray:
    """Keypoint positions ``(K, 2)`` (OpenCV x, y) of ``detector`` inside ``mask``."""
    kps = _detector(detector, n_features).detect(gray, mask)
    return np.array([k.pt for k in kps], dtype=float).reshape(-1, 2)


def feature_cover(gray: np.ndarray, detector: str, cell_px: int = 8, threshold: int = 6) -> tuple[int, float]:
    """``(number of features, cover)``: cover is the fraction of ``cell_px`` cells of the ROI holding a feature."""
    mask = roi_mask(gray, threshold, dilate_px=0)
    xy = detect(gray, mask, detector)
    h, w = gray.shape
    ch, cw = (h + cell_px - 1) // cell_px, (w + cell_px - 1) // cell_px
    padded = np.zeros((ch * cell_px, cw * cell_px), np.uint8)
    padded[:h, :w] = mask
    roi_cells = padded.reshape(ch, cell_px, cw, cell_px).any(axis=(1, 3))
    cells = np.zeros((ch, cw), bool)
    if len(xy):
        cells[(xy[:, 1] // cell_px).astype(int), (xy[:, 0] // cell_px).astype(int)] = True
    n_roi = roi_cells.sum()
    return len(xy), float((cells & roi_cells).sum() / n_roi) if n_roi else 0.0


def _match_along_row(gl, gr, x: int, y: int, max_disp: int, half: int, min_ncc: float, uniqueness: float) -> float:
    """Sub-pixel disparity of left pixel ``(x, y)``: NCC of a patch along the same right-image row.

    The best score must reach ``min_ncc`` and beat every score more than 2 px
    away by ``uniqueness``; the peak is refined by a parabola through its
    neighbours. NaN when no reliable match exists.
    """
    h, w = gl.shape
    if y - half < 0 or y + half >= h or x - half < 0 or x + half >= w:
        return np.nan
    tpl = gl[y - half : y + half + 1, x - half : x + half + 1]
    if tpl.std() < 2.0:  # featureless patch (e.g. the black sky)
        return np.nan
    c0 = max(x - half - max_disp, 0)
    strip = gr[y - half : y + half + 1, c0 : x + half + 1]
    ncc = cv2.matchTemplate(strip, tpl, cv2.TM_CCOEFF_NORMED)[0]  # index k <-> right centre c0 + half + k
    ncc = ncc[:-1]  # disparity > 0
    if ncc.size < 3:
        return np.nan
    k = int(np.argmax(ncc))
    best = ncc[k]
    others = np.concatenate([ncc[: max(k - 2, 0)], ncc[k + 3 :]])
    if best < min_ncc or (others.size and others.max() > best - uniqueness) or k == 0 or k == ncc.size - 1:
        return np.nan
    a, c = ncc[k - 1], ncc[k + 1]
    den = a - 2.0 * best + c
    sub = 0.5 * (a - c) / den if den < 0 else 0.0
    return x - (c0 + half + k + sub)


def triangulate(camera: StereoCamera, u, r, disparity) -> np.ndarray:
    """Eq. 1 of Maestrini et al.: points ``(M, 3)`` in C from left-image ``u``, row ``r`` and disparity (px)."""
    u, r, a = (np.asarray(v, dtype=float) for v in (u, r, disparity))
    k = camera.baseline_m / a
    return np.stack([k * (r - camera.center_px), k * (u - camera.center_px), -camera.f_px * k], axis=-1)


def stereo_cloud(
    left_rgb,
    right_rgb,
    camera: StereoCamera,
    *,
    detector: str = "orb",
    white_radiance: float | None = None,
    roi_threshold: int = 6,
    min_range_m: float = 5.0,
    patch_half_px: int = 5,
    min_ncc: float = 0.9,
    uniqueness: float = 0.05,
    n_features: int = 4000,
) -> PointCloud:
    """Point cloud in C from a stereo pair of linear RGB images (``(H, W, 3)``, same exposure).

    ``white_radiance``: radiance mapped to white before the γ tone map; by
    default the left image's maximum (automatic exposure, the same for both
    images). The ROI is thresholded on the tone-mapped image; features and
    matching then use it after CLAHE (local contrast equalisation). ``min_range_m`` bounds the disparity
    search (``f d b / min_range``). ``patch_half_px``, ``min_ncc``,
    ``uniqueness``: the row matcher (:func:`_match_along_row`).
    """
    L, R = luminance(left_rgb), luminance(right_rgb)
    n = camera.resolution_px
    if L.shape != (n, n) or R.shape != (n, n):
        raise ValueError(f"left_rgb and right_rgb must be ({n}, {n}, 3) images, got {L.shape}, {R.shape}")
    if detector not in DETECTORS:
        raise ValueError(f"detector must be one of {DETECTORS}, got {detector!r}")
    empty = PointCloud(np.zeros((0, 3)), np.zeros((0, 2)), np.zeros(0), detector, 0, (0, 0, 0, 0))
    if white_radiance is None:
        white_radiance = float(L.max())
        if white_radiance <= 0:
            return empty
    gl, gr = tone_map(L, white_radiance), tone_map(R, white_radiance)
    ml = roi_mask(gl, roi_threshold)
    # local contrast (CLAHE) for features and matching: bright MLI and dark cells in one frame
    clahe = cv2.createCLAHE(clipLimit=3.0, tileGridSize=(8, 8))
    gl, gr = clahe.apply(gl), clahe.apply(gr)
    if not ml.any():
        return empty
    rows, cols = np.nonzero(ml)
    roi = (int(rows.min()), int(rows.max()) + 1, int(cols.min()), int(cols.max()) + 1)
    xy = np.round(detect(gl, ml, detector, n_features)).astype(int)
    xy = np.unique(xy, axis=0)
    max_disp = int(np.ceil(camera.f_px * camera.baseline_m / min_range_m))
    glf, grf = gl.astype(np.float32), gr.astype(np.float32)
    disp = np.array([_match_along_row(glf, grf, x, y, max_disp, patch_half_px, min_ncc, uniqueness) for x, y in xy]).reshape(-1)
    ok = np.isfinite(disp) & (disp > 0)
    u, r = xy[ok, 0] + 0.5, xy[ok, 1] + 0.5
    return PointCloud(triangulate(camera, u, r, disp[ok]), np.stack([u, r], axis=1), disp[ok], detector, len(xy), roi)
