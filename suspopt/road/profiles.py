"""Road profiles (docs/roads.md, paper Figure 3); the model's road input is
:class:`suspopt.models.road_input.RoadInputComp`.

A road profile is a height ``r(s)`` [m] along the travelled distance ``s`` [m], with its
slope ``r'(s)``. The vehicle drives at constant speed ``v``; the front wheel sees
``δ_1(t) = r(v t)`` and the rear wheel, a wheelbase ``L = a1 - a2`` behind it,
``δ_2(t) = r(v t - L)`` (docs/roads.md). Every profile is a frozen dataclass built from a plain
dictionary (:func:`make_road`), so a study description stays serializable.

Built-in profiles (``profile = ...`` in the study file):

``two_bumps``  the paper's road: 1-cos bumps of height ``h``, length ``ℓ``, at ``starts``.
``bump``       a single 1-cos bump.
``step``       a smoothed step of height ``h`` rising over ``ramp_length`` from ``position``.
``iso8608``    a random road of an ISO 8608 class (A-H) and seed, as a sum of cosines.
``csv``        a measured profile: a CSV file of distance [m], height [m].

A vehicle with two wheel tracks (the full car) drives on :func:`road_tracks`: the same
profile under both tracks, two profiles (``profile = "two_tracks"`` with ``left`` and
``right`` tables, e.g. two CSV files), or an ISO 8608 road whose right track is coherent
with the left one by the isotropic model of Kamash & Robson (1978): for the ISO waviness
2, the coherence at track separation B is ``γ(n) = x K₁(x)``, ``x = 2π n B``.
"""

from __future__ import annotations

import csv
import dataclasses
import functools
import io
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar, Literal, overload

import numpy as np
from numpy.typing import ArrayLike

from suspopt.errors import ConfigError
from suspopt.inputs import read_text


class RoadProfile:
    """Base class of road profiles: height ``r(s)``, slope ``dr_ds(s)``, kinks of ``r''``."""

    kind: ClassVar[str] = ''
    #: every profile is a dataclass (its fields are its study-file parameters)
    __dataclass_fields__: ClassVar[dict[str, dataclasses.Field[Any]]]
    #: made of discrete features (bumps, steps) that a collocation grid must sample
    #: whatever their frequency (:mod:`suspopt.transcription.grid`)
    transient: ClassVar[bool] = False

    def r(self, s: ArrayLike) -> np.ndarray:
        raise NotImplementedError

    def feature(self) -> str:
        """What the profile's fastest content is, in words (for messages)."""
        return self.kind

    def dr_ds(self, s: ArrayLike) -> np.ndarray:
        raise NotImplementedError

    def breakpoints(self) -> list[float]:
        """Distances where ``r''`` is discontinuous (for the time-marching integrator)."""
        return []

    def knots(self) -> np.ndarray | None:
        """Distances between which the profile is one cubic polynomial (a spline's knots),
        or None if it is not piecewise cubic (the exact time marching of the linear models
        samples it then by its own interpolation error)."""
        return None

    def max_frequency(self) -> float:
        """The highest significant spatial frequency of the profile [cycle/m] (for the
        automatic grid)."""
        raise NotImplementedError

    def to_dict(self) -> dict[str, Any]:
        d = {'profile': self.kind}
        d.update(
            {f.name: _plain(getattr(self, f.name)) for f in dataclasses.fields(self) if f.init}
        )
        return d

    def validate(self, required_length: float, where: str = 'road') -> list[str]:
        """Problems of this profile for a drive of ``required_length`` metres (empty if none)."""
        return []


#: the highest bump or step suspopt accepts [m] (a guard against cm typed as m)
MAX_FEATURE_HEIGHT = 1.0


def _height_problems(height: float, where: str) -> list[str]:
    if abs(height) > MAX_FEATURE_HEIGHT:
        return [
            f'{where}.height: {height:g} m is beyond a road feature (at most '
            f'{MAX_FEATURE_HEIGHT:g} m; heights are in metres: 5 cm is 0.05)'
        ]
    return []


def _plain(value: Any) -> Any:
    if isinstance(value, tuple):
        return list(value)
    if isinstance(value, Path):
        return str(value)
    return value


