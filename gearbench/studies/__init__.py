"""Studies: scripted comparisons of gearbench models with published measurements and results."""
