"""Assemble a linear multibody model from small-motion Jacobians: mass, stiffness and damping matrices and port maps.

Every element is described by how its deflection depends on the generalised coordinates q (a row of partial
derivatives) and on the actuator post displacements. A force F that resists the deflection d acts on the coordinates
as the generalised force -row^T F (virtual work). The result is

    M q'' + C q' + K q = Qu u + Qf,

which `to_vehicle` turns into the first-order form x' = A x + B u + f, y = C x + D u + e with x = [q, q'].
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from nnfmu.vehicle.dynamics.builtin_elements import LinearSpring, SplineDamper
from nnfmu.vehicle.dynamics.errors import VehicleModelError
from nnfmu.vehicle.dynamics.linear import LinearVehicle
from nnfmu.vehicle.dynamics.ports import VehiclePort


def skew(p: np.ndarray) -> np.ndarray:
    """Matrix S with S @ r == p x r."""
    return np.array([[0.0, -p[2], p[1]], [p[2], 0.0, -p[0]], [-p[1], p[0], 0.0]])


@dataclass(frozen=True)
class RigidMotion:
    """Small motion of a rigid body: translation of `origin` and rotation vector, each 3 x n in the coordinates."""

    translation: np.ndarray
    rotation: np.ndarray
    origin: np.ndarray

    def point(self, p: np.ndarray) -> np.ndarray:
        """3 x n Jacobian of the displacement of body point `p`: t + r x (p - origin)."""
        return self.translation - skew(np.asarray(p, dtype=float) - self.origin) @ self.rotation


@dataclass(frozen=True)
class Deflection:
    """d = row . q + post . (post displacements); its rate uses the same rows on q' and the post velocities."""

    row: np.ndarray
    post: np.ndarray


