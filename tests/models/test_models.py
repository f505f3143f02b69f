"""Menagerie-style model checks: every scene compiles and steps with zero warnings; layout."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from models import AUV_DIR, SCENES
from twin.world.vehicle import REMUS100


@pytest.mark.parametrize("scene", sorted(SCENES))
def test_scene_compiles_and_steps_without_warnings(scene: str) -> None:
    model = mujoco.MjModel.from_xml_path(str(SCENES[scene]))
    data = mujoco.MjData(model)
    # Deterministic pseudo-random controls in each actuator's range (Halton, as menagerie does).
    lo, hi = model.actuator_ctrlrange[:, 0], model.actuator_ctrlrange[:, 1]
    for i in range(int(1.0 / model.opt.timestep)):
        u = np.array([mujoco.mju_Halton(i + 1, b) for b in (2, 3, 5)][: model.nu])
        data.ctrl[:] = lo + u * (hi - lo)
        mujoco.mj_step(model, data)
    warnings = {mujoco.mjtWarning(i).name: int(n) for i, n in enumerate(data.warning.number) if n}
    assert warnings == {}
    assert np.all(np.isfinite(data.qpos))


def test_model_folder_layout() -> None:
    for name in (
        "auv.xml",
        "scene_open_sea.xml",
        "scene_tank.xml",
        "README.md",
        "LICENSE",
        "CHANGELOG.md",
    ):
        assert (AUV_DIR / name).is_file(), name


def test_model_has_the_sites_sensors_and_actuators_the_twin_uses() -> None:
    m = mujoco.MjModel.from_xml_path(str(SCENES["open_sea"]))
    for site in ("polarimeter", "imu", "depth", "rudder", "stern_planes", "thruster"):
        m.site(site)
    for sensor in ("imu/accelerometer", "imu/gyro", "imu/linvel", "depth/position"):
        m.sensor(sensor)
    assert [m.actuator(i).name for i in range(m.nu)] == ["rudder", "stern_planes", "propeller"]
    # Built-in fluid model off: twin.world.hydrodynamics does the hydrodynamics.
    assert m.opt.density == 0 and m.opt.viscosity == 0


def test_polarimeter_looks_along_body_up() -> None:
    m = mujoco.MjModel.from_xml_path(str(SCENES["open_sea"]))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    z_axis = d.site_xmat[m.site("polarimeter").id].reshape(3, 3)[:, 2]
    np.testing.assert_allclose(z_axis, [0, 0, 1], atol=1e-12)


def test_mjcf_mass_and_inertia_match_the_vehicle_parameters() -> None:
    m = mujoco.MjModel.from_xml_path(str(SCENES["open_sea"]))
    body = m.body("auv").id
    assert m.body_mass[body] == pytest.approx(REMUS100.mass_kg, rel=1e-3)
    ix, iy, iz = REMUS100.inertia_f  # Fossen axes: roll about forward, pitch about starboard
    # Body axes x starboard, y forward, z up: (I_pitch, I_roll, I_yaw).
    np.testing.assert_allclose(m.body_inertia[body], [iy, ix, iz], rtol=1e-3)
    np.testing.assert_allclose(m.body_ipos[body], [0, 0, -REMUS100.cg_below_cb_m], atol=1e-12)


@pytest.mark.parametrize("key", ["trimmed", "cruising"])
def test_keyframes_hold_their_state_under_the_twins_physics(key: str) -> None:
    # The plant (MuJoCo + Fossen hydrodynamics) started from the keyframe holds it: it is a trim.
    from twin.core.messages import ActuatorCommand
    from twin.world.plant import Plant, PlantConfig

    plant = Plant(PlantConfig())
    m, d = plant.model, plant.data
    mujoco.mj_resetDataKeyframe(m, d, m.key(key).id)
    act = d.act.copy()
    plant.limiter.reset(tuple(act))
    plant._sync()  # bring the wrench, accelerations and sensors to the keyframe's state
    t0 = plant.truth()
    for _ in range(2000):  # 20 s
        plant.step(ActuatorCommand(*act))
    t1 = plant.truth()
    assert plant.data.warning.number.sum() == 0
    assert t1.depth_m == pytest.approx(10.0, abs=0.05)
    assert t1.speed_through_water_mps == pytest.approx(t0.speed_through_water_mps, abs=0.015)
    assert t1.roll_rad == pytest.approx(t0.roll_rad, abs=np.radians(0.2))
    assert abs(t1.pitch_rad) < np.radians(0.5)


def test_the_lags_that_act_are_the_vehicle_parameters_declared() -> None:
    # MuJoCo integrates the fins' servo and the motor's lag (auv.xml's filterexact dynprm);
    # VehicleParams declares them with their sources: the two must agree (and the travel too).
    model = mujoco.MjModel.from_xml_path(str(AUV_DIR / "auv.xml"))

    def act(name: str) -> int:
        return mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, name)

    for fin in ("rudder", "stern_planes"):
        assert model.actuator_dynprm[act(fin), 0] == pytest.approx(REMUS100.fin_time_constant_s)
        assert model.actuator_ctrlrange[act(fin), 1] == pytest.approx(REMUS100.fin_max_rad, 1e-4)
    prop = act("propeller")
    assert model.actuator_dynprm[prop, 0] == pytest.approx(REMUS100.prop_time_constant_s)
    assert model.actuator_ctrlrange[prop, 1] == pytest.approx(REMUS100.prop_max_rpm / 60, 1e-3)
