"""--table-format parquet, output: {table_format: parquet}, Result.write(table_format=...): the
same tables as the CSV run, bit for bit, under the same output contract; a usage error naming
the extra when pyarrow is missing."""

import json
import signal
import subprocess

import numpy as np
import pytest

from clitools import PLAIN_SLIDER_CRANK, command, run_cli

import planarkin
from planarkin import InputError
from planarkin.model import spec as model_spec
from planarkin.studies.compare import SAME, compare_dirs

pq = pytest.importorskip("pyarrow.parquet")

CENTRES = PLAIN_SLIDER_CRANK + "output: {centres: true}\n"


def _csv(path):
    """Header and float array of one of our CSV tables (shortest round-trip doubles)."""
    lines = path.read_text().splitlines()
    return lines[0].split(","), np.array([[float(v) for v in r.split(",")] for r in lines[1:]])


def _bits(a):
    return np.ascontiguousarray(a, dtype=np.float64).view(np.uint64)


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """The same model run with CSV tables and with Parquet tables (centres.csv: a derived
    table)."""
    d = tmp_path_factory.mktemp("pq")
    model = d / "sc.yaml"
    model.write_text(CENTRES)
    for fmt in ("csv", "parquet"):
        r = run_cli("run", model, "--out", d / fmt, "--no-plots", "--steps", "200",
                    "--table-format", fmt)
        assert r.returncode == 0, r.stderr
    return d / "csv" / "sc", d / "parquet" / "sc"


def test_parquet_tables_hold_the_csv_tables_bit_for_bit(runs):
    csv_dir, pq_dir = runs
    names = sorted(p.stem for p in csv_dir.glob("*.csv"))
    assert names == ["bodies", "centres", "points"]
    assert sorted(p.stem for p in pq_dir.glob("*.parquet")) == names
    for n in names:
        header, X = _csv(csv_dir / f"{n}.csv")
        t = pq.read_table(pq_dir / f"{n}.parquet")
        assert t.column_names == header          # units in the names
        assert all(str(f.type) == "double" for f in t.schema)
        Y = np.column_stack([t.column(k).to_numpy() for k in range(t.num_columns)])
        assert Y.shape == X.shape
        assert np.array_equal(_bits(Y), _bits(X)), n


def test_summary_lists_the_parquet_files(runs):
    csv_dir, pq_dir = runs
    s = json.loads((pq_dir / "summary.json").read_text())
    c = json.loads((csv_dir / "summary.json").read_text())
    assert set(s["files"]) == {"bodies.parquet", "points.parquet", "centres.parquet"}
    assert {p.name for p in pq_dir.iterdir()} == set(s["files"]) | {"summary.json"}
    for name, info in s["files"].items():
        f = pq.ParquetFile(pq_dir / name)
        assert info == {"rows": 201, "columns": f.metadata.num_columns}
        assert f.metadata.num_rows == 201
        assert c["files"][name.replace(".parquet", ".csv")] == info
        # the column statistics are the CSV run's, under the file's name
        assert s["columns"][name] == c["columns"][name.replace(".parquet", ".csv")]


def test_compare_reads_parquet_tables(runs, tmp_path):
    _, pq_dir = runs
    assert compare_dirs(pq_dir, pq_dir).status == SAME
    changed = tmp_path / "changed"
    changed.mkdir()
    for p in pq_dir.iterdir():
        (changed / p.name).write_bytes(p.read_bytes())
    t = pq.read_table(changed / "points.parquet")
    cols = [t.column(k).to_numpy().copy() for k in range(t.num_columns)]
    cols[1][7] *= 1 + 1e-6
    import pyarrow as pa
    pq.write_table(pa.Table.from_arrays([pa.array(c) for c in cols], names=t.column_names),
                   changed / "points.parquet")
    c = compare_dirs(changed, pq_dir)
    assert c.status == 1
    [d] = c.differences
    assert (d.table, d.column, d.row) == ("points.parquet", t.column_names[1], 8)


def test_compare_a_parquet_run_with_a_csv_run(runs, tmp_path):
    # the same model in both formats: the values are compared, whatever the table format
    csv_dir, pq_dir = runs
    for new, golden in ((pq_dir, csv_dir), (csv_dir, pq_dir)):
        c = compare_dirs(new, golden, rtol=0, atol=0)
        assert c.status == SAME, c.error
        assert c.columns == sum(len(_csv(p)[0]) for p in csv_dir.glob("*.csv"))
        assert len(c.tables) == 3
    r = run_cli("compare", pq_dir, csv_dir)
    assert r.returncode == 0 and r.stdout.startswith("same: 3 tables"), r.stdout + r.stderr
    # a changed value in the Parquet run is found against the CSV run, named in both formats
    changed = tmp_path / "changed"
    changed.mkdir()
    for p in pq_dir.iterdir():
        (changed / p.name).write_bytes(p.read_bytes())
    t = pq.read_table(changed / "bodies.parquet")
    cols = [t.column(k).to_numpy().copy() for k in range(t.num_columns)]
    cols[2][5] += 1e-3
    import pyarrow as pa
    pq.write_table(pa.Table.from_arrays([pa.array(c) for c in cols], names=t.column_names),
                   changed / "bodies.parquet")
    c = compare_dirs(changed, csv_dir)
    assert c.status == 1
    [d] = c.differences
    assert (d.table, d.column, d.row) == ("bodies.parquet vs bodies.csv", t.column_names[2], 6)
    # a table only one run has is still named
    (changed / "points.parquet").unlink()
    c = compare_dirs(changed, csv_dir)
    assert c.status == 2 and c.error == f"different tables (missing in {changed}: points.csv)"


