"""The low-fidelity vehicle as a linear state-space model, from the vehicle assembly.

The low-fidelity models (quarter, half and full car, with their metric filters) are
linear in their states and in the road heights under the wheels, and affine in the
design variables (the forces are bilinear in rates and deflections). Their matrices are
read off the assembly's own equations (:class:`~suspopt.models.assembly.AssemblyEvaluator`)
by evaluating it at unit states and road heights — exact, since the model is linear — so
the exact time marching and the spectral method integrate the very equations the
collocation does (``docs/model.md``)::

    x' = A x + B δ,    y = C x + D δ

with ``x`` the assembly's states in order (flattened), ``δ`` the road height under every
corner and ``y`` the requested signals (flattened, (node-free) columns in order).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from suspopt.models.assembly import AssemblyEvaluator, VehicleAssembly


class NonlinearModelError(ValueError):
    """The vehicle is not linear time-invariant in its states and road heights (a
    nonlinear curve, a time-varying input, the mixed fidelity): no state-space matrices."""


@dataclass(frozen=True)
class LinearModel:
    """``x' = A x + B δ``, ``y = C x + D δ`` of one vehicle at one design; ``states`` and
    ``outputs`` label the entries (``z_W[1L]``), ``signals`` maps each output signal to its
    rows of ``C``, ``D``."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    states: tuple[str, ...]
    outputs: tuple[str, ...]
    signals: dict[str, slice]


@dataclass(frozen=True)
class AffineLinearModel:
    """The matrices as affine functions of the design, ``A(p) = A0 + Σ_i p_i A_i`` (and
    ``B``, ``C``, ``D``), ``p`` the design variables in ``design`` order."""

    base: LinearModel
    design: tuple[str, ...]
    dA: np.ndarray
    dB: np.ndarray
    dC: np.ndarray
    dD: np.ndarray

    def at(self, values: Mapping[str, float]) -> LinearModel:
        p = np.array([float(values[n]) for n in self.design])
        b = self.base
        return LinearModel(
            A=b.A + np.tensordot(p, self.dA, 1),
            B=b.B + np.tensordot(p, self.dB, 1),
            C=b.C + np.tensordot(p, self.dC, 1),
            D=b.D + np.tensordot(p, self.dD, 1),
            states=b.states,
            outputs=b.outputs,
            signals=b.signals,
        )


