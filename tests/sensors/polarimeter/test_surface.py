"""Stage 4, the air–water interface: Quan–Fry, Snell, Fresnel Mueller, Cox–Munk waves, ports."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sensors.polarimeter import stokes as st
from sensors.polarimeter.optics import surface as sf
from sensors.polarimeter.optics import transmission as transmission_mod
from sensors.polarimeter.optics import waves as wv
from sensors.polarimeter.unit import port as port_mod


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _random_dirs(rng: np.random.Generator, n: int, zmin: float = -1.0) -> np.ndarray:
    v = _unit(rng.standard_normal((n, 3)))
    v[:, 2] = np.where(v[:, 2] < zmin, -v[:, 2], v[:, 2])
    return _unit(v)


def _rot(axis: str, ang: float) -> np.ndarray:
    c, s = math.cos(ang), math.sin(ang)
    if axis == "x":
        return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


# ---- water index and Snell's window (optics.md §2.1 table) ---------------------------------


@pytest.mark.parametrize(
    ("s", "t", "lam", "n_ref", "theta_c_deg"),
    [
        (0, 20, 589, 1.3330, 48.61),
        (0, 20, 500, 1.3364, 48.44),
        (35, 20, 550, 1.3408, 48.23),
        (35, 20, 500, 1.3430, 48.13),
        (35, 20, 450, 1.3459, 47.99),
    ],
)
@pytest.mark.measures
def test_quan_fry_reproduces_the_verified_table(s, t, lam, n_ref, theta_c_deg, record_property):
    n = sf.water_index(s, t, lam)
    record_property(
        f"snell_half_angle_deg[S={s}, {lam} nm]", math.degrees(sf.snell_window_half_angle(n))
    )
    assert isinstance(n, float)
    assert n == pytest.approx(n_ref, abs=6e-5)
    assert math.degrees(sf.snell_window_half_angle(n)) == pytest.approx(theta_c_deg, abs=0.006)


def test_water_index_vectorises_and_names_bad_parameters():
    n = sf.water_index(np.array([0.0, 35.0]), 20.0, 500.0)
    assert n.shape == (2,) and n[1] > n[0]  # salt raises the index
    for kwargs, name in [
        ({"salinity_psu": 43}, "salinity_psu"),
        ({"salinity_psu": -1}, "salinity_psu"),
        ({"temperature_c": 41}, "temperature_c"),
        ({"temperature_c": -2.5}, "temperature_c"),
        ({"wavelength_nm": 349}, "wavelength_nm"),
        ({"wavelength_nm": 801}, "wavelength_nm"),
        ({"wavelength_nm": float("nan")}, "wavelength_nm"),
    ]:
        with pytest.raises(ValueError, match=name):
            sf.water_index(**kwargs)
    with pytest.raises(ValueError, match="n must"):
        sf.snell_window_half_angle(0.9)


# ---- Fresnel (optics.md §2.2 table, n = 1.34) ----------------------------------------------

FRESNEL_TABLE = [
    # θ_i, θ_t, T_s, T_p, T, DoLP from unpolarized, n²T
    (0.0, 0.0, 0.979, 0.979, 0.979, 0.0, 1.758),
    (30.0, 21.9, 0.968, 0.988, 0.978, 0.010, 1.756),
    (60.0, 40.3, 0.882, 0.996, 0.939, 0.060, 1.686),
    (80.0, 47.3, 0.539, 0.761, 0.650, 0.171, 1.167),
    (85.0, 48.0, 0.323, 0.506, 0.415, 0.221, 0.745),
    (89.9, 48.3, 0.008, 0.014, 0.011, 0.283, 0.020),
]


@pytest.mark.parametrize(("ti", "tt", "ts", "tp", "t", "dolp", "n2t"), FRESNEL_TABLE)
def test_fresnel_transmission_reproduces_the_verified_table(ti, tt, ts, tp, t, dolp, n2t):
    m = sf.fresnel_transmission_mueller(math.radians(ti), 1.34, factor="flux")
    assert m[0, 0] - m[0, 1] == pytest.approx(ts, abs=6e-4)  # T_s
    assert m[0, 0] + m[0, 1] == pytest.approx(tp, abs=6e-4)  # T_p
    assert m[0, 0] == pytest.approx(t, abs=6e-4)
    assert m[0, 1] / m[0, 0] == pytest.approx(dolp, abs=6e-4)  # unpolarized in → p-polarized
    assert m[1, 1] == m[0, 0] and m[1, 0] == m[0, 1] and m[0, 2] == 0 and m[2, 0] == 0
    assert m[2, 2] == pytest.approx(math.sqrt(ts * tp), abs=2e-3)
    mr = sf.fresnel_transmission_mueller(math.radians(ti), 1.34)  # radiance: n² law
    assert mr[0, 0] == pytest.approx(n2t, abs=6e-4)
    e = sf.fresnel_elements(math.cos(math.radians(ti)), 1.0, 1.34)
    assert math.degrees(math.acos(float(e.cos_t))) == pytest.approx(tt, abs=0.06)


def test_fresnel_factors_and_total_internal_reflection():
    e0 = sf.fresnel_elements(1.0, 1.0, 1.34, "none")  # amplitudes: t_s = t_p = 2/(1 + n)
    assert float(e0.m00) == pytest.approx((2 / 2.34) ** 2)
    # The n² law: at normal incidence, L/n² is conserved apart from the Fresnel loss.
    n = 1.34
    t0 = 4 * n / (1 + n) ** 2
    rad = sf.fresnel_elements(1.0, 1.0, n, "radiance")
    assert float(rad.m00) / n**2 == pytest.approx(t0, rel=1e-12)
    # Water → air beyond the critical angle: nothing transmitted, no NaN.
    cos_i = np.cos(np.radians([0.0, 48.0, 49.0, 80.0, 90.0]))
    e = sf.fresnel_elements(cos_i, n, 1.0, "radiance")
    assert e.transmitted.tolist() == [True, True, False, False, False]
    assert np.all(np.isfinite(e.m00)) and np.all(e.m00[2:] == 0) and np.all(e.m22[2:] == 0)
    with pytest.raises(ValueError, match="factor"):
        sf.fresnel_elements(0.5, 1.0, n, "bogus")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="theta_i"):
        sf.fresnel_transmission_mueller(2.0, n)


def test_fully_polarized_light_turns_by_ts_over_tp():
    """tan ψ' = (t_s/t_p) tan ψ, ψ from the p-axis, for any input reference."""
    n = 1.34
    rng = np.random.default_rng(1)
    for theta_i in np.radians([10.0, 45.0, 70.0, 85.0]):
        phi = rng.uniform(-math.pi, math.pi)
        a = np.array([math.sin(theta_i) * math.cos(phi), math.sin(theta_i) * math.sin(phi)])
        sky = np.array([a[0], a[1], math.cos(theta_i)])
        d = -sky
        # an arbitrary reference ⟂ d
        ref = _unit(np.cross(d, rng.standard_normal(3)))
        s_ax = _unit(np.cross([0.0, 0.0, 1.0], d))
        p_ax = np.cross(s_ax, d)
        for psi in np.radians([5.0, 30.0, 60.0, -40.0]):
            e_vec = math.cos(psi) * p_ax + math.sin(psi) * np.cross(d, p_ax)
            stokes_in = st.from_evector(np.array(1.0), np.array(1.0), e_vec, d, ref)
            out = sf.transmit_stokes(stokes_in, ref, d, [0.0, 0.0, 1.0], 1.0, n)
            aop, dop = st.to_aop_dop(out.stokes)
            assert float(dop) == pytest.approx(1.0, abs=1e-9)
            ef = sf.fresnel_elements(math.cos(theta_i), 1.0, n, "none")
            tp_ts = (float(ef.m00) + float(ef.m01), float(ef.m00) - float(ef.m01))  # t_p², t_s²
            expected = math.atan(math.sqrt(tp_ts[1] / tp_ts[0]) * math.tan(psi))
            assert float(aop) == pytest.approx(expected, abs=1e-9)
            # The output reference is the transmitted ray's p-axis: in the vertical plane.
            assert float(np.dot(out.ref, np.cross(out.d, [0.0, 0.0, 1.0]))) == pytest.approx(0.0)


