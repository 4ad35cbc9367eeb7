"""report.html and index.html (`planarkin run --report html`, planarkin.output.report_html), and
animation.mp4 beside animation.gif (planarkin.output.plots.animation).

The page is one file that asks nothing of the network (checked by parsing it), every value of the
summary it shows is summary.json's (each tagged with its place, compared here one by one), its
key rows are bodies.csv's rows, a 360-row run's page is under 2 MB, and a batch's index.html links
every model's page. Where chromium is installed, the page is opened headless (the DevTools
protocol over a pipe, every read under a deadline, the browser killed at the end): no request
but the page itself, no console error, and moving the time scrubber moves the drawing.

    python tests/test_report_html.py --screenshot docs/images/how-to-report.png

writes the screenshot of docs/how-to/report.md (its example run, the top of the page); it needs
chromium, so the docs' figure test does not compare that image (the page marks it so).
"""

import errno
import fcntl
import html
import json
import os
import select
import shutil
import struct
import subprocess
import sys
import tempfile
import time
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest
from clitools import PLAIN_SLIDER_CRANK, run_cli

ROOT = Path(__file__).resolve().parent.parent
SLIDER_CRANK = ROOT / "mechanisms" / "slider-crank.yaml"
CHROMIUM = next((shutil.which(n) for n in ("chromium", "chromium-browser", "google-chrome")
                 if shutil.which(n)), None)
needs_chromium = pytest.mark.skipif(CHROMIUM is None, reason="chromium is not installed")

# The slider-crank driven by its slider: the crank reaches dead centre at t = 0.5 s (a failure).
SLIDER_DRIVEN = PLAIN_SLIDER_CRANK.replace('{type: angle, body: crank, f: "2*pi*t"}',
                                           '{type: x, body: slider, f: "0.32 + 0.16*t"}') \
    .replace("name: slider-crank", "name: slider-driven") \
    .replace("slider: {q: [0.4, 0.0, 0.0]}", "slider: {q: [0.32, 0.0, 0.0]}") \
    .replace("crank:  {q: [0.05, 0.0, 0.3]}", "crank:  {q: [0.05, 0.0, 0.8]}")


class Page(HTMLParser):
    """A page's tags and attributes, its tagged values (data-k) and key-row cells (data-r)."""

    def __init__(self, text: str):
        super().__init__(convert_charrefs=True)
        self.tags, self.values, self.cells, self.links = [], [], [], []
        self._open = None
        self.feed(text)

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        self.tags.append((tag, a))
        if "data-k" in a:
            self._open = ("k", json.loads(a["data-k"]), [])
        elif "data-r" in a:
            self._open = ("r", (int(a["data-r"]), int(a["data-c"])), [])
        if tag == "a" and "href" in a:
            self.links.append(a["href"])

    def handle_data(self, data):
        if self._open is not None:
            self._open[2].append(data)

    def handle_endtag(self, tag):
        if self._open is not None and tag in ("span", "td"):
            kind, key, text = self._open
            (self.values if kind == "k" else self.cells).append((key, "".join(text)))
            self._open = None


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    """The slider-crank example (masses and a load: loops, cycle figures, forces, loads) at 360
    steps with --report html: its directory."""
    out = tmp_path_factory.mktemp("report")
    r = run_cli("run", SLIDER_CRANK, "--out", out, "--steps", "360", "--report", "html")
    assert r.returncode == 0, r.stdout + r.stderr
    return out / "slider-crank"


@pytest.fixture(scope="module")
def page(run_dir):
    return (run_dir / "report.html").read_text(encoding="utf-8")


@pytest.fixture(scope="module")
def summary(run_dir):
    return json.loads((run_dir / "summary.json").read_text())


def _at(d, path):
    for k in path:
        d = d[k]
    return d


