"""The soil beds' calibration on the virtual cone penetrometer (seed 001 Table 2) and its checks."""