@dataclass
class Assembly:
    """Collects masses, linear elements, force ports, nonlinear feedback elements and outputs of one model."""

    coordinates: list[VehiclePort]
    posts: list[str]
    gravity: float
    mass: np.ndarray = field(init=False)
    stiffness: np.ndarray = field(init=False)
    damping: np.ndarray = field(init=False)
    post_stiffness: np.ndarray = field(init=False)
    post_damping: np.ndarray = field(init=False)
    weight: np.ndarray = field(init=False)
    preload: np.ndarray = field(init=False)
    forces: list[tuple[VehiclePort, np.ndarray, LinearSpring | None]] = field(default_factory=list)
    feedbacks: list[tuple[str, Deflection, SplineDamper]] = field(default_factory=list)
    outputs: list[tuple[VehiclePort, str, Deflection, LinearSpring | None]] = field(default_factory=list)

    def __post_init__(self) -> None:
        n, p = len(self.coordinates), len(self.posts)
        self.mass = np.zeros((n, n))
        self.stiffness = np.zeros((n, n))
        self.damping = np.zeros((n, n))
        self.post_stiffness = np.zeros((n, p))
        self.post_damping = np.zeros((n, p))
        self.weight = np.zeros(n)
        self.preload = np.zeros(n)

    @property
    def size(self) -> int:
        return len(self.coordinates)

    def unit_row(self, index: int) -> np.ndarray:
        row = np.zeros(self.size)
        row[index] = 1.0
        return row

    def post_row(self, post: str | None = None) -> np.ndarray:
        row = np.zeros(len(self.posts))
        if post is not None:
            row[self.posts.index(post)] = 1.0
        return row

    def add_point_mass(self, mass: float, jacobian: np.ndarray) -> None:
        """A mass whose displacement is `jacobian` (3 x n, or 1 x n vertical only) @ q; it also gets its weight."""
        jac = np.atleast_2d(jacobian)
        self.mass += mass * jac.T @ jac
        self.weight -= mass * self.gravity * jac[-1]

    def add_inertia(self, inertia: np.ndarray, rotation: np.ndarray) -> None:
        """A rotary inertia tensor (3 x 3, or 1 x 1 about one axis) turning by `rotation` @ q."""
        rot = np.atleast_2d(rotation)
        self.mass += rot.T @ np.atleast_2d(inertia) @ rot

    def add_spring(self, deflection: Deflection, spring: LinearSpring) -> None:
        """A linear spring-damper resisting `deflection`; its preload is the force it carries in the design position."""
        r = deflection.row
        self.stiffness += spring.stiffness * np.outer(r, r)
        self.damping += spring.damping * np.outer(r, r)
        self.post_stiffness -= spring.stiffness * np.outer(r, deflection.post)
        self.post_damping -= spring.damping * np.outer(r, deflection.post)
        self.preload -= spring.preload * r

    def add_force_input(
        self, port: VehiclePort, deflection: Deflection, stabiliser: LinearSpring | None = None
    ) -> None:
        """An external force (input port) resisting `deflection`. With a `stabiliser` (the element's linear
        reference), the force set at a step's start is applied plus the stabiliser's change since then, so a stiff
        component coupled through a held force acts on the vehicle with its linear part solved exactly over the step
        (see `LinearVehicle.stabiliser`)."""
        if np.any(deflection.post):
            raise VehicleModelError(f"force port {port.name} must act between bodies, not on an actuator post")
        self.forces.append((port, deflection.row, stabiliser))

    def add_feedback(self, name: str, deflection: Deflection, law: SplineDamper) -> None:
        """A nonlinear damper resisting `deflection` with force law(rate of deflection)."""
        self.feedbacks.append((name, deflection, law))

    def add_output(
        self, port: VehiclePort, kind: str, deflection: Deflection, spring: LinearSpring | None = None
    ) -> None:
        """Output `kind` of a deflection: 'displacement', 'velocity', 'acceleration' or 'force' (of `spring`)."""
        if kind not in ("displacement", "velocity", "acceleration", "force"):
            raise VehicleModelError(f"output {port.name}: unknown kind {kind!r}")
        if (kind == "force") != (spring is not None):
            raise VehicleModelError(f"output {port.name}: a force output needs its spring, other kinds none")
        self.outputs.append((port, kind, deflection, spring))

    def to_vehicle(self, name: str, description: str, post_ports: list[VehiclePort]) -> LinearVehicle:
        """First-order model x' = A x + B u + f, y = C x + D u + e with u = [post displacements, post velocities,
        forces]."""
        n, p, nf = self.size, len(self.posts), len(self.forces)
        try:
            minv = np.linalg.inv(self.mass)
        except np.linalg.LinAlgError:
            raise VehicleModelError(f"{name}: singular mass matrix (a coordinate carries no mass or inertia)") from None
        force_rows = np.array([-row for _, row, _ in self.forces]).T.reshape(n, nf)
        q_u = np.hstack([self.post_stiffness, self.post_damping, force_rows])
        lower_a = np.hstack([-minv @ self.stiffness, -minv @ self.damping])
        lower_b = minv @ q_u
        a = np.vstack([np.hstack([np.zeros((n, n)), np.eye(n)]), lower_a])
        b = np.vstack([np.zeros((n, q_u.shape[1])), lower_b])
        gravity = np.concatenate([np.zeros(n), minv @ self.weight])
        preload = np.concatenate([np.zeros(n), minv @ self.preload])
        nn = len(self.feedbacks)
        lower_bn = minv @ np.array([-d.row for _, d, _ in self.feedbacks]).T.reshape(n, nn)
        bn = np.vstack([np.zeros((n, nn)), lower_bn])
        cn = np.array([np.concatenate([np.zeros(n), d.row]) for _, d, _ in self.feedbacks]).reshape(nn, 2 * n)
        dn = np.array([np.concatenate([np.zeros(p), d.post, np.zeros(nf)]) for _, d, _ in self.feedbacks]).reshape(
            nn, b.shape[1]
        )
        rows = [
            self._output_rows(kind, d, s, lower_a, lower_b, lower_bn, gravity[n:] + preload[n:])
            for _, kind, d, s in self.outputs
        ]
        states = self.coordinates + [
            VehiclePort(f"{c.name}_rate", f"{c.unit}/s" if c.unit != "1" else "1/s", f"rate of {c.name}")
            for c in self.coordinates
        ]
        return LinearVehicle(
            name=name,
            description=description,
            states=states,
            inputs=post_ports + [port for port, _, _ in self.forces],
            outputs=[port for port, *_ in self.outputs],
            A=a,
            B=b,
            C=np.array([r[0] for r in rows]),
            D=np.array([r[1] for r in rows]),
            e=np.array([r[2] for r in rows]),
            gravity=gravity,
            preload=preload,
            feedback_names=[name for name, _, _ in self.feedbacks],
            feedback_laws=[law for _, _, law in self.feedbacks],
            Bn=bn,
            Cn=cn,
            Dn=dn,
            Dyn=np.array([r[3] for r in rows]).reshape(len(rows), nn),
            stabiliser=self._stabiliser(q_u.shape[1]),
            stabiliser_rows=self._stabiliser_rows(q_u.shape[1]),
            stabiliser_elements=self._stabiliser_elements(q_u.shape[1]),
        )

    def _stabiliser(self, inputs: int) -> np.ndarray:
        """(nu, nx) rows S: the stabilised force ports' linear reference force S x (zero rows for other inputs)."""
        n, first = self.size, inputs - len(self.forces)
        s = np.zeros((inputs, 2 * n))
        for i, (_, row, spring) in enumerate(self.forces):
            if spring is not None:
                s[first + i] = np.concatenate([spring.stiffness * row, spring.damping * row])
        return s

    def _stabiliser_rows(self, inputs: int) -> np.ndarray:
        """(nu, n) rows: each stabilised force port's deflection as a row over q (zero rows for other inputs)."""
        first = inputs - len(self.forces)
        rows = np.zeros((inputs, self.size))
        for i, (_, row, spring) in enumerate(self.forces):
            if spring is not None:
                rows[first + i] = row
        return rows

    def _stabiliser_elements(self, inputs: int) -> np.ndarray:
        """(nu, 2): (stiffness, damping) of each stabilised force port's element (zero rows for other inputs)."""
        first = inputs - len(self.forces)
        elements = np.zeros((inputs, 2))
        for i, (_, _, spring) in enumerate(self.forces):
            if spring is not None:
                elements[first + i] = (spring.stiffness, spring.damping)
        return elements

    def _output_rows(
        self,
        kind: str,
        d: Deflection,
        spring: LinearSpring | None,
        lower_a: np.ndarray,
        lower_b: np.ndarray,
        lower_bn: np.ndarray,
        constant: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray, float, np.ndarray]:
        """(C row, D row, e, Dyn row) of one output."""
        n, p, nf = self.size, len(self.posts), len(self.forces)
        zeros_q, zeros_f = np.zeros(n), np.zeros(nf)
        zeros_n = np.zeros(len(self.feedbacks))
        pos_c = np.concatenate([d.row, zeros_q])
        pos_d = np.concatenate([d.post, np.zeros(p), zeros_f])
        vel_c = np.concatenate([zeros_q, d.row])
        vel_d = np.concatenate([np.zeros(p), d.post, zeros_f])
        if kind == "displacement":
            return pos_c, pos_d, 0.0, zeros_n
        if kind == "velocity":
            return vel_c, vel_d, 0.0, zeros_n
        if kind == "acceleration":
            if np.any(d.post):
                raise VehicleModelError("an acceleration output must be of a body point, not relative to a post")
            return d.row @ lower_a, d.row @ lower_b, float(d.row @ constant), d.row @ lower_bn
        assert spring is not None
        c_row = spring.stiffness * pos_c + spring.damping * vel_c
        d_row = spring.stiffness * pos_d + spring.damping * vel_d
        return c_row, d_row, spring.preload, zeros_n
