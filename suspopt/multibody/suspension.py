"""The vehicle-facing interface of a suspension mechanism (docs/model.md, paper eqs. 11-13).

One :class:`SuspensionModule` per mechanism wraps a :class:`PlanarMultibodySolver` and
maps the vehicle's quantities onto the mechanism's roles (its ``[suspension]`` table):
wheel travel ``z_W`` drives the independent coordinate; ``q^z_W`` is the vertical
displacement of the wheel marker; ``F_T`` is the magnitude of the tyre load; and the
suspension spring-damper is a force element of the mechanism between its chassis-side
mount and the linkage, whose rate ``k_S`` and damping ``c_S`` are inputs of the module.

The chassis couples to the spring along the spring's own line of action (eq. 12
generalized): with ``e`` the unit vector from the spring's linkage end to its chassis end,
the chassis mount's vertical motion ``z_M`` (``v_M``) shortens the spring by ``e_z z_M``, so
the spring's tension is ``f = k (ℓ - ℓ0 + e_z z_M) + c (ℓ̇ + e_z v_M)``, ``ℓ`` its length in
the linkage, and the chassis receives its vertical component ``F_S = -f e_z`` (up). For a
vertical spring (the double wishbones) this is exactly eq. 12,
``F_S = k (q^z_U - z_M) + c (q̇^z_U - v_M)``. With ``mount = 'ground'`` the frame stays
fixed to the ground (the paper's coupling, docs/model.md).

With ``mount = 'chassis'`` the frame is the chassis at this corner: the mechanism's one
fixed body becomes a prescribed body (a rheonomic joint, :mod:`~suspopt.multibody.elements
.prescribed`) whose pose follows the chassis. In the front view the chassis point ``P``
at the wheel marker's reference position moves vertically by ``z_M`` (heave, pitch and
roll above the corner) and the frame turns about it by ``ψ`` (``±φ_C`` of the full car's
roll: ``+`` on a left corner, ``-`` on a right one, because the planar model's x points
outboard; 0 on the half car). The ride model has no heights and no lateral motion, so the
roll axis is taken at ``P``'s height and ``P`` does not move sideways. The spring then acts
between two moving bodies and needs no preload. What the chassis receives is everything
the linkage applies on the frame, by Newton-Euler on the frame, ``M_F q̈_F - R_mount``
(the frame's own inertia cancels: the frame belongs to the chassis, whose mass and
inertia already count it): the chassis-side joints' reactions and the spring's force on
its chassis end, as a force ``(F_x, F_z)`` and a moment ``M_P`` about ``P``. They are the
tyre force minus the linkage's ``Σ m_i a_i`` (gravity ignored). The chassis' generalized
forces follow from power: ``F_z`` on the vertical motion of ``P`` and ``±M_P`` on roll.

Those reactions depend on the mount's acceleration, which the chassis equations give:
an algebraic loop at every node. The augmented system is linear in ``γ`` and ``γ`` is
affine in the frame's acceleration, so :meth:`SuspensionModule.mount_response` answers
one query with the response at zero mount acceleration (velocity terms included) and the
response to a unit mount acceleration of each mount coordinate (the linkage's inertia as
the mount feels it; one batched solve with 2 or 3 right-hand sides sharing a matrix).
The chassis equations then solve the loop per node in closed form
(:func:`suspopt.models.equations.chassis_mount_accelerations`).

Both the black-box OpenMDAO components and the time-marching integrator call these two
methods, so both integrate one model.
"""

from __future__ import annotations

import dataclasses
import time
from collections import OrderedDict
from dataclasses import dataclass, field

import numpy as np

from suspopt.errors import ConfigError
from suspopt.multibody.elements import PrescribedJoint, PrescribedMotion
from suspopt.multibody.elements.base import ScalarSpringGroup, cross, perp, rot_apply
from suspopt.multibody.mechanism import GROUND, Mechanism, load_mechanism
from suspopt.multibody.solver import MultibodyState, PlanarMultibodySolver, freeze

