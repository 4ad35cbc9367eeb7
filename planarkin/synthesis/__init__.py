"""Synthesis and identification: find the parameters of a model from what it should do
(`synthesize`: path, function and motion generation) or from what it was measured doing
(`fit`: tracked point trajectories). Both are fed by the ordinary pipeline (load -> compile ->
solve) and use the exact sensitivities of planarkin.studies.sensitivity as their Jacobian."""