def test_transmission_does_not_depend_on_the_input_reference():
    n = 1.34
    rng = np.random.default_rng(2)
    sky = _random_dirs(rng, 50, zmin=0.05)
    d = -sky
    ref1 = st.meridian_reference(d)
    ref2 = _unit(np.cross(d, rng.standard_normal((50, 3))))
    s1 = np.stack([np.ones(50), rng.uniform(-0.5, 0.5, 50), rng.uniform(-0.5, 0.5, 50)], -1)
    s2 = st.rotate_reference(s1, d, ref1, ref2)
    up = [0.0, 0.0, 1.0]
    o1 = sf.transmit_stokes(s1, ref1, d, up, 1.0, n)
    o2 = sf.transmit_stokes(s2, ref2, d, up, 1.0, n)
    np.testing.assert_allclose(o1.stokes, o2.stokes, atol=1e-12)
    assert o1.transmitted.all()


# ---- Snell refraction -----------------------------------------------------------------------


def test_flat_snell_round_trip_window_and_masks():
    n = 1.34
    rng = np.random.default_rng(3)
    sky = _random_dirs(rng, 2000, zmin=0.0)
    w = sf.water_directions_from_sky(sky, n)
    assert w.transmitted.all()
    theta_w = np.arccos(w.directions[:, 2])
    assert theta_w.max() <= sf.snell_window_half_angle(n) + 1e-12
    # azimuth kept, Snell's law holds
    np.testing.assert_allclose(
        np.sin(np.arccos(sky[:, 2])), n * np.sin(theta_w), rtol=1e-9, atol=1e-12
    )
    back = sf.sky_directions_from_water(w.directions, n)
    assert back.transmitted.all()
    np.testing.assert_allclose(back.directions, sky, atol=1e-9)
    # In-water rays outside the window: TIR, mirrored, masked; below the horizon: unchanged.
    look = _unit(np.array([[0.8, 0.0, 0.6], [0.0, 1.0, 0.0], [0.3, 0.3, -0.9], [0, 0, 1.0]]))
    r = sf.sky_directions_from_water(look, n)
    assert r.transmitted.tolist() == [False, False, False, True]
    np.testing.assert_allclose(r.directions[0], look[0] * [1, 1, -1])
    np.testing.assert_allclose(r.directions[2], look[2])
    np.testing.assert_allclose(r.directions[3], [0, 0, 1])
    assert np.all(np.isfinite(r.directions)) and np.all(np.isfinite(r.cos_t))