MOUNTS = ('ground', 'chassis')
#: the entries of a chassis-mounted module's response (:meth:`SuspensionModule.
#: mount_response`), then the reaction (x, z) of every mechanism joint on its first body
RESPONSE = ('zdd_W', 'F_z', 'M_P', 'F_x')
#: index in :data:`RESPONSE` of the generalized force of each mount coordinate (vertical
#: motion of P, rotation about P)
MOUNT_FORCES = (1, 2)


@dataclass
class AnalysedState(MultibodyState):
    """A state of a :class:`SuspensionModule`'s :meth:`~SuspensionModule.kinematics`, with
    what the analysis found on the way for the dynamics at it: the partitioning of ``Cq``
    (``C_q,dep⁻¹`` and the tangent, :meth:`PlanarMultibodySolver.partition`), the
    coincidence joints' pool, the largest constraint violation ``residual`` and the mount
    pose the state was analysed at (chassis mount). ``pose_memo`` and ``memo`` are shared
    with the module's remembered analysis of the same positions (the joint Jacobians)
    and of the same state (γ of eq. 11): computed at the first query that needs them."""

    partition: tuple[np.ndarray, np.ndarray] | None = None
    pool: np.ndarray | None = None
    residual: float | None = None
    pose: tuple[np.ndarray, ...] | None = None
    pose_memo: dict = field(default_factory=dict)
    memo: dict = field(default_factory=dict)


@dataclass
class ModuleKinematics:
    """Vertical displacement/velocity of the wheel marker (q^z_W) and the linkage state."""

    q_W: np.ndarray
    qd_W: np.ndarray
    state: MultibodyState
    #: chassis mount: the pose it was analysed at, ``(z_M, v_M, ψ, ψ̇)`` each (N,)
    pose: tuple[np.ndarray, ...] | None = None


def chassis_mounted(mechanism: Mechanism) -> tuple[Mechanism, str, str]:
    """The mechanism with its frame (its one fixed body) driven by a prescribed joint
    instead of welded to the ground: (mechanism, frame body, mount joint name)."""
    frames = [b for b in mechanism.bodies if b.fixed]
    on_ground = [j.name for j in mechanism.joints if GROUND in j.bodies]
    on_ground += [m.name for m in mechanism.markers if m.body == GROUND]
    if len(frames) != 1 or on_ground:
        raise ConfigError(
            f'{mechanism.name}: multibody.mount = "chassis" needs every '
            'chassis-side part on one frame body (fixed = true) and nothing on '
            f'the ground; it has fixed bodies {[b.name for b in frames]} and '
            f'ground joints or markers {on_ground}'
        )
    frame = frames[0].name
    names = {j.name for j in mechanism.joints}
    joint = next(n for n in (f'{frame} mount', f'{frame} mount (chassis)') if n not in names)
    bodies = tuple(
        dataclasses.replace(b, fixed=False) if b.name == frame else b for b in mechanism.bodies
    )
    return (
        dataclasses.replace(
            mechanism, bodies=bodies, joints=mechanism.joints + (PrescribedJoint(joint, frame),)
        ),
        frame,
        joint,
    )


