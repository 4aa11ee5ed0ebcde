"""Vectorised Mamdani fuzzy inference over one crisp input (paper 000, sec. 5.3, Figs. 19-22).

The paper grades the pressing force from the area of net pressing events with a Mamdani
classifier: fuzzify the area with overlapping membership functions (Fig. 20), fire the
rules of Table III (``IF area is <term> THEN force is <grade>``), clip each output
membership function at its rule's firing strength (min implication), aggregate the clipped
functions with max and defuzzify the result by its centroid (Figs. 21-22).

This module is the pure array core: ``(n,)`` crisp inputs in, an :class:`Inference` out,
with no Python loop over samples (loops run over the handful of terms and rules only) and
in chunks so that millions of inputs fit in memory.

Defuzzification, two ways, both exact for what they define:

- ``resolution=None``: the centroid of the continuous aggregated function. For
  piecewise-linear output terms (``trimf``/``trapmf``) in an ordered fuzzy partition (every
  term overlaps only its neighbours), the clipped terms are trapezoids and the aggregate is
  ``sum(clipped) - sum(min of neighbouring clipped pairs)`` (with at most two terms
  non-zero anywhere, ``max(a, b) = a + b - min(a, b)``); each part has a closed-form area
  and moment, so the centroid costs O(terms) per input.
- ``resolution=M``: what scikit-fuzzy's control system computes on an output universe of
  ``M`` evenly spaced points (plus the terms' knots): the output terms sampled on the
  universe, the universe refined by the points where each term crosses its clip level,
  the aggregate evaluated there, linearly interpolated between those points and
  integrated exactly. With piecewise-linear terms this differs from the continuous centroid
  only where two clipped terms cross between two universe points (the interpolant cuts the
  corner); the closed form above plus that corner's correction gives it in O(terms) too.
  Other terms (``gaussmf`` outputs, wider overlaps) are evaluated on the refined universe
  directly, which costs O(M) per input.

Inputs are clipped to the input range first (as scikit-fuzzy's ``clip_to_bounds`` does);
NaN inputs give NaN outputs and grade -1. The grade of an input is the output term with
the largest membership at the crisp output (ties go to the lower grade).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

#: Membership-function kinds and their parameter counts.
MF_KINDS: dict[str, int] = {"trimf": 3, "trapmf": 4, "gaussmf": 2}
#: Inputs per chunk: keeps the (chunk, terms) temporaries in cache and memory bounded.
CHUNK = 1 << 13
#: Bytes of temporaries the general (universe) path may hold per chunk.
GRID_CHUNK_BYTES = 1 << 26


# -- membership functions --------------------------------------------------------------------
def trapmf(x: np.ndarray, abcd: tuple[float, float, float, float] | np.ndarray) -> np.ndarray:
    """Trapezoid: 0 outside ``[a, d]``, rising on ``[a, b]``, 1 on ``[b, c]``, falling on
    ``[c, d]``. ``a == b`` (or ``c == d``) is a vertical edge with membership 1 at ``b``
    (``c``), the shoulder of an end term. Shape of ``x``, float64; NaN stays NaN."""
    a, b, c, d = (float(v) for v in abcd)
    if not a <= b <= c <= d:
        raise ValueError(f"trapmf needs a <= b <= c <= d, got {[a, b, c, d]}")
    x = np.asarray(x, dtype=np.float64)
    y = np.ones_like(x)
    if b > a:
        y = np.minimum(y, (x - a) / (b - a))
    else:
        y = np.where(x < a, 0.0, y)
    if d > c:
        y = np.minimum(y, (d - x) / (d - c))
    else:
        y = np.where(x > d, 0.0, y)
    return np.clip(y, 0.0, 1.0)


def trimf(x: np.ndarray, abc: tuple[float, float, float] | np.ndarray) -> np.ndarray:
    """Triangle with feet ``a``, ``c`` and peak ``b`` (``trapmf(a, b, b, c)``)."""
    a, b, c = (float(v) for v in abc)
    if not a <= b <= c:
        raise ValueError(f"trimf needs a <= b <= c, got {[a, b, c]}")
    return trapmf(x, (a, b, b, c))


def gaussmf(x: np.ndarray, mean: float, sigma: float) -> np.ndarray:
    """Gaussian ``exp(-(x - mean)^2 / (2 sigma^2))``, peak 1 at ``mean``; ``sigma > 0``."""
    if not sigma > 0:
        raise ValueError(f"gaussmf needs sigma > 0, got {sigma}")
    x = np.asarray(x, dtype=np.float64)
    return np.exp(-0.5 * ((x - float(mean)) / float(sigma)) ** 2)


@dataclass(frozen=True)
class MembershipFunction:
    """One linguistic term's membership function: ``kind`` in :data:`MF_KINDS`, ``params``
    ``(a, b, c)`` for trimf, ``(a, b, c, d)`` for trapmf, ``(mean, sigma)`` for gaussmf, in
    the variable's units."""

    kind: str
    params: tuple[float, ...]

    def __post_init__(self) -> None:
        if self.kind not in MF_KINDS:
            raise ValueError(f"`kind` (={self.kind!r}) must be one of {', '.join(MF_KINDS)}")
        params = tuple(float(p) for p in self.params)
        object.__setattr__(self, "params", params)
        if len(params) != MF_KINDS[self.kind]:
            raise ValueError(
                f"{self.kind} takes {MF_KINDS[self.kind]} parameters, got {len(params)}")
        if not all(np.isfinite(params)):
            raise ValueError(f"{self.kind} parameters must be finite, got {list(params)}")
        if self.kind == "gaussmf":
            if params[1] <= 0:
                raise ValueError(f"gaussmf sigma must be > 0, got {params[1]}")
        elif any(b < a for a, b in zip(params, params[1:], strict=False)):
            raise ValueError(f"{self.kind} parameters must not decrease, got {list(params)}")

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """Membership of ``x`` (any shape), float64 in [0, 1]."""
        if self.kind == "gaussmf":
            return gaussmf(x, *self.params)
        return trapmf(x, self.trapezoid)

    @property
    def piecewise_linear(self) -> bool:
        return self.kind != "gaussmf"

    @property
    def trapezoid(self) -> tuple[float, float, float, float]:
        """``(a, b, c, d)`` of a trimf or trapmf (a triangle has ``b == c``)."""
        if self.kind == "trimf":
            a, b, c = self.params
            return (a, b, b, c)
        if self.kind == "trapmf":
            return self.params  # type: ignore[return-value]
        raise ValueError("a gaussmf is not a trapezoid")

    @property
    def peak(self) -> float:
        """Centre of the membership-1 region."""
        if self.kind == "gaussmf":
            return self.params[0]
        _, b, c, _ = self.trapezoid
        return 0.5 * (b + c)


