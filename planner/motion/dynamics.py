"""The delta's lumped-mass dynamics: motor torques a planned TCP motion takes.

The standard simplification of delta-robot dynamics (e.g. Codourey, "Dynamic modeling of
parallel robots for computed-torque control implementation", IJRR 1998): each upper arm turns
with its own inertia and carries part of its rods at the elbow; the platform, the tool, the
payload and the rods' other part move with the TCP. With the Jacobian `J = dp/dq` the motor
torques are `tau = I qdd + b qd - m_arm g r cos(q) + J^T M (a + g)`. The numbers come from the
MJCF (`sim.cell.executor.lumped_dynamics`); this module only computes, so planning stays pure.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from planner.errors import PlannerInputError

GRAVITY = 9.81
"""Standard gravity [m/s^2]."""


@dataclass(frozen=True)
class LumpedDynamics:
    """Lumped-mass model of the three legs and the moving platform.

    Attributes:
        arm_inertia: Inertia about the motor axis, reflected rotor and elbow masses included
            [kg m^2].
        arm_moment: Gravity moment of the arm and elbow masses at q = 0, per g [kg m].
        damping: Motor joint viscous damping [N m s/rad].
        moving_mass: Mass moving with the TCP (platform, cup, payload, rod shares) [kg].
        torque_limit: The motors' peak torque [N m].
    """

    arm_inertia: float
    arm_moment: float
    damping: float
    moving_mass: float
    torque_limit: float

    def __post_init__(self):
        for name in self.__dataclass_fields__:
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0.0):
                raise PlannerInputError(name, "a finite number >= 0", value)

    def torque(self, q, qdot, qddot, jac, tcp_acc) -> np.ndarray:
        """Motor torques [N m], shape (n, 3).

        Args:
            q: Motor angles (n, 3) [rad].
            qdot: Motor speeds (n, 3) [rad/s].
            qddot: Motor accelerations (n, 3) [rad/s^2].
            jac: Jacobians dp/dq (n, 3, 3) [m/rad].
            tcp_acc: TCP accelerations (n, 3) [m/s^2].
        """
        arms, force = self.arms_and_force(np.cos(q), qdot, qddot, tcp_acc)
        return arms + np.einsum("nji,nj->ni", jac, force)

    def arms_and_force(self, cos_q, qdot, qddot, tcp_acc) -> tuple[np.ndarray, np.ndarray]:
        """The two parts of `torque` = arms + J^T force: the torques [N m] of the arms' own
        inertia, damping and weight, and the force [N] the moving mass needs, each (n, 3),
        from the cosines of the motor angles (n, 3) and the arguments of `torque`."""
        force = self.moving_mass * (np.asarray(tcp_acc) + np.array([0.0, 0.0, GRAVITY]))
        arms = self.arm_inertia * qddot + self.damping * qdot
        arms = arms - self.arm_moment * GRAVITY * cos_q
        return arms, force
