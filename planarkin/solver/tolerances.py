"""Tolerances that the solver and the checks before it share (a leaf: it imports nothing)."""

NODE_TOL = 1e-12      # Newton tolerance at internal nodes (internal units)
ASSEMBLED = 1e-10     # largest |Phi| (internal units) of an assembled pose