def test_tilted_facets_refract_like_a_rotated_flat_surface():
    """A facet tilted by R gives R applied to the flat-surface answer in the rotated frame."""
    n = 1.34
    rng = np.random.default_rng(4)
    rot = _rot("x", 0.3) @ _rot("y", -0.2)
    normal = rot @ [0.0, 0.0, 1.0]
    look_local = _random_dirs(rng, 500, zmin=0.0)
    look = look_local @ rot.T
    tilted = sf.sky_directions_from_water(look, n, np.broadcast_to(normal, look.shape))
    flat = sf.sky_directions_from_water(look_local, n)
    ok = flat.transmitted & ((flat.directions @ rot.T)[:, 2] > 0)
    np.testing.assert_array_equal(tilted.transmitted, ok)
    np.testing.assert_allclose(tilted.directions[ok], flat.directions[ok] @ rot.T, atol=1e-9)
    fwd = sf.water_directions_from_sky(tilted.directions[ok], n, normal)
    np.testing.assert_allclose(fwd.directions, look[ok], atol=1e-9)


# ---- per-frame surface transmission ---------------------------------------------------------


def _planar(dirs: np.ndarray) -> np.ndarray:
    return np.moveaxis(np.ascontiguousarray(np.moveaxis(dirs, -1, 0)), 0, -1)


