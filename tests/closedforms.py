"""What the closed-form tests of machine elements share: a model solved from its text, and the
error measure (the largest |got - want| over the run, relative to the largest |want| or to a
scale given)."""

import numpy as np

import planarkin


def run(text: str, name: str = "model.yaml"):
    """The Result of the model written in text (name: its file name in messages); it must run."""
    res = planarkin.solve(planarkin.load(name, text=text))
    assert res.status == 0, res.message
    return res


def rel(got, want, scale=None) -> float:
    """Largest |got - want| over the run, relative to the largest |want| (or scale)."""
    got, want = np.asarray(got, float), np.asarray(want, float)
    s = scale if scale is not None else np.max(np.abs(want))
    return float(np.max(np.abs(got - want)) / s)
