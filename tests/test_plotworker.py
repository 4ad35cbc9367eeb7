"""Plots in the process that solves (planarkin.output.writer): drawn after the tables, the same
files as planarkin.output.plots draws, and an interrupted batch with plots, or a SIGTERM to the
process group of a plotting run (a CI timeout, systemd, docker stop), leaves every directory
consistent, quietly."""

import json
import signal
import subprocess
from pathlib import Path

import pytest

import planarkin
from planarkin.output import plots

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = [ROOT / "mechanisms" / f"{n}.yaml" for n in ("slider-crank", "four-bar", "boom")]


def test_run_draws_the_same_files_as_the_plots_module(tmp_path):
    """`planarkin run` (in process) writes the figures planarkin.output.plots draws from the
    same result, byte for byte, after the tables, and lists them in summary.json."""
    from click.testing import CliRunner

    from planarkin.cli import main
    r = CliRunner().invoke(main, ["run", str(EXAMPLES[1]), "--out", str(tmp_path / "cli"),
                                  "--steps", "40"])
    assert r.exit_code == 0, r.output
    d = tmp_path / "cli" / "four-bar"
    s = json.loads((d / "summary.json").read_text())
    cm = planarkin.load(EXAMPLES[1])
    res = planarkin.solve(cm, steps=40)
    here = tmp_path / "here"
    here.mkdir()
    mine = plots.write_plots(cm, res._chunk, res.info, here, "png")
    assert s["plots"][:len(mine)] == [p.name for p in mine]
    for p in mine:
        assert (d / p.name).read_bytes() == p.read_bytes(), p.name
    assert {f.name for f in d.iterdir()} == set(s["files"]) | set(s["plots"]) | {"summary.json"}


def test_a_batch_prints_its_lines_in_order_and_every_directory_has_its_plots(tmp_path):
    from click.testing import CliRunner

    from planarkin.cli import main
    r = CliRunner().invoke(main, ["run", *map(str, EXAMPLES), "--out", str(tmp_path),
                                  "--steps", "40"])
    assert r.exit_code == 0, r.output
    lines = [ln for ln in r.output.splitlines() if ln.startswith("ok ")]
    assert [ln.split()[1] for ln in lines] == [f"{p}:" for p in EXAMPLES]
    for p in EXAMPLES:
        s = json.loads((tmp_path / p.stem / "summary.json").read_text())
        assert s["plots"][:4] == ["bodies.png", "points.png", "trajectories.png",
                                  "mechanism.png"]
        assert {f.name for f in (tmp_path / p.stem).iterdir()} == \
            set(s["files"]) | set(s["plots"]) | {"summary.json"}


# moments of a batch, each held (tests/hold/sitecustomize.py) until the signal arrives: the first
# model's first figure drawn (its other figures not yet), the second model's first rows in its
# tables, the third one's mechanism figure drawn; the models before it are complete
MOMENTS = [("figure:m0:bodies.png", signal.SIGINT), ("rows:m1", signal.SIGTERM),
           ("figure:m2:mechanism.png", signal.SIGINT)]


@pytest.mark.parametrize("moment, sig", MOMENTS, ids=[f"{m.split(':')[1]}-{s.name}"
                                                      for m, s in MOMENTS])
def test_interrupted_batch_with_plots_leaves_every_directory_consistent(tmp_path, moment, sig):
    """A batch with plots, stopped by a signal while a model is solved or drawn: the run ends
    with the signal's status, the models before it are complete (whole PNG files), the model
    says it was interrupted (its plots left out), the later models are not started, and no
    temporary is left."""
    from clitools import start_held
    from test_contract import assert_contract, no_leftovers
    models = []
    for k in range(9):
        m = tmp_path / f"m{k}.yaml"
        m.write_text(EXAMPLES[k % 3].read_text())
        models.append(str(m))
    out = tmp_path / "out"
    p = start_held(["run", *models, "--out", out, "--steps", "200", "--animate"], moment,
                   tmp_path / "ready")
    p.send_signal(sig)
    try:
        stdout, stderr = p.communicate(timeout=120)
    except subprocess.TimeoutExpired:
        p.kill()
        pytest.fail("planarkin hung after the signal")
    assert "Traceback" not in stderr, stderr
    assert p.returncode == {signal.SIGINT: 130, signal.SIGTERM: 143}[sig], (stdout, stderr)
    stopped = int(moment.split(":")[1][1:])              # the model held: m0, m1 or m2
    done = sorted(d.name for d in out.iterdir() if d.is_dir() and not d.name.startswith("."))
    assert done == [f"m{k}" for k in range(stopped + 1)], (done, stdout)
    for name in done:
        d = out / name
        s = assert_contract(d, ("interrupted",) if name == f"m{stopped}" else ("ok",))
        assert s["time"]["rows_written"] == 201
        if name == f"m{stopped}":
            assert s["plots"] == [] and s["exit_code"] == 128 + sig
        else:
            assert "mechanism.png" in s["plots"] and "animation.gif" in s["plots"]
        for f in s["plots"]:
            data = (d / f).read_bytes()
            if f == "animation.mp4":        # where ffmpeg is installed: its boxes fill the file
                k = 0
                while k + 8 <= len(data) and int.from_bytes(data[k:k + 4], "big") >= 8:
                    k += int.from_bytes(data[k:k + 4], "big")
                assert data[4:8] == b"ftyp" and k == len(data), (d, f)
                continue
            assert data[:6] in (b"\x89PNG\r\n", b"GIF89a"), (d, f)
            assert data.endswith(b"IEND\xaeB`\x82") or data.endswith(b";"), (d, f)
        assert f"{name}.yaml" in stdout, (name, stdout)
    assert f"{stopped} ok" in stdout.strip().splitlines()[-1], stdout
    no_leftovers(out)
