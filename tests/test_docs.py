"""Executable docs: every Python and shell block of README.md and docs/**/*.md runs here.

Blocks fenced as ``python``, ``sh``/``bash``/``shell``, and unlabelled blocks whose lines
are ``$ command`` prompts (their other lines are output) run in order, one test per
Markdown file, in a fresh directory that holds small stand-ins for the mesh files the docs
name (``bunny.ply``, ``cow.obj``, ... are a few-thousand-face demo surface: the docs show
calls, not figures) and an empty ``img/``, with ``lodkit`` and ``python`` on PATH meaning
the lodkit under test; evaluations take at most DOC_SAMPLES samples.  Plain
``lodkit ...`` and ``python script.py ...`` lines run in this process (``lodkit.cli.main``,
``runpy``: the same code, without starting Python again); anything else (pipes,
variables, setup lines) runs in ``bash``.
The Python blocks of one file share a namespace, as a reader following the page would.

Markers, written in the Markdown source (a reader on a code host does not see them):

* ``<!-- doc-test: skip: why -->`` on the line before a block: not run (a window, the
  network, a long run, a package that is not installed); ``why`` is required.  The same
  words may follow the language on the fence line instead: ````` ```sh skip: why `````.
* ``<!-- doc-test: setup: python code -->`` before a block: run first, in the page's
  namespace, to give the names the block takes from the text around it (``mesh`` ...).
* A Python block whose first line is ``# name.py`` (or ``# name.py, continued``) is also
  written (appended) to that file, so later blocks can import it.
"""
from __future__ import annotations

import os
import re
import runpy
import shlex
import shutil
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

import pytest

import lodkit
from conftest import lodkit_subprocess_env
from lodkit.evaluate import Evaluator

REPO = Path(__file__).resolve().parents[1]
PAGES = [REPO / "README.md", *sorted((REPO / "docs").rglob("*.md"))]
FENCE = re.compile(r"^(?P<indent>\s*)```(?P<lang>[\w+-]*)\s*(?P<info>.*)$")
MARKER = re.compile(r"<!--\s*doc-test:\s*(?P<kind>skip|setup)\s*:\s*(?P<text>.*?)\s*-->", re.S)
SHELL = {"sh", "bash", "shell", "console"}
FILE_LINE = re.compile(r"^#\s*(?P<name>[\w./-]+\.py)(?P<cont>,\s*continued)?\s*$")
# stand-ins for the mesh files the docs name, and the size they are made at
# evaluations (evaluate, compare, the CLI) take at most this many samples here: the stand-ins
# are small and the docs show calls, not figures
DOC_SAMPLES = 20_000
STAND_INS = {"bunny.ply": 8000, "in.ply": 3000, "A.ply": 3000, "colored_airplane.ply": 3000, "cow.obj": 3000,
             "fandisk.obj": 3000, "igea.ply": 30_000}       # cluster examples ask for 5k and 20k faces


@dataclass
class Block:
    page: Path
    line: int                    # 1-based line of the opening fence
    lang: str                    # "python" or "sh"
    code: str
    skip: str = ""
    setup: list[str] = field(default_factory=list)

    @property
    def where(self) -> str:
        return f"{self.page.relative_to(REPO)}:{self.line}"


def blocks(page: Path, text: str | None = None) -> list[Block]:
    """The runnable blocks of ``page`` (or of ``text``), with their markers."""
    lines = (page.read_text(encoding="utf-8") if text is None else text).splitlines()
    out, i = [], 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        indent, lang, info = m["indent"], m["lang"].lower(), m["info"]
        j = i + 1
        while j < len(lines) and lines[j].strip() != "```":
            j += 1
        body = [ln[len(indent):] if ln.startswith(indent) else ln.lstrip() for ln in lines[i + 1:j]]
        above = _comments_above(lines, i)
        markers = MARKER.findall(above)
        skip = next((t for kind, t in markers if kind == "skip"), "")
        if info.startswith("skip:"):
            skip = info[len("skip:"):].strip()
        setup = [t for kind, t in markers if kind == "setup"]
        if lang == "python":
            out.append(Block(page, i + 1, "python", "\n".join(body) + "\n", skip, setup))
        elif lang in SHELL:
            out.append(Block(page, i + 1, "sh", _shell(body, prompts=lang == "console"), skip, setup))
        elif not lang and body and any(b.startswith("$ ") for b in body):
            out.append(Block(page, i + 1, "sh", _shell(body, prompts=True), skip, setup))
        i = j + 1
    return out


def _comments_above(lines: list[str], i: int) -> str:
    """The HTML comments stacked just above line ``i`` (blank lines between allowed)."""
    k, found = i - 1, []
    while k >= 0:
        if not lines[k].strip():
            k -= 1
            continue
        if not lines[k].rstrip().endswith("-->"):
            break
        end = k
        while k >= 0 and "<!--" not in lines[k]:
            k -= 1
        if k < 0:
            break
        found.insert(0, "\n".join(lines[k:end + 1]))
        k -= 1
    return "\n".join(found)


def _shell(body: list[str], prompts: bool) -> str:
    """The commands of a shell block; with prompts only the ``$ `` lines (and their
    backslash continuations), the rest being output."""
    if not prompts:
        return "\n".join(body) + "\n"
    cmds, cont = [], False
    for b in body:
        if b.startswith("$ ") or cont:
            cmds.append(b[2:] if b.startswith("$ ") else b)
            cont = b.rstrip().endswith("\\")
    return "\n".join(cmds) + "\n"


@pytest.fixture(scope="module")
def stand_ins(tmp_path_factory):
    from lodkit.demo import demo_mesh

    d = tmp_path_factory.mktemp("stand_ins")
    for name, faces in STAND_INS.items():
        lodkit.save(demo_mesh(faces), d / name)
    lodkit.save(lodkit.simplify(demo_mesh(3000), target_ratio=0.1).mesh, d / "bunny_10.ply")
    shutil.copy(d / "bunny_10.ply", d / "B.ply")
    return d


