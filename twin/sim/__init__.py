"""The stepping core and the vehicle's build (between the world and the front doors)."""
