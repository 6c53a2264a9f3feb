"""Seed 000: the pepper transplanter's duck-beak planting mechanism, its design and its punch's report."""