def test_flat_surface_transmission_matches_the_general_path():
    n = 1.34
    rng = np.random.default_rng(5)
    look = _random_dirs(rng, 3000)
    tr = transmission_mod.surface_transmission(look, n)
    theta_c = sf.snell_window_half_angle(n)
    np.testing.assert_array_equal(tr.sees_sky, look[:, 2] > math.cos(theta_c))
    sky_dirs = tr.sky_directions()
    sky = np.stack([np.ones(3000), rng.uniform(-0.4, 0.4, 3000), rng.uniform(-0.4, 0.4, 3000)], -1)
    mer = st.meridian_reference(-sky_dirs)
    fast = tr.apply(sky)
    general = tr.apply_with_reference(sky, mer)
    back = st.rotate_reference(general.stokes, general.d, general.ref, st.meridian_reference(-look))
    np.testing.assert_allclose(fast, back, atol=1e-12)
    assert np.all(fast[~tr.sees_sky] == 0)
    # The zenith ray: radiance/n² conserved apart from the normal-incidence Fresnel loss.
    z = transmission_mod.surface_transmission(np.array([[0.0, 0.0, 1.0]]), n)
    out = z.apply(np.array([[2.0, 0.0, 0.0]]))
    assert out[0, 0] / n**2 == pytest.approx(2.0 * 4 * n / (1 + n) ** 2, rel=1e-12)


def test_surface_transmission_in_a_rotated_frame_and_float32():
    n = 1.34
    rng = np.random.default_rng(6)
    c = _rot("x", 0.25) @ _rot("y", 0.4)  # C_F^n: camera tilted
    look_f = _random_dirs(rng, 4000).reshape(40, 100, 3)
    look_w = look_f @ c.T
    a = transmission_mod.surface_transmission(look_w, n)
    b = transmission_mod.surface_transmission(_planar(look_f.astype(np.float32)), n, rotation=c)
    assert b.m00.dtype == np.float32 and b.m00.shape == (40, 100)
    # float32 near the window edge, where c_a = √(1 − n² sin²θ_w) is steep: ~1e-5.
    np.testing.assert_allclose(b.storage, a.storage, atol=5e-5)
    np.testing.assert_allclose(b.sky_directions() @ c.T, a.sky_directions(), atol=5e-4)
    again = transmission_mod.surface_transmission(
        _planar(look_f.astype(np.float32)), n, rotation=c, out=b
    )
    assert again.storage is b.storage
    with pytest.raises(ValueError, match="rotation"):
        transmission_mod.surface_transmission(look_f, n, rotation=np.ones((3, 3)))


def test_wavy_transmission_agrees_with_the_general_path_and_moves_the_window_edge():
    n = 1.34
    rng = np.random.default_rng(7)
    look = _random_dirs(rng, 2000, zmin=0.0)
    normals = wv.slopes_to_normals(rng.normal(0.0, 0.15, (2000, 2)))
    tr = transmission_mod.surface_transmission(look, n, normals=normals)
    sky = np.stack([np.ones(2000), rng.uniform(-0.4, 0.4, 2000), rng.uniform(-0.4, 0.4, 2000)], -1)
    sd = tr.sky_directions()
    fast = tr.apply(sky)
    gen = tr.apply_with_reference(sky, st.meridian_reference(-sd))
    back = st.rotate_reference(gen.stokes, gen.d, gen.ref, st.meridian_reference(-look))
    np.testing.assert_allclose(fast, back, atol=1e-10)
    assert np.all(np.isfinite(fast))
    # Facets let some rays beyond θ_c see the sky and hide some inside it.
    outside = look[:, 2] < math.cos(sf.snell_window_half_angle(n))
    assert tr.sees_sky[outside].any() and not tr.sees_sky[~outside].all()


