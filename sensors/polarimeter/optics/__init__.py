"""The light the camera sees, stage by stage (docs/polarimeter.md stages 2–5).

The sun (``sun``), the sky (``sky``), the sea surface (``surface``: Snell, Fresnel, Cox–Munk waves;
``caustics``, ``bubbles``), the water column (``water``, ``scattering``, ``column_kernel``,
``particles``) and its polarized radiative-transfer reference and tables (``rt``).
"""
