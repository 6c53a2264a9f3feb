"""Analysis side of the hole-forming study: theory, metrology, reports. Never imports YADE."""