def test_yaml_key_and_api_write(tmp_path):
    model = tmp_path / "sc.yaml"
    model.write_text(PLAIN_SLIDER_CRANK + "output: {table_format: parquet}\n")
    m = planarkin.load(model)
    assert m.spec.output.table_format == "parquet"
    res = planarkin.solve(m, steps=20)
    s = res.write(tmp_path / "a", plots=None)
    assert set(s["files"]) == {"bodies.parquet", "points.parquet"}
    s = res.write(tmp_path / "b", plots=None, table_format="csv")   # the argument wins
    assert set(s["files"]) == {"bodies.csv", "points.csv"}
    with pytest.raises(InputError, match="table_format must be one of csv, parquet, not 'xls'"):
        res.write(tmp_path / "c", plots=None, table_format="xls")


def test_missing_pyarrow_is_an_error_naming_the_extra(tmp_path, monkeypatch):
    from click.testing import CliRunner
    from planarkin.cli import main
    monkeypatch.setattr(model_spec, "pyarrow_available", lambda: False)
    model = tmp_path / "sc.yaml"
    model.write_text(PLAIN_SLIDER_CRANK)
    r = CliRunner().invoke(main, ["run", str(model), "--out", str(tmp_path / "o"),
                                  "--table-format", "parquet"])
    assert r.exit_code == 2, r.output
    assert "Traceback" not in r.output
    assert "Invalid value for '--table-format': parquet needs pyarrow, which is not " \
           "installed: pip install 'planarkin[parquet]', or use csv" in r.output
    assert not (tmp_path / "o").exists()
    model.write_text(PLAIN_SLIDER_CRANK + "output: {table_format: parquet}\n")
    with pytest.raises(InputError) as e:
        planarkin.load(model)
    assert str(e.value).strip().endswith(
        f"{model}:{PLAIN_SLIDER_CRANK.count(chr(10)) + 1}: error: output: table_format: parquet needs pyarrow, which is not "
        f"installed: pip install 'planarkin[parquet]', or use csv")
    res = planarkin.solve(planarkin.load(model.with_name("plain.yaml"),
                                         text=PLAIN_SLIDER_CRANK), steps=5)
    with pytest.raises(InputError, match=r"planarkin\[parquet\]"):
        res.write(tmp_path / "w", plots=None, table_format="parquet")


def test_interruption_leaves_complete_row_groups(tmp_path):
    """SIGTERM in the middle of a long run (held after three blocks of rows): every table holds
    the same complete rows, in complete row groups, and summary.json says how many."""
    from clitools import start_held
    from test_contract import no_leftovers
    model = tmp_path / "sc.yaml"
    model.write_text(PLAIN_SLIDER_CRANK)
    out = tmp_path / "out"
    p = start_held(["run", model, "--out", out, "--no-plots", "--steps", "40000",
                    "--table-format", "parquet"], "rows:sc:3", tmp_path / "ready")
    p.send_signal(signal.SIGTERM)
    try:
        stdout, stderr = p.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        p.kill()
        pytest.fail("planarkin hung after the signal")
    assert "Traceback" not in stderr, stderr
    d = out / "sc"
    s = json.loads((d / "summary.json").read_text())
    assert {q.name for q in d.iterdir()} == set(s["files"]) | {"summary.json"}
    rows = s["time"]["rows_written"]
    assert p.returncode == 143 and s["status"] == "interrupted", (p.returncode, stderr)
    assert rows == 3 * 8192
    assert pq.ParquetFile(d / "bodies.parquet").metadata.num_row_groups > 1
    for name, info in s["files"].items():
        f = pq.ParquetFile(d / name)         # a readable footer: the file was closed in order
        assert f.metadata.num_rows == info["rows"] == rows
        t = f.read()
        assert t.num_rows == rows
    t = pq.read_table(d / "bodies.parquet", columns=["t [s]"]).column(0).to_numpy()
    assert t[-1] == s["time"]["last_t"]
    no_leftovers(out)


def test_jobs_pass_the_table_format_on(tmp_path):
    for n in ("m1", "m2"):
        (tmp_path / f"{n}.yaml").write_text(PLAIN_SLIDER_CRANK)
    r = run_cli("run", tmp_path / "m1.yaml", tmp_path / "m2.yaml", "--jobs", "2", "--out",
                tmp_path / "o", "--no-plots", "--steps", "10", "--table-format", "parquet")
    assert r.returncode == 0, r.stderr
    for n in ("m1", "m2"):
        assert sorted(p.name for p in (tmp_path / "o" / n).iterdir()) == \
            ["bodies.parquet", "points.parquet", "summary.json"]


def test_full_disk_leaves_the_previous_parquet_results(tmp_path):
    import resource
    from test_contract import _env, no_leftovers
    model = tmp_path / "sc.yaml"
    model.write_text(PLAIN_SLIDER_CRANK)
    out = tmp_path / "out"
    assert run_cli("run", model, "--out", out, "--no-plots", "--steps", "10",
                   "--table-format", "parquet").returncode == 0
    before = (out / "sc" / "bodies.parquet").read_bytes()

    def small_files():                # every file the run writes is cut at 100 kB
        resource.setrlimit(resource.RLIMIT_FSIZE, (100_000, 100_000))
    r = subprocess.run(command() + ["run", str(model), "--out", str(out), "--no-plots",
                                    "--steps", "20000", "--table-format", "parquet"],
                       capture_output=True, text=True, timeout=120, env=_env(),
                       preexec_fn=small_files)
    assert r.returncode == 1, r.stderr
    assert "Traceback" not in r.stderr and "File too large" in r.stderr
    assert "is left as it was" in r.stderr
    assert (out / "sc" / "bodies.parquet").read_bytes() == before
    no_leftovers(out)
