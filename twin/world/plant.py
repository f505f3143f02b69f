"""The plant: MuJoCo rigid-body physics plus Fossen hydrodynamics, buoyancy and current.

One :meth:`Plant.step` is one MuJoCo step. Between ``mj_step1`` (positions, velocities, bias
forces) and the acceleration stage the plant computes the hydrodynamic wrench and applies it
through ``qfrc_applied``; see :meth:`Plant.step` for the order that keeps sensors in time.

Added mass, implicitly. A REMUS's sway/heave added mass (29.4 kg) is about its rigid mass (31.0 kg);
applied as an explicit force from last step's acceleration (as UUV Simulator and MarineGym do) that
is at the stability limit of the explicit scheme. Instead the plant solves for this step's
acceleration with the added mass on the left-hand side:

    (M_RB + M_A) q̈ = f_smooth + f_hydro − M_A c

in generalized coordinates of the free joint (world-frame linear, body-frame angular velocity),
with M_A mapped from the body frame by T = blockdiag(Rᵀ, I) (M_A,gen = Tᵀ M_A T) and c collecting
the velocity-dependent part of the body-frame acceleration (−ω × v and the current's
acceleration). It then applies ``qfrc_applied = f_hydro − M_A,gen q̈ − Tᵀ M_A c``, so that MuJoCo's
own ``M_RB q̈ = f_smooth + qfrc_applied`` reproduces exactly that q̈. This is exact for the free
vehicle; in contact (on the tank floor) the constraint solver sees the rigid mass only.

The world frame is the local-level ENU navigation frame with its origin at the scenario's place;
latitude and longitude of the vehicle follow from its position through the WGS84 radii, and
MuJoCo's gravity is set to the local normal gravity (Somigliana).
"""

from __future__ import annotations

import datetime as dt
import math
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from models import SCENES
from twin.core import earth
from twin.core.frames import F_FROM_B, dcm_to_euler, euler_to_quat, yaw_to_heading_deg
from twin.world import hydrodynamics_kernel
from twin.world.actuators import ACTUATOR_NAMES, ActuatorCommand, CommandLimiter
from twin.world.current import Current
from twin.world.hydrodynamics import Hydrodynamics
from twin.world.truth import Truth
from twin.world.vehicle import REMUS100, VehicleParams

STANDARD_ATMOSPHERE_PA = 101_325.0
VEHICLE_BODY = "auv"


@dataclass(frozen=True, slots=True)
class PlantConfig:
    """What the plant needs to know about the world.

    Attributes:
        scene: A key of :data:`models.SCENES` or a path to a scene XML.
        latitude_deg: Latitude of the world origin.
        longitude_deg: Longitude of the world origin.
        start_utc: UTC at sim time 0 (timezone-aware).
        water_density_kg_m3: Sea-water density.
        seabed_depth_m: Add a seabed plane at this depth (open-sea scene), or None.
        timestep_s: Physics step.
        atmospheric_pressure_pa: Air pressure at the surface.
        buoyancy_ratio: B / W. 1.0 = trimmed neutral in this water (vehicles are ballasted for the
            water they dive in).
        vehicle: Vehicle parameters.
    """

    scene: str = "open_sea"
    latitude_deg: float = 37.54
    longitude_deg: float = 122.06
    start_utc: dt.datetime = dt.datetime(2021, 9, 3, 2, 0, tzinfo=dt.UTC)
    water_density_kg_m3: float = 1025.0
    seabed_depth_m: float | None = None
    timestep_s: float = 0.01
    atmospheric_pressure_pa: float = STANDARD_ATMOSPHERE_PA
    buoyancy_ratio: float = 1.0
    vehicle: VehicleParams = REMUS100