def _workdir(tmp_path: Path, stand_ins: Path) -> dict:
    for f in stand_ins.iterdir():
        shutil.copy(f, tmp_path / f.name)
    (tmp_path / "docs").symlink_to(REPO / "docs")
    (tmp_path / "img").mkdir()                 # docs/examples/README.md writes its pictures there
    (tmp_path / "plugins").symlink_to(REPO / "plugins")
    bin_dir = tmp_path / ".bin"
    bin_dir.mkdir()
    (bin_dir / "lodkit").write_text(f'#!/bin/sh\nexec "{sys.executable}" -m lodkit "$@"\n')
    (bin_dir / "lodkit").chmod(0o755)
    for name in ("python", "python3"):        # a script, not a link: a venv knows itself by its path
        (bin_dir / name).write_text(f'#!/bin/sh\nexec "{sys.executable}" "$@"\n')
        (bin_dir / name).chmod(0o755)
    env = lodkit_subprocess_env(MPLBACKEND="Agg")
    env["PATH"] = os.pathsep.join([str(bin_dir), env.get("PATH", "")])
    return env


def _run_python(block: Block, namespace: dict, cwd: Path) -> None:
    if (m := FILE_LINE.match(block.code.splitlines()[0] if block.code.strip() else "")):
        with open(cwd / m["name"], "a" if m["cont"] else "w", encoding="utf-8") as fh:
            fh.write(block.code)
    for code in block.setup:
        exec(compile(code, f"{block.where} (setup)", "exec"), namespace)
    exec(compile(block.code, block.where, "exec"), namespace)


def _commands(code: str) -> list[list[str]] | None:
    """The block as argument lists, one per command, when every command is a plain
    ``lodkit ...`` or ``python script.py ...`` line (no pipes, redirections, variables);
    else None (the block goes to bash)."""
    out = []
    for line in code.replace("\\\n", " ").splitlines():
        try:
            argv = shlex.split(line, comments=True)
        except ValueError:
            return None
        if not argv:
            continue
        if any(ch in line.split("#")[0] for ch in "|&;<>$`") or argv[0] not in ("lodkit", "python", "python3"):
            return None
        out.append(argv)
    return out


def _run_in_process(argv: list[str], where: str) -> None:
    """``lodkit ...`` through lodkit.cli.main, ``python script.py ...`` through runpy: the
    same code a subprocess would run, without starting Python (and Open3D) again."""
    from lodkit.cli import main

    if argv[0] == "lodkit":
        rc = main(argv[1:])
    else:
        old = sys.argv
        sys.argv = argv[1:]
        try:
            runpy.run_path(argv[1], run_name="__main__")
            rc = 0
        except SystemExit as exc:
            rc = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
        finally:
            sys.argv = old
    assert rc == 0, f"{where}: {' '.join(argv)} exited {rc}"


def _run_shell(block: Block, env: dict, cwd: Path) -> None:
    commands = _commands(block.code) if not block.setup else None
    if commands is not None:
        for argv in commands:
            _run_in_process(argv, block.where)
        return
    script = "set -e\n" + "".join(f"{s}\n" for s in block.setup) + block.code
    p = subprocess.run(["bash", "-c", script], cwd=cwd, env=env, capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, (f"{block.where}: exit {p.returncode}\n{block.code}\n"
                               f"{p.stdout[-2000:]}\n{p.stderr[-2000:]}")


@pytest.mark.parametrize("page", [p for p in PAGES if blocks(p)], ids=lambda p: str(p.relative_to(REPO)))
def test_page_runs(page, stand_ins, tmp_path, monkeypatch):
    env = _workdir(tmp_path, stand_ins)
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setenv("MPLBACKEND", "Agg")
    real_init = Evaluator.__init__

    def fewer_samples(self, original, samples=DOC_SAMPLES, seed=0):
        real_init(self, original, min(samples, DOC_SAMPLES), seed)

    monkeypatch.setattr(Evaluator, "__init__", fewer_samples)
    namespace = {"__name__": "__doc_test__"}
    import lodkit.metrics as registry
    monkeypatch.setattr(registry, "_registered", dict(registry._registered))   # register() stays on this page
    ran = 0
    for block in blocks(page):
        if block.skip:
            continue
        if block.lang == "python":
            _run_python(block, namespace, tmp_path)
        else:
            _run_shell(block, env, tmp_path)
        ran += 1
    for name in [m for m in sys.modules if m in {"anchor", "fields", "meshes", "normal_turn"}]:
        del sys.modules[name]                      # a page's own modules: not shared with the next page
    if ran == 0:
        pytest.skip("every block of this page is marked skip")


def test_the_collector():
    every = [b for p in PAGES for b in blocks(p)]
    assert len(every) >= 40, "the collector lost blocks"
    text = ("Text.\n\n<!-- doc-test: setup: mesh = 1 -->\n<!-- doc-test: skip: needs a window -->\n\n"
            "```python\nx = 1\n```\n\n```sh skip: the network\npip install x\n```\n"
            "```\n$ lodkit info a.ply\nn faces 3\n$ lodkit x \\\n    --y\n```\n```\nnot code\n```\n")
    a, b, c = blocks(REPO / "README.md", text)
    assert (a.lang, a.skip, a.setup, a.code) == ("python", "needs a window", ["mesh = 1"], "x = 1\n")
    assert (b.lang, b.skip) == ("sh", "the network")
    assert (c.lang, c.skip, c.code) == ("sh", "", "lodkit info a.ply\nlodkit x \\\n    --y\n")
