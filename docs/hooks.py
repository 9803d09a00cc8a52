"""MkDocs hooks: the pages generated at build time (nothing generated is kept in the tree).

* ``reference/scenes.md`` from the scene schema (:mod:`tiseg.setup.reference`);
* ``reference/cli.md`` from the argparse parser (:mod:`tiseg.apps.cli_reference`);
* ``gallery.md``: every script in ``examples/`` run with its ``GALLERY`` arguments, its
  docstring, code and printed output, and a picture of the run where it writes one;
* ``benchmarks.md``, the full benchmark tables, from ``benchmarks/README.md``, with its pictures
  copied in and links to files outside the site turned into plain paths;
* the pictures of ``assets/`` (figures and the GIF), which the written pages show as
  ``assets/...``, copied in under the same path.

A failing example fails the build (``mkdocs build --strict`` in CI).
"""

from __future__ import annotations

import ast
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

from mkdocs.structure.files import File

ROOT = Path(__file__).resolve().parents[1]
_LINK = re.compile(r"(!?)\[([^\]]*)\]\(([^)\s]+)\)")


def _rewrite(text: str, base: Path, images: set[Path]) -> str:
    """Keep web links; copy pictures in (recorded in ``images``, relative to ROOT); links to
    other files become their repository path in code."""

    def fix(m):
        bang, label, target = m.groups()
        if re.match(r"^[a-z]+://|^#|^mailto:", target):
            return m.group(0)
        path = (base / target.split("#")[0]).resolve()
        rel = path.relative_to(ROOT)
        if bang:
            images.add(rel)
            return f"![{label}]({rel.as_posix()})"
        if rel.as_posix() == "docs/numerics.md":
            return f"[{label}](numerics.md)"
        return f"{label} (`{rel.as_posix()}`)" if label != rel.as_posix() else f"`{label}`"

    return _LINK.sub(fix, text)


def _gallery() -> tuple[str, list[tuple[str, bytes]]]:
    """The gallery page and the pictures it shows ([(site path, PNG bytes)])."""
    out = [
        "# Gallery",
        "",
        "*Each script of `examples/` was run when this site was built, with the arguments "
        "shown; the output below is what it printed.*",
        "",
    ]
    pictures = []
    env = dict(
        os.environ, TI_SKIP_VERSION_CHECK="ON", ENABLE_TAICHI_HEADER_PRINT="0", MPLBACKEND="Agg"
    )
    for script in sorted((ROOT / "examples").glob("*.py")):
        src = script.read_text()
        tree = ast.parse(src)
        doc = ast.get_docstring(tree) or script.stem
        gallery = next(
            (
                ast.literal_eval(n.value)
                for n in tree.body
                if isinstance(n, ast.Assign)
                and any(getattr(t, "id", "") == "GALLERY" for t in n.targets)
            ),
            None,
        )
        if gallery is None:
            raise RuntimeError(f"examples/{script.name} has no GALLERY arguments")
        with tempfile.TemporaryDirectory() as tmp:
            args = [a.replace("{out}", str(Path(tmp) / "run")) for a in gallery]
            p = subprocess.run(
                [sys.executable, str(script), *args],
                cwd=tmp,
                env=env,
                capture_output=True,
                text=True,
                timeout=600,
            )
            if p.returncode != 0:
                raise RuntimeError(f"examples/{script.name} failed:\n{p.stderr[-2000:]}")
            title, _, rest = doc.partition("\n")
            # the body keeps its indentation: an indented usage line stays a code block
            out += [
                f"## `{script.name}`: {title.rstrip('.')}",
                "",
                rest.strip("\n"),
                "",
                f"Run as `python examples/{script.name} {' '.join(gallery)}`:",
                "",
                "```text",
                p.stdout.strip(),
                "```",
                "",
            ]
            run = Path(tmp) / "run"
            if (run / "fields.nc").exists():
                png = Path(tmp) / f"{script.stem}.png"
                r = subprocess.run(
                    [
                        sys.executable,
                        "-c",
                        "import sys; from tiseg.apps.cli import main; sys.exit(main())",
                        "render",
                        str(run),
                        "--panels",
                        str(png),
                    ],
                    cwd=tmp,
                    env=env,
                    capture_output=True,
                    text=True,
                    timeout=600,
                )
                if r.returncode != 0 or not png.exists():
                    raise RuntimeError(
                        f"rendering the run of examples/{script.name} failed:\n{r.stderr[-2000:]}"
                    )
                site = f"gallery/{script.stem}.png"
                pictures.append((site, png.read_bytes()))
                out += [f"![{script.stem}]({site})", ""]
            out += [
                '??? note "The code"',
                "",
                "    ```python",
                *("    " + ln if ln else "" for ln in src.splitlines()),
                "    ```",
                "",
            ]
    return "\n".join(out) + "\n", pictures


def on_files(files, config):
    sys.path.insert(0, str(ROOT))
    from tiseg.apps import cli_reference
    from tiseg.setup import reference as scene_reference

    def add(path: str, content):
        files.append(File.generated(config, path, content=content))

    add("reference/scenes.md", scene_reference.markdown())
    add("reference/cli.md", cli_reference.markdown())
    page, pictures = _gallery()
    add("gallery.md", page)
    for site, data in pictures:
        add(site, data)

    images: set[Path] = set()
    bench = [
        "# Benchmark tables",
        "",
        "*The measurements behind [Performance](performance.md), with their dates and "
        "machines, as kept in `benchmarks/README.md`.*",
        "",
        _rewrite(
            (ROOT / "benchmarks" / "README.md").read_text().split("\n", 1)[1],
            ROOT / "benchmarks",
            images,
        ),
    ]
    add("benchmarks.md", "\n".join(bench))
    images.update(p.relative_to(ROOT) for p in (ROOT / "assets").rglob("*") if p.is_file())
    for rel in sorted(images):
        add(rel.as_posix(), (ROOT / rel).read_bytes())
    return files
