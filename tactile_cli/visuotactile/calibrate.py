"""Calibration labels of the normal MLP from ball-bearing presses (paper 002, sec. II-B).

For each calibration frame (a ball bearing of known radius pressed into the gel):

1. **Contact circle.** The colour difference from the no-contact reference,
   ``|frame - reference|`` (RGB Euclidean, 0-255 units, Gaussian-smoothed), is
   thresholded at ``median + k * 1.4826 * MAD`` of the frame (the flat majority sets the
   noise level); the largest connected region, holes filled (the flat-ish top of the cap
   changes colour little), is the contact disk. A circle is fitted to the disk's boundary
   pixels: algebraic (Kasa) start, then a geometric least-squares fit with a soft-L1 loss,
   so stray boundary pixels (noise, a shadow) pull little. The paper uses the Hough
   transform and manual adjustment; this fit needs neither image library nor a person.
   On a real gel the region is too large: the gel around the contact deforms too (a halo
   whose colour change fades over tens of pixels), markers move, and a reference taken at
   another time or uneven LEDs shift the flat level. So the circle is refined (``robust``,
   the default) on the rim itself: in each of 32 angular sectors the radial profile of the
   median-filtered difference (5 px: marker dots out, steps kept) rises with the sphere's
   slope to a peak and falls fastest at the rim; a circle fitted (soft-L1) to those rim
   points gives centre and radius. When the rim points scatter about it by more than
   :data:`UNCERTAIN_EDGE_PX` (or :data:`UNCERTAIN_EDGE_SHARE` of the radius; median RMS),
   or too few sectors show a rim, the press gets an ``uncertain circle`` status: reported
   by ``tactile normal-labels`` and left out of the table, never silently used. Measured
   against hand-annotated circles of real GelSight presses and on simulated ones by
   ``benchmarks/press_circles.py``.
2. **Normals** (eqs. 5-8) inside the circle from the sphere: with ``d_PV`` the distance of
   pixel P from the centre in mm (``pixels / px_per_mm``) and R the ball radius,
   ``a = atan2(y - yc, x - xc)``, ``b = arccos(d_PV / R)``,
   ``n = (cos a cos b, sin a cos b, sin b)``; ``(0, 0, 1)`` outside. (Eq. 5 writes ``a`` as
   ``arctan((x - xc) / (y - yc))``, an angle from the y axis; ``atan2`` from the x axis
   gives the same normal in this toolkit's convention, x = column and y = row, with
   ``render.surface_normals``: the ball's outward normal.)
3. **Pixel table.** ``x, y, dR, dG, dB, R, G, B`` per pixel with labels ``nx, ny, nz``:
   every pixel inside the circle and at most ``flat_per_press`` random flat pixels outside
   (a frame has 76,800 pixels, mostly flat; the number left out is reported), written as a
   tactile HDF5 file (stream ``pixels``, one trial per press) that ``tactile train`` reads
   with ``window: 1``.

``px_per_mm`` comes from the sensor attribute of the same name (``tactile ingest
--px-per-mm``), the ball radius from the trial label ``ball_radius_mm``. Scene files also
carry the true circle (labels ``true_centre_x_px``, ``true_centre_y_px``,
``true_contact_radius_px``); the circle-finding error against it is reported when present.

:func:`normal_rmse` is the paper's precision figure: per image, the RMSE of predicted
against geometric normals over all pixels and the three components, averaged over images.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from ..progress import NullProgress, Progress
from ..store.trials import TactileFile, Trial

#: Channels of the pixel table, in order (x = column, y = row; dR = R - R_reference).
PIXEL_CHANNELS = ("x", "y", "dR", "dG", "dB", "R", "G", "B")
PIXEL_UNITS = ("px", "px", "0-255", "0-255", "0-255", "0-255", "0-255", "0-255")
#: Per-sample regression labels of the pixel table.
NORMAL_LABELS = ("nx", "ny", "nz")
#: Stream (and sensor) name of the pixel table.
PIXEL_STREAM = "pixels"
#: Smallest contact radius, as a share of the ball's radius, that labels a press: below
#: it the sphere's normals tilt by less than 1.2 degrees at the circle's edge (flat labels),
#: a sign of a wrong ``ball_radius_mm`` or ``px_per_mm``.
MIN_CONTACT_FRACTION = 0.02


@dataclass(frozen=True)
class CircleFit:
    """A contact circle found in one frame: centre (x = column, y = row) and radius in px,
    boundary pixels used, their RMS distance to the circle (px), the threshold on the
    colour difference (0-255 units), and a status (``ok`` or why it failed)."""

    x_px: float
    y_px: float
    radius_px: float
    n_boundary: int
    residual_px: float
    threshold: float
    status: str = "ok"

    @property
    def ok(self) -> bool:
        return self.status == "ok"


def colour_difference(frame: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """(H, W, 3) uint8 frame and reference -> (H, W, 3) float32 signed difference, 0-255."""
    return frame.astype(np.float32) - reference.astype(np.float32)


def find_contact_circle(frame: np.ndarray, reference: np.ndarray, *, k_mad: float = 8.0,
                        smooth_px: float = 1.5, min_radius_px: float = 3.0,
                        robust: bool = True) -> CircleFit:
    """The ball's contact circle in one frame (method: module docstring, step 1).

    frame, reference: (H, W, 3) uint8. k_mad: threshold in robust standard deviations of
    the colour-difference magnitude above its median. smooth_px: Gaussian smoothing (px)
    of the magnitude before thresholding. robust: refine on the rim per sector (module
    docstring; False: the region's boundary only, as before issue 35). Never raises on a
    bad frame: a frame without a usable contact gets a status saying why and NaN geometry;
    an uncertain circle keeps its geometry with an ``uncertain circle`` status.
    n_boundary / residual_px: with ``robust``, the rim points and their median RMS
    distance to the circle.
    """
    from scipy import ndimage
    from scipy.optimize import least_squares

    diff = np.linalg.norm(colour_difference(frame, reference), axis=-1)
    mag = ndimage.gaussian_filter(diff, smooth_px)
    med = float(np.median(mag))
    mad = float(np.median(np.abs(mag - med))) * 1.4826
    threshold = med + k_mad * max(mad, 1e-3)
    nan = float("nan")

    def failed(why: str, n: int = 0) -> CircleFit:
        return CircleFit(nan, nan, nan, n, nan, threshold, why)

    mask = mag > threshold
    regions, n_regions = ndimage.label(mask)
    if n_regions == 0:
        return failed("no contact: no pixel differs from the reference above the threshold")
    sizes = np.bincount(regions.ravel())[1:]
    disk = ndimage.binary_fill_holes(regions == (int(np.argmax(sizes)) + 1))
    boundary = disk & ~ndimage.binary_erosion(disk)
    # pixels on the frame's edge are where the disk was cut off, not its rim
    boundary[0, :] = boundary[-1, :] = boundary[:, 0] = boundary[:, -1] = False
    ys, xs = np.nonzero(boundary)
    if len(xs) < 8:
        return failed(f"contact region too small ({int(disk.sum())} px)", len(xs))
    x, y = xs.astype(np.float64), ys.astype(np.float64)
    # Kasa: x^2 + y^2 = 2 a x + 2 b y + c, linear in (a, b, c)
    design = np.column_stack([2 * x, 2 * y, np.ones_like(x)])
    (a, b, c), *_ = np.linalg.lstsq(design, x * x + y * y, rcond=None)
    r0 = float(np.sqrt(max(c + a * a + b * b, 1e-9)))
    if not np.isfinite([a, b, r0]).all():
        return failed("the contact region's boundary does not fit a circle", len(xs))

    def residuals(p: np.ndarray) -> np.ndarray:
        return np.hypot(x - p[0], y - p[1]) - p[2]

    fit = least_squares(residuals, np.array([a, b, r0]), loss="soft_l1", f_scale=1.0)
    xc, yc, radius = (float(v) for v in fit.x)
    rms = float(np.sqrt(np.mean(residuals(fit.x) ** 2)))
    n_used = len(xs)
    if robust:
        # the region takes in the deformation halo around a real contact: the rim is
        # where the colour change falls fastest, found per sector and fitted again
        edge = _sector_edges(diff, xc, yc, radius)
        if edge is None:
            return failed("uncertain circle: too few sectors show the contact's edge", len(xs))
        ex, ey = edge

        def edge_residuals(p: np.ndarray) -> np.ndarray:
            return np.hypot(ex - p[0], ey - p[1]) - p[2]

        refit = least_squares(edge_residuals, np.array([xc, yc, radius]), loss="soft_l1",
                              f_scale=1.0)
        xc, yc, radius = (float(v) for v in refit.x)
        rms = float(np.sqrt(np.median(edge_residuals(refit.x) ** 2)))
        n_used = len(ex)
        limit = max(UNCERTAIN_EDGE_PX, UNCERTAIN_EDGE_SHARE * radius)
        if not rms <= limit:
            return CircleFit(xc, yc, radius, n_used, rms, threshold,
                             f"uncertain circle: its edge points scatter {rms:.1f} px (median "
                             f"RMS) about it, more than {limit:.1f} px")
    # the smoothing spreads the rim's colour step outwards, so the thresholded disk is too
    # large by about 2 * smooth_px; the rim is where the unsmoothed step is half-way
    radius = _half_step_radius(diff, xc, yc, radius, reach_px=3 * smooth_px + 3)
    if not (np.isfinite(radius) and radius >= min_radius_px):
        return failed(f"fitted radius {radius:.1f} px is below {min_radius_px} px", n_used)
    return CircleFit(xc, yc, radius, n_used, rms, threshold)


#: the median RMS (px) of the edge points about the circle above which a circle is
#: uncertain, or this share of its radius when larger
UNCERTAIN_EDGE_PX = 2.0
UNCERTAIN_EDGE_SHARE = 0.08
#: sectors that must show an edge for a circle
MIN_EDGE_SECTORS = 12


def _sector_edges(diff: np.ndarray, xc: float, yc: float, r0: float, *, n_sectors: int = 32,
                  bin_px: float = 0.5) -> tuple[np.ndarray, np.ndarray] | None:
    """The contact's rim per angular sector: on the colour-difference magnitude ``diff``
    (H, W) median-filtered over 5 px (marker dots and noise out, steps kept), the radial
    profile around (``xc``, ``yc``) out to ``r0`` + 6 px (bins of ``bin_px``, smoothed
    over 1 px); from its peak beyond ``r0`` / 4 (the sphere's slope, steepest at the rim)
    the radius where it falls fastest. Returns the (x, y) rim points of the sectors that
    have one, None when fewer than :data:`MIN_EDGE_SECTORS` do."""
    from scipy import ndimage

    h, w = diff.shape
    hi = r0 + 6.0
    y0, y1 = max(0, int(yc - hi) - 3), min(h, int(yc + hi) + 4)
    x0, x1 = max(0, int(xc - hi) - 3), min(w, int(xc + hi) + 4)
    if y1 - y0 < 3 or x1 - x0 < 3:
        return None
    mag = ndimage.median_filter(diff[y0:y1, x0:x1], size=5)
    ys, xs = np.mgrid[y0:y1, x0:x1]
    r = np.hypot(xs - xc, ys - yc)
    near = r < hi
    r, mag = r[near], mag[near]
    sector = ((np.arctan2(ys[near] - yc, xs[near] - xc) + np.pi) / (2 * np.pi)
              * n_sectors).astype(int) % n_sectors
    n_bins = int(np.ceil(hi / bin_px))
    rbin = np.minimum((r / bin_px).astype(int), n_bins - 1)
    sums = np.zeros((n_sectors, n_bins))
    counts = np.zeros((n_sectors, n_bins))
    np.add.at(sums, (sector, rbin), mag)
    np.add.at(counts, (sector, rbin), 1)
    centres = (np.arange(n_bins) + 0.5) * bin_px
    px, py = [], []
    for k in range(n_sectors):
        ok = counts[k] > 0
        if ok.sum() < n_bins // 2:
            continue
        prof = np.interp(centres, centres[ok], sums[k][ok] / counts[k][ok])
        prof = ndimage.gaussian_filter1d(prof, 1.0 / bin_px)
        lo = int(0.25 * r0 / bin_px)
        top = min(n_bins - 2, int((r0 + 2.0) / bin_px))
        if top <= lo:
            continue
        peak = lo + int(np.argmax(prof[lo:top + 1]))
        slope = np.diff(prof)
        if peak >= n_bins - 2:
            continue
        j = peak + int(np.argmin(slope[peak:]))
        if not slope[j] < 0:
            continue
        radius = (j + 1) * bin_px  # between the centres of bins j and j + 1
        theta = (k + 0.5) / n_sectors * 2 * np.pi - np.pi
        px.append(xc + radius * np.cos(theta))
        py.append(yc + radius * np.sin(theta))
    if len(px) < MIN_EDGE_SECTORS:
        return None
    return np.asarray(px), np.asarray(py)


def _half_step_radius(diff: np.ndarray, xc: float, yc: float, r0: float, *,
                      reach_px: float, n_sectors: int = 16, bin_px: float = 0.5) -> float:
    """Refine a circle's radius on the unsmoothed colour-difference magnitude ``diff``
    (H, W): per angular sector, the radial profile around ``r0`` (bins of ``bin_px``) and
    the outermost radius where it is above half-way between the rim's peak (inside) and the
    flat level (outside); the median over sectors (``r0`` where no sector has a step)."""
    h, w = diff.shape
    lo, hi = max(0.0, r0 - reach_px), r0 + reach_px
    y0, y1 = max(0, int(yc - hi) - 1), min(h, int(yc + hi) + 2)
    x0, x1 = max(0, int(xc - hi) - 1), min(w, int(xc + hi) + 2)
    ys, xs = np.mgrid[y0:y1, x0:x1]
    r = np.hypot(xs - xc, ys - yc)
    near = (r >= lo) & (r < hi)
    r, mag = r[near], diff[y0:y1, x0:x1][near]
    sector = ((np.arctan2((ys[near] - yc), (xs[near] - xc)) + np.pi) / (2 * np.pi)
              * n_sectors).astype(int) % n_sectors
    n_bins = int(np.ceil((hi - lo) / bin_px))
    rbin = np.minimum(((r - lo) / bin_px).astype(int), n_bins - 1)
    sums = np.zeros((n_sectors, n_bins))
    counts = np.zeros((n_sectors, n_bins))
    np.add.at(sums, (sector, rbin), mag)
    np.add.at(counts, (sector, rbin), 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        profile = sums / counts
    centres = lo + (np.arange(n_bins) + 0.5) * bin_px
    edges = []
    for prof in profile:
        ok = np.isfinite(prof)
        inner, outer = ok & (centres < r0), ok & (centres > r0 + 1.5)
        if not inner.any() or not outer.any():
            continue
        peak, flat = np.max(prof[inner]), np.median(prof[outer])
        if peak <= flat:
            continue
        above = np.flatnonzero(ok & (prof > 0.5 * (peak + flat)) & (centres < r0 + 1.5))
        if above.size:
            k = above[-1]
            # interpolate the half-way crossing between bin k and the next finite bin
            nxt = k + 1
            if nxt < n_bins and np.isfinite(prof[nxt]) and prof[k] != prof[nxt]:
                frac = (prof[k] - 0.5 * (peak + flat)) / (prof[k] - prof[nxt])
                edges.append(centres[k] + float(np.clip(frac, 0, 1)) * bin_px)
            else:
                edges.append(centres[k])
    return float(np.median(edges)) if edges else r0


def sphere_normals(shape_hw: tuple[int, int], centre_px: tuple[float, float], radius_px: float,
                   *, ball_radius_mm: float, px_per_mm: float) -> np.ndarray:
    """Eqs. 5-8: (H, W, 3) float32 normals of a ball of ``ball_radius_mm`` whose contact
    circle (centre x, y and radius in px) is given; (0, 0, 1) outside the circle."""
    h, w = shape_hw
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float64)
    dx, dy = xs - centre_px[0], ys - centre_px[1]
    d_pv_mm = np.hypot(dx, dy) / px_per_mm
    inside = np.hypot(dx, dy) <= radius_px
    a = np.arctan2(dy, dx)
    b = np.arccos(np.clip(d_pv_mm / ball_radius_mm, 0.0, 1.0))
    normals = np.zeros((h, w, 3), dtype=np.float64)
    normals[..., 2] = 1.0
    normals[inside, 0] = (np.cos(a) * np.cos(b))[inside]
    normals[inside, 1] = (np.sin(a) * np.cos(b))[inside]
    normals[inside, 2] = np.sin(b)[inside]
    return normals.astype(np.float32)


def pixel_inputs(frame: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """(H, W, 8) float32 table inputs of every pixel: x, y, dR, dG, dB, R, G, B."""
    h, w = frame.shape[:2]
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float32)
    return np.concatenate([xs[..., None], ys[..., None], colour_difference(frame, reference),
                           frame.astype(np.float32)], axis=-1)


@dataclass(frozen=True)
class PressLabels:
    """One calibration press: its circle, pixel counts and (scene files) the circle error.

    n_contact: pixels inside the circle (all kept); n_flat: flat pixels kept; n_flat_left:
    flat pixels left out by the subsampling. centre_error_px, radius_error_px: against the
    scene's true circle, None without one."""

    trial: str
    circle: CircleFit
    ball_radius_mm: float
    n_contact: int
    n_flat: int
    n_flat_left: int
    centre_error_px: float | None
    radius_error_px: float | None

    def row(self) -> dict[str, Any]:
        return {"trial": self.trial, "status": self.circle.status,
                "centre_x_px": _r(self.circle.x_px), "centre_y_px": _r(self.circle.y_px),
                "radius_px": _r(self.circle.radius_px), "ball_radius_mm": self.ball_radius_mm,
                "n_contact": self.n_contact, "n_flat": self.n_flat,
                "n_flat_left": self.n_flat_left,
                "centre_error_px": _r(self.centre_error_px),
                "radius_error_px": _r(self.radius_error_px)}


def _r(v: float | None, nd: int = 3) -> float | None:
    return None if v is None or not np.isfinite(v) else round(float(v), nd)


@dataclass(frozen=True)
class NormalLabelsResult:
    """What :func:`write_normal_labels` wrote: one row per press, totals, the circle error
    over presses with a true circle (median and max, px) and the output path."""

    out: Path
    px_per_mm: float
    presses: tuple[PressLabels, ...]
    flat_per_press: int
    elapsed_s: float

    def as_dict(self) -> dict[str, Any]:
        ok = [p for p in self.presses if p.circle.ok]
        cerr = [p.centre_error_px for p in ok if p.centre_error_px is not None]
        rerr = [abs(p.radius_error_px) for p in ok if p.radius_error_px is not None]
        return {"out": str(self.out), "px_per_mm": self.px_per_mm,
                "n_presses": len(self.presses), "n_labelled": len(ok),
                "n_failed": len(self.presses) - len(ok),
                "n_pixels": sum(p.n_contact + p.n_flat for p in ok),
                "n_contact_pixels": sum(p.n_contact for p in ok),
                "n_flat_pixels": sum(p.n_flat for p in ok),
                "n_flat_left_out": sum(p.n_flat_left for p in ok),
                "flat_per_press": self.flat_per_press,
                "centre_error_px": _stats(cerr), "radius_error_px": _stats(rerr),
                "elapsed_s": round(self.elapsed_s, 3),
                "presses": [p.row() for p in self.presses]}

    def summary_lines(self) -> list[str]:
        """Per press its circle (or why none), the table written and the circle error."""
        s = self.as_dict()
        lines = []
        for row in s["presses"]:
            if row["status"] != "ok":
                lines.append(f"{row['trial']}: not labelled: {row['status']}")
                continue
            err = ("" if row["centre_error_px"] is None else
                   f"  error: centre {row['centre_error_px']:.2f} px, radius "
                   f"{row['radius_error_px']:+.2f} px")
            lines.append(f"{row['trial']}: circle ({row['centre_x_px']:.1f}, "
                         f"{row['centre_y_px']:.1f}) r {row['radius_px']:.1f} px, "
                         f"{row['n_contact']} contact + {row['n_flat']} flat px{err}")
        lines.append(f"wrote {s['out']}: {s['n_pixels']:,} pixels from {s['n_labelled']} of "
                     f"{s['n_presses']} presses ({s['n_contact_pixels']:,} in contact; "
                     f"{s['n_flat_left_out']:,} flat pixels left out, at most "
                     f"{s['flat_per_press']} per press); px_per_mm {s['px_per_mm']:g}")
        for key in ("centre_error_px", "radius_error_px"):
            if s[key] is not None:
                lines.append(f"circle {key.replace('_px', '').replace('_', ' ')} against the "
                             f"scene truth: median {s[key]['median']:.2f} px, max "
                             f"{s[key]['max']:.2f} px (n={s[key]['n']})")
        return lines


def _stats(values: Sequence[float]) -> dict[str, float | int] | None:
    if not values:
        return None
    v = np.asarray(values, dtype=np.float64)
    return {"n": len(v), "median": round(float(np.median(v)), 3),
            "mean": round(float(np.mean(v)), 3), "max": round(float(np.max(v)), 3)}


def file_px_per_mm(file: TactileFile, trial: Trial) -> float:
    """The gel scale of the trial's frame sensor (sensor attribute ``px_per_mm``)."""
    frames = trial.frames()
    sensor = file.sensor(frames.sensor_name)
    value = sensor.attrs.get("px_per_mm")
    if value is None:
        raise InputError(f"sensor {sensor.name!r} has no px_per_mm attribute; ingest the "
                         "frames with `tactile ingest ... --px-per-mm PX` (pixels per mm on the "
                         "gel)", path=file.path, where=f"/sensors/{sensor.name}")
    from .heightmap import check_px_per_mm

    return check_px_per_mm(value, what="px_per_mm", path=file.path,
                           where=f"/sensors/{sensor.name}")


def _ball_radius(trial: Trial) -> float:
    value = trial.labels.get("ball_radius_mm")
    if not (isinstance(value, int | float) and np.isfinite(value) and value > 0):
        raise InputError(f"trial label ball_radius_mm is {value!r}; each calibration press "
                         "needs the ball's radius in mm (a column ball_radius_mm of the "
                         "trial-labels CSV given to ingest)", path=trial.path,
                         where=f"/trials/{trial.name}/labels")
    return float(value)


def _true_circle(trial: Trial) -> tuple[float, float, float] | None:
    lab = trial.labels
    keys = ("true_centre_x_px", "true_centre_y_px", "true_contact_radius_px")
    if all(isinstance(lab.get(k), int | float) for k in keys):
        return tuple(float(lab[k]) for k in keys)  # type: ignore[return-value]
    return None


def label_press(trial: Trial, *, px_per_mm: float, flat_per_press: int,
                rng: np.random.Generator) -> tuple[PressLabels, np.ndarray | None,
                                                   np.ndarray | None]:
    """Circle, labels and table rows of one press (the trial's first frame).

    Returns (summary, rows (n, 8) float32 or None when the circle was not found, labels
    (n, 3) float32 or None)."""
    frames = trial.frames()
    if len(frames) < 1:
        raise InputError("has no frames", path=trial.path, where=f"/trials/{trial.name}")
    frame, reference = frames[0], frames.reference
    ball_mm = _ball_radius(trial)
    circle = find_contact_circle(frame, reference)
    truth = _true_circle(trial)
    cerr = rerr = None
    if truth is not None and circle.ok:
        cerr = float(np.hypot(circle.x_px - truth[0], circle.y_px - truth[1]))
        rerr = float(circle.radius_px - truth[2])
    if not circle.ok:
        return PressLabels(trial.name, circle, ball_mm, 0, 0, 0, cerr, rerr), None, None
    radius_mm = circle.radius_px / px_per_mm
    why = None
    if radius_mm >= ball_mm:
        why = f"contact radius {radius_mm:.2f} mm is not below the ball radius {ball_mm:g} mm"
    elif radius_mm < MIN_CONTACT_FRACTION * ball_mm:
        why = (f"contact radius {radius_mm:.3g} mm is under {100 * MIN_CONTACT_FRACTION:g} % "
               f"of the ball radius {ball_mm:g} mm, so its normals would be flat")
    if why is not None:
        circle = CircleFit(circle.x_px, circle.y_px, circle.radius_px, circle.n_boundary,
                           circle.residual_px, circle.threshold,
                           f"{why} (wrong ball_radius_mm or px_per_mm?)")
        return PressLabels(trial.name, circle, ball_mm, 0, 0, 0, cerr, rerr), None, None
    h, w = frame.shape[:2]
    normals = sphere_normals((h, w), (circle.x_px, circle.y_px), circle.radius_px,
                             ball_radius_mm=ball_mm, px_per_mm=px_per_mm)
    inputs = pixel_inputs(frame, reference)
    ys, xs = np.mgrid[0:h, 0:w]
    inside = np.hypot(xs - circle.x_px, ys - circle.y_px) <= circle.radius_px
    contact_idx = np.flatnonzero(inside.ravel())
    flat_idx = np.flatnonzero(~inside.ravel())
    keep_flat = (flat_idx if len(flat_idx) <= flat_per_press
                 else np.sort(rng.choice(flat_idx, flat_per_press, replace=False)))
    idx = np.concatenate([contact_idx, keep_flat])
    rows = inputs.reshape(-1, len(PIXEL_CHANNELS))[idx]
    labels = normals.reshape(-1, 3)[idx]
    summary = PressLabels(trial.name, circle, ball_mm, len(contact_idx), len(keep_flat),
                          len(flat_idx) - len(keep_flat), cerr, rerr)
    return summary, rows, labels


def write_normal_labels(calibration: str | Path, out: str | Path, *, flat_per_press: int = 3000,
                        seed: int = 0, overwrite: bool = False,
                        progress: Progress | None = None, command: str | None = None,
                        plot_dir: str | Path | None = None) -> NormalLabelsResult:
    """The pixel table of every press in ``calibration`` (an ingested file of ball presses,
    one trial each), written to ``out``: stream ``pixels`` (channels
    :data:`PIXEL_CHANNELS`, per-sample regression labels ``nx, ny, nz``), one trial per
    labelled press with the press's labels plus ``fit_centre_x_px``, ``fit_centre_y_px``,
    ``fit_radius_px``. A press whose circle is not found is reported (status) and left out
    of the table; none found at all is an InputError. ``seed`` draws the flat subsample.
    plot_dir: also write ``circles.png`` there (every press with its fitted circle, and the
    scene's true circle where known), the check the paper does by hand.
    """
    import contextlib

    from ..input_guard import check_outputs
    from ..store.atomic import check_output_file
    from ..store.outdir import check_output_folder, output_folder
    from ..store.writer import StoreWriter
    from .heightmap import absolute_folder

    plot_dir = None if plot_dir is None else absolute_folder(plot_dir)
    check_outputs({"out": out, "plot_dir": plot_dir}, [calibration])
    check_output_file(out, overwrite=overwrite)
    if plot_dir is not None:
        check_output_folder(plot_dir, overwrite=overwrite)
    started = time.perf_counter()
    progress = progress or NullProgress()
    if flat_per_press < 0:
        raise InputError(f"`flat_per_press` (={flat_per_press}) must be >= 0")
    calibration = Path(calibration)
    rng = np.random.default_rng(seed)
    presses: list[PressLabels] = []
    tables: list[tuple[Trial, PressLabels, np.ndarray, np.ndarray]] = []
    with TactileFile(calibration) as f:
        trials = [t for t in f.trials() if t.has_frames]
        if not trials:
            raise InputError("has no trials with image frames; ingest the calibration "
                             "presses' image folders first", path=calibration)
        px_per_mm = file_px_per_mm(f, trials[0])
        shape = trials[0].frames().shape
        from .sensor_unit import frames_unit

        unit, unit_from = frames_unit(f, trials[0])
        progress.start(len(trials), "presses")
        for trial in trials:
            summary, rows, labels = label_press(trial, px_per_mm=px_per_mm,
                                                flat_per_press=flat_per_press, rng=rng)
            presses.append(summary)
            if rows is not None and labels is not None:
                tables.append((trial, summary, rows, labels))
            progress.advance(1)
        progress.finish()
        if not tables:
            raise InputError(f"no contact circle found in any of its {len(trials)} presses ("
                             f"{presses[0].trial}: {presses[0].circle.status})",
                             path=calibration)
        config = {"calibration": str(calibration), "flat_per_press": flat_per_press,
                  "seed": seed, "px_per_mm": px_per_mm, "sensor_unit": unit}
        with StoreWriter(out, command=command, config=config, overwrite=overwrite) as writer:
            source = writer.add_source(calibration)
            sensor = writer.add_sensor(
                PIXEL_STREAM, kind="visuotactile", sample_rate_hz=1.0,
                channel_names=PIXEL_CHANNELS, channel_units=PIXEL_UNITS,
                width_px=int(shape[1]), height_px=int(shape[0]), px_per_mm=px_per_mm,
                sensor_unit=unit, sensor_unit_from=unit_from,
                description="calibration pixel table (paper 002 sec. II-B): one row per pixel, "
                "t_s = row index (the rows are not a time series)")
            for trial, summary, rows, labels in tables:
                c = summary.circle
                tw = writer.trial(trial.name, labels={
                    **{k: v for k, v in trial.labels.items() if isinstance(v, str | int | float)},
                    "fit_centre_x_px": round(c.x_px, 4), "fit_centre_y_px": round(c.y_px, 4),
                    "fit_radius_px": round(c.radius_px, 4)}, split=trial.split,
                    sources=[source])
                tw.write_signal(PIXEL_STREAM, sensor=sensor, data=rows,
                                t_s=np.arange(len(rows), dtype=np.float64),
                                sample_labels={n: (labels[:, i].astype(np.float32), None)
                                               for i, n in enumerate(NORMAL_LABELS)})
            with (output_folder(plot_dir, overwrite=overwrite) if plot_dir is not None
                  else contextlib.nullcontext()) as folder:
                if folder is not None:  # the figure first: both outputs or neither
                    plot_circles(trials, presses, folder)
                written = writer.commit()
    return NormalLabelsResult(written, px_per_mm, tuple(presses), flat_per_press,
                              time.perf_counter() - started)


def plot_circles(trials: Sequence[Trial], presses: Sequence[PressLabels], folder: str | Path,
                 *, max_presses: int = 36) -> Path:
    """``folder/circles.png`` (a folder being built, see :mod:`tactile_cli.store.outdir`):
    the first ``max_presses`` presses, each frame with its fitted contact circle (solid)
    and the scene's true circle (dashed) where known."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    shown = list(zip(trials, presses, strict=True))[:max_presses]
    cols = min(6, len(shown))
    rows = int(np.ceil(len(shown) / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(2.6 * cols, 2.1 * rows), squeeze=False)
    for ax in axes.ravel():
        ax.axis("off")
    for ax, (trial, press) in zip(axes.ravel(), shown, strict=False):
        ax.imshow(trial.frames()[0])
        c = press.circle
        if c.ok:
            ax.add_patch(plt.Circle((c.x_px, c.y_px), c.radius_px, fill=False, color="w",
                                    lw=1.0))
        truth = _true_circle(trial)
        if truth is not None:
            ax.add_patch(plt.Circle(truth[:2], truth[2], fill=False, color="k", lw=0.8,
                                    ls="--"))
        err = "" if press.centre_error_px is None else f"  err {press.centre_error_px:.2f} px"
        ax.set_title(f"{trial.name}{err}" if c.ok else f"{trial.name}: {c.status[:30]}",
                     fontsize=7)
    fig.suptitle("contact circles: fitted (white), scene truth (black dashed)", fontsize=9)
    fig.tight_layout()
    try:
        fig.savefig(Path(folder) / "circles.png", dpi=90)
    finally:
        plt.close(fig)
    return Path(folder) / "circles.png"


# -- precision of a normal model ------------------------------------------------------------
@dataclass(frozen=True)
class NormalRmse:
    """RMSE of predicted normals on held-out presses (paper 002: 0.0262 with colour
    differences, 0.0349 with absolute colour). per_image: (trial, rmse) pairs; rmse: their
    mean; rmse_contact: the same over pixels inside the circles only; baseline_rmse: the
    trivial predictor (0, 0, 1) everywhere, same pixels; truth: ``scene`` when the scene's
    true circles were used, ``fit`` when the circles were found in the frames."""

    per_image: tuple[tuple[str, float], ...]
    rmse: float
    rmse_contact: float
    baseline_rmse: float
    baseline_rmse_contact: float
    truth: str

    def as_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["per_image"] = [{"trial": t, "rmse": round(v, 5)} for t, v in self.per_image]
        for k in ("rmse", "rmse_contact", "baseline_rmse", "baseline_rmse_contact"):
            d[k] = round(float(d[k]), 5)
        return d


def image_rmse(pred: np.ndarray, true: np.ndarray, mask: np.ndarray | None = None) -> float:
    """RMSE over pixels (and the 3 components) of (H, W, 3) normals, optionally masked."""
    err = (np.asarray(pred, dtype=np.float64) - np.asarray(true, dtype=np.float64)) ** 2
    if mask is not None:
        err = err[mask]
    return float(np.sqrt(np.mean(err)))


def normal_rmse(predict: Callable[[np.ndarray, np.ndarray], np.ndarray],
                calibration: str | Path, *, truth: str = "auto") -> NormalRmse:
    """The paper's precision figure for a normal model on the presses of ``calibration``
    (an ingested file of ball presses, like :func:`write_normal_labels` reads).

    predict: ``(frame, reference) -> (H, W, 3)`` unit normals (e.g.
    ``NormalModel.from_run(run).predict``). truth: ``scene`` (the presses' true circles,
    trial labels ``true_*``), ``fit`` (circles found in the frames) or ``auto`` (scene when
    every press has them). Per image: RMSE over all pixels and components; reported: the
    mean over images, and the same inside the contact circles and for (0, 0, 1)."""
    if truth not in ("auto", "scene", "fit"):
        raise InputError(f"`truth` (={truth!r}) must be auto, scene or fit")
    per_image: list[tuple[str, float]] = []
    contact_sq: list[np.ndarray] = []
    base_contact_sq: list[np.ndarray] = []
    base: list[float] = []
    with TactileFile(calibration) as f:
        trials = [t for t in f.trials() if t.has_frames]
        if not trials:
            raise InputError("has no trials with image frames", path=calibration)
        px_per_mm = file_px_per_mm(f, trials[0])
        use_scene = truth == "scene" or (truth == "auto"
                                         and all(_true_circle(t) for t in trials))
        for trial in trials:
            frames = trial.frames()
            frame, reference = frames[0], frames.reference
            ball_mm = _ball_radius(trial)
            circle = _true_circle(trial) if use_scene else None
            if use_scene and circle is None:
                raise InputError("has no true circle (labels true_centre_x_px, "
                                 "true_centre_y_px, true_contact_radius_px); use "
                                 "`truth='fit'`", path=f.path, where=f"/trials/{trial.name}")
            if circle is None:
                fit = find_contact_circle(frame, reference)
                if not fit.ok:
                    continue
                circle = (fit.x_px, fit.y_px, fit.radius_px)
            h, w = frame.shape[:2]
            true = sphere_normals((h, w), circle[:2], circle[2], ball_radius_mm=ball_mm,
                                  px_per_mm=px_per_mm)
            pred = np.asarray(predict(frame, reference), dtype=np.float64)
            if pred.shape != true.shape:
                raise InputError(f"the model predicted normals of shape {pred.shape} for "
                                 f"frames of {true.shape}", path=f.path,
                                 where=f"/trials/{trial.name}")
            ys, xs = np.mgrid[0:h, 0:w]
            inside = np.hypot(xs - circle[0], ys - circle[1]) <= circle[2]
            flat = np.zeros_like(true)
            flat[..., 2] = 1.0
            per_image.append((trial.name, image_rmse(pred, true)))
            base.append(image_rmse(flat, true))
            contact_sq.append(((pred - true) ** 2)[inside])
            base_contact_sq.append(((flat - true) ** 2)[inside])
    if not per_image:
        raise InputError("no press with a contact circle to score", path=calibration)
    return NormalRmse(
        per_image=tuple(per_image), rmse=float(np.mean([v for _, v in per_image])),
        rmse_contact=float(np.sqrt(np.mean(np.concatenate(contact_sq)))),
        baseline_rmse=float(np.mean(base)),
        baseline_rmse_contact=float(np.sqrt(np.mean(np.concatenate(base_contact_sq)))),
        truth="scene" if use_scene else "fit")


__all__ = ["NORMAL_LABELS", "PIXEL_CHANNELS", "PIXEL_STREAM", "UNCERTAIN_EDGE_PX",
           "UNCERTAIN_EDGE_SHARE", "CircleFit", "NormalLabelsResult",
           "NormalRmse", "PressLabels", "colour_difference", "find_contact_circle",
           "image_rmse", "label_press", "normal_rmse", "pixel_inputs", "sphere_normals",
           "write_normal_labels"]
