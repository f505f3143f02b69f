"""The camera unit (docs/polarimeter.md stages 1 and 7): what turns light into a raw frame.

The lens's geometry (``camera``) and polarization (``lens``), the DoFP sensor (``mosaic``,
``mosaic_kernel``, ``sensor_spec``), the unit's drawn errors (``hardware``), its calibration
(``calibration``) and the bench that measures its lens (``bench``).
"""
