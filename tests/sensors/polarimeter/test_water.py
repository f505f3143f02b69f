"""Stage 5, the water column: Jerlov IOPs, Beer–Lambert, single scattering, multiple scattering."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from scipy.integrate import quad

from sensors.polarimeter import stokes as st
from sensors.polarimeter import surface as sf
from sensors.polarimeter import water as wa

N = 1.34


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _dirs(theta_deg: np.ndarray, phi_deg: np.ndarray) -> np.ndarray:
    t, p = np.radians(theta_deg), np.radians(phi_deg)
    return np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=-1)


def _column(water="1C", depth=5.0, sun_el_deg=40.0, sun_az_deg=90.0, e_sky=0.2, **model):
    el, az = math.radians(sun_el_deg), math.radians(sun_az_deg)
    sun = np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
    beam = sf.refract_sun_beam(sun, N)
    w = wa.jerlov_water(water) if isinstance(water, str) else water
    col = wa.WaterColumn(w, N, wa.ScatteringModel(**model))
    state = col.state(depth, beam.look_dir, beam.irradiance_factor, beam.dop, 1.0, e_sky)
    return col, state


# ---- Jerlov water types ---------------------------------------------------------------------


def test_jerlov_table_ordering_and_errors():
    waters = [wa.jerlov_water(t) for t in wa.JERLOV_TYPES]
    kd = [w.kd_per_m for w in waters]
    c = [w.c_per_m for w in waters]
    assert kd == sorted(kd) and len(set(kd)) == len(kd)  # clearer types attenuate less
    assert c == sorted(c)
    t10 = [float(wa.beam_transmittance(1.0, 10.0, w.c_per_m)) for w in waters]
    assert t10 == sorted(t10, reverse=True)
    assert wa.jerlov_water("1c") == wa.jerlov_water("1C")
    assert wa.jerlov_water("II").kd_per_m == 0.070  # Jerlov (1976) Table XXVII, 500 nm
    with pytest.raises(ValueError, match=r"water_type must be one of I, IA, IB, II, III, 1C"):
        wa.jerlov_water("IV")
    with pytest.raises(ValueError, match="turbidity"):
        wa.jerlov_water("I", turbidity=-1.0)
    with pytest.raises(ValueError, match="a_per_m"):
        wa.WaterOptics(a_per_m=0.0, b_per_m=0.1, kd_per_m=0.1)


def test_turbidity_scales_particle_scattering_and_kd():
    base = wa.jerlov_water("3C")
    milky = wa.jerlov_water("3C", turbidity=3.0)
    clear = wa.jerlov_water("3C", turbidity=0.0)
    assert milky.b_particle_per_m == pytest.approx(3.0 * base.b_particle_per_m)
    assert clear.b_per_m == pytest.approx(wa.B_SEAWATER_500NM)
    assert clear.kd_per_m < base.kd_per_m < milky.kd_per_m
    assert milky.a_per_m == base.a_per_m


# ---- attenuation ----------------------------------------------------------------------------


def test_beer_lambert_and_optical_depth():
    cz = np.array([1.0, 0.8, 0.5, 0.1, 0.0, -0.3], dtype=np.float32)
    c, z = 0.4, 7.0
    t = wa.beam_transmittance(cz, z, c)
    assert t.dtype == np.float32
    np.testing.assert_allclose(t[:4], np.exp(-c * z / cz[:4]), rtol=1e-6)
    assert t[4] == 0 and t[5] == 0  # never reaches the surface
    # Beer–Lambert composes over layers.
    np.testing.assert_allclose(
        wa.beam_transmittance(cz[:4], 3.0, c) * wa.beam_transmittance(cz[:4], 4.0, c),
        t[:4],
        rtol=1e-5,
    )
    np.testing.assert_array_equal(wa.beam_transmittance(cz, 0.0, c), cz > 0)
    path = wa.path_length_to_surface(cz, z)
    np.testing.assert_allclose(path[:4], z / cz[:4])
    assert np.isinf(path[4:]).all()
    w = wa.jerlov_water("II")
    taus = [wa.optical_depths(w, d) for d in (0.0, 1.0, 5.0, 20.0)]
    assert taus[0] == (0.0, 0.0)
    assert all(a[0] < b[0] and a[1] < b[1] for a, b in itertools.pairwise(taus))
    assert wa.optical_depths(w, 5.0)[0] == pytest.approx(w.c_per_m * 5.0)
    with pytest.raises(ValueError, match="depth_m"):
        wa.optical_depths(w, -1.0)


# ---- phase functions ------------------------------------------------------------------------


def test_fournier_forand_normalisation_and_backscatter():
    mu = wa.ff_slope_for_backscatter(0.0183)
    assert mu == pytest.approx(3.5835, abs=2e-3)  # Mobley et al. 2002, Petzold's B
    for slope in (mu, 4.0):

        def f(t: float, s: float = slope) -> float:
            return 2 * math.pi * float(wa.fournier_forand(math.cos(t), 1.10, s)) * math.sin(t)

        edges = [1e-4, 1e-3, 1e-2, 0.1, 0.5, math.pi / 2, math.pi]
        parts = [quad(f, a, b, limit=200)[0] for a, b in itertools.pairwise(edges)]
        # ∫ over ψ ≥ 1e-4 rad: 1 minus the (integrable) forward spike below it (≈1.3 % of the
        # mass for Petzold-like μ, ≈0.06 % for μ = 4).
        assert sum(parts) == pytest.approx(1.0, abs=0.015 if slope < 3.9 else 1e-3)
        assert parts[-1] == pytest.approx(wa.ff_backscatter_fraction(1.10, slope), rel=1e-3)
    psi = np.linspace(0.0, math.pi, 1001)
    pm = wa.molecular_phase(np.cos(psi))
    assert float(np.trapezoid(2 * math.pi * pm * np.sin(psi), psi)) == pytest.approx(1, rel=1e-5)
    assert np.all(np.isfinite(wa.fournier_forand(np.cos(psi))))


# ---- Rayleigh polarization ------------------------------------------------------------------


def test_rayleigh_scattering_is_perpendicular_with_the_rayleigh_dop():
    rng = np.random.default_rng(1)
    v = _unit(rng.standard_normal((500, 3)))
    ref = _unit(np.cross(v, rng.standard_normal((500, 3))))  # arbitrary references ⟂ v
    s = _unit(np.array([0.3, -0.2, 0.9]))
    out = wa.rayleigh_stokes(v, ref, s, dop_max=0.8)
    cos_g = v @ s
    _, dop = st.to_aop_dop(out)
    np.testing.assert_allclose(out[:, 0], 1.0)
    np.testing.assert_allclose(dop, 0.8 * (1 - cos_g**2) / (1 + cos_g**2), atol=1e-12)
    e = st.to_evector(out, -v, ref)
    pol = dop > 1e-6
    # E ⟂ the scattering plane (the plane through v and s): E ∥ s × v.
    np.testing.assert_allclose(np.abs(np.sum(e * _unit(np.cross(s, v)), -1))[pol], 1.0, atol=1e-9)
    # 90° scattering: DoP = DoP_max.
    v90 = _unit(np.cross(s, [1.0, 0.0, 0.0]))[None]
    r90 = st.meridian_reference(-v90)
    _, d90 = st.to_aop_dop(wa.rayleigh_stokes(v90, r90, s, dop_max=0.8))
    assert float(d90[0]) == pytest.approx(0.8)


def test_rayleigh_of_a_polarized_beam_is_the_dipole_projection():
    rng = np.random.default_rng(2)
    v = _unit(rng.standard_normal((300, 3)))
    ref = st.meridian_reference(-v)
    s = _unit(np.array([0.1, 0.4, 0.8]))
    e0 = _unit(np.cross(s, [0.0, 0.0, 1.0]))  # an E-vector ⟂ the beam
    out = wa.rayleigh_stokes(v, ref, s, dop_max=1.0, beam_dop=1.0, beam_evec=e0)
    proj = e0 - (v @ e0)[:, None] * v  # E_out ∝ e₀ − (e₀·v) v
    cos_g = v @ s
    np.testing.assert_allclose(out[:, 0], np.sum(proj * proj, -1) * 2 / (1 + cos_g**2), atol=1e-12)
    expected = st.from_evector(np.ones(300), np.ones(300), proj, -v, ref)
    _, dop = st.to_aop_dop(out)
    np.testing.assert_allclose(dop, 1.0, atol=1e-9)
    np.testing.assert_allclose(out[:, 1:] / out[:, :1], expected[:, 1:], atol=1e-9)
    # A half-polarized beam is the average of the two.
    half = wa.rayleigh_stokes(v, ref, s, dop_max=1.0, beam_dop=0.5, beam_evec=e0)
    unpol = wa.rayleigh_stokes(v, ref, s, dop_max=1.0)
    np.testing.assert_allclose(half, 0.5 * (out + unpol), atol=1e-12)


# ---- multiple scattering model --------------------------------------------------------------


def test_depolarization_factor_starts_at_one_and_decreases():
    d = wa.depolarization_factor(np.array([0.0, 0.5, 2.0, 10.0, 100.0, 1e4]))
    assert d[0] == 1.0
    assert np.all(np.diff(d) < 0)
    assert d[-1] == pytest.approx(wa.ScatteringModel().depol_floor)


def test_effective_sun_shift_is_zero_at_the_surface_and_grows_towards_the_zenith():
    theta = math.radians(35.0)
    assert float(wa.effective_sun_zenith_shift(theta, 0.0)) == 0.0
    clean = wa.WaterOptics(a_per_m=0.05, b_per_m=0.0, kd_per_m=0.05)  # no scattering at all
    assert wa.optical_depths(clean, 30.0)[1] == 0.0
    shifts = []
    for t in (0.0, 0.5, 1.0, 4.0):
        w = wa.jerlov_water("1C", turbidity=t) if t else clean
        row = [
            float(wa.effective_sun_zenith_shift(theta, wa.optical_depths(w, z)[1]))
            for z in (0.0, 2.0, 10.0, 30.0)
        ]
        assert row[0] == 0.0
        shifts.append(row)
    shifts = np.array(shifts)
    assert np.all(shifts <= 0.0)  # towards the zenith
    assert np.all(shifts[0] == 0.0)  # no turbidity (b = 0): no shift at any depth
    assert np.all(np.diff(shifts[1:, 1:], axis=0) < 0)  # grows with turbidity
    assert np.all(np.diff(shifts[1:], axis=1) < 0)  # grows with depth
    assert -shifts.min() < theta  # never past the zenith
    # The equivalent sun stays in the solar vertical plane (no azimuth bias by default).
    s = np.array([math.sin(theta), 0.0, math.cos(theta)])
    e = wa.equivalent_sun(s, 5.0)
    assert e[1] == 0.0 and math.acos(e[2]) == pytest.approx(
        theta + float(wa.effective_sun_zenith_shift(theta, 5.0))
    )
    knob = wa.equivalent_sun(s, 5.0, wa.ScatteringModel(azimuth_shift_rad=0.1))
    assert math.atan2(knob[1], knob[0]) > 0


# ---- single scattering ----------------------------------------------------------------------


def test_single_scattering_matches_the_line_of_sight_integral():
    col, state = _column("3C", depth=4.0, sun_el_deg=50.0)
    w = col.water
    c, z = w.c_per_m, state.depth_m
    s = state.sun_look
    mu_s = s[2]
    az = math.degrees(math.atan2(s[1], s[0]))
    thetas = np.array([0.0, 20.0, math.degrees(math.acos(mu_s)), 60.0, 85.0, 90.0, 92.0])
    v = _dirs(thetas, np.full(thetas.shape, az + 100.0))
    got = col.single_scattering_radiance(v, state)
    for vi, g in zip(v, got, strict=False):
        beta = float(col.volume_scattering(vi @ s))
        s_max = z / vi[2] if vi[2] > 1e-9 else np.inf

        def integrand(t: float, vz: float = vi[2]) -> float:
            return math.exp(-c * (z - t * vz) / mu_s - c * t)

        ref = state.e_sun_normal * beta * quad(integrand, 0.0, s_max, limit=200)[0]
        assert g == pytest.approx(ref, rel=1e-4)
    # No sun, no single scattering; a camera at the surface has no water above it.
    night = state._replace(e_sun_normal=0.0)
    assert np.all(col.single_scattering_radiance(v, night) == 0)
    assert np.all(np.isfinite(col.single_scattering_radiance(v, state._replace(depth_m=0.0))))


def test_radiance_stays_on_the_true_sun_while_polarization_follows_the_effective_sun():
    # No skylight: the zenith-centred window term would pull the maximum towards the zenith.
    col, state = _column(
        "5C", depth=12.0, sun_el_deg=40.0, sun_az_deg=90.0, e_sky=0.0, diffuse_dop_scale=1.0
    )
    s, e = state.sun_look, state.sun_eff
    assert math.acos(e[2]) < math.acos(s[2]) - math.radians(5)  # a real shift at τ_b ≈ 15
    # Scattered radiance peaks at the true refracted sun (the intensity-gradient premise).
    th = np.linspace(0.0, 80.0, 161)
    v = _dirs(th, np.full(th.shape, 90.0))  # the solar vertical plane
    out = col.scattered(v, state)
    peak = th[np.argmax(out[:, 0])]
    assert peak == pytest.approx(math.degrees(math.acos(s[2])), abs=0.6)
    # The E-vector is ⟂ the plane through each ray and the *effective* sun.
    rng = np.random.default_rng(3)
    vr = _unit(rng.standard_normal((400, 3)))
    vr[:, 2] = np.abs(vr[:, 2])
    o = col.scattered(vr, state)
    ev = st.to_evector(o, -vr, st.meridian_reference(-vr))
    _, dop = st.to_aop_dop(o)
    ok = dop > 1e-3
    np.testing.assert_allclose(np.abs(np.sum(ev * _unit(np.cross(e, vr)), -1))[ok], 1, atol=1e-4)
    # The DoP is the Rayleigh form about ŝ_eff scaled by DoP_max·D(τ_b).
    cg = vr @ e
    expected = col.model.dop_max * state.depolarization * (1 - cg**2) / (1 + cg**2)
    np.testing.assert_allclose(dop, expected, atol=2e-3)  # beam polarization: a small extra


def test_shallow_clear_water_is_single_scattering_with_the_rayleigh_dop():
    col, state = _column(
        "I",
        depth=1.0,
        sun_el_deg=60.0,
        e_sky=0.0,
        include_beam_polarization=False,
        diffuse_dop_scale=1.0,
    )
    assert state.depolarization == pytest.approx(1.0, abs=1e-3)
    s = state.sun_look
    v = _unit(np.cross(s, [1.0, 0.0, 0.0]))  # 90° from the refracted sun
    v = v if v[2] > 0 else -v
    out = col.render(v[None], state)
    _, dop = st.to_aop_dop(out)
    assert float(dop[0]) == pytest.approx(0.8, abs=1e-3)
    # Looking horizontally (an unbounded line of sight), single scattering is a large share.
    h = np.array([[-s[1], s[0], 0.0]]) / math.hypot(s[0], s[1])  # ⟂ the sun's azimuth: ψ = 90°
    single = col.single_scattering_radiance(h, state)
    assert float(single[0]) > 0.3 * float(col.render(h, state)[0, 0])


# ---- the whole column -----------------------------------------------------------------------


def _awkward_rays() -> np.ndarray:
    th = np.array([0.0, 0.0, 30.0, 48.0, 48.3, 60.0, 89.999, 90.0, 90.001, 92.5, 120.0, 180.0])
    ph = np.array([0.0, 45.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0, 90.0, 0.0])
    v = _dirs(th, ph)
    v[0] = (0.0, 0.0, 1.0)  # exactly straight up
    v[-1] = (0.0, 0.0, -1.0)  # exactly straight down
    return v


@pytest.mark.parametrize(
    ("water", "depth", "el", "e_sky"),
    [
        ("I", 0.0, 40.0, 0.2),
        ("I", 5.0, 80.0, 0.0),
        ("1C", 10.0, 5.0, 0.3),
        ("9C", 30.0, 40.0, 0.2),
        ("5C", 3.0, -10.0, 0.01),  # night: the sun is below the horizon
    ],
)
def test_no_nan_anywhere(water, depth, el, e_sky):
    col, state = _column(water, depth=depth, sun_el_deg=el, e_sky=e_sky)
    for dt in (np.float64, np.float32):
        v = _awkward_rays().astype(dt)
        tr = sf.surface_transmission(v, N)
        window = tr.apply(np.tile([1.0, 0.3, -0.2], (len(v), 1)).astype(dt))
        out = col.render(v, state, window)
        assert out.dtype == dt
        assert np.all(np.isfinite(out)), out
        assert np.all(out[:, 0] >= 0)
        _, dop = st.to_aop_dop(out)
        assert np.all(dop <= 1.0 + 1e-6)


def test_direct_light_and_the_window():
    col, state = _column("II", depth=6.0)
    v = _dirs(np.array([0.0, 30.0, 45.0, 60.0]), np.zeros(4))
    tr = sf.surface_transmission(v, N)
    window = tr.apply(np.tile([1.0, 0.2, 0.1], (4, 1)))
    direct = col.direct(v, window, state)
    t = np.exp(-col.water.c_per_m * 6.0 / v[:, 2])
    np.testing.assert_allclose(direct, window * t[:, None], rtol=1e-12)
    assert np.all(direct[3] == 0)  # outside Snell's window


def test_diffuse_background_grows_outside_the_window_with_depth():
    """Across Snell's window edge (44° in, 53° out, away from the sun) the contrast fades with τ."""
    v = _dirs(np.array([44.0, 53.0]), np.array([-90.0, -90.0]))
    tr = sf.surface_transmission(v, N)
    window = tr.apply(np.tile([0.2 / math.pi, 0.0, 0.0], (2, 1)))  # a uniform sky
    for water in ("II", "3C"):
        ratios = []
        for depth in (0.0, 1.0, 2.0, 4.0, 8.0, 16.0, 30.0):
            col, state = _column(water, depth=depth)
            if depth == 0.0:
                assert state.e_diffuse == 0.0
            tot = col.render(v, state, window)[:, 0]
            ratios.append(tot[1] / tot[0])
        assert np.all(np.diff(ratios) > 0), ratios
        assert ratios[0] < 0.15 and ratios[-1] > 0.45