def test_the_report_is_one_file_with_no_external_reference(run_dir, page, summary):
    assert summary["report"] == "report.html"
    assert sorted(p.name for p in run_dir.iterdir()) == sorted(
        ["summary.json", "report.html", *summary["files"], *summary["plots"]])
    parsed = Page(page)
    tags = [t for t, _ in parsed.tags]
    assert "link" not in tags and "img" not in tags and "iframe" not in tags
    assert "object" not in tags and "embed" not in tags and "base" not in tags
    assert all("src" not in a for t, a in parsed.tags)         # nothing loaded: <script src> ...
    for tag, attrs in parsed.tags:
        for name in ("href", "xlink:href", "action", "poster", "data"):
            v = attrs.get(name)
            assert v is None or v.startswith("#"), (tag, name, v)
    assert "http:" not in page and "https:" not in page and "//" not in page
    assert "@import" not in page and "url(" not in page.replace("url(#", "")
    csp = [a["content"] for t, a in parsed.tags if t == "meta" and
           a.get("http-equiv") == "Content-Security-Policy"]
    assert csp and csp[0].startswith("default-src 'none'")
    # every figure of the run is there as SVG, with its name
    svgs = [a for t, a in parsed.tags if t == "svg" and a.get("class") == "fig"]
    assert len(svgs) == len([p for p in summary["plots"] if not p.startswith("animation")])
    for name in summary["plots"]:
        assert f"<figcaption>{name}</figcaption>" in page
    ids = [a["id"] for _, a in parsed.tags if "id" in a]
    assert len(ids) == len(set(ids)), "an id used twice"


def _same_values(page: str, summary: dict) -> set:
    """Check every tagged value of page against summary; return the paths shown."""
    values = Page(page).values
    for path, text in values:
        v = _at(summary, path)
        if v is None:
            assert text == "\u2013", path
        elif isinstance(v, bool):
            assert text == str(v).lower(), path
        elif isinstance(v, (int, float)):
            assert float(text) == v and text == repr(v), (path, text, v)
        else:
            assert text == v, path
    return {tuple(p) for p, _ in values}


def test_every_value_shown_equals_summary_json(page, summary):
    shown = _same_values(page, summary)
    assert len(shown) > 500
    # the figures the page is for: every column's extremes, the cycle figures, loops, forces
    for table, cols in summary["columns"].items():
        for col, stats in cols.items():
            for k in stats:
                assert ("columns", table, col, k) in shown
    assert ("cycle", "coordinates", "bodies", "slider", "x", "stroke") in shown
    assert ("cycle", "coordinates", "bodies", "rod", "phi", "time_ratio") in shown
    assert ("loops", 0, "transmission_angle", "min", "value") in shown
    assert ("forces", "peak", "motor.torque", "value") in shown
    for k in ("status", "model", "message"):
        assert (k,) in shown


def test_key_rows_are_rows_of_bodies_csv(run_dir, page):
    lines = (run_dir / "bodies.csv").read_text().splitlines()
    cells = Page(page).cells
    rows = sorted({r for (r, _), _ in cells})
    assert len(rows) == 20 and rows[0] == 0 and rows[-1] == len(lines) - 2
    for (r, c), text in cells:
        assert text == lines[1 + r].split(",")[c], (r, c)


def test_a_360_row_report_is_under_2_mb(run_dir, summary):
    assert summary["time"]["rows_written"] == 361
    size = (run_dir / "report.html").stat().st_size
    assert 100_000 < size <= 2_000_000, size


def test_a_long_run_is_thinned_and_says_so(tmp_path):
    """20,000 steps: at most 400 animation frames, said on the page."""
    (tmp_path / "m.yaml").write_text(PLAIN_SLIDER_CRANK)
    r = run_cli("run", tmp_path / "m.yaml", "--out", tmp_path / "o", "--steps", "20000",
                "--no-plots", "--report", "html")
    assert r.returncode == 0, r.stderr
    page = (tmp_path / "o" / "m" / "report.html").read_text()
    data = json.loads(page.split('id="pk-data">', 1)[1].split("</script>", 1)[0])
    assert len(data["t"]) == 400 and data["row"][0] == 0 and data["row"][-1] == 20000
    assert "The animation has 400 frames: rows evenly spread over the run's 20001 rows" in \
        html.unescape(page)
    assert len(page) < 400_000
    assert "<svg class=\"fig\"" not in page         # --no-plots: no figures