# ---- the sun beam ---------------------------------------------------------------------------


def test_refracted_sun_beam():
    n = 1.34
    high = sf.refract_sun_beam([0.0, 0.0, 1.0], n)
    assert high.irradiance_factor == pytest.approx(4 * n / (1 + n) ** 2) and high.dop == 0
    el = math.radians(30.0)  # θ_a = 60°
    b = sf.refract_sun_beam([0.0, math.cos(el), math.sin(el)], n)
    assert b.transmitted and b.dop == pytest.approx(0.060, abs=6e-4)
    theta_w = math.acos(b.look_dir[2])
    assert math.sin(theta_w) * n == pytest.approx(math.sin(math.radians(60.0)))
    assert b.irradiance_factor == pytest.approx(0.939 * 0.5 / math.cos(theta_w), abs=1e-3)
    night = sf.refract_sun_beam([0.0, 1.0, -0.1], n)
    assert not night.transmitted and night.irradiance_factor == 0.0


# ---- waves ----------------------------------------------------------------------------------


def test_cox_munk_variances_and_density():
    var_c, var_u = wv.cox_munk_variances(10.0)
    assert (var_c, var_u) == pytest.approx((0.003 + 1.92e-3 * 10.0, 3.16e-3 * 10.0))
    # ... whose sum is within 1 % of Cox & Munk's separate isotropic fit.
    assert var_c + var_u == pytest.approx(0.003 + 5.12e-3 * 10.0, rel=0.01)
    assert wv.cox_munk_variances(10.0, slick=True) == pytest.approx((0.0114, 0.0128))
    assert wv.cox_munk_variances(0.0) == (0.0, 0.0)  # glassy sea
    with pytest.raises(ValueError, match="wind_speed_mps"):
        wv.cox_munk_variances(-1.0)
    # The Gram–Charlier density integrates to 1 and its Gaussian part has the σ².
    g = np.linspace(-1.2, 1.2, 801)
    zx, zy = np.meshgrid(g, g, indexing="ij")
    p = wv.cox_munk_pdf(zx, zy, 8.0)
    da = (g[1] - g[0]) ** 2
    assert float(p.sum() * da) == pytest.approx(1.0, abs=2e-3)
    var_c, var_u = wv.cox_munk_variances(8.0)
    assert float((p * zx * zx).sum() * da) == pytest.approx(var_c, rel=0.02)
    assert float((p * zy * zy).sum() * da) == pytest.approx(var_u, rel=0.02)


def test_wave_field_statistics_seed_and_time_correlation():
    sea = wv.WindSea(wind_speed_mps=7.0, wind_dir_rad=0.6, correlation_time_s=0.5)
    var_c, var_u = sea.slope_variances
    # Slope variances along the wind axes match Cox–Munk, over independent frames.
    ws = wv.WaveSurface(sea, np.random.default_rng(8))
    u_hat = np.array([math.cos(0.6), math.sin(0.6)])
    c_hat = np.array([-math.sin(0.6), math.cos(0.6)])
    zu, zc = [], []
    for _ in range(24):
        ws.step(50.0)  # ≫ τ: independent
        zu.append(ws.slopes @ u_hat)
        zc.append(ws.slopes @ c_hat)
    assert np.var(np.array(zu)) == pytest.approx(var_u, rel=0.05)
    assert np.var(np.array(zc)) == pytest.approx(var_c, rel=0.05)
    # Same seed ⇒ same field, step for step.
    a = wv.WaveSurface(sea, np.random.default_rng(9))
    b = wv.WaveSurface(sea, np.random.default_rng(9))
    a.step(0.1)
    b.step(0.1)
    np.testing.assert_array_equal(a.slopes, b.slopes)
    # Lag-Δt correlation = exp(−Δt/τ).
    dt = 0.2
    prev, corr = a.slopes.copy(), []
    for _ in range(30):
        a.step(dt)
        corr.append(np.corrcoef(prev.ravel(), a.slopes.ravel())[0, 1])
        prev = a.slopes.copy()
    assert np.mean(corr) == pytest.approx(math.exp(-dt / 0.5), abs=0.03)