class _Probe:
    """The assembly without its road block: the road heights are an input."""

    def __init__(self, assembly: VehicleAssembly, outputs: Sequence[str], linear: bool = True):
        if linear and assembly.fidelity != 'low':
            raise NonlinearModelError('only the low-fidelity vehicle is linear (fidelity "low")')
        if linear and assembly.spec.has_curves:
            raise NonlinearModelError(
                'the suspension has curves (docs/nonlinear_hardware.md): the vehicle is not linear'
            )
        self.assembly = assembly
        self.evaluate = AssemblyEvaluator(assembly, skip=('road',))
        self.outputs = tuple(outputs)
        self.sizes = [int(np.prod(s.shape)) for s in assembly.states]
        self.n = sum(self.sizes)
        self.nc = assembly.spec.layout.n

    def __call__(
        self,
        x: np.ndarray,
        delta: np.ndarray,
        design: Mapping[str, float],
        time: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Rates and outputs at states ``x`` (n, K) and road heights ``delta`` (corners,
        K), K probes at once, at times ``time`` (K,; default zero)."""
        K = x.shape[1]
        signals: dict[str, np.ndarray] = {
            'time': np.zeros(K) if time is None else np.asarray(time, dtype=float),
            'delta': delta.T,
            **{n: np.array([float(design[n])]) for n in self.assembly.spec.design},
        }
        k = 0
        for st, size in zip(self.assembly.states, self.sizes):
            block = x[k : k + size]
            signals[st.name] = block[0] if st.scalar else block.T
            k += size
        self.evaluate(signals)
        rates = np.concatenate(
            [np.reshape(signals[st.rate], (K, -1)) for st in self.assembly.states], axis=1
        )
        outputs = [np.reshape(signals[name], (K, -1)) for name in self.outputs]
        return rates.T, (np.concatenate(outputs, axis=1).T if outputs else np.zeros((0, K)))


def _labels(assembly: VehicleAssembly) -> tuple[str, ...]:
    corners = assembly.spec.layout.labels
    out: list[str] = []
    for st in assembly.states:
        size = int(np.prod(st.shape))
        if st.scalar:
            out.append(st.name)
        elif size == len(corners):
            out += [f'{st.name}[{c}]' for c in corners]
        else:
            out += [f'{st.name}[{i}]' for i in range(size)]
    return tuple(out)


def linearize(
    assembly: VehicleAssembly, design: Mapping[str, float], outputs: Sequence[str] = ()
) -> LinearModel:
    """The state-space matrices of the low-fidelity ``assembly`` at ``design``, with the
    signals ``outputs`` (e.g. ``zdd_C``, ``travel``, ``F_T``, ``a_w``) as ``y``."""
    probe = _Probe(assembly, outputs)
    n, nc = probe.n, probe.nc
    X = np.concatenate([np.zeros((n, 1)), np.eye(n), np.zeros((n, nc))], axis=1)
    U = np.concatenate([np.zeros((nc, 1 + n)), np.eye(nc)], axis=1)
    rates, ys = probe(X, U, design)
    base_r, base_y = rates[:, :1], ys[:, :1]
    if np.any(base_r) or np.any(base_y):
        raise NonlinearModelError('the model is not linear: nonzero rates at zero state and road')
    widths = [int(np.size(_one_signal(probe, name, design))) for name in outputs]
    bounds = np.cumsum([0] + widths)
    signals = {name: slice(a, b) for name, a, b in zip(outputs, bounds[:-1], bounds[1:])}
    labels = []
    for name, width in zip(outputs, widths):
        labels += [name] if width == 1 else [f'{name}[{i}]' for i in range(width)]
    return LinearModel(
        A=rates[:, 1 : 1 + n],
        B=rates[:, 1 + n :],
        C=ys[:, 1 : 1 + n],
        D=ys[:, 1 + n :],
        states=_labels(assembly),
        outputs=tuple(labels),
        signals=signals,
    )


def rest_jacobian(assembly: VehicleAssembly, design: Mapping[str, float]) -> np.ndarray:
    """``A = ∂f/∂x`` of any ``assembly`` (the mixed fidelity's too) at rest on a flat road
    at ``design``, by central differences of steps ``1e-6`` of each state's reference
    (every probe in one vectorized call)."""
    probe = _Probe(assembly, (), linear=False)
    refs = np.concatenate([np.full(size, st.ref) for st, size in zip(assembly.states, probe.sizes)])
    step = 1e-6 * refs
    X = np.concatenate([np.diag(step), -np.diag(step)], axis=1)
    rates, _ = probe(X, np.zeros((probe.nc, X.shape[1])), design)
    return (rates[:, : probe.n] - rates[:, probe.n :]) / (2.0 * step)


def affine_rest_jacobian(
    assembly: VehicleAssembly, design: Mapping[str, float], names: Sequence[str]
) -> tuple[np.ndarray, np.ndarray]:
    """``A(p) = A0 + Σ_i p_i A_i`` of :func:`rest_jacobian` in the design variables
    ``names``, from its values at ``design`` and at each variable moved by a tenth of its
    value (exact where the forces are linear in the design, as a spring's in its rate and
    a feedback force in its gains at any linkage geometry). Returns ``A0, dA``."""
    base = rest_jacobian(assembly, design)
    dA = []
    for n in names:
        h = 0.1 * max(abs(float(design[n])), 1.0)
        dA.append((rest_jacobian(assembly, {**design, n: float(design[n]) + h}) - base) / h)
    slopes = np.array(dA).reshape((len(names),) + base.shape)
    p = np.array([float(design[n]) for n in names])
    return base - np.tensordot(p, slopes, axes=1), slopes


def check_linear(
    assembly: VehicleAssembly,
    design: Mapping[str, float],
    model: LinearModel,
    outputs: Sequence[str] = (),
    *,
    horizon: float = 1.0,
    probes: int = 4,
    rtol: float = 1e-9,
    seed: int = 0,
) -> None:
    """Raise :class:`NonlinearModelError` unless the assembly's rates and ``outputs`` (the
    signals ``model`` was read with) equal ``A x + B δ`` and ``C x + D δ`` at random
    states and road heights (each state from a thousandth to ten times its typical
    magnitude ``State.ref``, heights up to half a metre) and random times in
    ``[0, horizon]``: a nonlinear curve, a stop, or an input that varies in time makes
    the matrices (read at unit probes at time zero) inapplicable."""
    probe = _Probe(assembly, outputs)
    rng = np.random.default_rng(seed)
    refs = np.concatenate([np.full(int(np.prod(st.shape)), st.ref) for st in assembly.states])
    amplitude = np.repeat([1e-3, 1.0, 10.0], probes)
    K = amplitude.size
    X = rng.standard_normal((probe.n, K)) * refs[:, None] * amplitude
    U = rng.standard_normal((probe.nc, K)) * 0.05 * amplitude
    try:
        with np.errstate(all='ignore'):
            rates, ys = probe(X, U, design, time=rng.uniform(0.0, horizon, K))
    except Exception as err:  # a component that cannot take these states is not linear
        raise NonlinearModelError(f'the model cannot be probed: {err}') from err
    for name, value, (M, N), labels in (
        ('rate of', rates, (model.A, model.B), model.states),
        ('output', ys, (model.C, model.D), model.outputs),
    ):
        linear = M @ X + N @ U
        scale = np.abs(M) @ np.abs(X) + np.abs(N) @ np.abs(U)
        bad = ~(np.abs(value - linear) <= rtol * scale)
        if np.any(bad):
            row = int(np.argwhere(bad)[0][0])
            raise NonlinearModelError(
                f'the model is not linear time-invariant: the {name} {labels[row]} '
                'departs from its linearization at a probe state'
            )


def _one_signal(probe: _Probe, name: str, design: Mapping[str, float]) -> np.ndarray:
    """One node's value of signal ``name`` (its width)."""
    single = _Probe(probe.assembly, (name,))
    return single(np.zeros((probe.n, 1)), np.zeros((probe.nc, 1)), design)[1][:, 0]


def affine_linearize(
    assembly: VehicleAssembly, outputs: Sequence[str] = (), design: Sequence[str] | None = None
) -> AffineLinearModel:
    """The matrices as affine functions of the design variables ``design`` (default: all
    of the assembly's): read at zero design and at each unit design variable."""
    names = tuple(assembly.spec.design if design is None else design)
    zero = dict.fromkeys(assembly.spec.design, 0.0)
    base = linearize(assembly, zero, outputs)
    steps = [linearize(assembly, {**zero, n: 1.0}, outputs) for n in names]
    return AffineLinearModel(
        base=base,
        design=names,
        dA=np.array([s.A - base.A for s in steps]).reshape((len(names),) + base.A.shape),
        dB=np.array([s.B - base.B for s in steps]).reshape((len(names),) + base.B.shape),
        dC=np.array([s.C - base.C for s in steps]).reshape((len(names),) + base.C.shape),
        dD=np.array([s.D - base.D for s in steps]).reshape((len(names),) + base.D.shape),
    )