def _memberships(mfs: tuple[MembershipFunction, ...], x: np.ndarray) -> np.ndarray:
    """(n_terms, n) membership of every term at ``x`` (n,), terms-major so that every
    term's row is contiguous (numpy loops over whole rows, not over 6-wide rows): the
    trapezoids in one broadcast (a vertical edge has an infinite slope; ``fmin`` drops the
    0 * inf NaN it makes exactly at the edge, where the other edge decides), Gaussians one
    by one."""
    lin = [k for k, m in enumerate(mfs) if m.piecewise_linear]
    out = np.empty((len(mfs), x.shape[0]))
    if lin:
        a, b, c, d = (np.array(v)[:, None]
                      for v in zip(*(mfs[k].trapezoid for k in lin), strict=True))
        with np.errstate(divide="ignore", invalid="ignore"):
            up, down = 1.0 / (b - a), 1.0 / (d - c)
            rise = x - a
            rise *= up
            fall = d - x
            fall *= down
            np.fmin(rise, fall, out=rise)
        np.clip(rise, 0.0, 1.0, out=rise)
        rise[:, np.isnan(x)] = np.nan
        if len(lin) == len(mfs):
            return rise
        out[lin] = rise
    for k, m in enumerate(mfs):
        if not m.piecewise_linear:
            out[k] = m(x)
    return out


