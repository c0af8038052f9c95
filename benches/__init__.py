"""Python-level benchmark cases of accelcore, run by ``accelcore bench``."""
