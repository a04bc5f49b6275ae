"""A floating base (a free root joint) in MuJoCo's convention, which every adapter speaks,
and in PyBullet's and DART's, which they convert from and to.

Ours and MuJoCo's (the adapters' q, v and tau; quaternions w x y z, unit):
  q[:7] = (x, y, z, qw, qx, qy, qz): the base frame's world position and orientation;
  v[:6] = (the base origin's world velocity, the base-frame angular velocity);
  tau[:6] = (a world force at the base origin, a base-frame torque): the forces that do
  work on v.

PyBullet (3.2.7): the base's pose is that of its inertial frame (the COM, and the
principal axes: PyBullet turns a full inertia to its principal axes on loading), with a
quaternion x y z w it reports with w >= 0; its velocities are the COM's and the angular
velocity, both in world axes. A free base's COM moves in a straight line over a step while
MuJoCo's body origin does: the two take the same step only when the base's COM is its
origin (reference_models/floating_arm.urdf).

DART (dartpy 6.20, measured): a FreeJoint's positions are the rotation vector and the
translation of the base frame in the joint's parent frame; its velocities are the angular
velocity and the base origin's velocity, both in that parent frame; its forces are
conjugate to those. It turns the base by a truncated series when |w| h < 1e-3: the
orientation then parts from the exact exponential (MuJoCo's, ours) by about (|w| h)^3 / 20,
at most 5e-11; above, the two agree to rounding.

A quaternion read back from an engine is either sign; `near` picks the one closer to the
state last set, as MuJoCo's continuous integration would have it.
"""

from __future__ import annotations

import numpy as np


def quat_multiply(a, b) -> np.ndarray:
    """a b, both w x y z."""
    return np.r_[a[0] * b[0] - np.dot(a[1:], b[1:]), a[0] * b[1:] + b[0] * a[1:] + np.cross(a[1:], b[1:])]


def quat_conjugate(a) -> np.ndarray:
    return np.r_[a[0], -np.asarray(a[1:])]


def quat_matrix(a) -> np.ndarray:
    """The rotation matrix of a unit quaternion (w x y z)."""
    w, x, y, z = a
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


def matrix_quat(R) -> np.ndarray:
    """A unit quaternion (w x y z, either sign) of a rotation matrix (Shepperd's method)."""
    t = np.trace(R)
    k = int(np.argmax([t, R[0, 0], R[1, 1], R[2, 2]]))
    if k == 0:
        s = 2 * np.sqrt(1 + t)
        q = [s / 4, (R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s]
    else:
        i, j, m = k - 1, k % 3, (k + 1) % 3
        s = 2 * np.sqrt(1 + 2 * R[i, i] - t)
        q = np.zeros(4)
        q[0], q[1 + i] = (R[m, j] - R[j, m]) / s, s / 4
        q[1 + j], q[1 + m] = (R[j, i] + R[i, j]) / s, (R[m, i] + R[i, m]) / s
    return np.asarray(q) / np.linalg.norm(q)


def rotvec_quat(r) -> np.ndarray:
    angle = np.linalg.norm(r)
    axis = r / angle if angle > 0 else np.zeros(3)
    return np.r_[np.cos(angle / 2), np.sin(angle / 2) * axis]


def quat_rotvec(a) -> np.ndarray:
    a = a if a[0] >= 0 else -a
    s = np.linalg.norm(a[1:])
    return 2 * np.arctan2(s, a[0]) * a[1:] / s if s > 0 else np.zeros(3)


def rpy_quat(rpy) -> np.ndarray:
    """URDF's fixed-axis roll-pitch-yaw, R = Rz(yaw) Ry(pitch) Rx(roll), as a quaternion."""
    return quat_multiply(quat_multiply(rotvec_quat([0.0, 0.0, rpy[2]]), rotvec_quat([0.0, rpy[1], 0.0])),
                         rotvec_quat([rpy[0], 0.0, 0.0]))


def near(a, reference) -> np.ndarray:
    """The sign of quaternion a closer to reference."""
    return -a if np.dot(a, reference) < 0 else a


class PybulletBase:
    """A PyBullet free base whose inertial frame sits at `com` (base frame) turned by `frame`
    (w x y z): getDynamicsInfo(body, -1)[3:5]."""

    def __init__(self, com, frame_xyzw):
        self.com = np.asarray(com, float)
        self.frame = np.r_[frame_xyzw[3], frame_xyzw[:3]]

    def to_engine(self, q, v) -> tuple:
        """(COM position, quaternion x y z w, COM velocity, world angular velocity)."""
        R = quat_matrix(q[3:7])
        com, orientation = q[:3] + R @ self.com, quat_multiply(q[3:7], self.frame)
        omega = R @ v[3:6]
        return com, np.r_[orientation[1:], orientation[0]], v[:3] + np.cross(omega, R @ self.com), omega

    def from_engine(self, com, orientation_xyzw, com_velocity, omega, reference) -> tuple:
        """(q[:7], v[:6]) from what getBasePositionAndOrientation and getBaseVelocity return."""
        quat = quat_multiply(np.r_[orientation_xyzw[3], orientation_xyzw[:3]], quat_conjugate(self.frame))
        quat = near(quat / np.linalg.norm(quat), reference)
        R = quat_matrix(quat)
        origin = np.asarray(com) - R @ self.com
        velocity = np.asarray(com_velocity) - np.cross(omega, R @ self.com)
        return np.r_[origin, quat], np.r_[velocity, R.T @ np.asarray(omega)]

    @staticmethod
    def wrench(q, tau) -> tuple:
        """(world force, the world point it acts at, world torque) of tau[:6] at q."""
        return np.asarray(tau[:3], float), np.asarray(q[:3], float), quat_matrix(q[3:7]) @ tau[3:6]


class DartBase:
    """A DART FreeJoint whose parent frame is (rotation P, origin p) in the world:
    joint.getTransformFromParentBodyNode(), the child transform being the identity."""

    def __init__(self, parent_transform):
        T = np.asarray(parent_transform, float)
        self.P, self.p = T[:3, :3], T[:3, 3]

    def to_engine(self, q, v) -> tuple:
        """(the FreeJoint's 6 positions, its 6 velocities)."""
        R = quat_matrix(q[3:7])
        rotation = quat_rotvec(quat_multiply(matrix_quat(self.P.T), q[3:7]))
        return np.r_[rotation, self.P.T @ (q[:3] - self.p)], np.r_[self.P.T @ R @ v[3:6], self.P.T @ v[:3]]

    def from_engine(self, positions, velocities, reference) -> tuple:
        quat = near(quat_multiply(matrix_quat(self.P), rotvec_quat(positions[:3])), reference)
        R = quat_matrix(quat)
        origin = self.P @ positions[3:6] + self.p
        return np.r_[origin, quat], np.r_[self.P @ velocities[3:6], R.T @ self.P @ velocities[:3]]

    def forces(self, q, tau) -> np.ndarray:
        """The FreeJoint's 6 generalized forces for tau[:6] at q."""
        return np.r_[self.P.T @ quat_matrix(q[3:7]) @ tau[3:6], self.P.T @ tau[:3]]