def test_a_large_model_gets_fewer_frames(tmp_path, monkeypatch):
    """The animation's data is bounded in numbers, not only in frames: fewer frames for a model
    with many bodies and paths (here the bound is lowered for the slider-crank)."""
    from planarkin.output import report_html
    monkeypatch.setattr(report_html, "MOTION_NUMBERS", 3000)
    (tmp_path / "m.yaml").write_text(PLAIN_SLIDER_CRANK)
    r = run_cli("run", tmp_path / "m.yaml", "--out", tmp_path / "o", "--no-plots", "--report",
                "html")
    assert r.returncode == 0, r.stderr
    page = (tmp_path / "o" / "m" / "report.html").read_text()
    data = json.loads(page.split('id="pk-data">', 1)[1].split("</script>", 1)[0])
    per_frame = 3 * data["nb"] + 4 * len(data["paths"])
    assert len(data["t"]) == 3000 // per_frame and len(data["pose"]) == 3 * 3 * len(data["t"])
    assert data["row"][0] == 0 and data["row"][-1] == 360
    assert f"The animation has {len(data['t'])} frames: rows evenly spread" in page


def test_the_animation_draws_the_models_shapes(tmp_path):
    """Bodies with shapes (issue 29) move as their plates, each hole with them; the frame's
    obstacles stand still with the ground. The plate's outline is a rounded capsule around the
    crank's two pins: every vertex lies half the plate's width from the segment A-B."""
    model = Path(__file__).resolve().parent.parent / "mechanisms" / "crank-rocker-clearance.yaml"
    r = run_cli("run", model, "--out", tmp_path / "o", "--no-plots", "--report", "html")
    assert r.returncode == 0, r.stderr
    page = (tmp_path / "o" / "crank-rocker-clearance" / "report.html").read_text()
    assert page.count('class="shape plate"') == 3           # crank, coupler, rocker
    assert page.count('class="shape hole"') == 6            # two pins each
    assert page.count('class="obstacle"') == 2              # the cover and the stop
    data = json.loads(page.split('id="pk-data">', 1)[1].split("</script>", 1)[0])
    crank = [V for b, V in data["shapes"] if b == 0]
    V = np.asarray(max(crank, key=len)).reshape(-1, 2)      # the plate (holes have fewer)
    # crank frame: A at the origin, B at (40, 0) mm; plate 12 mm wide
    u = np.clip(V[:, 0] / 40.0, 0.0, 1.0)
    d = np.hypot(V[:, 0] - 40.0 * u, V[:, 1])
    assert np.allclose(d, 6.0, atol=1e-4)


def test_a_failed_run_has_its_report(tmp_path):
    (tmp_path / "m.yaml").write_text(SLIDER_DRIVEN)
    r = run_cli("run", tmp_path / "m.yaml", "--out", tmp_path / "o", "--no-plots", "--report",
                "html")
    assert r.returncode == 1, r.stdout + r.stderr
    s = json.loads((tmp_path / "o" / "m" / "summary.json").read_text())
    page = (tmp_path / "o" / "m" / "report.html").read_text()
    assert s["status"] == "failed" and s["report"] == "report.html"
    assert ("event", "t") in _same_values(page, s)
    assert '<p class="status failed">' in page and s["event"]["kind"] in page
    index = Page((tmp_path / "o" / "index.html").read_text())
    assert index.links == ["m/report.html"]


