"""Studies made of many independent solves (sweeps, two-parameter maps, the band over the
bound's minimisers) and where they run."""
