"""Python-level benchmark cases of accelcore: ``python -m benches`` (``make bench``) runs them."""