def test_the_index_links_every_model(tmp_path):
    (tmp_path / "a.yaml").write_text(PLAIN_SLIDER_CRANK)
    (tmp_path / "b.yaml").write_text(PLAIN_SLIDER_CRANK.replace("steps: 360", "steps: 36"))
    (tmp_path / "bad.yaml").write_text("bodies: [\n")
    out = tmp_path / "o"
    r = run_cli("run", tmp_path / "a.yaml", tmp_path / "bad.yaml", tmp_path / "b.yaml", "--out",
                out, "--no-plots", "--report", "cycle,html")
    assert r.returncode == 2
    assert "bodies (coordinates that move):" in r.stdout          # cycle, as before
    index = (out / "index.html").read_text()
    parsed = Page(index)
    assert parsed.links == ["a/report.html", "b/report.html"]
    for href in parsed.links:
        assert (out / href).is_file()
    rows = [a for t, a in parsed.tags if t == "tr"]
    assert len(rows) == 4                                         # the header and 3 models
    assert "bad.yaml" in index and ">invalid<" in index
    assert "http:" not in index and "https:" not in index
    assert sorted(p.name for p in out.iterdir()) == ["a", "b", "index.html"]   # no temporary


def test_report_option_takes_cycle_and_html_repeated_or_listed(tmp_path):
    (tmp_path / "m.yaml").write_text(PLAIN_SLIDER_CRANK.replace("steps: 360", "steps: 36"))
    r = run_cli("run", tmp_path / "m.yaml", "--out", tmp_path / "o", "--no-plots", "--report",
                "cycle", "--report", "html")
    assert r.returncode == 0 and "bodies (coordinates that move):" in r.stdout
    assert (tmp_path / "o" / "m" / "report.html").is_file()
    r = run_cli("run", tmp_path / "m.yaml", "--out", tmp_path / "p", "--no-plots", "--report",
                "cycle")
    assert r.returncode == 0 and "bodies (coordinates that move):" in r.stdout
    assert not (tmp_path / "p" / "m" / "report.html").exists()
    assert not (tmp_path / "p" / "index.html").exists()
    assert "report" not in json.loads((tmp_path / "p" / "m" / "summary.json").read_text())
    r = run_cli("run", tmp_path / "m.yaml", "--out", tmp_path / "q", "--report", "cycle,pdf")
    assert r.returncode == 2 and "'pdf' is not one of 'cycle', 'html'" in r.stderr
    assert not (tmp_path / "q").exists()


def test_a_report_that_cannot_be_written_is_exit_1_in_one_line(tmp_path, monkeypatch):
    (tmp_path / "m.yaml").write_text(PLAIN_SLIDER_CRANK.replace("steps: 360", "steps: 36"))
    real = Path.write_text

    def full(self, *args, **kwargs):
        if self.name == "report.html":
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real(self, *args, **kwargs)
    monkeypatch.setattr(Path, "write_text", full)
    r = run_cli("run", tmp_path / "m.yaml", "--out", tmp_path / "o", "--no-plots", "--report",
                "html")
    assert r.returncode == 1
    errors = [line for line in r.stderr.splitlines() if "error" in line]
    assert errors == [f"{tmp_path / 'm.yaml'}: error: writing report.html failed: No space "
                      f"left on device; {tmp_path / 'o' / 'm'}/ is left as it was"]
    assert not (tmp_path / "o" / "m").exists()                    # nothing half written
    assert [p.name for p in (tmp_path / "o").iterdir()] == ["index.html"]


def test_an_index_that_cannot_be_written_is_exit_1_in_one_line(tmp_path):
    (tmp_path / "m.yaml").write_text(PLAIN_SLIDER_CRANK.replace("steps: 360", "steps: 36"))
    (tmp_path / "o" / "index.html").mkdir(parents=True)           # in the way
    r = run_cli("run", tmp_path / "m.yaml", "--out", tmp_path / "o", "--no-plots", "--report",
                "html")
    assert r.returncode == 1, r.stderr
    assert r.stderr.strip().splitlines() == [
        f"error: writing {tmp_path / 'o' / 'index.html'} failed: Is a directory; it is left "
        f"as it was"]
    assert (tmp_path / "o" / "m" / "report.html").is_file()
    assert sorted(p.name for p in (tmp_path / "o").iterdir()) == ["index.html", "m"]


