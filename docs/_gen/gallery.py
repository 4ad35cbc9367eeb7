"""mkdocs-gen-files script: the gallery, made by running every model in mechanisms/ with the
code being documented, at every build. No figure of the site is checked in, so none can go stale.

One `planarkin run` of all models (the command a user types; its exit status must be 0 or 1),
then gallery/index.md (one figure per model) and gallery/<model>.md (the model's comment, its
source, the command and every figure it wrote) go into the site.
"""

import json
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import mkdocs_gen_files

ROOT = Path(__file__).resolve().parents[2]
ORDER = ("mechanism", "trajectories", "bodies", "points", "forces", "measures", "centres")


def comment(path: Path) -> str:
    """The model file's leading comment lines, as prose (a page of the documentation it names,
    docs/....md, becomes a link to that page)."""
    lines = []
    for line in path.read_text().splitlines():
        if not line.startswith("#"):
            break
        lines.append(line.lstrip("#").strip())
    return re.sub(r"\bdocs/([\w/.-]+\.md)\b", r"[\g<0>](../\1)", " ".join(lines))


def figures(outdir: Path) -> list[Path]:
    rank = {name: k for k, name in enumerate(ORDER)}
    return sorted(outdir.glob("*.png"), key=lambda p: (rank.get(p.stem, len(ORDER)), p.stem))


def main():
    models = sorted((ROOT / "mechanisms").glob("*.yaml"))
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [sys.executable, "-m", "planarkin", "run", *map(str, models), "--out", tmp,
               "--quiet", "--report", "html"]
        done = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
        if done.returncode not in (0, 1):
            raise RuntimeError(f"the gallery's planarkin run exited {done.returncode}:\n"
                               f"{done.stdout}{done.stderr}")
        index = ["# Gallery", "",
                 "Every model in `mechanisms/`, analysed by this version of planarkin when this "
                 "site was built (`planarkin run mechanisms/*.yaml`, each model's own grid). "
                 "Click a model for its source and every figure it writes.", ""]
        for path in models:
            name = path.stem
            out = Path(tmp) / name
            status = json.loads((out / "summary.json").read_text()).get("status", "?")
            figs = figures(out)
            for fig in figs:
                with mkdocs_gen_files.open(f"gallery/{name}/{fig.name}", "wb") as f:
                    f.write(fig.read_bytes())
            about = comment(path)
            report = out / "report.html"        # the page a user can send: one file, offline
            if report.exists():
                with mkdocs_gen_files.open(f"gallery/{name}/report.html", "wb") as f:
                    f.write(report.read_bytes())
            link = f"[report.html]({name}/report.html)" if report.exists() else ""
            index += [f"## [{name}]({name}.md)", "", about, ""]
            if link:
                index += [f"Its run's {link}, one self-contained page.", ""]
            if figs:
                index += [f"[![{name}: {figs[0].stem}]({name}/{figs[0].name})]({name}.md)", ""]
            page = [f"# {name}", "", f"[Gallery](index.md) / `mechanisms/{path.name}`", "",
                    about, "",
                    f"`planarkin run mechanisms/{path.name}` (status: **{status}**)"
                    + (f"; its {link} (`--report html`)" if link else ""), "",
                    f'??? example "mechanisms/{path.name}"', "", "    ```yaml"]
            page += [f"    {line}".rstrip() for line in path.read_text().splitlines()]
            page += ["    ```", ""]
            for fig in figs:
                page += [f"## {fig.name}", "", f"![{name}: {fig.stem}]({name}/{fig.name})", ""]
            with mkdocs_gen_files.open(f"gallery/{name}.md", "w") as f:
                f.write("\n".join(page))
        with mkdocs_gen_files.open("gallery/index.md", "w") as f:
            f.write("\n".join(index))


main()
