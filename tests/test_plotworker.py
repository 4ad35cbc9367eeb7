"""Plots in the process that solves (planarkin.output.writer): drawn after the tables, the same
files as planarkin.output.plots draws, and an interrupted batch with plots, or a SIGTERM to the
process group of a plotting run (a CI timeout, systemd, docker stop), leaves every directory
consistent, quietly."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import planarkin
from planarkin.output import plots

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = [ROOT / "mechanisms" / f"{n}.yaml" for n in ("slider-crank", "four-bar", "boom")]


def _env():
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    return env


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


# moments of a batch, as what is on disk then: the first model's first figure drawn (its other
# figures being drawn), the second model solving, the third one's figures being drawn
MOMENTS = [(".m0.tmp-*/bodies.png", signal.SIGINT), (".m1.tmp-*/bodies.csv", signal.SIGTERM),
           (".m2.tmp-*/mechanism.png", signal.SIGINT)]


@pytest.mark.parametrize("when, sig", MOMENTS, ids=[f"{w.split('.')[1]}-{s.name}"
                                                   for w, s in MOMENTS])
def test_interrupted_batch_with_plots_leaves_every_directory_consistent(tmp_path, when, sig):
    """A batch with plots, stopped by a signal while models solve and are drawn: the run ends
    with the signal's status, every directory on disk holds exactly what its summary lists
    (whole PNG files), the later models are not started, and no temporary is left."""
    from test_contract import assert_contract, no_leftovers
    models = []
    for k in range(9):
        m = tmp_path / f"m{k}.yaml"
        m.write_text(EXAMPLES[k % 3].read_text())
        models.append(str(m))
    out = tmp_path / "out"
    p = subprocess.Popen([sys.executable, "-m", "planarkin", "run", *models, "--out", str(out),
                          "--steps", "200", "--animate"], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, env=_env(), cwd=ROOT)
    deadline = time.time() + 120
    while not list(out.glob(when)) and p.poll() is None and time.time() < deadline:
        time.sleep(0.005)
    assert p.poll() is None, "the batch ended before the moment"
    p.send_signal(sig)
    try:
        stdout, stderr = p.communicate(timeout=120)
    except subprocess.TimeoutExpired:
        p.kill()
        pytest.fail("planarkin hung after the signal")
    assert "Traceback" not in stderr, stderr
    assert p.returncode == {signal.SIGINT: 130, signal.SIGTERM: 143}[sig], (stdout, stderr)
    done = [d for d in out.iterdir() if d.is_dir() and not d.name.startswith(".")]
    statuses = []
    for d in done:
        s = assert_contract(d, ("ok", "interrupted"))
        statuses.append(s["status"])
        for name in s["plots"]:
            data = (d / name).read_bytes()
            assert data[:6] in (b"\x89PNG\r\n", b"GIF89a"), (d, name)
            assert data.endswith(b"IEND\xaeB`\x82") or data.endswith(b";"), (d, name)
        assert f"{d.name}.yaml" in stdout, (d, stdout)
    assert "interrupted" in statuses and len(done) < 9
    assert f"{statuses.count('ok')} ok" in stdout.strip().splitlines()[-1], stdout
    no_leftovers(out)


