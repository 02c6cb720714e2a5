"""Physics: vessels, Fossen hydrodynamics, propellers, currents, obstacles, the MuJoCo world and step, trials."""
