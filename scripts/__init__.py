"""YADE scenes: each is a small assembly of named parts (bed, tool, kinematics, recorder)."""