def load_scene_model(scene: str, seabed_depth_m: float | None = None) -> mujoco.MjModel:
    """Compile a scene (a SCENES key or an XML path), optionally with a seabed plane."""
    path = SCENES.get(scene, Path(scene))
    if not Path(path).is_file():
        raise FileNotFoundError(f"scene {scene!r}: no such scene (known: {', '.join(SCENES)})")
    spec = mujoco.MjSpec.from_file(str(path))
    if seabed_depth_m is not None:
        if not (math.isfinite(seabed_depth_m) and seabed_depth_m > 0):
            raise ValueError(f"seabed_depth_m = {seabed_depth_m!r}: must be a finite number > 0")
        spec.worldbody.add_geom(
            name="seabed",
            type=mujoco.mjtGeom.mjGEOM_PLANE,
            size=[0, 0, 0.05],
            pos=[0, 0, -seabed_depth_m],
            rgba=[0.45, 0.4, 0.3, 1],
        )
    return spec.compile()


class Plant:
    """The simulated vehicle in its world. Implements :class:`sensors.base.WorldView`.

    Args:
        config: World and vehicle configuration.
        current: The current field (defaults to none).
    """

    #: Apply the hydrodynamics through :func:`hydrodynamics_kernel.body_wrench` (one compiled
    #: call a step, the same numbers bit for bit); False: the Python reference.
    compiled: bool = True

    def __init__(self, config: PlantConfig, current: Current | None = None):
        if not (-90.0 <= config.latitude_deg <= 90.0):
            raise ValueError(f"latitude_deg = {config.latitude_deg!r}: allowed [-90, 90]")
        if not (0.0 < config.timestep_s <= 0.05):
            raise ValueError(f"timestep_s = {config.timestep_s!r}: allowed (0, 0.05]")
        if config.start_utc.tzinfo is None:
            raise ValueError("start_utc must be timezone-aware (UTC)")
        self.config = config
        self.params = config.vehicle
        self.model = load_scene_model(config.scene, config.seabed_depth_m)
        self.model.opt.timestep = config.timestep_s
        self._lat0 = math.radians(config.latitude_deg)
        self._lon0 = math.radians(config.longitude_deg)
        self._g = earth.normal_gravity(self._lat0, 0.0)
        self.model.opt.gravity[:] = (0.0, 0.0, -self._g)
        self.data = mujoco.MjData(self.model)
        self.current = current or Current("none")
        self.hydro = Hydrodynamics(self.params, config.water_density_kg_m3, self._g)
        self.limiter = CommandLimiter(self.params)

        m = self.model
        self._body = m.body(VEHICLE_BODY).id
        joint = m.body_jntadr[self._body]
        if joint < 0 or m.jnt_type[joint] != mujoco.mjtJoint.mjJNT_FREE:
            raise ValueError(f"body {VEHICLE_BODY!r} must have a free joint")
        self._qpos = m.jnt_qposadr[joint]
        self._dof = m.jnt_dofadr[joint]
        self._act_ids = [m.actuator(n).id for n in ACTUATOR_NAMES]
        self._sensor_slices: dict[str, slice] = {}
        self._site_ids: dict[str, int] = {}
        mass = float(m.body_mass[self._body])
        if not math.isclose(mass, self.params.mass_kg, rel_tol=1e-3):
            raise ValueError(
                f"MJCF mass {mass:.3f} kg differs from VehicleParams.mass_kg "
                f"{self.params.mass_kg:.3f} kg; keep models/auv/auv.xml and twin/vehicle.py in step"
            )
        # Buoyancy at the CB (body origin): B = ratio * W. The displaced volume follows.
        self._buoyancy_n = config.buoyancy_ratio * mass * self._g
        self._radius = self.params.diameter_m / 2
        # Added mass in the body frame b (diagonal in f, permuted by F_FROM_B).
        ma_f = self.params.added_mass_f
        p6 = np.zeros((6, 6))
        p6[:3, :3] = F_FROM_B
        p6[3:, 3:] = F_FROM_B
        self._ma_b_diag = np.diag(p6.T @ np.diag(ma_f) @ p6).copy()
        self._ma_b_tuple = tuple(float(x) for x in self._ma_b_diag)
        self._rhs_b = np.zeros(6)
        self._r_m, self._r_n = earth.principal_radii(self._lat0)
        # (M_RB + M_A)^-1 in body coordinates is constant (tests/test_plant.py checks it).
        mujoco.mj_forward(self.model, self.data)
        self._minv_total_b = np.linalg.inv(self.rigid_mass_matrix_b() + np.diag(self._ma_b_diag))
        # body_wrench's inputs: views of MjData's buffers (kept while the data is this one),
        # the activations' indices, and a still current.
        self._views_of: mujoco.MjData | None = None
        self._views: tuple[np.ndarray, ...] = ()
        self._act_ids_t = tuple(self._act_ids)
        self._still = np.zeros(3)
        self.reset()

    # ---- WorldView ---------------------------------------------------------------------------
    @property
    def t(self) -> float:
        return float(self.data.time)

    @property
    def utc(self) -> dt.datetime:
        return self.config.start_utc + dt.timedelta(seconds=self.t)

    @property
    def latitude_rad(self) -> float:
        # Flat-earth local-level frame: over a trial's few km the radii at the origin suffice.
        return self._lat0 + float(self.data.qpos[self._qpos + 1]) / self._r_m

    @property
    def longitude_rad(self) -> float:
        return self._lon0 + float(self.data.qpos[self._qpos]) / (self._r_n * math.cos(self._lat0))

    @property
    def gravity_mps2(self) -> float:
        return self._g

    @property
    def water_density_kg_m3(self) -> float:
        return self.config.water_density_kg_m3

    @property
    def atmospheric_pressure_pa(self) -> float:
        return self.config.atmospheric_pressure_pa

    @property
    def surface_z_m(self) -> float:
        return 0.0

    def mj_sensor(self, name: str) -> np.ndarray:
        sl = self._sensor_slices.get(name)
        if sl is None:
            s = self.model.sensor(name)
            sl = slice(int(s.adr[0]), int(s.adr[0] + s.dim[0]))
            self._sensor_slices[name] = sl
        return self.data.sensordata[sl]

    def site_pose(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        sid = self._site_ids.get(name)
        if sid is None:
            sid = self._site_ids[name] = self.model.site(name).id
        return self.data.site_xpos[sid], self.data.site_xmat[sid].reshape(3, 3)

    def rigid_mass_matrix_b(self) -> np.ndarray:
        """MuJoCo's free-body mass matrix in body coordinates, T M_gen Tᵀ (constant)."""
        m, d = self.model, self.data
        mfull = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, d, mfull)
        i0 = self._dof
        t_mat = np.eye(6)
        t_mat[:3, :3] = d.xmat[self._body].reshape(3, 3).T
        return t_mat @ mfull[i0 : i0 + 6, i0 : i0 + 6] @ t_mat.T

    # ---- state -------------------------------------------------------------------------------
    def reset(
        self,
        position_n: tuple[float, float, float] = (0.0, 0.0, -10.0),
        rpy_rad: tuple[float, float, float] = (0.0, 0.0, 0.0),
        forward_speed_mps: float = 0.0,
    ) -> None:
        """Place the vehicle: ENU position, (roll, pitch, ENU yaw), speed along the body y axis.

        The propeller starts at the speed that holds ``forward_speed_mps`` so that the vehicle
        starts in trim rather than coasting down.
        """
        mujoco.mj_resetData(self.model, self.data)
        q = euler_to_quat(*rpy_rad)
        self.data.qpos[self._qpos : self._qpos + 3] = position_n
        self.data.qpos[self._qpos + 3 : self._qpos + 7] = q
        c_bn = self._rotation_from_quat(q)
        self.data.qvel[self._dof : self._dof + 3] = c_bn @ np.array([0.0, forward_speed_mps, 0.0])
        rps = self.hydro.rps_for_speed(forward_speed_mps) if forward_speed_mps > 0 else 0.0
        self.data.act[self._act_ids[2]] = rps
        self.data.ctrl[self._act_ids[2]] = rps
        self.limiter.reset((0.0, 0.0, rps))
        mujoco.mj_forward(self.model, self.data)
        self._sync()

    @staticmethod
    def _rotation_from_quat(q: np.ndarray) -> np.ndarray:
        mat = np.zeros(9)
        mujoco.mju_quat2Mat(mat, q)
        return mat.reshape(3, 3)

    def actuator_state(self) -> np.ndarray:
        """True actuator states [rudder rad, stern rad, propeller rev/s] (MuJoCo activations)."""
        return np.array([self.data.act[i] for i in self._act_ids])

    def depth_m(self) -> float:
        return self.surface_z_m - float(self.data.qpos[self._qpos + 2])

    # ---- stepping ----------------------------------------------------------------------------
    def step(self, command: ActuatorCommand) -> None:
        """Advance one physics step under an actuator command.

        Order: ``mj_step2`` integrates from t to t + dt with the wrench computed for the state at
        t; then :meth:`_sync` brings positions, velocities, the hydrodynamic wrench, accelerations
        and every MJCF sensor to t + dt. So after a step ``data.time``, the state, the sensors and
        the site poses all describe the same instant (after a bare ``mj_step`` MuJoCo's sensors
        would still describe the state before integration).
        """
        m, d = self.model, self.data
        dt_s = m.opt.timestep
        limited = self.limiter(command, dt_s)
        for i, aid in enumerate(self._act_ids):
            d.ctrl[aid] = limited[i]
        mujoco.mj_step2(m, d)
        self.current.step(dt_s)
        self._sync()
        if not math.isfinite(d.qpos[self._qpos + 2]) or not math.isfinite(d.qvel[self._dof]):
            raise self.diverged()

    def diverged(self) -> FloatingPointError:
        """The error of a state gone non-finite (``step``'s, and the quiet steps' kernel's)."""
        return FloatingPointError(
            f"physics diverged at t = {self.data.time:.3f} s (non-finite state); "
            "check the scenario's speeds and the time step"
        )

    def _sync(self) -> None:
        """Positions/velocities (``mj_step1``), the wrench, then accelerations and sensors."""
        m, d = self.model, self.data
        mujoco.mj_step1(m, d)
        self._apply_hydrodynamics()
        mujoco.mj_forwardSkip(m, d, mujoco.mjtStage.mjSTAGE_VEL, 0)

    def _apply_hydrodynamics(self) -> None:
        """The hydrodynamic wrench and the added-mass solve, into ``qfrc_applied``.

        Compiled (:func:`twin.world.hydrodynamics_kernel.body_wrench`, one call a step):
        :meth:`_apply_hydrodynamics_reference` bit for bit (``tests/test_plant.py``). A
        :class:`Hydrodynamics` whose wrench is not the built-in one takes the reference.
        """
        if not self.compiled or type(self.hydro).wrench_f is not Hydrodynamics.wrench_f:
            self._apply_hydrodynamics_reference()
            return
        d = self.data
        depth = self.surface_z_m - float(d.qpos[self._qpos + 2])
        cur = self._still if self.current.kind == "none" else self.current.velocity_n(depth)
        if self._views_of is not d:
            i0 = self._dof
            self._views = (
                d.xmat[self._body], d.qvel[i0 : i0 + 6], d.qfrc_passive[i0 : i0 + 6],
                d.qfrc_bias[i0 : i0 + 6], d.qfrc_applied[i0 : i0 + 6],
            )  # fmt: skip
            self._views_of = d
        v = self._views
        hydrodynamics_kernel.body_wrench(
            v[0], v[1], depth, cur, d.act, self._act_ids_t, v[2], v[3],
            self.hydro.kernel_constants, self.hydro._strips, self._ma_b_tuple,
            self._buoyancy_n, self._radius, self._minv_total_b, self._rhs_b, v[4],
        )  # fmt: skip

    def _apply_hydrodynamics_reference(self) -> None:
        # Plain float arithmetic: on 3- and 6-vectors numpy's per-call overhead costs more than
        # the arithmetic, and this runs every physics step.
        d = self.data
        i0 = self._dof
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = d.xmat[self._body].tolist()  # C_b^n
        vx, vy, vz, px, py, pz = d.qvel[i0 : i0 + 6].tolist()
        depth = self.surface_z_m - float(d.qpos[self._qpos + 2])
        if self.current.kind != "none":
            ce, cn, cu = self.current.velocity_n(depth).tolist()
            vx, vy, vz = vx - ce, vy - cn, vz - cu
        # Velocity relative to the water in the body frame: Rᵀ (v − c).
        bx = r00 * vx + r10 * vy + r20 * vz
        by = r01 * vx + r11 * vy + r21 * vz
        bz = r02 * vx + r12 * vy + r22 * vz
        act = d.act
        ids = self._act_ids
        # Fossen f = (b.y, b.x, -b.z) for velocities and rates (frames.F_FROM_B).
        tau = self.hydro.wrench_f((by, bx, -bz, py, px, -pz), act[ids[0]], act[ids[1]], act[ids[2]])
        # Buoyancy at the CB (body origin), reduced smoothly as the hull breaks the surface; its
        # body-frame components are Rᵀ [0, 0, B].
        sub = (depth + self._radius) / (2 * self._radius)
        buoy = self._buoyancy_n * (1.0 if sub >= 1.0 else (0.0 if sub <= 0.0 else sub))
        ma = self._ma_b_tuple
        # Known part of the body-frame wrench (back to b: b = (f.y, f.x, -f.z)), less the
        # added-mass force of the velocity-dependent acceleration −ω × v_r of d/dt(Rᵀ v_r)
        # (the current is constant in n over a step).
        t0 = tau[1] + r20 * buoy + ma[0] * (py * bz - pz * by)
        t1 = tau[0] + r21 * buoy + ma[1] * (pz * bx - px * bz)
        t2 = -tau[2] + r22 * buoy + ma[2] * (px * by - py * bx)
        t3, t4, t5 = tau[4], tau[3], -tau[5]

        # Solve (M_RB + M_A) ν̇ = rhs in the body frame: T = blockdiag(Rᵀ, I) is orthogonal and
        # the body-frame mass matrices are constant, so only the rotations change per step.
        fx, fy, fz, f3, f4, f5 = (d.qfrc_passive[i0 : i0 + 6] - d.qfrc_bias[i0 : i0 + 6]).tolist()
        rhs = self._rhs_b
        rhs[0] = r00 * fx + r10 * fy + r20 * fz + t0
        rhs[1] = r01 * fx + r11 * fy + r21 * fz + t1
        rhs[2] = r02 * fx + r12 * fy + r22 * fz + t2
        rhs[3] = f3 + t3
        rhs[4] = f4 + t4
        rhs[5] = f5 + t5
        a0, a1, a2, a3, a4, a5 = (self._minv_total_b @ rhs).tolist()
        # Applied = known wrench − M_A ν̇, mapped back: linear part by R, angular part as is.
        l0, l1, l2 = t0 - ma[0] * a0, t1 - ma[1] * a1, t2 - ma[2] * a2
        qf = d.qfrc_applied
        qf[i0] = r00 * l0 + r01 * l1 + r02 * l2
        qf[i0 + 1] = r10 * l0 + r11 * l1 + r12 * l2
        qf[i0 + 2] = r20 * l0 + r21 * l1 + r22 * l2
        qf[i0 + 3] = t3 - ma[3] * a3
        qf[i0 + 4] = t4 - ma[4] * a4
        qf[i0 + 5] = t5 - ma[5] * a5

    # ---- truth -------------------------------------------------------------------------------
    def truth(self) -> Truth:
        """A snapshot of the true state (the separate truth channel)."""
        d = self.data
        i0 = self._dof
        q = d.qpos[self._qpos + 3 : self._qpos + 7].copy()
        c_bn = d.xmat[self._body].reshape(3, 3)
        roll, pitch, yaw = dcm_to_euler(c_bn)
        v_n = d.qvel[i0 : i0 + 3].copy()
        depth = self.depth_m()
        c_n = self.current.velocity_n(depth)
        return Truth(
            t=self.t,
            position_n=d.qpos[self._qpos : self._qpos + 3].copy(),
            quat_wxyz=q,
            velocity_n=v_n,
            omega_b=d.qvel[i0 + 3 : i0 + 6].copy(),
            roll_rad=roll,
            pitch_rad=pitch,
            yaw_rad=yaw,
            heading_deg=yaw_to_heading_deg(yaw),
            depth_m=depth,
            latitude_rad=self.latitude_rad,
            longitude_rad=self.longitude_rad,
            current_n=c_n,
            speed_through_water_mps=float(np.linalg.norm(v_n - c_n)),
            actuators=self.actuator_state(),
        )