def test_rotated_frames_and_buffer_reuse_give_the_same_answer():
    col, state = _column("1C", depth=7.0, include_beam_polarization=False, diffuse_dop_scale=1.0)
    c, s_ = math.cos(0.3), math.sin(0.3)
    rot = np.array([[1.0, 0.0, 0.0], [0.0, c, -s_], [0.0, s_, c]])  # C_F^n
    rng = np.random.default_rng(4)
    v_f = _unit(rng.standard_normal((20, 30, 3)))
    v_w = v_f @ rot.T
    win = np.zeros((20, 30, 3))
    a = col.render(v_w, state, win)
    planar = np.ascontiguousarray(np.moveaxis(v_f, -1, 0).astype(np.float32))
    buf = np.empty((3, 20, 30), dtype=np.float32)
    b = col.render(np.moveaxis(planar, 0, -1), state, win, rotation=rot, out=buf)
    assert np.shares_memory(b, buf) and b.shape == (20, 30, 3)
    np.testing.assert_allclose(b, a, rtol=2e-3, atol=1e-6)
    # The fast meridian-frame polarization equals the generic Rayleigh with meridian references.
    pol = wa.rayleigh_stokes(v_w, st.meridian_reference(-v_w), state.sun_eff)
    aop_a, dop_a = st.to_aop_dop(a)
    aop_p, dop_p = st.to_aop_dop(pol)
    ok = dop_p > 1e-6
    diff = np.angle(np.exp(2j * (aop_a - aop_p)))[ok] / 2
    assert np.abs(diff).max() < 1e-9
    np.testing.assert_allclose(dop_a, dop_p * col.model.dop_max * state.depolarization, atol=1e-9)


def test_diffuse_light_is_less_polarized_than_single_scattering():
    v = _dirs(np.array([30.0, 60.0, 89.0]), np.array([0.0, 0.0, 0.0]))
    full = _column("3C", depth=8.0, diffuse_dop_scale=1.0, include_beam_polarization=False)
    half = _column("3C", depth=8.0, diffuse_dop_scale=0.5, include_beam_polarization=False)
    col, state = half
    i_ss = col.single_scattering_radiance(v, state)
    i_d = col.diffuse_radiance(v, state)
    _, dop_full = st.to_aop_dop(full[0].scattered(v, full[1]))
    _, dop_half = st.to_aop_dop(col.scattered(v, state))
    np.testing.assert_allclose(dop_half, dop_full * (i_ss + 0.5 * i_d) / (i_ss + i_d), rtol=1e-5)