# -- the system ------------------------------------------------------------------------------
@dataclass(frozen=True)
class Inference:
    """Result of :func:`infer` for ``n`` crisp inputs.

    ``x`` (n,) the inputs as given; ``crisp`` (n,) centroid of the aggregated output (NaN
    where the input was NaN or no rule fired); ``grade`` (n,) int64 index of the output term
    with the largest membership at ``crisp`` (-1 where ``crisp`` is NaN); ``firing``
    (n, n_rules) firing strength of every rule; ``cut`` (n, n_outputs) clip level of every
    output term (max over its rules).
    """

    x: np.ndarray
    crisp: np.ndarray
    grade: np.ndarray
    firing: np.ndarray
    cut: np.ndarray


@dataclass(frozen=True)
class MamdaniSystem:
    """A single-input, single-output Mamdani system.

    ``rules`` are ``(input term index, output term index)`` pairs (``IF input is i THEN
    output is o``); an output term's clip level is the max over its rules. ``resolution``
    ``None`` defuzzifies the continuous aggregate; an int ``M >= 2`` defuzzifies on the
    universe ``linspace(*output_range, M)`` plus the output terms' knots, as scikit-fuzzy
    does (see the module docstring).
    """

    input_terms: tuple[str, ...]
    input_mfs: tuple[MembershipFunction, ...]
    input_range: tuple[float, float]
    output_terms: tuple[str, ...]
    output_mfs: tuple[MembershipFunction, ...]
    output_range: tuple[float, float]
    rules: tuple[tuple[int, int], ...]
    resolution: int | None = None

    def __post_init__(self) -> None:
        for name in ("input_terms", "input_mfs", "output_terms", "output_mfs", "rules"):
            object.__setattr__(self, name, tuple(getattr(self, name)))
        object.__setattr__(self, "rules", tuple((int(i), int(o)) for i, o in self.rules))
        for side in ("input", "output"):
            terms, mfs = getattr(self, f"{side}_terms"), getattr(self, f"{side}_mfs")
            lo, hi = (float(v) for v in getattr(self, f"{side}_range"))
            object.__setattr__(self, f"{side}_range", (lo, hi))
            if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
                raise ValueError(f"`{side}_range` (={(lo, hi)}) must be finite with lo < hi")
            if len(terms) != len(mfs) or not terms:
                raise ValueError(f"`{side}_terms` and `{side}_mfs` must be non-empty and of "
                                 f"equal length, got {len(terms)} and {len(mfs)}")
        if not self.rules:
            raise ValueError("`rules` must not be empty")
        for i, o in self.rules:
            if not (0 <= i < len(self.input_terms) and 0 <= o < len(self.output_terms)):
                raise ValueError(f"rule {(i, o)} refers to a term that does not exist")
        if self.resolution is not None and int(self.resolution) < 2:
            raise ValueError(f"`resolution` (={self.resolution}) must be >= 2 or None")
        lo, hi = self.output_range
        for name, mf in zip(self.output_terms, self.output_mfs, strict=True):
            if mf.piecewise_linear:
                a, b, c, d = mf.trapezoid
                if a < lo or d > hi:
                    raise ValueError(
                        f"output term `{name}` {mf.kind} {list(mf.params)} reaches outside the "
                        f"output range {[lo, hi]}; keep its feet inside the range")
                if (a == b and a > lo) or (c == d and d < hi):
                    raise ValueError(
                        f"output term `{name}` {mf.kind} {list(mf.params)} has a vertical edge "
                        "inside the output range; give the edge a width (vertical edges are "
                        "allowed only at the range ends, as shoulders)")
        if self.method == "universe" and self.resolution is None:
            raise ValueError(
                "the continuous centroid (resolution None) needs piecewise-linear output "
                "terms (trimf/trapmf) that overlap only their neighbours; set a resolution "
                f"for these output terms ({self._not_partition_reason})")

    # -- derived, cached ---------------------------------------------------------------------
    @cached_property
    def _partition(self) -> bool | None:
        """True when the output terms form an ordered fuzzy partition (each term's support
        meets only its neighbours', falling where the next one rises), else None (reason in
        ``_not_partition_reason``)."""
        reason = self._partition_problem()
        object.__setattr__(self, "_reason", reason)
        if reason:
            return None
        return True

    def _partition_problem(self) -> str:
        if not all(m.piecewise_linear for m in self.output_mfs):
            return "a gaussmf output term overlaps every other term"
        traps = [m.trapezoid for m in self.output_mfs]
        for k in range(len(traps) - 1):
            (a0, _, c0, d0), (a1, b1, _, d1) = traps[k], traps[k + 1]
            names = f"`{self.output_terms[k]}` and `{self.output_terms[k + 1]}`"
            if not (a0 <= a1 and d0 <= d1):
                return f"output terms {names} are not in increasing order"
            if d0 > a1 and not (c0 <= a1 and d0 <= b1):
                return f"output terms {names} overlap beyond one falling and one rising edge"
            if k + 2 < len(traps) and d0 > traps[k + 2][0]:
                return (f"output term `{self.output_terms[k]}` overlaps "
                        f"`{self.output_terms[k + 2]}`, which is not its neighbour")
        return ""

    @property
    def _not_partition_reason(self) -> str:
        _ = self._partition
        return getattr(self, "_reason", "")

    @cached_property
    def _closed(self) -> _Partition:
        return _make_partition(self)

    @property
    def method(self) -> str:
        """``"closed_form"`` (O(terms) per input) or ``"universe"`` (O(resolution))."""
        return "closed_form" if self._partition is not None else "universe"

    @cached_property
    def universe(self) -> np.ndarray | None:
        """(M',) output universe: ``resolution`` even points plus the piecewise-linear output
        terms' knots (so a sampled term is exactly its trapezoid); None for the continuous
        centroid."""
        if self.resolution is None:
            return None
        lo, hi = self.output_range
        knots = [v for m in self.output_mfs if m.piecewise_linear for v in m.trapezoid]
        return np.union1d(np.linspace(lo, hi, int(self.resolution)), np.clip(knots, lo, hi))

    @property
    def rule_inputs(self) -> np.ndarray:
        return np.array([i for i, _ in self.rules], dtype=np.int64)

    @property
    def rule_outputs(self) -> np.ndarray:
        return np.array([o for _, o in self.rules], dtype=np.int64)

    def input_membership(self, x: np.ndarray) -> np.ndarray:
        """(n, n_inputs) membership of every input term at ``x`` (n,), clipped to the range."""
        xc = np.clip(np.asarray(x, dtype=np.float64).reshape(-1), *self.input_range)
        return _memberships(self.input_mfs, xc).T

    def output_membership(self, y: np.ndarray) -> np.ndarray:
        """(n, n_outputs) membership of every output term at ``y`` (n,)."""
        return _memberships(self.output_mfs, np.asarray(y, dtype=np.float64).reshape(-1)).T

    def fire(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Firing strength of every rule (n, n_rules) and clip level of every output term
        (n, n_outputs) for inputs ``x`` (n,)."""
        firing, cut = self._fire(x)
        return firing.T, cut.T

    def _fire(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`fire`, terms-major: (n_rules, n) and (n_outputs, n)."""
        xc = np.clip(np.asarray(x, dtype=np.float64).reshape(-1), *self.input_range)
        mu = _memberships(self.input_mfs, xc)
        ins, outs = self.rule_inputs, self.rule_outputs
        n_in, n_out = len(self.input_terms), len(self.output_terms)
        if np.array_equal(ins, np.arange(n_in)) and np.array_equal(outs, np.arange(n_out)):
            return mu, mu  # Table III: rule k maps input term k to output term k
        firing = mu[ins]
        cut = np.zeros((n_out, mu.shape[1]))
        for o in range(n_out):
            rows = np.flatnonzero(outs == o)
            if rows.size == 1:
                cut[o] = firing[rows[0]]
            elif rows.size:
                cut[o] = firing[rows].max(axis=0)
        return firing, cut

    @cached_property
    def grade_boundaries(self) -> np.ndarray | None:
        """(n_out - 1,) crisp values where the largest output membership passes from one
        term to the next, for an ordered partition (where the falling edge meets the next
        rising edge; the middle of a gap); None otherwise."""
        if self._partition is None:
            return None
        out = []
        for left, right in zip(self.output_mfs, self.output_mfs[1:], strict=False):
            _, _, c, d = left.trapezoid
            a, b, _, _ = right.trapezoid
            if d > a:
                ks, kr = b - a, d - c
                out.append((a * kr + d * ks) / (ks + kr))
            else:
                out.append(0.5 * (d + a))
        return np.array(out)

    def grade_of(self, crisp: np.ndarray) -> np.ndarray:
        """(n,) int64 output term with the largest membership at ``crisp`` (ties and gaps:
        see below); -1 for NaN.

        For an ordered partition the terms are separated at :attr:`grade_boundaries` (a
        crisp value on a boundary gets the lower grade; one in a gap between two terms the
        nearer). Otherwise the argmax of the memberships, the first on a tie, the nearest
        peak where every membership is 0.
        """
        crisp = np.asarray(crisp, dtype=np.float64).reshape(-1)
        bounds = self.grade_boundaries
        if bounds is not None:
            grade = np.searchsorted(bounds, crisp, side="left").astype(np.int64)
        else:
            mu = self.output_membership(np.nan_to_num(crisp))
            peaks = np.array([m.peak for m in self.output_mfs])
            nearest = np.argmin(np.abs(crisp[:, None] - peaks), axis=1)
            grade = np.where(mu.max(axis=1) > 0, np.argmax(mu, axis=1), nearest)
        return np.where(np.isfinite(crisp), grade, -1)


# -- inference -------------------------------------------------------------------------------
def infer(system: MamdaniSystem, x: np.ndarray, *, chunk: int = CHUNK) -> Inference:
    """Fuzzify, fire, clip, aggregate and defuzzify ``x`` (n,) crisp inputs in one pass.

    Memory is bounded by ``chunk`` inputs at a time (the universe path uses smaller chunks
    sized to :data:`GRID_CHUNK_BYTES`).
    """
    x = np.asarray(x, dtype=np.float64).reshape(-1)
    n = x.shape[0]
    n_out = len(system.output_terms)
    crisp = np.empty(n)
    grade = np.empty(n, dtype=np.int64)
    # terms-major buffers; the result holds their transposes (views)
    firing = np.empty((len(system.rules), n))
    cut = np.empty((n_out, n))
    if system.method == "universe":
        m = system.universe.shape[0] + 2 * n_out
        chunk = max(1, min(chunk, GRID_CHUNK_BYTES // (8 * m * (n_out + 3))))
    for lo in range(0, n, chunk):
        hi = min(n, lo + chunk)
        f, h = system._fire(x[lo:hi])
        firing[:, lo:hi], cut[:, lo:hi] = f, h
        if system.method == "closed_form":
            area, moment = _closed_form(system, h)
            y0 = system._closed.y0
        else:
            area, moment = _on_universe(system, h.T)
            y0 = 0.0
        ok = area > 0
        crisp[lo:hi] = np.where(ok, y0 + moment / np.where(ok, area, 1.0), np.nan)
        grade[lo:hi] = system.grade_of(crisp[lo:hi])
    return Inference(x=x, crisp=crisp, grade=grade, firing=firing.T, cut=cut.T)


def _trapezoid_coefficients(a, k_rise, d, k_fall):
    """Polynomial coefficients of the area and first moment of ``min(h, trapezoid)``, the
    trapezoid with feet ``a``, ``d`` and edge widths ``k_rise``, ``k_fall`` (for
    ``0 <= h <= 1`` and ``h (k_rise + k_fall) <= d - a``)::

        area   = h (d - a) - h^2 (k_rise + k_fall) / 2
        moment = h (d^2 - a^2) / 2 - h^2 (a k_rise + d k_fall) / 2 + h^3 (k_fall^2 - k_rise^2) / 6

    (sum of the rising triangle, the top rectangle and the falling triangle)."""
    area = np.stack([d - a, -0.5 * (k_rise + k_fall)])
    moment = np.stack([0.5 * (d * d - a * a), -0.5 * (a * k_rise + d * k_fall),
                       (k_fall * k_fall - k_rise * k_rise) / 6.0])
    return area, moment


def _linear_piece(u, gu, v, gv):
    """Area and moment of the linear function through ``(u, gu)``, ``(v, gv)`` on [u, v]."""
    w = v - u
    return 0.5 * w * (gu + gv), (w / 6.0) * (gu * (2.0 * u + v) + gv * (u + 2.0 * v))


@dataclass(frozen=True)
class _Partition:
    """Output terms of an ordered fuzzy partition, in coordinates centred on ``y0`` (the
    output range's middle, which keeps the moment polynomials well conditioned)."""

    y0: float
    a: np.ndarray  # (n_out,) trapezoid knots
    b: np.ndarray
    c: np.ndarray
    d: np.ndarray
    term_area: np.ndarray  # (2, n_out) coefficients of h, h^2
    term_moment: np.ndarray  # (3, n_out) coefficients of h, h^2, h^3
    left: np.ndarray  # (n_pairs,) left term of every overlapping neighbour pair
    contiguous: bool  # every neighbour pair overlaps (left == 0 .. n_out - 2)
    az: np.ndarray  # (n_pairs,) overlap zone [az, dz]: the right term's foot, the left's
    dz: np.ndarray
    ks: np.ndarray  # right term's rising width
    kr: np.ndarray  # left term's falling width
    apex: np.ndarray  # height where the two edges cross
    pair_area: np.ndarray  # (2, n_pairs)
    pair_moment: np.ndarray  # (3, n_pairs)
    grid0: float  # first even universe point, centred
    step: float  # even universe spacing (nan for the continuous centroid)


def _make_partition(system: MamdaniSystem) -> _Partition:
    lo, hi = system.output_range
    y0 = 0.5 * (lo + hi)
    a, b, c, d = (np.array(v) - y0 for v in zip(*(m.trapezoid for m in system.output_mfs),
                                                strict=True))
    term_area, term_moment = _trapezoid_coefficients(a, b - a, d, d - c)
    left = np.flatnonzero(d[:-1] > a[1:])
    az, dz = a[left + 1], d[left]
    ks, kr = b[left + 1] - a[left + 1], d[left] - c[left]  # both > 0 in a partition
    apex = (dz - az) / (ks + kr)
    pair_area, pair_moment = _trapezoid_coefficients(az, ks, dz, kr)
    step = (hi - lo) / (system.resolution - 1) if system.resolution else float("nan")
    contiguous = bool(np.array_equal(left, np.arange(len(a) - 1)))
    return _Partition(y0, a, b, c, d, term_area, term_moment, left, contiguous, az, dz, ks, kr,
                      apex, pair_area, pair_moment, lo - y0, step)


def _closed_form(system: MamdaniSystem, h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Area and moment about ``y0`` (n,) of the aggregate for clip levels ``h``
    (n_out, n)."""
    P = system._closed
    # h: (n_out, n) clip levels, <= 1 (memberships are clipped to [0, 1], a clip level is a
    # max of them)
    h2 = h * h
    area = P.term_area[0] @ h + P.term_area[1] @ h2
    moment = P.term_moment[0] @ h + P.term_moment[1] @ h2 + P.term_moment[2] @ (h2 * h)
    if P.left.size == 0:
        return area, moment
    # the min of each overlapping neighbour pair: a tent clipped at t
    if P.contiguous:
        hl, hr = h[:-1], h[1:]
    else:
        hl, hr = h[P.left], h[P.left + 1]
    t = np.minimum(hl, hr)
    np.minimum(t, P.apex[:, None], out=t)
    t2 = t * t
    area -= P.pair_area[0] @ t + P.pair_area[1] @ t2
    moment -= P.pair_moment[0] @ t + P.pair_moment[1] @ t2 + P.pair_moment[2] @ (t2 * t)
    if system.resolution is None:
        return area, moment
    # scikit-fuzzy's interpolant cuts the corner where the two clipped terms cross between
    # two points of its refined universe. The tent's top runs from p = az + t ks to
    # q = dz - t kr; one of them is a clip point (in the refined universe) unless t is the
    # apex, where p == q: at most one corner per pair, at p unless the right term is the
    # lower one. No knot lies strictly inside (az, dz); the clip points inside are the right
    # term's rising one and the left term's falling one. Only pairs that both fire (t > 0)
    # have a corner: in a partition that is at most one pair per input.
    n = h.shape[1]
    idx = np.flatnonzero(t > 0)
    if idx.size == 0:
        return area, moment
    pair, rows = np.divmod(idx, n)
    t, hl, hr = t.ravel()[idx], hl.ravel()[idx], hr.ravel()[idx]
    az, dz, ks, kr, apex = (v[pair] for v in (P.az, P.dz, P.ks, P.kr, P.apex))
    use_q = (t < apex) & (t == hr)
    kink = np.where(use_q, dz - t * kr, az + t * ks)
    # the tent's slope drops by 1/ks at a kink where its rising edge ends and by 1/kr at
    # one where its falling edge starts (both at the apex)
    drop = np.where(use_q, 0.0, 1.0 / ks) + np.where(use_q | (t >= apex), 1.0 / kr, 0.0)
    # refined-universe neighbours of the kink: even grid points, the zone's ends (knots)
    # and the two clip points inside the zone
    i = np.floor((kink - P.grid0) / P.step)
    lo = np.maximum(P.grid0 + i * P.step, az)
    hi = np.minimum(P.grid0 + (i + 1.0) * P.step, dz)
    for cut in (az + hr * ks, dz - hl * kr):
        lo = np.where((cut <= kink) & (cut > lo), cut, lo)
        hi = np.where((cut >= kink) & (cut < hi), cut, hi)
    # the chord misses a triangle (lo, kink, hi) of area (k - lo)(hi - k) drop / 2
    ca = 0.5 * (kink - lo) * (hi - kink) * drop
    cm = ca * (lo + kink + hi) * (1.0 / 3.0)
    return (area + np.bincount(rows, weights=ca, minlength=n),
            moment + np.bincount(rows, weights=cm, minlength=n))


def _on_universe(system: MamdaniSystem, h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Area and moment (n,) on the refined universe (any output terms), O(M) per input."""
    U = system.universe
    mu_u = np.stack([mf(U) for mf in system.output_mfs])  # (n_out, M) sampled terms
    h = np.minimum(h, 1.0)
    n, n_out = h.shape
    cuts = np.empty((n, 2 * n_out))
    for o in range(n_out):
        cuts[:, 2 * o], cuts[:, 2 * o + 1] = _crossings(U, mu_u[o], h[:, o])
    pts = np.sort(np.concatenate([np.broadcast_to(U, (n, U.shape[0])), cuts], axis=1), axis=1)
    agg = np.zeros_like(pts)
    for o in range(n_out):
        np.maximum(agg, np.minimum(h[:, o:o + 1], np.interp(pts, U, mu_u[o])), out=agg)
    a, m = _linear_piece(pts[:, :-1], agg[:, :-1], pts[:, 1:], agg[:, 1:])
    return a.sum(axis=1), m.sum(axis=1)


def _crossings(U: np.ndarray, mu: np.ndarray, h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where the linear interpolant of a unimodal sampled term ``mu`` (M,) on ``U`` first
    reaches and last leaves level ``h`` (n,); ``U[0]`` where it does not (a duplicate
    universe point adds nothing to the integral)."""
    top = int(np.argmax(mu))
    rise, fall = mu[:top + 1], mu[top:][::-1]
    if np.any(np.diff(rise) < 0) or np.any(np.diff(fall) < 0):
        raise ValueError("output terms must be unimodal (rise, then fall)")
    out = []
    for part, xs in ((rise, U[:top + 1]), (fall, U[top:][::-1])):
        if part.shape[0] < 2:  # a vertical edge at the range end
            out.append(np.full(h.shape, U[0]))
            continue
        j = np.searchsorted(part, h, side="left")  # first sample at or above h
        ok = (j >= 1) & (j < part.shape[0]) & (h > 0)
        j = np.clip(j, 1, part.shape[0] - 1)
        m0, m1, x0, x1 = part[j - 1], part[j], xs[j - 1], xs[j]
        with np.errstate(invalid="ignore", divide="ignore"):
            x = x0 + (h - m0) * (x1 - x0) / (m1 - m0)
        out.append(np.where(ok & (m1 > m0), x, U[0]))
    return out[0], out[1]


__all__ = ["CHUNK", "MF_KINDS", "Inference", "MamdaniSystem", "MembershipFunction", "gaussmf",
           "infer", "trapmf", "trimf"]
