"""Imported by the forkserver of a study's workers on the compiled route (planarkin.processes:
context(engine=True)): numba imported and the compiled route's entry points loaded from the
cache once, in the server, while the command prepares the study, so that every worker forked
from it starts with them (each worker loading them itself waited for the others at the cache's
lock). Anything that fails here is left to the workers, which load as before."""

try:
    from planarkin.solver.compiled import kernel
    if not kernel.disabled():
        _lib = kernel.library()
        if _lib is not None:
            _lib.need("points").need("study")
except Exception:  # noqa: BLE001 - the workers load it themselves, and say what fails
    pass