def test_calm_sea_is_exactly_flat_and_waves_distort_the_window():
    look = _random_dirs(np.random.default_rng(10), 500, zmin=0.0)
    calm = wv.WaveSurface(wv.WindSea(wind_speed_mps=0.0), np.random.default_rng(11))
    assert np.all(calm.slopes == 0.0)
    nrm = calm.normals_for_rays(look, (3.0, -2.0), 5.0)
    np.testing.assert_array_equal(nrm, np.broadcast_to([0.0, 0.0, 1.0], look.shape))
    flat = transmission_mod.surface_transmission(look, 1.34)
    calm_tr = transmission_mod.surface_transmission(look, 1.34, normals=nrm)
    np.testing.assert_allclose(calm_tr.storage, flat.storage, atol=1e-12)
    windy = wv.WaveSurface(wv.WindSea(wind_speed_mps=10.0), np.random.default_rng(11))
    nw = windy.normals_for_rays(look, (0.0, 0.0), 5.0)
    assert np.all(np.isfinite(nw)) and np.allclose(np.linalg.norm(nw, axis=-1), 1.0)
    tilt = np.degrees(np.arccos(nw[:, 2]))
    assert 1.0 < tilt.mean() < 20.0
    with pytest.raises(ValueError, match="cell_m"):
        wv.WindSea(wind_speed_mps=5.0, cell_m=1.0)


# ---- flat port ------------------------------------------------------------------------------


def test_flat_port_round_trip_and_double_fresnel():
    n_w, n_g = 1.34, 1.49
    rng = np.random.default_rng(12)
    axis = np.array([0.0, 0.0, 1.0])
    inside = _random_dirs(rng, 1000, zmin=0.0)
    out = port_mod.flat_port_from_camera(inside, axis, n_w, n_g)
    assert out.valid.all()
    theta_w = np.arccos(out.directions[:, 2])
    assert theta_w.max() < sf.snell_window_half_angle(n_w)
    back = port_mod.flat_port_from_water(out.directions, axis, n_w, n_g)
    assert back.valid.all()
    np.testing.assert_allclose(back.directions, inside, atol=1e-9)
    np.testing.assert_allclose(back.m00, out.m00, rtol=1e-9)
    # The two interfaces' product, from the camera module's (n_i, n_t, cos_i, cos_t) chain.
    cos_w = out.directions[:, 2]
    cos_g = np.sqrt(1 - (n_w / n_g) ** 2 * (1 - cos_w**2))
    m00, m01, m22 = port_mod.interface_chain_elements(
        ((n_w, n_g, cos_w, cos_g), (n_g, 1.0, cos_g, inside[:, 2]))
    )
    np.testing.assert_allclose(m00, out.m00, rtol=1e-9)
    np.testing.assert_allclose(m01, out.m01, rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(m22, out.m22, rtol=1e-9)
    # Radiance law overall: L_air = L_water / n_w² × T at normal incidence.
    t_total = (4 * n_w * n_g / (n_w + n_g) ** 2) * (4 * n_g / (1 + n_g) ** 2)
    z = port_mod.flat_port_from_camera(np.array([[0.0, 0.0, 1.0]]), axis, n_w, n_g)
    assert float(z.m00[0]) == pytest.approx(t_total / n_w**2)
    # Beyond the port's window the water is not seen; behind the port nothing is.
    bad = port_mod.flat_port_from_water(_unit(np.array([[0.9, 0.0, 0.3], [0, 0, -1.0]])), axis, n_w)
    assert not bad.valid.any() and np.all(bad.m00 == 0)
