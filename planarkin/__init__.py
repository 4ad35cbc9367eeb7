"""planarkin: kinematic analysis of planar mechanisms.

    >>> import planarkin
    >>> model = planarkin.load("mechanisms/slider-crank.yaml")
    >>> result = planarkin.solve(model, steps=720)
    >>> result.body("slider")["vx"]          # slider velocity at every grid time, m/s

Pipeline: read (YAML with line marks) -> validate (diagnostics) -> compile (arrays, internal
units) -> assemble -> solve (path following, then every grid point) -> write (CSV, JSON, plots).
"""

from __future__ import annotations

from .version import __version__

__all__ = ["load", "solve", "synthesize", "fit", "InputError", "__version__"]


def __getattr__(name):
    if name == "InputError":
        from .diagnostics import InputError
        return InputError
    raise AttributeError(name)


def load(path, text: str | None = None, **overrides):
    """Read, validate and compile a model file. Raises planarkin.InputError (with every
    FILE:LINE diagnostic) for invalid input. Returns the compiled model.

    overrides: parameter values replacing the file's, ``load(path, a=0.12, b="3*a")`` (a number
    or an expression of earlier parameters); every number that depends on them follows."""
    from .model.compile import compile_model
    from .model.validate import validate
    from .model.yamlread import read_file, read_yaml
    name = str(path)
    root = read_yaml(text, name) if text is not None else read_file(path)
    return compile_model(validate(root, name, overrides))


def solve(model, **options):
    """Analyse a model (a path or the result of load). Options override the model's analysis:
    block, with the names and rules of the command line (planarkin.options.OPTIONS): start,
    end, steps, tol, newton ('reuse'|'full'|'fixed'), iterations, path_tol, max_step,
    interpolate, bifurcation ('stop'|'continue'),
    up_to ('position'|'velocity'|'acceleration'|'jerk'), max_rows, max_nodes. Returns a planarkin.results.Result (status 0 ok, 1 analysis failure);
    invalid models and invalid or unknown options raise InputError."""
    from .options import resolve
    from .analysis import analyse
    if not hasattr(model, "spec"):
        model = load(model)
    opts = resolve(model, options, source="api")
    _, result = analyse(model, opts, session=True)
    return result


def synthesize(path, overrides=None, **options):
    """Synthesis of the model file's design: block (planarkin.synthesis.synth): options steps,
    starts, local, keep, seed, goal, evaluations, time (seconds), jobs (processes for the
    local runs: the same designs as with 1). Returns a SynthResult (status 0 designs found,
    1 none acceptable; designs best first, each with values, cost, residuals, margins); invalid
    input raises InputError."""
    from .synthesis.synth import synthesize as run
    steps = options.pop("steps", None)
    return run(path, overrides, {"steps": steps}, **options)


def fit(path, data, free=None, overrides=None, steps=None):
    """Estimate the parameters `free` (default: the design: block's free) of the model file from
    tracked point data (a CSV: t [s], POINT.x [UNIT], POINT.y [UNIT]). Returns a FitResult
    (estimate, se, corr, residuals, rms); invalid input raises InputError."""
    from .synthesis.fit import fit as run
    return run(path, data, free, overrides, {"steps": steps})
