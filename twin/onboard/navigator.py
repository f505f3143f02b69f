"""The vehicle computer's navigation loop: sensor readings in, a filtered estimate out.

One :class:`Navigator` is one filter variant (issue #5): the strapdown INS + 15-state ESKF
(:mod:`twin.onboard.eskf`) fed with the IMU at its rate, gravity-vector updates at
``gravity_rate_hz`` when quasi-static, depth-gauge updates, gravimeter readings matched to a
stored anomaly map when the vehicle has both (:mod:`twin.onboard.gravity.matching`; every variant
alike), and — for a compass variant — the solar
vector of one compass method (:mod:`twin.onboard.compass`) from a polarimeter frame every
``1/compass_rate_hz`` seconds. The compass method gets the attitude hint (roll, pitch) and the
position from *this* variant's own estimate, as on a real vehicle.

Variants run side by side on the same readings (the run loop hands every reading to each), so
their comparison is paired: same IMU noise, same frames, same initial error.

Onboard side: it sees only readings and the vehicle's declared knowledge
(:class:`VehicleKnowledge`); scoring against truth is the world's business
(``twin.scoring.navigation``).
"""

from __future__ import annotations

import dataclasses
import datetime as dt
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from twin.core import earth
from twin.core.calibration import CameraCalibration
from twin.core.ephemeris import sun_direction_enu
from twin.core.extensions import INS_ONLY
from twin.core.messages import Reading
from twin.onboard.aids import NavAid
from twin.onboard.compass import CompassContext, CompassFix, create
from twin.onboard.eskf import Eskf, EskfConfig, NavEstimate, UpdateResult
from twin.onboard.gravity.matching import GravityMatcher, MatchResult, StoredMap
from twin.onboard.imu_batch import ImuBatch, batchable, compiled_path
from twin.onboard.ins import NavState, rotvec_to_dcm

# When an instant is due on the IMU's clock (a gravity update's): MuJoCo's clock, which stamps the
# samples, is a running sum of its time step, off n·dt by about t² · 2e-15 s (steps of 0.01 s:
# 1.2e-9 s behind at 1500 s, 3e-7 ahead at 16 000 s, 1.9e-6 behind at 30 000 s); with 1e-9 s
# an update came a sample late whenever the clock lagged by more. 1 µs holds for about 6 h of
# simulated time (sensors/suite.py counts steps instead) and is far below any IMU's interval.
_DUE_TOL_S = 1e-6


@dataclass(frozen=True, slots=True)
class VehicleKnowledge:
    """What the vehicle is told before a mission (no truth).

    Attributes:
        start_utc: UTC of sim time 0 (the vehicle's clock).
        latitude_deg: Launch latitude (the local-level origin).
        longitude_deg: Launch longitude.
        water_index: Refractive index of the water (from declared salinity, temperature).
        calibration: The polarimeter's calibration; None for a vehicle without one.
        gravity_map: The stored gravity-anomaly map and its declared errors; None for a vehicle
            without one.
        imu: Sensor name of the IMU readings.
        depth: Sensor name of the depth-gauge readings.
        camera: Sensor name of the polarimeter readings.
        gravimeter: Sensor name of the gravimeter readings.
    """

    start_utc: dt.datetime
    latitude_deg: float
    longitude_deg: float
    water_index: float = 1.338
    calibration: CameraCalibration | None = None
    gravity_map: StoredMap | None = None
    imu: str = "imu"
    depth: str = "depth"
    camera: str = "polarimeter"
    gravimeter: str = "gravimeter"


