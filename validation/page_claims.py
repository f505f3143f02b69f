"""The claims of docs/validation.md: what was checked, and where each number is read from.

A claim's ``checked`` text names the reference and its source; numbers measured by the twin
appear only through its body (page_numbers.py), which reads them from a results file (page.py).
Add a claim here after the study that backs it has written its results.
"""

from __future__ import annotations

import page_numbers as n
from page import Claim

CLAIMS = (
    Claim(
        "Top speed at 1525 rpm",
        "The steady speed where the propeller's thrust equals the hull's drag, against REMUS 100's"
        " about 2.5 m/s (Allen et al. 2000).",
        (n.CHECKS,),
        n.measured_lines(
            "- steady speed at 1525 rpm, ρ = 1026 kg/m³: {top_speed_1525rpm_mps:.2f} m/s",
        ),
    ),
    Claim(
        "Roll righting period after a 30° release",
        "The period of the roll oscillation in MuJoCo against the linearised coupled sway–roll "
        "model's eigenvalue (Fossen 2021).",
        (n.CHECKS,),
        n.measured_lines(
            (
                "- measured period {righting_period_s:.3f} s; the linearised model's "
                "{righting_period_model_s:.3f} s"
            ),
        ),
    ),
    Claim(
        "15° rudder turn at 1.5 m/s",
        "The plant in MuJoCo against Fossen's 6-DOF equations integrated with scipy, same wrench, "
        "no MuJoCo.",
        (n.CHECKS,),
        n.measured_lines(
            (
                "- turning radius {turn_1p5mps_radius_m:.2f} m; the independent integration's "
                "{turn_1p5mps_radius_reference_m:.2f} m"
            ),
            (
                "- yaw rate at 2, 5, 10, 60 and 110 s: at most "
                "{turn_1p5mps_yaw_rate_max_rel_diff:pct} from the integration's"
            ),
        ),
    ),
    Claim(
        "15° rudder turn at 1525 rpm (ρ = 1026)",
        "The twin against PythonVehicleSimulator's remus100 (commit c717e07) under the same "
        "inputs; the middle row switches the twin's two modelling departures to PVS's choice "
        "([why](physics.md)).",
        ("validation/results/turning_vs_pvs.json",),
        n.turn_full,
        "With PVS's two choices the twin turns and heels as PVS does; its own two (the "
        "exact cross-flow integral, the whole propeller torque on the hull) turn tighter "
        "and heel more ([physics.md](physics.md)).",
    ),
    Claim(
        "Standing heel from the propeller torque",
        "The straight-running heel against the closed form W z_g sin φ = Q from the propeller "
        "model.",
        (n.CHECKS,),
        n.measured_lines(
            (
                "- 1525 rpm: {heel_1525rpm_deg:.2f}° measured, "
                "{heel_1525rpm_closed_form_deg:.2f}° from W z_g sin φ = Q"
            ),
        ),
    ),
    Claim(
        "Neutral buoyancy, 60 s at rest",
        "A neutrally buoyant vehicle released at 10 m with no command.",
        (n.CHECKS,),
        n.measured_lines(
            (
                "- depth change after 60 s: {rest_60s_depth_change_m:sig} m; horizontal drift "
                "{rest_60s_horizontal_drift_m:sig} m"
            ),
        ),
    ),
    Claim(
        "Passive vehicle in a 0.3 m/s current",
        "A vehicle at rest, beam-on to a 0.3 m/s current, must drift with the water.",
        (n.CHECKS,),
        n.measured_lines(
            (
                "- horizontal velocity after 120 s within {current_drift_velocity_error_mps:sig} "
                "m/s of the current's"
            ),
        ),
    ),
    Claim(
        "IMU white noise and Allan deviation",
        "The lig2024 IMU model's output against its datasheet densities (IEEE-952 read-off).",
        (n.CHECKS,),
        n.measured_lines(
            (
                "- white noise σ against density × √rate, every axis: within "
                "{imu_white_std_vs_spec_max_rel:pct}"
            ),
            (
                "- Allan deviation at τ = 1 s against the ARW and VRW: "
                "{imu_allan_1s_vs_spec_min_abs_rel:pct} to {imu_allan_1s_vs_spec_max_abs_rel:pct}"
                " (300 s at 100 Hz)"
            ),
        ),
    ),
    Claim(
        "Plant real-time factor, 10-minute mission, one core",
        "Wall time of the plant alone and of a full run.",
        ("benchmarks/results/plant_rtf.json",),
        n.plant_rtf,
    ),
    Claim(
        "Snell's window",
        "The half-angle from the Quan–Fry water index against the verified table of optics.md "
        "§2.1 (each within 0.006°, the test's bound).",
        (n.CHECKS,),
        n.snell_window,
    ),
    Claim(
        "Sky polarization",
        "The sky model against the MOI paper's closed forms (eqs. 9–25) and Berry's model against "
        "Rayleigh's in its limit.",
        (n.CHECKS,),
        n.sky,
    ),
    Claim(
        "Raw → Stokes",
        "The DoFP mosaic's Stokes images against polanalyser (a test-only oracle).",
        (n.CHECKS,),
        n.stokes,
    ),
    Claim(
        "AoP noise on a uniform field",
        "The AoP's standard deviation on a uniform polarized field against the shot-noise law "
        "(optics.md §3.3).",
        (n.CHECKS,),
        n.aop_noise,
    ),
    Claim(
        "MOI / PATZ / HT on the MOI paper's frames (Fig. 8)",
        "The three methods on the paper's ideal and noisy frames, 250 of the paper's 2000 trials "
        "per elevation and case; the paper reports MOI's error at 1 % noise as 0.011°.",
        (f"{n.CAMPAIGNS}/moi_noise/report.md",),
        n.moi_noise,
    ),
    Claim(
        "Snell-window attitude across ±50° tilt (noisy camera), 2 m Jerlov II, sun 35°",
        "The paper's Snell-window method as written and the twin's refinement, on the same frames "
        "([why](polarimeter.md)).",
        (
            f"{n.CAMPAIGNS}/snell_attitude/report.md",
            f"{n.CAMPAIGNS}/snell_water/report.md",
            f"{n.CAMPAIGNS}/snell_waves/report.md",
        ),
        n.snell_attitude,
        "The cause, measured by switching it: a low sun's forward-scattering glow crosses"
        " the window's rim once b z > 0.05; in clear water (Jerlov I) and with a high sun"
        " the twin's method holds "
        "([snell_water](../validation/results/campaigns/snell_water/report.md)); waves: "
        "[snell_waves](../validation/results/campaigns/snell_waves/report.md).",
    ),
    Claim(
        "The underwater light field",
        "The polarized Monte Carlo reference, untuned, against Jerlov's K_d, energy conservation"
        " and the renderer ([model](polarimeter.md)).",
        (
            "validation/results/lightfield_reference.md",
            "validation/results/renderer_vs_reference.md",
            "validation/results/fast_path_error.json",
        ),
        n.lightfield,
    ),
    Claim(
        "Every optical input sourced, with its range",
        "Each sourced input (the particles' peak polarization P, the depolarization δ, the CIE sky"
        " type) set to the ends of its range; the largest change it makes to the headline results.",
        ("validation/results/optics_sensitivity.md",),
        n.sensitivity,
    ),
    Claim(
        "Bubbles and caustics under a wind sea",
        "The Hall–Novarini bubble population and the caustic beam against measured seas.",
        ("validation/results/sea_surface_light.md",),
        n.sea_surface,
    ),
    Claim(
        "LIG vs POL under water, Jerlov I → 3C, 1–20 m, sun 20–70°",
        "Both papers' methods as written and as the twin refines them, on the same frames of the "
        "noisy 612×512 camera ([why LIG leans](../validation/results/lig_bias_cause.md)).",
        (f"{n.CAMPAIGNS}/compass_underwater/report.md", "validation/results/lig_bias_cause.md"),
        n.compass_underwater,
        "POL's apparent sun drifts towards the zenith with depth and turbidity; LIG's "
        "leans towards the horizon in shallow or clear water, by the clear sky's "
        "gradation seen through Snell's window, not by radiative transfer ([switched "
        "cause by cause](../validation/results/lig_bias_cause.md)).",
    ),
    Claim(
        "The seeds' hardware experiments",
        "Each paper's experiment under the full hardware budget (bubbles, marine snow and "
        "caustics included), each method as its paper writes it and as the twin refines it; the "
        "paper's numbers beside the twin's, every reason with the switch that shows it in the "
        "report.",
        (n.HW, "validation/results/paper_methods.md"),
        n.hardware,
        "Where the twin and a paper differ by more than a factor of 2, the report gives "
        "the reason with the switch that shows it, or marks it a hypothesis; "
        "[paper_methods](../validation/results/paper_methods.md) switches each departure "
        "from a paper alone.",
    ),
    Claim(
        "Gravity-aided navigation (wang2023)",
        "The paper's two tests with Table 1's Q_t read as printed, on maps drawn with the paper's"
        " 78 mGal range ([why](gravity.md)).",
        ("validation/results/gravity_path_planning.md", "validation/results/gravity_aided_twin.md"),
        n.gravity,
        "SITAN as the paper describes it loses lock on the 5 km maps, so the planned path"
        " is seldom least there; at 10 km it holds and the planned path wins. The "
        "random-walk bound is no bound for a Schuler-correlated INS "
        "([gravity.md](gravity.md)).",
    ),
    Claim(
        "INS vs pyins on a 300 s manoeuvre",
        "The strapdown mechanization against python-ins on the same increments and gravity.",
        (n.CHECKS,),
        n.measured_lines(
            (
                "- after 300 s: position {ins_vs_pyins_300s_position_m:sig2} m, height "
                "{ins_vs_pyins_300s_height_m:sig2} m, velocity "
                "{ins_vs_pyins_300s_velocity_mps:sig2} m/s, attitude "
                "{ins_vs_pyins_300s_attitude_rad:sig2} rad apart"
            ),
        ),
    ),
    Claim(
        "Filter consistency with the paper's IMU",
        "The 15-state filter's attitude NEES at rest with solar and gravity aiding "
        "([navigation.md](navigation.md)).",
        (n.CHECKS,),
        n.measured_lines(
            (
                "- mean attitude NEES (3 dof, after 60 s): {nees_attitude_imu_tuning:.2f} with "
                "the IMU-derived tuning, {nees_attitude_paper_tuning:.0f} with the paper's "
                "printed P0/Q"
            ),
        ),
    ),
    Claim(
        "INS + 15-state filter alone",
        "Wall time of the INS and the filter at 100 Hz.",
        ("benchmarks/results/ins_filter_rtf.json",),
        n.ins_rtf,
    ),
    Claim(
        "Polarimeter frame, one core",
        "The whole frame (light field, lens, sensor) against the baseline commit in the same run.",
        ("benchmarks/results/polarimeter_frame.json",),
        n.frame,
    ),
    Claim(
        "Compass methods, full 2448×2048 frame",
        "Time per frame, one thread, median of 10.",
        ("benchmarks/results/compass_timing.md",),
        n.compass_timing,
    ),
    Claim(
        "10-minute sea trial with the 612×512 camera at 1 Hz, one core",
        "Wall time of the whole trial against its simulated time, the baseline in the same run.",
        ("benchmarks/results/sea_trial_rtf.json",),
        n.sea_trial_rtf,
    ),
    Claim(
        "What one core allows the sea trial: its compiled and C work alone",
        "Every compiled kernel, MuJoCo and OpenCV call of the 10-minute trial timed in one run, "
        "each less its timer's measured cost; the rest is Python and numpy between the calls.",
        ("benchmarks/results/sea_trial_profile.json",),
        n.sea_trial_limit,
    ),
    Claim(
        "Campaign throughput, 2 cores",
        "Runs a minute on the local pool and on Ray with one and two workers.",
        ("benchmarks/results/campaign_throughput.json",),
        n.throughput,
    ),
)