# -- animation.mp4 ------------------------------------------------------------------------------
def _gif_frames(path: Path) -> int:
    from PIL import Image
    with Image.open(path) as im:
        return im.n_frames


def _mp4_frames(path: Path) -> int:
    """The sample count of the MP4's (only) track: its stsz box."""
    data = path.read_bytes()
    k = data.index(b"stsz")
    return struct.unpack(">I", data[k + 12:k + 16])[0]


@pytest.mark.skipif(not shutil.which("ffmpeg"), reason="ffmpeg is not installed")
def test_mp4_has_the_gifs_frames(tmp_path):
    (tmp_path / "m.yaml").write_text(PLAIN_SLIDER_CRANK.replace("steps: 360", "steps: 60"))
    r = run_cli("run", tmp_path / "m.yaml", "--out", tmp_path / "o", "--no-plots", "--animate")
    assert r.returncode == 0, r.stderr
    d = tmp_path / "o" / "m"
    s = json.loads((d / "summary.json").read_text())
    assert s["plots"] == ["animation.gif", "animation.mp4"] and "notes" not in s
    assert (d / "animation.mp4").read_bytes()[4:8] == b"ftyp"
    assert _mp4_frames(d / "animation.mp4") == _gif_frames(d / "animation.gif") == 61


def test_without_ffmpeg_the_summary_says_why_there_is_no_mp4(tmp_path, monkeypatch):
    from planarkin.output.plots import animation
    monkeypatch.setattr(animation, "mp4_missing", lambda: "ffmpeg was not found (test)")
    (tmp_path / "m.yaml").write_text(PLAIN_SLIDER_CRANK.replace("steps: 360", "steps: 20"))
    r = run_cli("run", tmp_path / "m.yaml", "--out", tmp_path / "o", "--no-plots", "--animate",
                "--report", "html")
    assert r.returncode == 0 and "mp4" not in r.stdout + r.stderr
    d = tmp_path / "o" / "m"
    s = json.loads((d / "summary.json").read_text())
    assert s["plots"] == ["animation.gif"] and s["warnings"] == []
    assert s["notes"] == ["animation.mp4 was not written: ffmpeg was not found (test); "
                          "animation.gif has the frames"]
    assert not (d / "animation.mp4").exists()
    assert s["notes"][0] in html.unescape((d / "report.html").read_text())