@dataclass(frozen=True, slots=True)
class NavigatorConfig:
    """How a variant runs.

    Attributes:
        compass_rate_hz: Frames processed per second (at most the camera's rate).
        gravity_rate_hz: Gravity-vector updates per second (each uses the mean of the IMU samples
            since the last one).
        gravity_aiding: Use gravity updates.
        depth_aiding: Use depth updates.
        sun_azimuth_only: Fuse only the solar vector's azimuth (``Eskf.update_sun``).
        map_aiding: Fuse gravimeter readings against the stored map (when the vehicle has one:
            :mod:`twin.onboard.gravity.matching`).
        eskf: Filter parameters.
    """

    compass_rate_hz: float = 1.0
    gravity_rate_hz: float = 10.0
    gravity_aiding: bool = True
    depth_aiding: bool = True
    sun_azimuth_only: bool = False
    map_aiding: bool = True
    eskf: EskfConfig = field(default_factory=EskfConfig)

    def __post_init__(self) -> None:
        for name in ("compass_rate_hz", "gravity_rate_hz"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and 0 < v <= 1000):
                raise ValueError(f"NavigatorConfig.{name}: {v!r}; allowed (0, 1000] Hz")


@dataclass(frozen=True, slots=True)
class CompassEvent:
    """One processed frame: the fix and what the filter did with it."""

    t: float
    fix: CompassFix
    update: UpdateResult | None


