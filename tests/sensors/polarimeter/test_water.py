"""Stage 5, the water column: Jerlov IOPs, Beer–Lambert, single scattering, the whole column."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from scipy.integrate import quad

from sensors.polarimeter import stokes as st
from sensors.polarimeter.optics import surface as sf
from sensors.polarimeter.optics import transmission as transmission_mod
from sensors.polarimeter.optics import water as wa

N = 1.34


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _dirs(theta_deg: np.ndarray, phi_deg: np.ndarray) -> np.ndarray:
    t, p = np.radians(theta_deg), np.radians(phi_deg)
    return np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=-1)


def _column(water="1C", depth=5.0, sun_el_deg=40.0, sun_az_deg=90.0, e_sky=0.2):
    el, az = math.radians(sun_el_deg), math.radians(sun_az_deg)
    sun = np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
    beam = sf.refract_sun_beam(sun, N)
    w = wa.jerlov_water(water) if isinstance(water, str) else water
    col = wa.WaterColumn(w, N)
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


def _single_reference(col, state, v):
    """R(−χ₂) M(Θ) R(χ₁) (1, q_b, 0) from the stokes module's rotations (not the kernel's)."""
    s = state.sun_look
    d0, d = -s, -v
    ct = np.clip(v @ s, -1.0, 1.0)
    e1 = _unit(d - ct[:, None] * d0)
    beam = np.tile([1.0, state.beam_q, 0.0], (len(v), 1))
    in_plane = st.rotate_reference(
        beam, np.broadcast_to(d0, v.shape), st.meridian_reference(np.broadcast_to(d0, v.shape)), e1
    )
    _, m12, m22, m33, _ = col.phase.elements(ct)
    i, q, u = in_plane[:, 0], in_plane[:, 1], in_plane[:, 2]
    out = np.stack([i + m12 * q, m12 * i + m22 * q, m33 * u], axis=-1)
    e2 = ct[:, None] * e1 - np.sqrt(1 - ct**2)[:, None] * d0
    return st.rotate_reference(out, d, e2, st.meridian_reference(d))


def test_single_scattering_polarization_is_the_phase_matrix_in_the_scattering_plane():
    col, state = _column("II", depth=3.0, sun_el_deg=35.0, sun_az_deg=60.0)
    assert state.beam_q > 0.02  # a low sun: a clearly p-polarized beam
    rng = np.random.default_rng(3)
    v = _unit(rng.standard_normal((500, 3)))
    got = col.single_scattering(v, state)
    ref = _single_reference(col, state, v)
    i_ss = col.single_scattering_radiance(v, state)  # the unpolarized-beam magnitude
    # Normalise by the unpolarized magnitude: the kernel's Stokes over L_ss is the matrix product.
    np.testing.assert_allclose(got / i_ss[:, None], ref, atol=2e-3)
    # An unpolarized beam: the E-vector is ⟂ the scattering plane with DoP = −m12(Θ).
    st0 = state._replace(beam_q=0.0)
    out = col.single_scattering(v, st0)
    _, dop = st.to_aop_dop(out)
    _, m12, *_ = col.phase.elements(v @ state.sun_look)
    np.testing.assert_allclose(dop, -m12, atol=1e-3)
    e = st.to_evector(out, -v, st.meridian_reference(-v))
    ok = dop > 1e-2
    n = _unit(np.cross(state.sun_look, v))
    np.testing.assert_allclose(np.abs(np.sum(e * n, -1))[ok], 1.0, atol=1e-3)


def test_shallow_clear_water_is_single_scattering_with_the_molecular_dop():
    col, state = _column("I", depth=1.0, sun_el_deg=60.0, e_sky=0.0)
    s = state.sun_look
    v = _unit(np.cross(s, [1.0, 0.0, 0.0]))  # 90° from the refracted sun
    v = v if v[2] > 0 else -v
    _, dop = st.to_aop_dop(col.single_scattering(v[None], state._replace(beam_q=0.0)))
    # Type I scatters almost only by molecules: DoP(90°) = (1 − δ)/(1 + δ) (0.916 at δ = 0.044).
    d = col.water.depolarization_ratio
    assert float(dop[0]) == pytest.approx((1.0 - d) / (1.0 + d), abs=0.01)
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
        tr = transmission_mod.surface_transmission(v, N)
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
    tr = transmission_mod.surface_transmission(v, N)
    window = tr.apply(np.tile([1.0, 0.2, 0.1], (4, 1)))
    direct = col.direct(v, window, state)
    t = np.exp(-col.water.c_per_m * 6.0 / v[:, 2])
    np.testing.assert_allclose(direct, window * t[:, None], rtol=1e-12)
    assert np.all(direct[3] == 0)  # outside Snell's window


def test_diffuse_background_grows_outside_the_window_with_depth():
    """Across Snell's window edge (44° in, 53° out, away from the sun) the contrast fades with
    depth, then settles: the asymptotic radiance distribution keeps a contrast of its own."""
    v = _dirs(np.array([44.0, 53.0]), np.array([-90.0, -90.0]))
    tr = transmission_mod.surface_transmission(v, N)
    window = tr.apply(np.tile([0.2 / math.pi, 0.0, 0.0], (2, 1)))  # a uniform sky
    for water in ("II", "3C"):
        ratios = []
        depths = (0.0, 1.0, 2.0, 4.0, 8.0, 16.0, 30.0)
        for depth in depths:
            col, state = _column(water, depth=depth)
            tot = col.render(v, state, window)[:, 0]
            ratios.append(tot[1] / tot[0])
        tau = np.array(depths) * wa.jerlov_water(water).c_per_m
        fading = np.diff(np.array(ratios)[tau <= 5.0])
        settled = np.array(ratios)[tau >= 6.0]
        assert np.all(fading > 0), ratios  # the window's edge fades while c z < 5 …
        assert settled.size == 0 or np.ptp(settled) < 0.05, ratios  # … then the shape has settled
        assert ratios[0] < 0.15 and ratios[-1] > 0.45


def test_rotated_frames_and_buffer_reuse_give_the_same_answer():
    col, state = _column("1C", depth=7.0)
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
