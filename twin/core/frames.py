"""Frame, attitude and unit conventions: decided once, here.

* Navigation frame n: ENU (x East, y North, z Up). The MuJoCo world frame is n.
* Body frame b: x right (starboard), y forward, z up (the LIG paper's convention).
* Fossen's hydrodynamic body frame f: x forward, y starboard, z down. ``F_FROM_B`` converts,
  and nothing else in the code base builds that permutation.
* Attitude: C_b^n = Rz(yaw) · Rx(pitch) · Ry(roll), where
  pitch is about body x (nose up positive), roll about body y (starboard down positive) and
  yaw about z (counter-clockwise from North positive, the ENU right-hand sense).
* Heading shown to users is compass degrees, clockwise from North: heading = -yaw.
* Quaternions: MuJoCo is (w, x, y, z); Rerun wants (x, y, z, w). ``wxyz_to_xyzw`` is the boundary.
* Angles are radians inside, degrees at the edges (config files, reports).
"""

from __future__ import annotations

import math

import numpy as np

from twin.core.arrays import Float64Array as FloatArray

# Fossen f-frame axes expressed in the body b-frame: f = F_FROM_B @ b.
# f.x (forward) = b.y, f.y (starboard) = b.x, f.z (down) = -b.z. det = +1: a proper rotation.
F_FROM_B: FloatArray = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])


def wxyz_to_xyzw(q: FloatArray) -> FloatArray:
    """MuJoCo quaternion(s) (w, x, y, z) to Rerun/SciPy order (x, y, z, w)."""
    return np.roll(np.asarray(q, dtype=np.float64), -1, axis=-1)


def xyzw_to_wxyz(q: FloatArray) -> FloatArray:
    """Rerun/SciPy quaternion(s) (x, y, z, w) to MuJoCo order (w, x, y, z)."""
    return np.roll(np.asarray(q, dtype=np.float64), 1, axis=-1)


def quat_to_dcm(q_wxyz: FloatArray) -> FloatArray:
    """Rotation matrix C_b^n (body to navigation) from a unit quaternion (w, x, y, z)."""
    w, x, y, z = (float(v) for v in q_wxyz)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def dcm_to_quat(c: FloatArray) -> FloatArray:
    """Unit quaternion (w, x, y, z), w >= 0, from a rotation matrix (Shepperd's method)."""
    m = np.asarray(c, dtype=np.float64)
    tr = m[0, 0] + m[1, 1] + m[2, 2]
    if tr > 0:
        s = math.sqrt(tr + 1.0) * 2
        q = [0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s]
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = math.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2]) * 2
        q = [(m[2, 1] - m[1, 2]) / s, 0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s]
    elif m[1, 1] > m[2, 2]:
        s = math.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2]) * 2
        q = [(m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s]
    else:
        s = math.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1]) * 2
        q = [(m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s]
    out = np.array(q)
    out /= np.linalg.norm(out)
    return out if out[0] >= 0 else -out


def euler_to_dcm(roll: float, pitch: float, yaw: float) -> FloatArray:
    """C_b^n = Rz(yaw) · Rx(pitch) · Ry(roll), angles in radians (see module docstring)."""
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cp, -sp], [0.0, sp, cp]])
    ry = np.array([[cr, 0.0, sr], [0.0, 1.0, 0.0], [-sr, 0.0, cr]])
    return rz @ rx @ ry


def dcm_to_euler(c: FloatArray) -> tuple[float, float, float]:
    """(roll, pitch, yaw) in radians from C_b^n; inverse of :func:`euler_to_dcm`.

    Pitch is in [-pi/2, pi/2]; at exactly +-90 deg pitch roll and yaw are not separable and roll is
    reported as 0.
    """
    m = np.asarray(c, dtype=np.float64)
    pitch = math.asin(max(-1.0, min(1.0, m[2, 1])))
    if abs(m[2, 1]) < 1.0 - 1e-12:
        roll = math.atan2(-m[2, 0], m[2, 2])
        yaw = math.atan2(-m[0, 1], m[1, 1])
    else:  # gimbal lock: pitch = +-90 deg
        roll = 0.0
        yaw = math.atan2(m[1, 0], m[0, 0])
    return roll, pitch, yaw


def euler_to_quat(roll: float, pitch: float, yaw: float) -> FloatArray:
    """Quaternion (w, x, y, z) from (roll, pitch, yaw) in radians."""
    return dcm_to_quat(euler_to_dcm(roll, pitch, yaw))


def yaw_to_heading_deg(yaw: float) -> float:
    """ENU yaw (rad, CCW from North) to compass heading in degrees [0, 360), CW from North."""
    return float((-math.degrees(yaw)) % 360.0)


def heading_deg_to_yaw(heading_deg: float) -> float:
    """Compass heading in degrees (CW from North) to ENU yaw in radians, wrapped to (-pi, pi]."""
    return wrap_pi(-math.radians(heading_deg))


def wrap_pi(angle: float) -> float:
    """Wrap an angle in radians to (-pi, pi]."""
    a = math.fmod(angle + math.pi, 2.0 * math.pi)
    if a <= 0.0:
        a += 2.0 * math.pi
    return a - math.pi


def wrap_deg180(angle_deg: float | FloatArray) -> float | FloatArray:
    """Wrap degrees to [-180, 180): the signed difference of two headings."""
    return (np.asarray(angle_deg) + 180.0) % 360.0 - 180.0


def skew(v: FloatArray) -> FloatArray:
    """Cross-product matrix: ``skew(a) @ b == cross(a, b)``."""
    x, y, z = v
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