@dataclass(frozen=True)
class CosineBumps(RoadProfile):
    """Consecutive 1-cos bumps: ``r(s) = Σ_j h/2 (1 - cos(2π (s - s_j)/ℓ))`` on each bump."""

    kind: ClassVar[str] = 'two_bumps'
    transient: ClassVar[bool] = True
    height: float = 0.05
    length: float = 2.0
    starts: tuple[float, ...] = (5.0, 10.0)

    def _phase(self, s: ArrayLike):
        s = np.asarray(s, dtype=float)
        for s_j in self.starts:
            x = s - s_j
            on = (x >= 0.0) & (x <= self.length)
            yield on, 2.0 * np.pi * x / self.length

    def r(self, s: ArrayLike) -> np.ndarray:
        r = np.zeros(np.shape(s))
        for on, ph in self._phase(s):
            r += np.where(on, 0.5 * self.height * (1.0 - np.cos(ph)), 0.0)
        return r

    def dr_ds(self, s: ArrayLike) -> np.ndarray:
        dr = np.zeros(np.shape(s))
        for on, ph in self._phase(s):
            dr += np.where(on, 0.5 * self.height * 2.0 * np.pi / self.length * np.sin(ph), 0.0)
        return dr

    def breakpoints(self) -> list[float]:
        return sorted({b for s_j in self.starts for b in (s_j, s_j + self.length)})

    def max_frequency(self) -> float:
        """A 1-cos bump of length ℓ is one period of frequency 1/ℓ."""
        return 1.0 / self.length

    def feature(self) -> str:
        return f'bumps of {self.length:g} m'

    def validate(self, required_length: float, where: str = 'road') -> list[str]:
        errs = _height_problems(self.height, where)
        if not self.length > 0.0:
            errs.append(f'{where}.length: must be > 0, got {self.length}')
        if any(s < 0.0 for s in self.starts):
            errs.append(f'{where}.starts: bumps must start at s >= 0, got {list(self.starts)}')
        if list(self.starts) != sorted(self.starts):
            errs.append(f'{where}.starts: must be increasing, got {list(self.starts)}')
        return errs


@dataclass(frozen=True)
class SingleBump(CosineBumps):
    """One 1-cos bump of height ``height`` and length ``length`` starting at ``start``."""

    kind: ClassVar[str] = 'bump'
    starts: tuple[float, ...] = field(default=(5.0,), init=False)
    start: float = 5.0

    def __post_init__(self) -> None:
        object.__setattr__(self, 'starts', (float(self.start),))


@dataclass(frozen=True)
class SmoothStep(RoadProfile):
    """A step up of ``height`` rising as a half cosine over ``ramp_length`` from ``position``.

    A sharp step cannot be represented by any time integrator of a tyre without width;
    the ramp length is the tyre-contact smoothing length and must be > 0.
    """

    kind: ClassVar[str] = 'step'
    transient: ClassVar[bool] = True
    height: float = 0.05
    position: float = 5.0
    ramp_length: float = 0.5

    def r(self, s: ArrayLike) -> np.ndarray:
        x = np.clip((np.asarray(s, dtype=float) - self.position) / self.ramp_length, 0.0, 1.0)
        return 0.5 * self.height * (1.0 - np.cos(np.pi * x))

    def dr_ds(self, s: ArrayLike) -> np.ndarray:
        x = (np.asarray(s, dtype=float) - self.position) / self.ramp_length
        on = (x >= 0.0) & (x <= 1.0)
        return np.where(
            on,
            0.5 * self.height * np.pi / self.ramp_length * np.sin(np.pi * np.clip(x, 0.0, 1.0)),
            0.0,
        )

    def breakpoints(self) -> list[float]:
        return [self.position, self.position + self.ramp_length]

    def max_frequency(self) -> float:
        """The ramp is half a period of frequency 1/(2 ramp_length)."""
        return 0.5 / self.ramp_length

    def feature(self) -> str:
        return f'ramp of {self.ramp_length:g} m'

    def validate(self, required_length: float, where: str = 'road') -> list[str]:
        errs = _height_problems(self.height, where)
        if not self.ramp_length > 0.0:
            errs.append(
                f'{where}.ramp_length: must be > 0 (a sharp step is not integrable), '
                f'got {self.ramp_length}'
            )
        return errs


#: ISO 8608 displacement PSD G_d(n0) at n0 = 0.1 cycle/m, geometric mean of each class [m³].
ISO8608_CLASSES = {c: 16e-6 * 4.0**i for i, c in enumerate('ABCDEFGH')}


