"""What every part shares, without YADE: configs and their checks, files, the disk run's layout and specification, beds' keys."""