# -- in a browser --------------------------------------------------------------------------------
class Browser:
    """Headless chromium driven through the DevTools protocol over a pipe (its fds 3 and 4: no
    port, no websocket), every answer awaited under a deadline. It runs in a session of its own
    with its temporary files in its profile folder; close() asks it to quit, kills what is left
    of its process group and removes the folder."""

    def __init__(self, timeout: float = 30.0, width: int = 1100, height: int = 1300):
        self.timeout = timeout
        self.profile = tempfile.mkdtemp(prefix="planarkin-chromium-")
        to_child, self._w = os.pipe()
        self._r, from_child = os.pipe()
        # the child's ends above 9, so that putting them at 3 and 4 overwrites neither (dup2
        # leaves the copies inheritable; every other descriptor of ours closes at exec)
        ends = [fcntl.fcntl(fd, fcntl.F_DUPFD_CLOEXEC, 10) for fd in (to_child, from_child)]
        for fd in (to_child, from_child):
            os.close(fd)

        def fds():
            os.dup2(ends[0], 3)
            os.dup2(ends[1], 4)
        try:
            self.proc = subprocess.Popen(
                [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
                 "--no-default-browser-check", "--disable-extensions", "--disable-breakpad",
                 "--disable-crash-reporter", "--remote-debugging-pipe",
                 f"--user-data-dir={self.profile}", "--hide-scrollbars", "about:blank"],
                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, close_fds=False,
                preexec_fn=fds, start_new_session=True,
                env=dict(os.environ, TMPDIR=self.profile))
        finally:
            for fd in ends:
                os.close(fd)
        self.buf, self.n, self.events, self.session = b"", 0, [], None
        try:
            target = self.call("Target.createTarget", url="about:blank")["targetId"]
            self.session = self.call("Target.attachToTarget", targetId=target,
                                     flatten=True)["sessionId"]
            for domain in ("Page", "Network", "Runtime", "Log"):
                self.call(f"{domain}.enable")
            self.call("Emulation.setDeviceMetricsOverride", width=width, height=height,
                      deviceScaleFactor=1, mobile=False)
        except BaseException:
            self.close()
            raise

    def _message(self, deadline: float) -> dict:
        while b"\0" not in self.buf:
            left = deadline - time.monotonic()
            if left <= 0 or not select.select([self._r], [], [], left)[0]:
                raise TimeoutError("chromium did not answer in time")
            chunk = os.read(self._r, 1 << 16)
            if not chunk:
                raise RuntimeError("chromium closed its pipe")
            self.buf += chunk
        msg, _, self.buf = self.buf.partition(b"\0")
        return json.loads(msg)

    def call(self, method: str, **params):
        self.n += 1
        msg = {"id": self.n, "method": method, "params": params}
        if self.session:
            msg["sessionId"] = self.session
        os.write(self._w, json.dumps(msg).encode() + b"\0")
        deadline = time.monotonic() + self.timeout
        while True:
            m = self._message(deadline)
            if m.get("id") == self.n:
                if "error" in m:
                    raise RuntimeError(f"{method}: {m['error']}")
                return m.get("result", {})
            self.events.append(m)

    def open(self, url: str) -> None:
        n = self.loads()
        self.call("Page.navigate", url=url)
        self.loaded(n + 1)

    def loads(self) -> int:
        """The pages loaded so far (Page.loadEventFired)."""
        return sum(e.get("method") == "Page.loadEventFired" for e in self.events)

    def loaded(self, n: int) -> None:
        """Wait until n pages have loaded."""
        deadline = time.monotonic() + self.timeout
        while self.loads() < n:
            self.events.append(self._message(deadline))

    def js(self, expression: str):
        r = self.call("Runtime.evaluate", expression=expression, returnByValue=True)
        if "exceptionDetails" in r:
            raise RuntimeError(r["exceptionDetails"])
        return r["result"].get("value")

    def screenshot(self, path: Path, y: float = 0, height: float = 1300) -> Path:
        import base64
        png = self.call("Page.captureScreenshot", format="png", captureBeyondViewport=True,
                        clip={"x": 0, "y": y, "width": 1100, "height": height, "scale": 1})
        Path(path).write_bytes(base64.b64decode(png["data"]))
        return Path(path)

    def errors(self) -> list:
        """The console's errors, the page's uncaught exceptions and the browser's error logs."""
        out = []
        for e in self.events:
            m, p = e.get("method"), e.get("params", {})
            if m == "Runtime.consoleAPICalled" and p.get("type") in ("error", "assert"):
                out.append(p)
            elif m == "Runtime.exceptionThrown":
                out.append(p)
            elif m == "Log.entryAdded" and p["entry"]["level"] == "error":
                out.append(p["entry"])
        return out

    def requests(self) -> list:
        return [e["params"]["request"]["url"] for e in self.events
                if e.get("method") == "Network.requestWillBeSent"]

    def close(self) -> None:
        import signal
        self.timeout = 5.0
        try:
            self.session = None
            self.call("Browser.close")
            self.proc.wait(timeout=10)
        except (OSError, RuntimeError, TimeoutError, subprocess.TimeoutExpired):
            pass
        try:
            os.killpg(self.proc.pid, signal.SIGKILL)        # whatever of it is left
        except ProcessLookupError:
            pass
        self.proc.wait()
        for fd in (self._r, self._w):
            os.close(fd)
        shutil.rmtree(self.profile, ignore_errors=True)