class SuspensionModule:
    """One mechanism's multibody suspension, queried as a black box.

    It remembers its last few analyses, by the values of their inputs: a query at exactly
    the inputs of one of them returns that analysis instead of repeating it. Under finite
    differences this is most queries: perturbing the wheel-travel rate, the chassis
    motion, a force or a setting leaves the positions unchanged, and the dynamics query
    repeats the kinematics query's state. What the dynamics at a state needs from its
    analysis (the partitioning, γ, the joint Jacobians) travels with the state
    (:class:`AnalysedState`). A position analysis (Newton on ``C(q) = 0``) starts from
    the solver's pose table (or the reference pose moved along its tangent outside the
    travel range) unless the caller gives a guess, so every answer is a function of the
    query alone, bit for bit, whatever was asked before.
    """

    #: analyses remembered per kind (position; position + velocity)
    memory = 8
    #: a state where the linkage moves this many times faster than at its reference pose
    #: is refused as the edge of its range (a toggle position: the double wishbone's arms
    #: vertical, 99.995 % of the 0.33 m arm length)
    max_sensitivity = 100.0

    def __init__(
        self, mechanism: Mechanism | str, newton_tol: float = 1e-13, mount: str = 'ground'
    ):
        if isinstance(mechanism, str):
            mechanism = load_mechanism(mechanism, suspension=True)
        if mount not in MOUNTS:
            raise ValueError(f'mount must be one of {MOUNTS}, got {mount!r}')
        self.mount = mount
        #: the mechanism as given (ground-mounted form; :attr:`mechanism` is the one solved)
        self.base_mechanism = mechanism
        fixed_names = {b.name for b in mechanism.bodies if b.fixed}
        self.n_joints = len(mechanism.joints)  # the mechanism's own (reported) joints
        if mount == 'chassis':
            mechanism, self.frame, self.mount_joint = chassis_mounted(mechanism)
        self.mechanism = mechanism
        self.solver = s = PlanarMultibodySolver(mechanism, newton_tol=newton_tol)
        roles = mechanism.roles
        self.spring_name = roles['spring']
        self.wheel = s.marker_names.index(roles['wheel_marker'])
        self.tyre_load = s.load_names.index(roles['tyre_load'])
        ends = s.spring(self.spring_name, s.q0[None]).bodies
        chassis = [i for i, b in enumerate(ends) if b == GROUND or b in fixed_names]
        if len(chassis) != 1:  # the reader refuses such files; a Mechanism built in Python
            raise ConfigError(
                f'{mechanism.name}: the suspension spring {self.spring_name!r} '
                f'must connect the chassis side to the linkage (ends {ends})'
            )
        self.chassis_end = chassis[0]
        self._spring_group = s.force_element(self.spring_name)
        #: the spring's curves (a SpringDamperUnit), None for the linear spring-damper
        self.unit = getattr(mechanism.force(self.spring_name), 'curves', None)
        #: the spring's run-time settings, per corner: ``k_S``, ``c_S`` (linear), or the
        #: scalar parameters of its curves (``k_S``, ``k_S3``, ``c_bump_low``, ...)
        self.settings: tuple[str, ...] = (
            ('k_S', 'c_S') if self.unit is None else tuple(self.unit.scalar_parameters())
        )
        #: their units (OpenMDAO)
        self.setting_units: dict[str, str] = {'k_S': 'N/m', 'c_S': 'N*s/m'}
        if self.unit is not None:
            self.setting_units = {
                n: p.units for p in self.unit.parameters() for n in p.scalar_names()
            }
        self.marker_ref = s.marker_reference()
        # the wheel marker: its body's coordinates in q, its point in body axes (u, perp(u))
        b = int(s.mk_body[self.wheel])
        self._wheel_coords = None if b == s.nb else (3 * b + 1, 3 * b + 2)
        (ux, uz), (px, pz) = s.mk_u[self.wheel], perp(s.mk_u[self.wheel])
        self._wheel_u = (float(ux), float(uz), float(px), float(pz))
        self.ind0 = s.q0[s.ind[0]]
        if mount == 'chassis':
            f = s.body_names.index(self.frame)
            self._frame = slice(3 * f, 3 * f + 3)
            self._frame_mass = s.mass_diag[self._frame]
            self._mount_k = s.joint_names.index(self.mount_joint)
            #: P, the frame point that follows z_M: the wheel marker's reference position
            self.mount_point = self.marker_ref[self.wheel].copy()
            self._arm = s.q0[self._frame][:2] - self.mount_point  # frame CG from P
        self.time_s = 0.0  # wall time spent inside this module (benchmarks)
        self.reused = 0  # queries answered from a remembered analysis
        #: remembered position analyses (by wheel travel and mount pose) and states (by
        #: all the kinematics' inputs), newest last
        self._poses: OrderedDict[bytes, tuple] = OrderedDict()
        self._states: OrderedDict[bytes, AnalysedState] = OrderedDict()

    @staticmethod
    def _remember(memory: OrderedDict, key: bytes, value, size: int) -> None:
        memory[key] = value
        while len(memory) > size:
            memory.popitem(last=False)

    def _pose(self, z_W: np.ndarray, guess: np.ndarray | None, mount=None, motion=None):
        """Position analysis at wheel travels ``z_W`` (and mount poses): (q, C_q, the wheel
        marker's vertical displacement (N,), its arm's x (N,), ``max |C|`` (N,), the
        coincidence joints' pool, the partitioning of C_q, a memo for the pose)."""
        key = z_W.tobytes()
        if mount is not None:
            key += mount[0].tobytes() + mount[2].tobytes()
        pose = self._poses.get(key)
        if pose is not None:
            self.reused += 1
            return pose
        s = self.solver
        pa = s.analyse_positions(z_W[:, None] + self.ind0, guess, motion)
        q, Cq, res, pool = pa.q, pa.Cq, pa.residual, pa.pool
        N = q.shape[0]
        if self._wheel_coords is None:  # a wheel marker on the ground
            q_W, arm_x = np.zeros(N), np.zeros(N)
        else:  # the marker's z and its arm's x: A(φ) u = cos φ u + sin φ perp(u)
            iz, iphi = self._wheel_coords
            ux, uz, px, pz = self._wheel_u
            c, sn = np.cos(q[:, iphi]), np.sin(q[:, iphi])
            arm_x = c * ux + sn * px
            q_W = (q[:, iz] + (c * uz + sn * pz)) - self.marker_ref[self.wheel, 1]
        for a in (q, Cq, q_W, arm_x, res, pool):
            if a is not None:
                freeze(a)
        pose = (q, Cq, q_W, arm_x, res, pool, s.partition(Cq), {})
        self._remember(self._poses, key, pose, self.memory)
        return pose

    def kinematics(
        self,
        z_W: np.ndarray,
        v_W: np.ndarray,
        guess: np.ndarray | None = None,
        pose: tuple[np.ndarray, ...] | None = None,
    ) -> ModuleKinematics:
        """Position and velocity analysis at N wheel-travel states (arrays of shape (N,));
        ``guess``: body coordinates (N, n) to start the position analysis from.

        ``z_W`` drives the independent coordinate (the wheel's global vertical position
        from its reference). A chassis-mounted module also needs the mount's ``pose``
        ``(z_M, v_M, ψ, ψ̇)`` (each (N,); ψ and ψ̇ may be scalars 0)."""
        t0 = time.perf_counter()
        z_W = np.ascontiguousarray(z_W, dtype=float)
        v_W = np.ascontiguousarray(v_W, dtype=float)
        if (pose is not None) != (self.mount == 'chassis'):
            raise ValueError(
                f'{self.mechanism.name}: a {self.mount}-mounted module '
                + ('needs the mount pose' if pose is None else 'takes no mount pose')
            )
        if pose is not None:
            pose = tuple(
                np.ascontiguousarray(np.broadcast_to(p, z_W.shape), dtype=float) for p in pose
            )
        key = z_W.tobytes() + v_W.tobytes()
        if pose is not None:
            key += b''.join(p.tobytes() for p in pose)
        try:
            known = self._states.get(key)
            if known is not None:
                self.reused += 1
            else:
                s = self.solver
                motion = None if pose is None else self.mount_motion(pose)
                q, Cq, q_W, arm_x, res, pool, part, pose_memo = self._pose(z_W, guess, pose, motion)
                qd = s.velocities(
                    q,
                    v_W[:, None],
                    Cq,
                    max_sensitivity=self.max_sensitivity,
                    motion=motion,
                    partition=part,
                )
                freeze(qd)
                if self._wheel_coords is None:
                    qd_W = np.zeros(q.shape[0])
                else:  # (r + B u φ)_z of the wheel marker
                    iz, iphi = self._wheel_coords
                    qd_W = qd[:, iz] + arm_x * qd[:, iphi]
                memo = {'q_W': q_W, 'qd_W': freeze(qd_W)}
                known = AnalysedState(
                    q=q,
                    qd=qd,
                    Cq=Cq,
                    partition=part,
                    pool=pool,
                    residual=float(np.maximum.reduce(res, initial=0.0)),
                    pose=pose,
                    pose_memo=pose_memo,
                    memo=memo,
                )
                self._remember(self._states, key, known, self.memory)
        finally:
            self.time_s += time.perf_counter() - t0
        # a fresh state object: dynamics() attaches accelerations and multipliers to it
        return ModuleKinematics(
            q_W=known.memo['q_W'],
            qd_W=known.memo['qd_W'],
            state=dataclasses.replace(known),
            pose=known.pose,
        )

    def mount_motion(
        self, pose: tuple[np.ndarray, ...], acceleration: np.ndarray | None = None
    ) -> dict[str, PrescribedMotion]:
        """The frame's prescribed motion for mount poses ``(z_M, v_M, ψ, ψ̇)`` (each (N,)):
        ``P`` up by ``z_M``, the frame turned by ``ψ`` about it. ``acceleration``: the
        frame CG's (N, 3), default the velocity term only (zero mount acceleration,
        :meth:`frame_accelerations`)."""
        z_M, v_M, psi, w = pose
        Ar = rot_apply(psi, self._arm)
        offset = np.stack([Ar[:, 0] - self._arm[0], z_M + Ar[:, 1] - self._arm[1], psi], -1)
        vel = np.stack([-w * Ar[:, 1], v_M + w * Ar[:, 0], w], -1)
        if acceleration is None:
            acceleration = self.frame_accelerations(pose)[0]
        return {self.mount_joint: PrescribedMotion(offset, vel, acceleration)}

    def frame_accelerations(self, pose: tuple[np.ndarray, ...]) -> np.ndarray:
        """The frame CG's acceleration (x, z, φ) at zero mount acceleration (the turning
        frame's centripetal term ``-ψ̇² A(ψ) r``), then per unit vertical acceleration of
        ``P`` and per unit angular acceleration ψ̈: (3, N, 3)."""
        _, _, psi, w = pose
        Ar = rot_apply(psi, self._arm)
        out = np.zeros((3, psi.shape[0], 3))
        out[0, :, :2] = -(w**2)[:, None] * Ar
        out[1, :, 1] = 1.0
        out[2, :, 0], out[2, :, 1], out[2, :, 2] = -Ar[:, 1], Ar[:, 0], 1.0
        return out

    def spring_params(self, state: MultibodyState, z_M, v_M, k_S, c_S, settings=None) -> dict:
        """The spring's run-time values: rate, damping, and the preload
        ``e_z (k_S z_M + c_S v_M)`` of the chassis mount's motion along its axis; for a
        spring with curves, its curve parameters (:meth:`curve_values`) and the length
        offsets ``e_z z_M``, ``e_z v_M``."""
        return {
            self.spring_name: self._spring_values(
                self.axis_vertical(state), z_M, v_M, k_S, c_S, settings
            )
        }

    def _spring_values(self, e_z, z_M, v_M, k_S, c_S, settings) -> dict:
        """The spring's run-time values (see :meth:`spring_params`); ``e_z`` None: a
        chassis-mounted module (no mount motion along the spring)."""
        if self.unit is None:
            if settings:
                raise ValueError(
                    f'{self.mechanism.name}: the spring {self.spring_name!r} has no curves; '
                    f'settings {sorted(settings)} given'
                )
            if e_z is None:
                return {'stiffness': k_S, 'damping': c_S}
            return {'stiffness': k_S, 'damping': c_S, 'preload': e_z * (k_S * z_M + c_S * v_M)}
        values = self.curve_values(k_S, c_S, settings)
        if e_z is not None:
            values['offset'], values['offset_rate'] = e_z * z_M, e_z * v_M
        return values

    def curve_values(self, k_S=None, c_S=None, settings=None) -> dict:
        """The curve parameters given at run time: ``settings`` by scalar name
        (:attr:`settings`), and ``k_S``, ``c_S`` for the curves' parameters of those names
        (a polynomial spring's rate, a linear damper), unless ``settings`` has them; the
        others keep the file's values."""
        settings = dict(settings or {})
        unknown = sorted(set(settings) - set(self.settings))
        if unknown:
            raise ValueError(
                f'{self.mechanism.name}: the spring {self.spring_name!r} has no settings '
                f'{unknown} (settings: {", ".join(self.settings)})'
            )
        for name, val in (('k_S', k_S), ('c_S', c_S)):
            if val is not None and name in self.settings:
                settings.setdefault(name, val)
        return settings

    def strut_rate(self, kin: ModuleKinematics, v_M: np.ndarray | None = None) -> np.ndarray:
        """The spring-damper's compression rate (N,) at states of :meth:`kinematics`, bump
        +: ``-(ℓ̇ + e_z v_M)`` on the ground mount (the chassis end follows ``v_M`` along
        the spring's line, as in :meth:`dynamics`), ``-ℓ̇`` on the chassis mount (both ends
        move with the linkage); the rate across an actuator or damper in parallel with it
        (``docs/codesign.md``). For a vertical spring at the wheel it is ``v_W - v_M``."""
        t0 = time.perf_counter()
        s, state = self.solver, kin.state
        try:
            qe, qde = s.extend(state.q), s.extend(state.qd)
            k = self._spring_group[1]
            grp = self._spring_elements()
            geo = grp.geometry(qe)
            _, grad = grp.measure(qe, geo)
            rate = -grp.rate(grad, qde)[:, k]
            if self.mount == 'ground':
                e_z = self._spring_directions(qe, geo)[:, 1 - self.chassis_end, 1]
                rate = rate - e_z * np.asarray(v_M, dtype=float)
        finally:
            self.time_s += time.perf_counter() - t0
        return rate

    def _preload(self) -> float:
        """The spring's own preload (its file's), the tension an actuator adds to."""
        return float(getattr(self.mechanism.force(self.spring_name), 'preload', 0.0))

    def axis_vertical(self, state: MultibodyState) -> np.ndarray:
        """``e_z``: vertical component of the unit vector from the spring's linkage end to
        its chassis end, (N,)."""
        return self._spring_directions(self.solver.extend(state.q))[:, 1 - self.chassis_end, 1]

    def _spring_elements(self) -> ScalarSpringGroup:
        """The force group of the spring (:meth:`PlanarMultibodySolver.force_element`)."""
        grp = self.solver.force_groups[self._spring_group[0]]
        assert isinstance(grp, ScalarSpringGroup)  # the spring role is checked on reading
        return grp

    def _spring_directions(self, qe: np.ndarray, geometry=None) -> np.ndarray:
        """The spring's line of action at both ends (N, 2, 2), see :meth:`spring`."""
        return self._spring_elements().directions(qe, geometry)[:, self._spring_group[1]]

    def _spring_force(self, qe, qde, values, parts) -> np.ndarray:
        """The spring's tension (N,) from the force groups' values and what their
        generalized forces computed on the way (:meth:`PlanarMultibodySolver.applied_forces`)."""
        gi, k = self._spring_group
        tension = parts[gi]
        if tension is None:
            grp = self._spring_elements()
            tension = grp.tension(qe, qde, values[gi], grp.geometry(qe))
        return tension[2][:, k]

    def dynamics(
        self,
        state: MultibodyState,
        z_M: np.ndarray,
        v_M: np.ndarray,
        k_S: np.ndarray | None,
        c_S: np.ndarray | None,
        F_T: np.ndarray,
        settings: dict[str, np.ndarray] | None = None,
        actuator: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Augmented-form dynamics (eq. 11) under the suspension spring (rate ``k_S``,
        damping ``c_S``, chassis mount at ``z_M``, ``v_M``) and ``+F_T`` on the contact
        patch: wheel-travel acceleration (N,), the spring's vertical force on the chassis
        ``F_S`` (N,) and the joint reactions (N, nj, 2). A spring with curves takes its
        parameters from ``settings`` (and ``k_S``, ``c_S``: :meth:`curve_values`), the
        mount's motion as the length offsets ``e_z z_M``, ``e_z v_M``. ``actuator``: a
        force (N,) along the spring's line in parallel with it, pushing its ends apart
        (``docs/codesign.md``): the spring's tension less that force (``F_S`` includes
        it)."""
        if self.mount != 'ground':
            raise ValueError(
                f"{self.mechanism.name}: dynamics() is the ground mount's "
                'query; a chassis-mounted module answers mount_response()'
            )
        t0 = time.perf_counter()
        s = self.solver
        try:
            q, qd = state.q, state.qd
            N = q.shape[0]
            qe, qde = s.extend(q), s.extend(qd)
            loads = np.zeros((N, len(s.load_names)))
            loads[:, self.tyre_load] = F_T
            gi = self._spring_group[0]
            geo = {gi: self._spring_elements().geometry(qe)}  # the spring's, once
            e_z = self._spring_directions(qe, geo[gi])[:, 1 - self.chassis_end, 1]
            if self.unit is None and not settings:
                params = {
                    self.spring_name: {
                        'stiffness': k_S,
                        'damping': c_S,  # spring_params
                        'preload': e_z * (k_S * z_M + c_S * v_M),
                    }
                }
            else:
                params = {self.spring_name: self._spring_values(e_z, z_M, v_M, k_S, c_S, settings)}
            if actuator is not None:
                own = params[self.spring_name].get('preload', self._preload())
                params[self.spring_name]['preload'] = own - np.asarray(actuator, dtype=float)
            values = s.force_values(N, loads, params)
            Q, parts = s.applied_forces(q, qe, qde, values, geo)
            known = state if isinstance(state, AnalysedState) else None
            gamma = None if known is None else known.memo.get('gamma')
            if gamma is None:
                gamma = s.gamma(q, qd, qe=qe, qde=qde, pool=None if known is None else known.pool)
                if known is not None:  # γ at this state, for its next query
                    known.memo['gamma'] = freeze(gamma)
            state.qdd, state.lam = s.solve_augmented(
                q,
                qd,
                Q,
                Cq=state.Cq,
                gamma=gamma,
                partition=None if known is None else known.partition,
            )
            F_S = -self._spring_force(qe, qde, values, parts) * e_z
        finally:
            self.time_s += time.perf_counter() - t0
        return state.qdd[:, s.ind[0]], F_S, s.joint_reactions(state.lam, q)

    def mount_response(
        self,
        kin: ModuleKinematics,
        k_S: np.ndarray | None,
        c_S: np.ndarray | None,
        F_T: np.ndarray,
        rotation: bool = False,
        acceleration: np.ndarray | None = None,
        settings: dict[str, np.ndarray] | None = None,
        actuator: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Chassis mount: what the linkage applies on the chassis at N states analysed by
        :meth:`kinematics`, under the spring (``k_S``, ``c_S``) and ``+F_T`` on the contact
        patch (and an ``actuator`` force along the spring's line, as in
        :meth:`dynamics`).

        Returns ``R`` (N, B, n_r), each row the entries :data:`RESPONSE` (wheel-travel
        acceleration, the force ``F_z``, the moment ``M_P`` about P and the force ``F_x`` of
        the linkage on the chassis) then every mechanism joint's reaction (x, z) on its
        first body; and ``F_S`` (N,), the spring's vertical force on its chassis end.

        Without ``acceleration`` the B blocks are the response at zero mount acceleration,
        then the response per unit vertical acceleration of P (and, with ``rotation``, per
        unit ψ̈): the response at mount accelerations ``a`` is ``R_0 + Σ_u a_u R_u``
        exactly. With ``acceleration`` (N, 2) = (vertical, angular) of the mount, B = 1:
        the response at that acceleration itself. A spring with curves takes its
        parameters from ``settings`` (and ``k_S``, ``c_S``, see :meth:`dynamics`)."""
        t0 = time.perf_counter()
        s, state, pose = self.solver, kin.state, kin.pose
        assert pose is not None  # a chassis mount's kinematics has its pose
        try:
            N = state.q.shape[0]
            loads = np.zeros((N, len(s.load_names)))
            loads[:, self.tyre_load] = F_T
            params = {self.spring_name: self._spring_values(None, None, None, k_S, c_S, settings)}
            if actuator is not None:
                params[self.spring_name]['preload'] = self._preload() - np.asarray(
                    actuator, dtype=float
                )
            qe, qde = s.extend(state.q), s.extend(state.qd)
            gi = self._spring_group[0]
            geo = {gi: self._spring_elements().geometry(qe)}
            values = s.force_values(N, loads, params)
            Q, parts = s.applied_forces(state.q, qe, qde, values, geo)
            frame = self.frame_accelerations(pose)
            if acceleration is not None:
                a = np.asarray(acceleration, dtype=float).reshape(N, 2)
                acc = frame[0] + a[:, :1] * frame[1] + a[:, 1:] * frame[2]
                blocks, qd, Qb = 1, state.qd, Q
            else:
                blocks = 3 if rotation else 2
                acc = frame[:blocks].reshape(blocks * N, 3)
                zeros = np.zeros(((blocks - 1) * N, s.n))
                qd, Qb = np.concatenate([state.qd, zeros]), np.concatenate([Q, zeros])
            tile = (lambda x: np.concatenate([x] * blocks)) if blocks > 1 else (lambda x: x)
            q, Cq = tile(state.q), tile(state.Cq)
            motion = self.mount_motion(tuple(tile(p) for p in pose), acc)
            # with the pose's partitioning and joint Jacobians (each block's are the same)
            known = state if isinstance(state, AnalysedState) else None
            part = None if known is None else known.partition
            if part is None:
                assert state.Cq is not None  # kinematics gives C_q with every state
                part = s.partition(state.Cq)
            jac = None if known is None else known.pose_memo.get('joint_jacobians')
            if jac is None:
                jac = tuple(freeze(j) for j in s.joint_jacobians(state.q))
                if known is not None:
                    known.pose_memo['joint_jacobians'] = jac
            qdd, lam = s.solve_augmented(
                q,
                qd,
                Qb,
                Cq=Cq,
                motion=motion,
                gamma=s.gamma(q, qd, motion),
                partition=(tile(part[0]), tile(part[1])),
            )
            R = s.reactions(q, lam, tuple(tile(j) for j in jac))
            # Newton-Euler on the frame: all the linkage applies on it (its drive aside)
            on_frame = self._frame_mass * qdd[:, self._frame] - R[:, self._mount_k, 0]
            P = np.stack(
                [np.full(q.shape[0], self.mount_point[0]), self.mount_point[1] + tile(pose[0])], -1
            )
            M_P = on_frame[:, 2] + cross(q[:, self._frame][:, :2] - P, on_frame[:, :2])
            out = np.concatenate(
                [
                    np.stack([qdd[:, s.ind[0]], on_frame[:, 1], M_P, on_frame[:, 0]], -1),
                    R[:, : self.n_joints, 0, :2].reshape(q.shape[0], -1),
                ],
                -1,
            )
            F_S = (
                -self._spring_force(qe, qde, values, parts)
                * self._spring_directions(qe, geo[gi])[:, 1 - self.chassis_end, 1]
            )
        finally:
            self.time_s += time.perf_counter() - t0
        return out.reshape(blocks, N, -1).transpose(1, 0, 2), F_S

    def constraint_residual(
        self, state: MultibodyState, pose: tuple[np.ndarray, ...] | None = None
    ) -> float:
        """Largest position-constraint violation ``max |C(q)|`` over the states [m]
        (chassis mount: at the mount ``pose`` the states were analysed at)."""
        if (
            isinstance(state, AnalysedState)
            and state.residual is not None
            and _same_pose(pose, state.pose)
        ):
            return state.residual  # its position analysis' last Newton iteration has it
        motion = None if pose is None else self.mount_motion(pose)
        return float(np.max(np.abs(self.solver.constraints(state.q, motion)), initial=0.0))


def _same_pose(a: tuple[np.ndarray, ...] | None, b: tuple[np.ndarray, ...] | None) -> bool:
    """Whether two mount poses (or their absence) are equal, value for value."""
    if a is None or b is None:
        return a is b
    return len(a) == len(b) and all(np.array_equal(x, y) for x, y in zip(a, b))
