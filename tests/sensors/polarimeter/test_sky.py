from __future__ import annotations

import math

import numpy as np
import pytest

from sensors.polarimeter import stokes
from sensors.polarimeter.optics.berry import berry_neutral_points
from sensors.polarimeter.optics.cie import CIE_SKY_TYPES, cie_relative_radiance
from sensors.polarimeter.optics.sky import SkySpec, photon_radiance, sky_radiance
from sensors.polarimeter.optics.sun import direction_from_zenith_azimuth
from sensors.polarimeter.unit.camera import SENSOR_PROPAGATION, SENSOR_REFERENCE, Camera
from sensors.polarimeter.unit.fisheye import preset
from twin.core.frames import euler_to_dcm

NO_DISC = {"sun_relative_radiance": 0.0}


def _sun(zenith_deg: float, azimuth_deg: float) -> np.ndarray:
    return direction_from_zenith_azimuth(math.radians(zenith_deg), math.radians(azimuth_deg))


def _hemisphere(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    p = rng.normal(size=(n, 3))
    p[:, 2] = np.abs(p[:, 2])
    return p / np.linalg.norm(p, axis=1, keepdims=True)


def _wrap_half_pi(a: np.ndarray) -> np.ndarray:
    """Angles of lines (mod π) to [−π/2, π/2)."""
    return (a + np.pi / 2) % np.pi - np.pi / 2


# --- the MOI paper's in-air simulation system (its §3, eqs. 9–23, Table 1) ----------------------


def _moi_attitude(yaw: float, pitch: float, roll: float) -> np.ndarray:
    """C_b^g of the MOI paper's eq. 17 (φ yaw, α pitch, β roll)."""
    p, a, b = yaw, pitch, roll
    sp, cp, sa, ca, sb, cb = (
        math.sin(p),
        math.cos(p),
        math.sin(a),
        math.cos(a),
        math.sin(b),
        math.cos(b),
    )
    return np.array(
        [
            [cb * cp + sb * sa * sp, ca * sp, sb * cp - cb * sa * sp],
            [-cb * sp + sb * sa * cp, ca * cp, -sb * sp - cb * sa * cp],
            [-sb * ca, sa, cb * ca],
        ]
    )


def _moi_closed_form(
    m_x: np.ndarray, m_y: np.ndarray, c_bg: np.ndarray, theta_s: float, phi_s: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The paper's hypothetical imager, in its own notation: (DOP, AOP, γ_P) per pixel.

    Table 1: D = 3.45 µm, η_x = 2048, η_y = 2448 (η_x along x = the columns, eq. 16), f = 8 mm,
    DOP_max = 1. φ are compass azimuths (eq. 19: arctan(V_g1 / V_g2), quadrant-resolved).
    """
    d_x = d_y = 3.45e-3
    eta_x, eta_y, f = 2048, 2448, 8.0
    v_b = np.stack(  # eq. 16
        [d_x * (m_x - (eta_x + 1) / 2), d_y * (-m_y + (eta_y + 1) / 2), np.zeros(m_x.shape)], -1
    )
    v_g = (v_b + f * np.array([0.0, 0.0, 1.0])) @ c_bg.T  # eq. 18
    phi_p = np.arctan2(v_g[..., 0], v_g[..., 1])  # eq. 19
    theta_p = np.arccos(v_g[..., 2] / np.linalg.norm(v_g, axis=-1))  # eq. 20
    cos_g = np.cos(theta_p) * math.cos(theta_s) + np.sin(theta_p) * math.sin(theta_s) * np.cos(
        phi_s - phi_p
    )  # eq. 21
    gamma = np.arccos(np.clip(cos_g, -1, 1))
    dop = np.sin(gamma) ** 2 / (1 + np.cos(gamma) ** 2)  # eq. 9, DOP_max = 1
    sg = np.sin(gamma)
    e_g = np.stack(  # eq. 15
        [
            (math.cos(phi_s) * np.cos(theta_p) * math.sin(theta_s)
             - np.cos(phi_p) * np.sin(theta_p) * math.cos(theta_s)) / sg,
            (-math.sin(phi_s) * np.cos(theta_p) * math.sin(theta_s)
             + np.sin(phi_p) * np.sin(theta_p) * math.cos(theta_s)) / sg,
            np.sin(phi_s - phi_p) * math.sin(theta_s) * np.sin(theta_p) / sg,
        ],
        -1,
    )  # fmt: skip
    e_b = e_g @ c_bg  # eq. 22: C_g^b E_g = (C_b^g)^T E_g
    with np.errstate(divide="ignore", invalid="ignore"):
        aop = np.arctan(e_b[..., 0] / e_b[..., 1])  # eq. 23: reference y_b, towards x_b
    return dop, aop, gamma


@pytest.mark.parametrize(
    ("sun_elev_deg", "sun_az_deg", "yaw_deg", "pitch_deg", "roll_deg"),
    [
        (30.0, 120.0, 0.0, 0.0, 0.0),
        (10.0, 250.0, 25.0, 0.0, 0.0),
        (50.0, 35.0, -140.0, 0.0, 0.0),
        (70.0, 300.0, 60.0, 0.0, 0.0),  # sun inside the 34.5° field of view
        (0.0, 80.0, 10.0, 0.0, 0.0),
        (40.0, 200.0, 30.0, 8.0, -5.0),  # tilted: eq. 17 in full
    ],
)
@pytest.mark.measures
def test_rayleigh_matches_moi_closed_forms(
    sun_elev_deg: float,
    sun_az_deg: float,
    yaw_deg: float,
    pitch_deg: float,
    roll_deg: float,
    record_property,
) -> None:
    cam = Camera(preset("moi_pinhole"), dtype=np.float64)
    m_y, m_x = np.meshgrid(
        np.r_[1:2449:19, 2448], np.r_[1:2049:17, 2048], indexing="ij"
    )  # 1-based rows and columns, a sub-sample including all four edges
    c_bg = _moi_attitude(*(math.radians(v) for v in (yaw_deg, pitch_deg, roll_deg)))
    np.testing.assert_allclose(c_bg @ c_bg.T, np.eye(3), atol=1e-15)
    theta_s, phi_s = math.radians(90.0 - sun_elev_deg), math.radians(sun_az_deg)
    dop_ref, aop_ref, gamma = _moi_closed_form(m_x, m_y, c_bg, theta_s, phi_s)

    # The chain: camera rays → sky (world) → lens mapping onto the sensor → eq. 23 on the image.
    rays, valid = cam.pixel_to_ray(m_x - 1, m_y - 1)
    assert valid.all()
    sky = sky_radiance(
        rays,
        direction_from_zenith_azimuth(theta_s, phi_s),
        SkySpec(cie_type=5, dop_max=1.0, **NO_DISC),
        rotation=c_bg,
    )
    s_sensor = cam.to_sensor_stokes(sky.stokes, sky.reference(), rays=rays)
    _, dop = stokes.to_aop_dop(s_sensor)
    e_img = stokes.to_evector(s_sensor, SENSOR_PROPAGATION, SENSOR_REFERENCE)
    with np.errstate(divide="ignore", invalid="ignore"):
        aop = np.arctan(e_img[..., 0] / e_img[..., 1])

    ok = gamma > 1e-3  # the AoP is undefined at the sun itself
    record_property("sky_rayleigh_vs_moi_dop_max_abs", float(np.abs(dop - dop_ref).max()))
    record_property(
        "sky_rayleigh_vs_moi_aop_max_abs_rad", float(np.abs(_wrap_half_pi(aop - aop_ref)[ok]).max())
    )
    np.testing.assert_allclose(dop, dop_ref, atol=1e-9)
    assert ok.mean() > 0.99
    assert np.abs(_wrap_half_pi(aop - aop_ref)[ok]).max() < 1e-6


# --- Rayleigh and Berry -------------------------------------------------------------------------


@pytest.mark.parametrize("sun", [(40.0, 70.0), (0.0, 0.0), (85.0, 200.0), (90.5, 10.0)])
def test_rayleigh_fast_path_equals_stokes_module(sun: tuple[float, float]) -> None:
    s = _sun(*sun)
    p = np.vstack(
        [
            _hemisphere(3000),
            [[0, 0, 1.0]],
            [[1e-7, 0, 1]],
            [[1, 0, 0]],
            [s if s[2] >= 0 else s * 0 + [0, 0, 1]],
        ]
    )
    p /= np.linalg.norm(p, axis=1, keepdims=True)
    sky = sky_radiance(p, s, SkySpec(cie_type=12, dop_max=0.8, **NO_DISC))
    d = -p
    ref = sky.reference()
    c = p @ s
    oracle = stokes.from_evector(
        sky.stokes[:, 0], 0.8 * (1 - c**2) / (1 + c**2), np.cross(s, p), d, ref
    )
    np.testing.assert_allclose(sky.stokes, oracle, atol=1e-12)
    # The reference is the meridian of stokes.py, North at the exact zenith.
    rho = np.hypot(p[:, 0], p[:, 1])
    # (stokes.meridian_reference loses digits within ~1e-6 rad of the zenith; ours does not.)
    far = rho > 1e-6
    np.testing.assert_allclose(ref[far], stokes.meridian_reference(d[far]), atol=1e-9)
    assert np.all(ref[rho == 0] == [0.0, 1.0, 0.0])
    np.testing.assert_allclose(np.sum(ref * p, axis=1), 0.0, atol=1e-15)
    aop, dop = sky.aop_dop()
    assert np.isfinite(aop).all() and (dop <= 0.8 + 1e-12).all()


@pytest.mark.parametrize("sun", [(40.0, 70.0), (0.0, 0.0), (65.0, -100.0), (90.5, 10.0)])
@pytest.mark.measures
def test_berry_with_zero_delta_is_rayleigh(sun: tuple[float, float], record_property) -> None:
    s = _sun(*sun)
    p = np.vstack([_hemisphere(3000, seed=3), [[0, 0, 1.0]], [[0, 1, 0.0]]])
    common = {"cie_type": 7, "dop_max": 0.9, **NO_DISC}
    ray = sky_radiance(p, s, SkySpec(polarization="rayleigh", **common))
    berry = sky_radiance(p, s, SkySpec(polarization="berry", berry_delta_rad=0.0, **common))
    record_property(
        "sky_berry0_vs_rayleigh_max_abs", float(np.abs(berry.stokes - ray.stokes).max())
    )
    np.testing.assert_allclose(berry.stokes, ray.stokes, atol=1e-9 * common["dop_max"])


def test_berry_neutral_points() -> None:
    delta = math.radians(30.0)
    spec = SkySpec(cie_type=5, dop_max=1.0, polarization="berry", berry_delta_rad=delta, **NO_DISC)
    # High sun: Babinet (θ_s − δ/2) and Brewster (θ_s + δ/2) both in the sky.
    s = _sun(40.0, 70.0)
    pts = berry_neutral_points(s, delta)
    assert math.degrees(math.acos(pts.babinet[2])) == pytest.approx(25.0)
    assert math.degrees(math.acos(pts.brewster[2])) == pytest.approx(55.0)
    _, dop = sky_radiance(np.stack([pts.babinet, pts.brewster]), s, spec).aop_dop()
    assert dop.max() < 1e-9
    # Low sun: Brewster below the horizon, Arago (its antipode) above the anti-sun.
    s = _sun(80.0, 30.0)
    pts = berry_neutral_points(s, delta)
    assert pts.brewster[2] < 0 < pts.arago[2] and pts.fourth[2] < 0
    _, dop = sky_radiance(np.stack([pts.babinet, pts.arago]), s, spec).aop_dop()
    assert dop.max() < 1e-9
    # Along the solar meridian the DoP minima sit exactly there (a fine scan through zenith).
    t = np.radians(np.linspace(-89.0, 89.0, 17801))  # signed zenith angle, + = sun side
    phi_s = math.atan2(s[1], s[0])
    mer = np.stack([np.sin(t) * math.cos(phi_s), np.sin(t) * math.sin(phi_s), np.cos(t)], -1)
    _, dop = sky_radiance(mer, s, spec).aop_dop()
    i_bab = np.argmin(np.where(t > 0, dop, 1))
    i_ara = np.argmin(np.where(t < 0, dop, 1))
    assert math.degrees(t[i_bab]) == pytest.approx(80.0 - 15.0, abs=0.011)
    assert math.degrees(t[i_ara]) == pytest.approx(-(180.0 - 80.0 - 15.0), abs=0.011)


def test_berry_neutral_point_index_and_zenith_dop() -> None:
    delta = math.radians(30.0)
    spec = SkySpec(cie_type=5, dop_max=1.0, polarization="berry", berry_delta_rad=delta, **NO_DISC)
    s = _sun(40.0, 70.0)
    bab = berry_neutral_points(s, delta).babinet
    # Walk a small loop around the Babinet point: the E-vector turns by ±π (index ½, Berry 2004).
    e1 = np.cross(bab, [0.0, 0.0, 1.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(bab, e1)
    a = np.linspace(0, 2 * np.pi, 721)
    loop = bab + 0.02 * (np.cos(a)[:, None] * e1 + np.sin(a)[:, None] * e2)
    loop /= np.linalg.norm(loop, axis=1, keepdims=True)
    sky = sky_radiance(loop, s, spec)
    # Express the AoP against a smooth reference field (e1 projected), so only the E-vector turns.
    ref = e1 - np.sum(e1 * -loop, axis=1, keepdims=True) * -loop
    ref /= np.linalg.norm(ref, axis=1, keepdims=True)
    st = stokes.rotate_reference(sky.stokes, -loop, sky.reference(), ref)
    turn = np.sum(_wrap_half_pi(np.diff(0.5 * np.arctan2(st[:, 2], st[:, 1]))))
    assert abs(turn) == pytest.approx(math.pi, abs=1e-6)
    # Zenith DoP for a sun at 50°: 0.415 → 0.408 / 0.386 / 0.351 for δ = 0/10/20/30° (optics.md).
    expected = {0.0: 0.415, 10.0: 0.408, 20.0: 0.386, 30.0: 0.351}
    for delta_deg, dop_z in expected.items():
        sp = SkySpec(
            cie_type=5, dop_max=1.0, polarization="berry", berry_delta_rad=math.radians(delta_deg)
        )
        _, dop = sky_radiance(np.array([[0.0, 0.0, 1.0]]), _sun(50.0, 17.0), sp).aop_dop()
        assert dop[0] == pytest.approx(dop_z, abs=1e-3)


@pytest.mark.parametrize("polarization", ["rayleigh", "berry"])
def test_symmetry_about_the_solar_meridian(polarization: str) -> None:
    s = _sun(55.0, 140.0)
    p = _hemisphere(2000, seed=5)
    n = np.cross([0.0, 0.0, 1.0], s)
    n /= np.linalg.norm(n)  # normal of the solar vertical plane
    mirror = p - 2 * (p @ n)[:, None] * n
    spec = SkySpec(cie_type=13, polarization=polarization, **NO_DISC)
    a = sky_radiance(p, s, spec).stokes
    b = sky_radiance(mirror, s, spec).stokes
    scale = spec.zenith_radiance
    np.testing.assert_allclose(b[:, 0], a[:, 0], atol=1e-12 * scale, rtol=1e-12)
    np.testing.assert_allclose(b[:, 1], a[:, 1], atol=1e-12 * scale)
    np.testing.assert_allclose(b[:, 2], -a[:, 2], atol=1e-12 * scale)  # a mirror flips the AoP


# --- CIE radiance -------------------------------------------------------------------------------


@pytest.mark.parametrize("cie_type", sorted(CIE_SKY_TYPES))
def test_cie_zenith_is_the_zenith_radiance(cie_type: int) -> None:
    for sun in ((0.0, 0.0), (30.0, 10.0), (60.0, 200.0), (85.0, 300.0)):
        spec = SkySpec(cie_type=cie_type, zenith_radiance=0.07, **NO_DISC)
        sky = sky_radiance(np.array([[0.0, 0.0, 1.0]]), _sun(*sun), spec)
        assert sky.stokes[0, 0] == pytest.approx(0.07, rel=1e-12)
        rel = cie_relative_radiance(np.array([0.0, 0.0, 1.0]), _sun(*sun), cie_type)
        assert rel == pytest.approx(1.0, rel=1e-12)


def test_cie_formula_by_hand() -> None:
    # Type 12, sun at Z_s = 30°, point at Z = 60° and 90° of azimuth from the sun.
    a, b, c, d, e = -1.0, -0.32, 10.0, -3.0, 0.45
    zs, z = math.radians(30), math.radians(60)
    chi = math.acos(math.cos(z) * math.cos(zs))

    def f(x: float) -> float:
        return 1 + c * (math.exp(d * x) - math.exp(d * math.pi / 2)) + e * math.cos(x) ** 2

    def phi(x: float) -> float:
        return 1 + a * math.exp(b / math.cos(x))

    expected = f(chi) * phi(z) / (f(zs) * phi(0.0))
    s = _sun(30.0, 0.0)  # sun due North
    p = direction_from_zenith_azimuth(z, math.radians(90.0))  # due East
    sky = sky_radiance(p[None], s, SkySpec(cie_type=12, zenith_radiance=1.0, **NO_DISC))
    assert sky.stokes[0, 0] == pytest.approx(expected, rel=1e-12)


def test_cie_overcast_gradation_and_azimuthal_uniformity() -> None:
    z = np.radians(np.linspace(0.0, 89.9, 200))
    az = np.radians(np.linspace(0.0, 360.0, 13))
    zz, aa = np.meshgrid(z, az)
    p = direction_from_zenith_azimuth(zz, aa)
    sky = sky_radiance(p, _sun(35.0, 80.0), SkySpec(cie_type=1, zenith_radiance=1.0))
    rad = sky.stokes[..., 0]
    np.testing.assert_allclose(rad, rad[0][None, :].repeat(len(az), 0), rtol=1e-12)  # no azimuth
    grad = (1 + 4 * np.exp(-0.7 / np.cos(z))) / (1 + 4 * math.exp(-0.7))
    np.testing.assert_allclose(rad[0], grad, rtol=1e-12)
    # ≈ the Moon–Spencer overcast sky L/L_z = (1 + 2 cos Z)/3 it stands for: within 4% up to
    # Z = 60°, and 1/3 at the horizon (it is darker in between, by up to 20% near Z = 80°).
    upper = z <= math.radians(60)
    np.testing.assert_allclose(rad[0][upper], ((1 + 2 * np.cos(z)) / 3)[upper], rtol=0.04)
    assert rad[0, -1] == pytest.approx(1 / 3, rel=0.01)
    assert SkySpec(cie_type=1).sun_disc_radiance == 0.0  # overcast: the sun is hidden


def test_clear_sky_is_brightest_around_the_sun() -> None:
    s = _sun(45.0, 0.0)
    p = _hemisphere(20000, seed=2)
    rad = sky_radiance(p, s, SkySpec(cie_type=12, **NO_DISC)).stokes[:, 0]
    cos_g = p @ s
    assert rad[cos_g > math.cos(math.radians(10))].min() > rad[cos_g < 0].max()


# --- sun disc, night, horizon, dtypes, frames ---------------------------------------------------


def test_sharp_sun_disc() -> None:
    s = _sun(40.0, 100.0)
    spec = SkySpec(cie_type=12, zenith_radiance=0.05, sun_relative_radiance=4e5)
    axis = np.cross(s, [0.0, 0.0, 1.0])
    axis /= np.linalg.norm(axis)

    def off(deg: float) -> np.ndarray:
        t = math.radians(deg)
        return math.cos(t) * s + math.sin(t) * axis

    p = np.stack([s, off(0.2), off(0.3), off(5.0)])
    with_disc = sky_radiance(p, s, spec).stokes[:, 0]
    without = sky_radiance(p, s, SkySpec(cie_type=12, zenith_radiance=0.05, **NO_DISC)).stokes
    np.testing.assert_allclose(with_disc - without[:, 0], [2e4, 2e4, 0.0, 0.0], rtol=1e-6)
    # The disc is unpolarized: Q, U unchanged.
    np.testing.assert_allclose(sky_radiance(p, s, spec).stokes[:, 1:], without[:, 1:])


def test_antialiased_sun_disc_keeps_its_energy() -> None:
    # Binned pixels (0.44°) are larger than the disc (0.27° radius): a sharp disc may fall between
    # pixel centres; seen through a Gaussian PSF of σ = 0.6 √Ω it keeps Σ L Ω = L_sun π r².
    cam = Camera(preset("phx050s_fe185", binning=4), dtype=np.float64)
    spec = SkySpec(cie_type=12, zenith_radiance=1.0, sun_relative_radiance=1e6)
    sigma = 0.6 * np.sqrt(cam.pixel_solid_angle_sr)
    rng = np.random.default_rng(7)
    energies = []
    for _ in range(6):
        s = _sun(rng.uniform(5, 60), rng.uniform(0, 360))
        with_disc = sky_radiance(cam.rays, s, spec, psf_sigma_rad=sigma).stokes[..., 0]
        base = sky_radiance(cam.rays, s, SkySpec(cie_type=12, zenith_radiance=1.0, **NO_DISC))
        disc = (with_disc - base.stokes[..., 0])[cam.valid]
        energies.append(np.sum(disc * cam.pixel_solid_angle_sr[cam.valid]))
    expected = 1e6 * math.pi * spec.sun_radius_rad**2
    np.testing.assert_allclose(energies, expected, rtol=0.01)


def test_each_samples_value_does_not_depend_on_the_others_evaluated_with_it() -> None:
    # The disc's tail is cut at 7 of each sample's own σ, not of the widest σ in its block: the
    # renderer evaluates the sky at the rays inside Snell's window only, and the blocks of
    # 16 384 samples fall elsewhere then.
    rng = np.random.default_rng(11)
    s = _sun(35.0, 120.0)
    near = s + rng.normal(scale=0.02, size=(40_000, 3))  # around the sun: the disc's candidates
    p = np.vstack([near / np.linalg.norm(near, axis=1, keepdims=True), _hemisphere(3000, 2)])
    p = p.astype(np.float32)
    sigma = rng.uniform(1e-4, 8e-3, len(p))  # a 100× spread of PSF widths
    # A disc 1e12 times the sky: the dropped tail (< 2.3e-11 of it) would show in float32.
    spec = SkySpec(cie_type=12, sun_relative_radiance=1e12)
    whole = sky_radiance(p, s, spec, psf_sigma_rad=sigma).stokes
    # A part without the widest PSFs: a block's widest σ no longer reaches as far.
    sel = np.flatnonzero((sigma < 4e-3) & (rng.random(len(p)) < 0.5))
    part = sky_radiance(p[sel], s, spec, psf_sigma_rad=sigma[sel]).stokes
    np.testing.assert_array_equal(part, whole[sel])
    no_disc = sky_radiance(p[:40_000], s, SkySpec(cie_type=12, **NO_DISC)).stokes[:, 0]
    lit = whole[:40_000, 0] > no_disc
    assert 100 < lit.sum() < 40_000  # the disc lies among the samples, and not everywhere


def test_night_sky_is_dark_and_valid() -> None:
    p = np.vstack([_hemisphere(500), [[0, 0, 1.0]], [[1, 0, 0.0]], [[0, 0.6, -0.8]]])
    s = _sun(95.0, 300.0)  # 5° below the horizon
    sky = sky_radiance(p, s, SkySpec())
    assert sky.night and np.all(sky.stokes == 0.0)
    aop, dop = sky.aop_dop()
    assert np.isfinite(aop).all() and np.all(dop == 0)
    lit = sky_radiance(p, s, SkySpec(night_radiance=1e-6)).stokes
    np.testing.assert_allclose(lit[:-1, 0], 1e-6)
    assert lit[-1, 0] == 0.0 and np.all(lit[:, 1:] == 0.0)


def test_sun_at_the_horizon_and_directions_below_it() -> None:
    p = np.vstack([_hemisphere(500), [[1, 0, 0.0]], [[0, 1, 0.0]], [[0.6, 0, -0.8]]])
    for zen in (89.9, 90.0, 90.5):  # the last: set, but the upper limb still shows (not night)
        for pol in ("rayleigh", "berry"):
            for dtype in (np.float64, np.float32):
                sky = sky_radiance(p.astype(dtype), _sun(zen, 45.0), SkySpec(polarization=pol))
                assert not sky.night
                assert np.isfinite(sky.stokes).all()
                assert np.all(sky.stokes[-1] == 0)  # below the horizon
                assert np.all(sky.stokes[:-1, 0] > 0)


@pytest.mark.parametrize("polarization", ["rayleigh", "berry"])
def test_float32_matches_float64(polarization: str) -> None:
    cam = Camera(preset("phx050s_fe185", binning=4), dtype=np.float64)
    s = _sun(35.0, 200.0)
    r = euler_to_dcm(0.1, -0.2, 0.4)
    spec = SkySpec(cie_type=12, polarization=polarization)
    ref = sky_radiance(cam.rays, s, spec, rotation=r).stokes
    f32 = sky_radiance(cam.rays.astype(np.float32), s, spec, rotation=r).stokes
    assert f32.dtype == np.float32
    big = ref[..., 0] < 100 * spec.zenith_radiance  # away from the disc's edge pixels
    err = np.abs(f32 - ref)[big]
    # float32 arccos near the sun limits the circumsolar CIE term to ~4e-5.
    assert err.max() < 1e-4 * ref[..., 0][big].max()


def test_rotation_argument_equals_world_directions() -> None:
    cam = Camera(preset("phx050s_fe185", binning=4), dtype=np.float64)
    r = euler_to_dcm(0.3, 0.2, -1.1)
    s = _sun(25.0, 10.0)
    a = sky_radiance(cam.rays, s, rotation=r)
    b = sky_radiance(cam.rotated_rays(r), s)
    np.testing.assert_allclose(a.stokes, b.stokes, atol=1e-12)
    # The reference comes back in each call's own frame.
    np.testing.assert_allclose(a.reference() @ r.T, b.reference(), atol=1e-12)


def test_photon_radiance() -> None:
    # 1 W at 550 nm is 550e-9 / (h c) = 2.769e18 photons per second.
    assert float(photon_radiance(1.0, 550.0)) == pytest.approx(2.7688e18, rel=1e-4)


@pytest.mark.parametrize(
    ("overrides", "field"),
    [
        ({"cie_type": 16}, "cie_type"),
        ({"cie_type": True}, "cie_type"),
        ({"polarization": "mie"}, "polarization"),
        ({"dop_max": 1.5}, "dop_max"),
        ({"dop_max": float("nan")}, "dop_max"),
        ({"berry_delta_rad": -0.1}, "berry_delta_rad"),
        ({"zenith_radiance": -1.0}, "zenith_radiance"),
        ({"sun_radius_rad": 0.5}, "sun_radius_rad"),
        ({"sun_relative_radiance": float("inf")}, "sun_relative_radiance"),
        ({"night_radiance": -1e-9}, "night_radiance"),
    ],
)
def test_spec_validation(overrides: dict, field: str) -> None:
    with pytest.raises(ValueError, match=field):
        SkySpec(**overrides)


def test_input_validation() -> None:
    p = _hemisphere(10)
    with pytest.raises(ValueError, match="unit vector"):
        sky_radiance(p, np.array([0.0, 0.0, 2.0]))
    with pytest.raises(ValueError, match="finite"):
        sky_radiance(p, np.array([0.0, np.nan, 1.0]))
    with pytest.raises(ValueError, match="shape"):
        sky_radiance(p[:, :2], _sun(10, 10))
    with pytest.raises(ValueError, match="rotation"):
        sky_radiance(p, _sun(10, 10), rotation=np.ones((3, 3)))
    with pytest.raises(ValueError, match="psf_sigma_rad"):
        sky_radiance(p, _sun(10, 10), psf_sigma_rad=-1.0)


def test_output_buffer_is_reused() -> None:
    cam = Camera(preset("phx050s_fe185", binning=4))
    buf = np.full((3, *cam.shape), np.nan, dtype=np.float32)
    a = sky_radiance(cam.rays, _sun(30.0, 40.0), out=buf)
    assert np.shares_memory(a.stokes, buf) and np.isfinite(buf).all()
    np.testing.assert_array_equal(a.stokes, sky_radiance(cam.rays, _sun(30.0, 40.0)).stokes)
    night = sky_radiance(cam.rays, _sun(100.0, 40.0), out=buf)
    assert np.all(night.stokes == 0)
    with pytest.raises(ValueError, match="out"):
        sky_radiance(cam.rays, _sun(30.0, 40.0), out=np.empty((3, 10), np.float32))