SHAPES = "Array.from(document.querySelectorAll('#pk-motion .shape')).map(e => " \
         "e.getAttribute('points'))"


@needs_chromium
def test_in_a_browser_the_page_asks_nothing_and_its_scrubber_moves_the_drawing(run_dir,
                                                                               tmp_path):
    url = (run_dir / "report.html").resolve().as_uri()
    b = Browser()
    try:
        b.open(url)
        assert b.requests() == [url]                   # the page itself, nothing else
        first = b.js(SHAPES)
        assert len(first) == 3 and all(first)          # the crank, the rod, the slider block
        assert b.js("document.getElementById('pk-label').textContent") == \
            "t = 0 s (row 0 of 361; frame 1 of 361)"
        b.js("(function () { var r = document.getElementById('pk-t'); r.value = '90'; "
             "r.dispatchEvent(new Event('input')); })()")
        moved = b.js(SHAPES)
        assert moved[0] != first[0] and moved[1] != first[1]       # the crank and rod turned
        assert b.js("document.getElementById('pk-label').textContent") == \
            "t = 0.25 s (row 90 of 361; frame 91 of 361)"
        b.js("document.getElementById('pk-play').click()")          # plays without an error
        top = b.screenshot(tmp_path / "top.png")
        y = b.js("document.getElementById('motion').getBoundingClientRect().top + scrollY")
        motion = b.screenshot(tmp_path / "motion.png", y=y, height=700)
        assert b.requests() == [url]
        assert b.errors() == []
    finally:
        b.close()
    for shot in (top, motion):
        assert shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and shot.stat().st_size > 20_000


@needs_chromium
def test_in_a_browser_the_index_links_open(tmp_path):
    (tmp_path / "m.yaml").write_text(PLAIN_SLIDER_CRANK.replace("steps: 360", "steps: 36"))
    r = run_cli("run", tmp_path / "m.yaml", "--out", tmp_path / "o", "--no-plots", "--report",
                "html")
    assert r.returncode == 0
    b = Browser()
    try:
        b.open((tmp_path / "o" / "index.html").as_uri())
        n = b.loads()
        b.js("document.querySelector('a').click()")
        b.loaded(n + 1)
        assert b.js("location.href") == (tmp_path / "o" / "m" / "report.html").as_uri()
        assert b.js("document.getElementById('pk-t').max") == "36"
        assert b.errors() == []
    finally:
        b.close()


def screenshot(image: Path) -> None:
    """The top of the report of docs/how-to/report.md's example (its blocks run as the docs
    test runs them, planarkin.docs.replay), 1100 px wide, into image."""
    from planarkin.docs import replay
    page = ROOT / "docs" / "how-to" / "report.md"
    with tempfile.TemporaryDirectory() as tmp:
        (Path(tmp) / "mechanisms").symlink_to(ROOT / "mechanisms")
        replay(page, tmp, figures_only=True)
        report = next(Path(tmp).glob("out/*/report.html"))
        b = Browser(height=1000)
        try:
            b.open(report.resolve().as_uri())
            b.js("(function () { var r = document.getElementById('pk-t'); r.value = "
                 "String(Math.round(r.max / 4)); r.dispatchEvent(new Event('input')); })()")
            b.screenshot(image, height=1000)
            assert b.errors() == [] and len(b.requests()) == 1
        finally:
            b.close()


if __name__ == "__main__":
    if sys.argv[1:2] == ["--screenshot"] and len(sys.argv) == 3:
        screenshot(Path(sys.argv[2]))
    else:
        sys.exit(__doc__)
