"""The solve stage: a compiled model's equations Phi(q, t) = 0 (system), their structure and
block order (structure, linalg), assembly at the start (assembly, closure, meshing, branches),
the path over the time grid (grid, path, singular, acceptance, warmstart), what a job may cost
(budget), point kinematics (kinematics), the rows a solve hands on (chunks, layout), and the
compiled route (compiled/). Nothing here reads files or writes results."""