@dataclass(frozen=True)
class ISO8608Road(RoadProfile):
    """A random road of ISO 8608 class ``road_class``: a sum of cosines, one per frequency
    line ``n_k = k / length`` in ``[n_min, n_max]`` cycle/m.

    Displacement PSD ``G_d(n) = G_d(n0) (n/n0)^-2`` with ``n0 = 0.1`` cycle/m; each line
    carries the exact power of its band ``n_k ± 1/(2 length)`` (so the variance is exact),
    with a random phase from ``seed`` (harmonic superposition). The lines are ``1/length``
    apart, so the profile does not repeat within ``length`` metres, and the same seed gives
    the same road for any drive up to ``length``. It is synthesized once by an inverse FFT
    on a uniform grid of spacing ``1/(16 n_max)`` (the sum of cosines exactly at the grid
    points) and interpolated by a cubic spline (C², so no breakpoints): evaluating it costs
    the same whatever the number of cosines. ``n_max`` defaults to 1 cycle/m (10 Hz at
    10 m/s). The first ``fade_in`` metres fade in with a half-cosine window (applied to the
    samples) so that the zero initial state of docs/model.md is consistent; before the road
    starts (the rear wheel at t = 0) it is flat at zero.
    """

    kind: ClassVar[str] = 'iso8608'
    road_class: str = 'C'
    seed: int = 0
    n_min: float = 0.011
    n_max: float = 1.0
    length: float = 2000.0
    fade_in: float = 2.0
    coherence: str = 'isotropic'

    #: grid points per wavelength of n_max (cubic spline interpolation between them)
    samples_per_wavelength: ClassVar[int] = 16
    #: largest synthesis grid (memory and time guard; see :meth:`validate`)
    max_samples: ClassVar[int] = 2_000_000

    def lines(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Frequencies [cycle/m], amplitudes [m] and phases [rad] of the cosines."""
        dn = 1.0 / self.length
        k = np.arange(int(np.ceil(self.n_min / dn)), int(np.floor(self.n_max / dn)) + 1)
        n = k * dn
        a = np.maximum(n - 0.5 * dn, self.n_min)
        b = np.minimum(n + 0.5 * dn, self.n_max)
        g0 = ISO8608_CLASSES[self.road_class.upper()]
        power = g0 * 0.1**2 * (1.0 / a - 1.0 / b)
        phase = np.random.default_rng(self.seed).uniform(0.0, 2.0 * np.pi, n.size)
        return n, np.sqrt(2.0 * power), phase

    @property
    def _spline(self):
        return _iso8608_spline(
            self.road_class.upper(),
            self.seed,
            self.n_min,
            self.n_max,
            self.length,
            self.fade_in,
            self.coherence,
            0,
            0.0,
        )

    def track(self, index: int, separation: float) -> RoadProfile:
        """This road under wheel track ``index`` (0 left, 1 right), the tracks
        ``separation`` metres apart: the right track shares the left one's lines, each mixed
        with an independent one by the coherence model (same PSD, coherence γ(n))."""
        return (
            self
            if index == 0
            else _ISO8608Track(
                **{f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.init},
                track_index=index,
                separation=separation,
            )
        )

    def r(self, s: ArrayLike) -> np.ndarray:
        return self._spline(np.clip(np.asarray(s, dtype=float), 0.0, self.length))

    def dr_ds(self, s: ArrayLike) -> np.ndarray:
        s = np.asarray(s, dtype=float)
        return np.where(
            (s > 0.0) & (s < self.length), self._spline(np.clip(s, 0.0, self.length), 1), 0.0
        )

    def breakpoints(self) -> list[float]:
        return [0.0, self.fade_in] if self.fade_in > 0.0 else [0.0]

    def knots(self) -> np.ndarray:
        """The synthesis grid: the cubic spline's knots (constant outside them)."""
        return np.asarray(self._spline.x)

    def max_frequency(self) -> float:
        return self.n_max

    def validate(self, required_length: float, where: str = 'road') -> list[str]:
        errs = []
        if str(self.road_class).upper() not in ISO8608_CLASSES:
            errs.append(
                f'{where}.road_class: must be one of {", ".join(ISO8608_CLASSES)}, '
                f'got {self.road_class!r}'
            )
        if not 0.0 < self.n_min < self.n_max:
            errs.append(
                f'{where}.n_min/n_max: need 0 < n_min < n_max, got {self.n_min}, {self.n_max}'
            )
        elif not self.length > 0.0:
            errs.append(f'{where}.length: must be > 0, got {self.length}')
        elif self.length * self.samples_per_wavelength * self.n_max > self.max_samples:
            errs.append(
                f'{where}.length: {self.length:g} m at n_max = {self.n_max:g} cycle/m '
                f'needs {self.length * self.samples_per_wavelength * self.n_max:.3g} '
                f'road samples (at most {self.max_samples:.3g}); shorten it or lower '
                'n_max'
            )
        elif self.length < required_length:
            errs.append(
                f'{where}.length: the drive needs {required_length:g} m (speed × '
                f'horizon) but the road is {self.length:g} m long'
            )
        elif self.length * self.n_min < 1.0:
            errs.append(
                f'{where}.length: {self.length:g} m holds no frequency line of '
                f'[{self.n_min:g}, {self.n_max:g}] cycle/m (lines are 1/length apart)'
            )
        if self.fade_in < 0.0:
            errs.append(f'{where}.fade_in: must be >= 0, got {self.fade_in}')
        if self.coherence not in COHERENCE_MODELS:
            errs.append(
                f'{where}.coherence: must be one of {", ".join(COHERENCE_MODELS)}, '
                f'got {self.coherence!r}'
            )
        return errs


#: Left/right coherence of an ISO 8608 road's two tracks.
COHERENCE_MODELS = ('isotropic', 'identical', 'independent')


def track_coherence(model: str, n: np.ndarray, separation: float) -> np.ndarray:
    """Coherence γ(n) of two parallel tracks ``separation`` metres apart: ``isotropic``
    (Kamash & Robson 1978, waviness 2: γ = x K₁(x), x = 2π n B), ``identical`` (1) or
    ``independent`` (0)."""
    if model == 'identical' or separation <= 0.0:
        return np.ones_like(n)
    if model == 'independent':
        return np.zeros_like(n)
    from scipy.special import k1

    x = 2.0 * np.pi * n * separation
    return x * k1(x)


@dataclass(frozen=True)
class _ISO8608Track(ISO8608Road):
    """The right track of an :class:`ISO8608Road` (built by :meth:`ISO8608Road.track`)."""

    track_index: int = 1
    separation: float = 0.0

    @property
    def _spline(self):
        return _iso8608_spline(
            self.road_class.upper(),
            self.seed,
            self.n_min,
            self.n_max,
            self.length,
            self.fade_in,
            self.coherence,
            self.track_index,
            self.separation,
        )


@dataclass(frozen=True)
class CSVRoad(RoadProfile):
    """A measured road: CSV of distance [m] and height [m], one point per row.

    A header row is allowed. The profile is a cubic spline through the points
    (``scipy.interpolate.CubicSpline(bc_type='not-a-knot')``, MATLAB's ``spline``), so
    height, slope and curvature are continuous. Before the first point (the rear wheel at
    t = 0 sits a wheelbase behind the front one) the road continues flat at the first
    height. The data must cover the whole drive.

    ``relative_to_start``: the heights are taken relative to the profile's height at
    ``s = 0``, where the front wheel starts: the zero initial state (every mass at rest
    at height 0, the tyre undeflected) is then the vehicle standing on the road. A
    measured profile's datum is arbitrary; without this its height at ``s = 0`` acts as
    a step under the wheel at ``t = 0``. A rear wheel, before the first point, sees the
    same flat continuation, so it starts on the road too.
    """

    kind: ClassVar[str] = 'csv'
    file: str = ''
    relative_to_start: bool = False

    def _data(self) -> tuple[np.ndarray, np.ndarray]:
        return _read_road_csv_once(self.file)

    @property
    def _spline(self):
        spline = self.__dict__.get('_spline_cache')
        if spline is None:
            from scipy.interpolate import CubicSpline

            s, h = self._data()
            if self.relative_to_start:
                h = h - CubicSpline(s, h, bc_type='not-a-knot')(max(0.0, s[0]))
            spline = CubicSpline(s, h, bc_type='not-a-knot')
            object.__setattr__(self, '_spline_cache', spline)
        return spline

    def r(self, s: ArrayLike) -> np.ndarray:
        sp = self._spline
        s = np.asarray(s, dtype=float)
        return sp(np.maximum(s, sp.x[0]))

    def dr_ds(self, s: ArrayLike) -> np.ndarray:
        sp = self._spline
        s = np.asarray(s, dtype=float)
        return np.where(s >= sp.x[0], sp(np.maximum(s, sp.x[0]), 1), 0.0)

    def breakpoints(self) -> list[float]:
        return [float(self._spline.x[0])]

    def knots(self) -> np.ndarray:
        """The data points: the cubic spline's knots (constant before the first)."""
        return np.asarray(self._spline.x)

    def max_frequency(self) -> float:
        """The frequency below which 99.9 % of the profile's variance lies (its spectrum
        on a uniform resampling at the smallest data spacing)."""
        s, h = self._data()
        ds = float(np.min(np.diff(s)))
        n = min(int(np.ceil((s[-1] - s[0]) / ds)) + 1, 2**22)
        grid = np.linspace(s[0], s[-1], n)
        power = np.abs(np.fft.rfft(self._spline(grid) - np.mean(h))) ** 2
        freq = np.fft.rfftfreq(n, d=(s[-1] - s[0]) / (n - 1))
        cum = np.cumsum(power[1:])
        if cum.size == 0 or cum[-1] <= 0.0:
            return float(freq[-1])
        return float(freq[1:][np.searchsorted(cum, 0.999 * cum[-1])])

    def validate(self, required_length: float, where: str = 'road') -> list[str]:
        try:
            s, _ = self._data()
        except ConfigError as err:
            return [f'{where}.file: {err}']
        if s[0] > 0.0 or s[-1] < required_length:
            return [
                f'{where}.file: {self.file} covers s = {s[0]:g}..{s[-1]:g} m but the drive '
                f'needs 0..{required_length:g} m (speed × horizon)'
            ]
        return []


@functools.lru_cache(maxsize=8)
def _iso8608_spline(
    road_class: str,
    seed: int,
    n_min: float,
    n_max: float,
    length: float,
    fade_in: float,
    coherence: str,
    track: int,
    separation: float,
):
    """The synthesized profile of an :class:`ISO8608Road` track (a pure function of its
    parameters, memoized: every model and integrator of a study shares one synthesis)."""
    from scipy.interpolate import CubicSpline

    road = ISO8608Road(road_class=road_class, seed=seed, n_min=n_min, n_max=n_max, length=length)
    n, amp, phase = road.lines()
    coef = np.exp(1j * phase)
    if track:  # mix in an independent set of phases (a second stream of the same seed)
        gamma = track_coherence(coherence, n, separation)
        other = np.random.default_rng([seed, track]).uniform(0.0, 2.0 * np.pi, n.size)
        coef = gamma * coef + np.sqrt(np.maximum(1.0 - gamma**2, 0.0)) * np.exp(1j * other)
    samples = int(np.ceil(length * ISO8608Road.samples_per_wavelength * n_max))
    k = np.rint(n * length).astype(np.int64)
    spec = np.zeros(samples // 2 + 1, dtype=complex)
    spec[k] = 0.5 * amp * coef * samples
    h = np.fft.irfft(spec, n=samples)  # Σ a cos(2π n s + φ) at s = i·length/samples
    s = np.arange(samples + 1) * (length / samples)
    h = np.append(h, h[0])
    if fade_in > 0.0:  # the half-cosine window: zero height and slope at s = 0
        h *= 0.5 * (1.0 - np.cos(np.pi * np.clip(s / fade_in, 0.0, 1.0)))
    return CubicSpline(s, h, bc_type=((1, 0.0), 'not-a-knot') if fade_in > 0.0 else 'periodic')


def _number(cell: str) -> float | None:
    try:
        return float(cell)
    except ValueError:
        return None


def _read_road_csv_once(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """:func:`read_road_csv`, read once per file version (by its path, size and time of
    modification): a study builds its road many times (checks, models, time marching)."""
    p = Path(path)
    try:
        st = p.stat()
    except OSError:
        return read_road_csv(p)  # the reader names the problem
    return _cached_road_csv(str(p.resolve()), st.st_size, st.st_mtime_ns)


@functools.lru_cache(maxsize=16)
def _cached_road_csv(path: str, size: int, mtime_ns: int) -> tuple[np.ndarray, np.ndarray]:
    s, h = read_road_csv(path)
    s.flags.writeable = False
    h.flags.writeable = False
    return s, h


def read_road_csv(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Read a distance/height CSV; raise :class:`ConfigError` naming the problem.

    A byte-order mark (spreadsheets write one) is dropped. The first row may be a header,
    a row of text only: a first row with a number in it is data, and must be two
    numbers."""
    text = read_text(path, 'road CSV', 'CSV')  # suspopt.inputs: one line naming the file
    path = Path(path)
    try:
        rows = [
            (i + 1, r)
            for i, r in enumerate(csv.reader(io.StringIO(text, newline='')))
            if r and any(c.strip() for c in r) and not r[0].lstrip().startswith('#')
        ]
    except csv.Error as err:
        raise ConfigError(f'{path}: not valid CSV: {err}') from None
    data = []
    for k, (line, row) in enumerate(rows):
        cells = [_number(c) for c in row[:2]]
        if k == 0 and all(c is None for c in cells):
            continue  # header
        if len(cells) != 2 or None in cells:
            raise ConfigError(
                f'{path}: row {line} is not two numbers (distance [m], '
                f'height [m]): {",".join(row)!r}'
            )
        data.append(cells)
    if len(data) < 4:
        raise ConfigError(f'{path}: needs at least 4 distance,height rows, found {len(data)}')
    arr = np.array(data)
    if not np.all(np.isfinite(arr)):
        raise ConfigError(f'{path}: contains non-finite numbers')
    if np.any(np.diff(arr[:, 0]) <= 0.0):
        i = int(np.argmax(np.diff(arr[:, 0]) <= 0.0))
        raise ConfigError(
            f'{path}: distances must be strictly increasing ({arr[i + 1, 0]:g} after {arr[i, 0]:g})'
        )
    return arr[:, 0], arr[:, 1]


#: Built-in profile names and their classes.
PROFILES: dict[str, type[RoadProfile]] = {
    cls.kind: cls for cls in (CosineBumps, SingleBump, SmoothStep, ISO8608Road, CSVRoad)
}


def profile_fields(kind: str) -> dict[str, Any]:
    """Parameters and defaults of profile ``kind`` (what its study-file table may contain)."""
    cls = PROFILES[kind]
    return {f.name: f.default for f in dataclasses.fields(cls) if f.init}


def make_road(description: dict[str, Any]) -> RoadProfile:
    """Build a road profile from ``{'profile': kind, **parameters}`` (already validated)."""
    params = dict(description)
    kind = params.pop('profile', 'two_bumps')
    cls = PROFILES[kind]
    for f in dataclasses.fields(cls):
        if f.name in params and isinstance(params[f.name], list):
            params[f.name] = tuple(params[f.name])
    return cls(**params)


TWO_TRACKS = 'two_tracks'


def road_tracks(
    description: dict[str, Any], n_tracks: int = 1, separation: float = 0.0
) -> tuple[RoadProfile, ...]:
    """The profile under each of ``n_tracks`` wheel tracks ``separation`` metres apart:
    ``two_tracks`` gives its ``left`` and ``right`` profiles; an ISO 8608 road its coherent
    right track (:meth:`ISO8608Road.track`); any other profile is the same under both."""
    if description.get('profile') == TWO_TRACKS:
        tracks = (make_road(description['left']), make_road(description['right']))
        return tracks[:n_tracks] if n_tracks == 1 else tracks
    road = make_road(description)
    if n_tracks == 1:
        return (road,)
    if isinstance(road, ISO8608Road):
        return (road, road.track(1, separation))
    return (road,) * n_tracks


@overload
def wheel_road_inputs(
    road: RoadProfile,
    t: ArrayLike,
    speed: float,
    offsets: tuple[float, ...],
    rates: Literal[True] = True,
) -> tuple[np.ndarray, np.ndarray]: ...


@overload
def wheel_road_inputs(
    road: RoadProfile, t: ArrayLike, speed: float, offsets: tuple[float, ...], rates: bool
) -> tuple[np.ndarray, np.ndarray | None]: ...


def wheel_road_inputs(
    road: RoadProfile, t: ArrayLike, speed: float, offsets: tuple[float, ...], rates: bool = True
) -> tuple[np.ndarray, np.ndarray | None]:
    """Road heights and rates under each wheel: ``δ_i(t) = r(v t - offset_i)`` (docs/roads.md).

    Returns arrays of shape ``(len(offsets),) + shape(t)``: heights [m] and rates [m/s]
    (None unless ``rates``).
    """
    t = np.asarray(t, dtype=float)
    s = speed * t[None, ...] - np.asarray(offsets, dtype=float).reshape((-1,) + (1,) * t.ndim)
    return road.r(s), (speed * road.dr_ds(s) if rates else None)
