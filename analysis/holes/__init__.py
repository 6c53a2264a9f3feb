"""Seed 001's holes: the rigid-punch theory, the metrology of simulated holes, the field comparison and the
machine's calibration."""
