"""An example auv-twin sensor plug-in: a USBL acoustic position fix (``usbl_sensor.sensor``)."""
