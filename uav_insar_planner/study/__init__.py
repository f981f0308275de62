"""Studies made of many independent solves (sweeps, two-parameter maps) and where they run."""