class Navigator:
    """One filter variant: ``"ins"`` or a compass method name (``"lig"``, ``"pol"``, ...).

    Args:
        variant: ``"ins"`` or a registered compass method.
        knowledge: The vehicle's declared knowledge.
        init: Initial navigation solution (from the launch alignment).
        config: How it runs.
        method_params: The compass method's config fields (the scenario's
            ``[navigation.methods.<variant>]``); empty: its defaults.
        aids: Navigation aids by the name of the sensor whose readings they fuse
            (:mod:`twin.onboard.aids`; the scenario's ``[navigation.aids.<sensor>]``).
    """

    def __init__(
        self,
        variant: str,
        knowledge: VehicleKnowledge,
        init: NavState,
        config: NavigatorConfig | None = None,
        method_params: Mapping[str, Any] | None = None,
        aids: Mapping[str, NavAid] | None = None,
    ):
        self.variant = variant
        self.knowledge = knowledge
        self.config = config or NavigatorConfig()
        params = dict(method_params or {})
        if variant == INS_ONLY and params:
            raise ValueError(f"navigation variant {INS_ONLY!r} has no compass method to configure")
        self.method = None if variant == INS_ONLY else create(variant, **params)
        if self.method is not None and knowledge.calibration is None:
            raise ValueError(
                f"navigation variant {variant!r} needs a polarimeter calibration; the vehicle "
                "has none"
            )
        self._filter = Eskf(self.config.eskf, init)
        # IMU samples received but not yet integrated (imu_batch): integrated, in order, before
        # anything reads or updates the filter (the ``filter`` property), so that every reader
        # sees the state the one-by-one path would have given it.
        self._batch = ImuBatch(self._filter) if compiled_path(self._filter) else None
        self._t_imu = init.t  # the INS's time once the batch is integrated
        self.aids: dict[str, NavAid] = dict(aids or {})
        for sensor in self.aids:
            if sensor in (knowledge.imu, knowledge.depth, knowledge.camera, knowledge.gravimeter):
                raise ValueError(
                    f"navigation aid for {sensor!r}: the filter fuses that sensor itself; an aid "
                    "takes an extra sensor's readings"
                )
        # The k-th gravity update is due at the first IMU sample at or after t0 + k / rate: the
        # instant from k, not a running sum, and due within _DUE_TOL_S (module comment).
        self._gravity_t0, self._gravity_k = init.t, 1
        self._next_gravity_t = init.t + 1.0 / self.config.gravity_rate_hz
        self._next_compass_t = init.t
        self.events: list[CompassEvent] = []
        self.updates: dict[str, int] = {"sun": 0, "sun_rejected": 0, "no_fix": 0, "frames": 0}
        self._rate_b = np.zeros(3)  # the last IMU sample's angular rate (body, rad/s)
        self.matcher: GravityMatcher | None = None
        if knowledge.gravity_map is not None and self.config.map_aiding:
            self.matcher = GravityMatcher(
                knowledge.gravity_map,
                math.radians(knowledge.latitude_deg),
                math.radians(knowledge.longitude_deg),
            )
        r_m, r_n = earth.principal_radii(math.radians(knowledge.latitude_deg))
        self._m_per_rad = (r_m, r_n * math.cos(math.radians(knowledge.latitude_deg)))

    # ---- inputs --------------------------------------------------------------------------------
    @property
    def filter(self) -> Eskf:
        """The variant's filter, every IMU sample and depth reading received so far taken."""
        if self._batch is not None and self._batch.pending:
            self._flush()
        return self._filter

    def _flush(self) -> None:
        if self._batch is not None:
            self._batch.flush()
        self._t_imu = self._filter.t

    def on_reading(self, reading: Reading) -> CompassEvent | None:
        """Consume one reading (in delivery order); the compass event when a frame was used."""
        k = self.knowledge
        if reading.sensor == k.imu:
            self._on_imu(reading)
            return None
        if reading.sensor == k.depth and self.config.depth_aiding:
            depth = float(np.asarray(reading["depth_m"]).reshape(-1)[0])
            if self._batch is not None and self._batch.takes_updates():
                # Queued after the samples kept so far; done, in that order, before anything
                # reads the filter (the ``filter`` property) or with the next gravity update.
                self._batch.add_depth(depth)
            else:
                self.filter.update_depth(depth)
            return None
        f = self.filter
        if reading.sensor == k.gravimeter and self.matcher is not None:
            g = float(np.asarray(reading["gravity_mgal"]).reshape(-1)[0])
            self.matcher.update(f, reading.t, g)
            return None
        aid = self.aids.get(reading.sensor)
        if aid is not None:
            aid.update(self, reading)
            return None
        if reading.sensor == k.camera and self.method is not None:
            if reading.t < self._next_compass_t - 1e-9:
                return None
            self._next_compass_t = reading.t + 1.0 / self.config.compass_rate_hz
            return self._compass(reading)
        return None

    def _keeps_imu(self, sensor: str) -> bool:
        """Whether this navigator's own paths keep ``sensor``'s samples in a batch (the fan-outs').

        A subclass that takes readings its own way is left to :meth:`on_reading`.
        """
        cls = type(self)
        return (
            cls.on_reading is Navigator.on_reading
            and cls._on_imu is Navigator._on_imu
            and self._batch is not None
            and sensor == self.knowledge.imu
        )

    @staticmethod
    def fan_out_imu(navigators: Iterable[Navigator], reading: Reading) -> bool:
        """Give one IMU reading to every navigator's batch at once, when none must act on it.

        The common step of a run (issue #31): every variant only keeps the sample for its next
        batch. That is :meth:`_on_imu`'s own path for a batchable sample that is after each
        INS's time and before each gravity update, taken with one :func:`batchable` check and
        no per-variant dispatch: the same batches, the same state, bit for bit. Returns False,
        having done nothing, when any variant must do more (each then takes the reading
        through :meth:`on_reading`).
        """
        navs = tuple(navigators)
        t = reading.t
        for nav in navs:
            if (
                not nav._keeps_imu(reading.sensor)
                or t <= nav._t_imu
                or (nav.config.gravity_aiding and t >= nav._next_gravity_t - _DUE_TOL_S)
            ):
                return False
        if not batchable(reading):
            return False
        rate = reading.values["angular_rate"]
        for nav in navs:
            nav._batch.add(reading)  # type: ignore[union-attr]  (checked above)
            nav._t_imu = t
            nav._rate_b = rate
        return True

    @staticmethod
    def quiet_imu_steps(navigators: Iterable[Navigator], sensor: str, times: list[float]) -> int:
        """How many of the IMU samples at ``times`` every navigator would only keep.

        :meth:`fan_out_imu`'s conditions, for a block of samples (:meth:`fan_out_imu_block`):
        the built-in navigator with a batch for this IMU, samples after its INS's time, and
        before its next gravity update.
        """
        n = len(times)
        for nav in navigators:
            if not nav._keeps_imu(sensor) or not times or times[0] <= nav._t_imu:
                return 0
            if nav.config.gravity_aiding:
                due = nav._next_gravity_t - _DUE_TOL_S
                while n and times[n - 1] >= due:
                    n -= 1
        return n

    @staticmethod
    def takes_quietly(navigators: Iterable[Navigator], reading: Reading) -> bool:
        """Whether every navigator takes this (non-IMU) reading without a compass event.

        A frame from the compass's camera may make one; a depth, a gravimeter or an aid's
        reading updates the filter and makes none.
        """
        return all(
            type(nav).on_reading is Navigator.on_reading and reading.sensor != nav.knowledge.camera
            for nav in navigators
        )

    @staticmethod
    def fan_out_imu_block(
        navigators: Iterable[Navigator], readings: list[Reading], samples: np.ndarray
    ) -> bool:
        """:meth:`on_reading` of each reading in turn, the IMU's kept as :meth:`fan_out_imu` does.

        For readings :meth:`quiet_imu_steps` and :meth:`takes_quietly` allowed, in delivery
        order; ``samples`` (n, 6) are the IMU readings' [angular_rate, specific_force] in order.
        Each run of IMU samples goes to the batch at once, each other reading through
        :meth:`on_reading`: the same batches, the same state, bit for bit. Returns False, having
        done nothing, when the IMU's readings are not what a batch reads (:func:`batchable`):
        each then takes its own way.
        """
        navs = tuple(navigators)
        if not navs:
            return True
        imu = navs[0].knowledge.imu
        runs: list[tuple[int, int]] = []  # [i, j) of readings that are IMU samples
        i, n = 0, len(readings)
        while i < n:
            j = i
            while j < n and readings[j].sensor == imu:
                j += 1
            if j > i:
                if not batchable(readings[i]):
                    return False
                runs.append((i, j))
            i = j + 1 if j == i else j
        for nav in navs:
            batch = nav._batch
            assert batch is not None
            row, i = 0, 0
            for a, b in runs:
                for r in readings[i:a]:
                    nav.on_reading(r)  # no event: takes_quietly
                m = b - a
                run = readings[a:b]
                batch.add_block(run, [r.t for r in run], samples[row : row + m])
                row += m
                last = readings[b - 1]
                nav._t_imu = last.t
                nav._rate_b = last.values["angular_rate"]
                i = b
            for r in readings[i:]:
                nav.on_reading(r)
        return True

    def _on_imu(self, reading: Reading) -> None:
        """An IMU sample: kept for the next batch (imu_batch), or integrated now when it must be.

        The one-by-one path's decisions, made on the time the INS will have: a sample at or
        before it only anchors the clock (the first, at t = 0); a gravity update is due when it
        reaches its time. Each is checked against the integrated filter before it is acted on,
        so that a skipped non-finite sample changes nothing.
        """
        f = self._filter
        if reading.t <= self._t_imu:
            self._flush()
            if reading.t <= f.t:
                return  # the first sample at t = 0 only anchors the clock
        if self._batch is not None and batchable(reading):
            self._batch.add(reading)
            self._t_imu = reading.t
        else:
            self._flush()
            f.predict_reading(reading)
            self._t_imu = f.t
        self._rate_b = reading["angular_rate"]  # kept as is: converted only when a fix needs it
        if self.config.gravity_aiding and self._t_imu >= self._next_gravity_t - _DUE_TOL_S:
            due = self._next_gravity_t - _DUE_TOL_S
            batch = self._batch
            if batch is not None and batch.takes_updates():
                # The kept samples, the queued depth updates and the gravity update (when the
                # INS's clock reaches its instant) in one compiled call.
                made = batch.flush(gravity_due=due)
                self._t_imu = f.t
            else:
                self._flush()
                made = f.t >= due
                if made:
                    f.update_gravity()
            if made:
                self._gravity_k += 1
                self._next_gravity_t = (
                    self._gravity_t0 + self._gravity_k / self.config.gravity_rate_hz
                )

    def _compass(self, reading: Reading) -> CompassEvent:
        assert self.method is not None and self.knowledge.calibration is not None
        k = self.knowledge
        est = self.filter.estimate()
        utc = k.start_utc + dt.timedelta(seconds=reading.t)
        lat, lon = math.degrees(est.lat_rad), math.degrees(est.lon_rad)
        ctx = CompassContext(
            utc=utc,
            latitude_deg=lat,
            longitude_deg=lon,
            roll_rad=est.roll,
            pitch_rad=max(min(est.pitch, math.pi / 2), -math.pi / 2),
            depth_m=max(est.depth_m, 0.0),
            water_index=k.water_index,
            sun_enu=sun_direction_enu(utc, lat, lon),
        )
        fix = self.method.solve(reading["raw"], k.calibration, ctx)
        self.updates["frames"] += 1
        update = None
        if fix.ok:
            update = self.filter.update_sun(
                self._at_filter_time(fix, reading.t), azimuth_only=self.config.sun_azimuth_only
            )
            self.updates["sun" if update.applied else "sun_rejected"] += 1
        else:
            self.updates["no_fix"] += 1
        event = CompassEvent(reading.t, fix, update)
        self.events.append(event)
        return event

    def _at_filter_time(self, fix: CompassFix, t_stamp: float) -> CompassFix:
        """The fix's body-frame sun turned from its frame's time stamp to the filter's time.

        A frame stamped ``t_stamp`` measured the sun in the body frame of that instant; the filter
        is at ``f.t`` (the last IMU sample). Between the two the body turned by ω·Δt, with ω the
        last gyro sample less the filter's bias estimate (constant over Δt: frames are fused
        within a camera delay of the IMU clock, ≤ 0.1 s, where the rate barely changes). The
        stamp is all the vehicle knows of the frame's time, so a camera clock offset leaves an
        error of ω times the offset (``sensors.polarimeter.unit.hardware``).
        """
        f = self.filter
        lag = f.t - t_stamp
        if abs(lag) < 1e-9 or fix.sun_body is None:
            return fix
        rate = np.asarray(self._rate_b, dtype=np.float64).reshape(3) - np.asarray(
            f.estimate().gyro_bias, dtype=np.float64
        )
        # C_b^n(t + Δt) = C_b^n(t) exp([ω×]Δt): a body vector at t is exp(−[ω×]Δt) of it at t + Δt.
        turn = rotvec_to_dcm(*(-rate * lag))
        cov = fix.covariance_body
        return dataclasses.replace(
            fix,
            sun_body=turn @ np.asarray(fix.sun_body, dtype=np.float64),
            covariance_body=None if cov is None else turn @ np.asarray(cov) @ turn.T,
        )

    # ---- outputs -------------------------------------------------------------------------------
    def estimate(self) -> NavEstimate:
        return self.filter.estimate()

    def nav_state(self) -> NavState:
        """The INS solution now (cheap; no covariance)."""
        return self.filter.nav_state()

    @property
    def metres_per_radian(self) -> tuple[float, float]:
        """(North, East) metres per radian of latitude and longitude at the launch point."""
        return self._m_per_rad

    def local_en(self, est: NavEstimate) -> tuple[float, float]:
        """Estimated (East, North) in metres from the launch point (the local-level frame)."""
        k = self.knowledge
        north = (est.lat_rad - math.radians(k.latitude_deg)) * self._m_per_rad[0]
        east = (est.lon_rad - math.radians(k.longitude_deg)) * self._m_per_rad[1]
        return east, north

    @property
    def map_matches(self) -> list[MatchResult]:
        """Every gravimeter reading's fate (empty without a stored map)."""
        return [] if self.matcher is None else self.matcher.results

    @property
    def rejections(self) -> list:
        return self.filter.rejections
