"""Design studies: comparing result directories, parameter sweeps, tolerance analysis.

Each study is a room of its own fed by the compiled model and the Result; none of them grows
the solver. `compare` compares two result directories (a CI regression gate).
"""
