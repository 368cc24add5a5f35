"""Fuzz lodkit's file readers and simplify() (issue 18, item 9).

    python bench/fuzz.py --minutes 2                 # every target, the time split between them
    python bench/fuzz.py --minutes 60 --target ply   # one target
    python bench/fuzz.py --engine mutate ...         # without atheris

Targets: one per reader (ply, obj, off, stl, glb, gltf: the bytes of a file, from seeds of
valid files that lodkit wrote) and ``simplify`` (vertex and face arrays and options decoded
from the bytes). A *crash* is anything but the errors lodkit raises on purpose
(:class:`lodkit.errors.LodkitError`; the readers' FileFormatError, which load() turns into
MeshIOError) -- a Python exception of another type, a signal, or an input taking longer
than ``--timeout`` seconds (a *hang*).

Engines: atheris (coverage-guided libFuzzer; ``pip install "lodkit[fuzz]"``), one
subprocess per target, or ``mutate`` (seeds mutated at random, in-process) when atheris
is not installed. Every crashing input is written to ``tests/fuzz_corpus/<target>/`` (test
tests/test_fuzz_corpus.py replays them all); the summary line per target gives executions,
crashes and hangs. Exit status 1 if anything crashed or hung.

Run it against the lodkit you mean to test: from the source tree with PYTHONPATH=. (built in
place), or against the installed copy (bench/ is first on sys.path, not the checkout).
"""
from __future__ import annotations

import argparse
import hashlib
import json
import re
import struct
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
CORPUS = ROOT / "tests" / "fuzz_corpus"
READERS = ("ply", "obj", "off", "stl", "glb", "gltf")
BLOCK_READERS = ("obj-blocks", "off-blocks")     # lodkit.io.stream: text read in blocks (simplify_large)
TARGETS = READERS + BLOCK_READERS + ("simplify",)
METRICS = ("qem", "qem_native", "melod", "curvature", "appearance", "schroeder", "volume",
           ("normal_qem", {"normals": "estimate"}), ["qem", ("importance", {"values": "height"})])


# ------------------------------------------------------------------ the targets
def check_reader(fmt: str, data: bytes) -> None:
    """Read ``data`` as a ``fmt`` file the way lodkit.load does; raise if it crashes."""
    from lodkit.errors import LodkitError
    from lodkit.io import read_file
    from lodkit.io.common import FileFormatError
    from lodkit.mesh import Mesh

    try:
        got = read_file(data, fmt, None)
        Mesh(got.vertices, got.faces, normals=got.normals, colors=got.colors, uvs=got.uvs)
    except (FileFormatError, LodkitError):
        pass


def check_blocks(target: str, data: bytes) -> None:
    """Convert ``data`` as an OBJ / OFF file into a binary PLY the way simplify_large does,
    in blocks of 1-64 bytes (the first byte chooses: every cut position gets tried); raise
    if it crashes."""
    import tempfile

    from lodkit.io.common import FileFormatError
    from lodkit.io.stream import to_binary_ply

    fmt = target.split("-")[0]
    with tempfile.TemporaryDirectory() as tmp:
        src = Path(tmp) / f"in.{fmt}"
        src.write_bytes(data)
        try:
            to_binary_ply(src, Path(tmp) / "out.ply", size=1 + (data[0] % 64 if data else 0))
        except FileFormatError:
            pass


class Bytes:
    """Deterministic values decoded from fuzz bytes (zeros once they run out)."""

    def __init__(self, data: bytes):
        self.data, self.pos = data, 0

    def take(self, n: int) -> bytes:
        chunk = self.data[self.pos: self.pos + n]
        self.pos += n
        return chunk.ljust(n, b"\0")

    def int(self, lo: int, hi: int) -> int:
        return lo + int.from_bytes(self.take(2), "little") % (hi - lo + 1)

    def float(self) -> float:
        kind = self.int(0, 15)
        if kind == 0:
            return struct.unpack("<d", self.take(8))[0]              # anything, nan and inf included
        if kind == 1:
            return [0.0, -0.0, 1e-300, 1e300, 1e-170, 1e170, float("nan"), float("inf")][self.int(0, 7)]
        return (self.int(0, 2000) - 1000) / 100.0

    def choice(self, seq):
        return seq[self.int(0, len(seq) - 1)]


def simplify_case(data: bytes) -> tuple:
    b = Bytes(data)
    nv = b.int(0, 40)
    vertices = np.array([[b.float() for _ in range(3)] for _ in range(nv)]).reshape(nv, 3)
    if nv and b.int(0, 3) == 0:                      # a regular grid: a valid mesh that simplifies
        g = max(2, int(nv ** 0.5))
        x, y = np.meshgrid(np.arange(g), np.arange(g), indexing="ij")
        vertices = np.stack([x, y, np.sin(x * y)], -1).reshape(-1, 3).astype(float)
        nv = vertices.shape[0]
        idx = np.arange(nv).reshape(g, g)
        a, c1, c2, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
        faces = np.concatenate([np.stack([a, c1, c2], 1), np.stack([a, c2, d], 1)])
        for _ in range(b.int(0, 3)):                  # a few corrupted indices
            if faces.size:
                faces[b.int(0, faces.shape[0] - 1), b.int(0, 2)] = b.int(0, nv + 2) - 1
    else:
        nf = b.int(0, 60)
        faces = np.array([[b.int(0, nv + 2) - 1 for _ in range(3)] for _ in range(nf)]).reshape(nf, 3)
    opts = {"metric": b.choice(METRICS)}
    which = b.int(0, 3)
    if which == 0:
        opts["target_ratio"] = b.choice([b.float(), b.int(0, 100) / 100.0, "abc", [0.5], None])
    elif which == 1:
        opts["target_faces"] = b.choice([b.int(0, 100) - 5, 10 ** 12, 2.5])
    else:
        opts["target_ratio"] = b.int(1, 99) / 100.0
    if b.int(0, 3) == 0:
        opts["max_error"] = b.choice([b.float(), "x"])
    if b.int(0, 3) == 0:
        opts["operator"] = b.choice(["edge", "triangle", "vertex", "bogus"])
    if b.int(0, 3) == 0:
        opts["placement"] = b.choice(["optimal", "endpoint", "middle"])
    if b.int(0, 3) == 0:
        opts["boundary"] = b.choice(["preserve", "lock", "free", 3])
    if b.int(0, 4) == 0:
        opts["max_normal_angle"] = b.choice([b.float(), 30.0])
    if b.int(0, 4) == 0:
        opts["min_quality"] = b.choice([b.float(), 0.1])
    if b.int(0, 4) == 0:
        opts["pair_threshold"] = b.choice([b.float(), 0.01])
    if b.int(0, 4) == 0:
        opts["driver"] = b.choice(["greedy", "pass", "nope"])
    if b.int(0, 4) == 0:
        opts["polish"] = b.choice([True, 1, -1, "x"])
    return vertices, faces, opts


# Errors the fuzzers find that another branch of issue 18 fixes (item 6: every input error
# a lodkit error -- option values of the wrong type, a target_faces beyond int64). They are
# counted as "known", not as crashes, and kept as known-* in the corpus; once that work is
# merged they no longer occur and this list can go.
KNOWN_OPEN = [
    (ValueError, r"could not convert string to float"),
    (TypeError, r"float\(\) argument must be"),
    (TypeError, r"int\(\) argument must be"),
    (OverflowError, r"too large to convert|int too large|Python int too large"),
    # pair_threshold with coordinates near 1e300: scipy's KD-tree overflows (lodkit/pairs.py);
    # found by atheris, tests/fuzz_corpus/simplify/known-pairs-overflow-*
    (ValueError, r"Encountering floating point overflow"),
]


class KnownIssue(Exception):
    """A failure matching KNOWN_OPEN."""


def check_simplify(data: bytes) -> None:
    from lodkit import simplify
    from lodkit.errors import LodkitError

    vertices, faces, opts = simplify_case(data)
    try:
        result = simplify((vertices, faces), **opts)
    except LodkitError:
        return
    except Exception as exc:
        if any(isinstance(exc, cls) and re.search(rx, str(exc)) for cls, rx in KNOWN_OPEN):
            raise KnownIssue(f"{type(exc).__name__}: {exc}") from exc
        raise
    out_vertices, out_faces = result.mesh          # a (V, F) tuple in gives one out
    if out_faces.size and (out_faces.min() < 0 or out_faces.max() >= out_vertices.shape[0]):
        raise AssertionError(f"simplify returned out-of-range faces for {opts}")
    if opts.get("polish") and np.isfinite(vertices).all() and not np.isfinite(out_vertices).all():
        raise AssertionError(f"polish made a position that is not finite for {opts}")


def check(target: str, data: bytes) -> None:
    if target == "simplify":
        check_simplify(data)
    elif target in BLOCK_READERS:
        check_blocks(target, data)
    else:
        check_reader(target, data)


# ------------------------------------------------------------------ seeds
def seeds(target: str) -> list[bytes]:
    """Valid inputs to mutate: small meshes lodkit wrote in the format (every attribute
    combination), plus the corpus kept in tests/fuzz_corpus/<target>/."""
    out = []
    if target in BLOCK_READERS:
        return seeds(target.split("-")[0]) + _corpus(target)
    if target in READERS:
        import tempfile
        import warnings

        from lodkit.io import save
        from lodkit.mesh import Mesh

        v = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]])
        f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3], [1, 4, 2]])
        rng = np.random.default_rng(0)
        variants = [{}, {"normals": rng.random((5, 3)) + 0.1}, {"colors": rng.random((5, 4))},
                    {"colors": rng.random((5, 3)), "uvs": rng.random((5, 2))}]
        with tempfile.TemporaryDirectory() as tmp, warnings.catch_warnings():
            warnings.simplefilter("ignore")
            for i, kw in enumerate(variants):
                for ascii in ((False, True) if target == "ply" else (False,)):
                    p = Path(tmp) / f"s{i}{int(ascii)}.{target}"
                    save(Mesh(v, f, **kw), p, ascii=ascii)
                    out.append(p.read_bytes())
        if target == "obj":
            out.append(b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nvt 0 0\nvn 0 0 1\nf 1/1/1 2/1/1 3/1/1 4/1/1\n"
                       b"f -1 -2 -3\ng x\nusemtl m\nf 1//1 2//1 5//1\n")
        if target == "off":
            out.append(b"COFF\n4 2 0\n0 0 0 255 0 0\n1 0 0 0 255 0\n1 1 0 0 0 255\n0 1 0 9 9 9\n"
                       b"4 0 1 2 3\n3 0 1 2 1 1 1\n")
    else:
        for i in range(8):
            out.append(hashlib.sha256(str(i).encode()).digest() * 4)
    return out + _corpus(target)


def _corpus(target: str) -> list[bytes]:
    d = CORPUS / target
    return [p.read_bytes() for p in sorted(d.iterdir()) if p.is_file()] if d.is_dir() else []


def corpus_files(target: str) -> list[Path]:
    d = CORPUS / target
    return sorted(p for p in d.iterdir() if p.is_file()) if d.is_dir() else []


# ------------------------------------------------------------------ engines
def run_atheris_child(target: str, seconds: int, timeout: int, work: Path) -> dict:
    """This process fuzzes one target with atheris (called through --child)."""
    import atheris

    with atheris.instrument_imports():
        import lodkit.io  # noqa: F401
        import lodkit.io.gltf  # noqa: F401
        import lodkit.io.obj  # noqa: F401
        import lodkit.io.off  # noqa: F401
        import lodkit.io.ply  # noqa: F401
        import lodkit.io.stl  # noqa: F401
        import lodkit.mesh  # noqa: F401
        if target == "simplify":
            import lodkit._pipeline  # noqa: F401
            import lodkit.api  # noqa: F401

    def one(data: bytes) -> None:
        try:
            check(target, data)
        except KnownIssue:
            pass

    for i, s in enumerate(seeds(target)):
        (work / f"seed{i}").write_bytes(s)
    (CORPUS / target).mkdir(parents=True, exist_ok=True)
    args = [sys.argv[0], str(work), f"-max_total_time={seconds}", f"-timeout={timeout}",
            f"-artifact_prefix={CORPUS / target}/", "-max_len=65536", "-print_final_stats=1",
            "-rss_limit_mb=3072"]
    atheris.Setup(args, one)
    atheris.Fuzz()
    return {}


def run_atheris(target: str, seconds: int, timeout: int) -> dict:
    import shutil
    import tempfile

    before = set(corpus_files(target))
    t0 = time.time()
    work = tempfile.mkdtemp(prefix=f"lodkit-fuzz-{target}-")     # libFuzzer's working corpus
    try:
        proc = subprocess.run([sys.executable, __file__, "--child", target, "--seconds", str(seconds),
                               "--timeout", str(timeout), "--workdir", work], capture_output=True, text=True,
                              timeout=seconds + 600)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    runs = re.findall(r"stat::number_of_executed_units:\s*(\d+)", proc.stderr)
    if not runs:
        runs = re.findall(r"Done (\d+) runs", proc.stderr)
    new = sorted(set(corpus_files(target)) - before)
    crashes = [p for p in new if not p.name.startswith(("timeout-", "slow-unit-"))]
    hangs = [p for p in new if p.name.startswith("timeout-")]
    if proc.returncode != 0 and not new:
        crashes.append(Path(f"<exit {proc.returncode}: {proc.stderr.strip().splitlines()[-1:]}>"))
    return {"target": target, "engine": "atheris", "seconds": round(time.time() - t0, 1),
            "executions": int(runs[-1]) if runs else 0, "crashes": len(crashes), "hangs": len(hangs),
            "new_files": [str(p) for p in new]}


def run_mutate(target: str, seconds: float, timeout: int, keep_to: Path | None = CORPUS) -> dict:
    """Without atheris: seeds mutated at random (flipped, inserted, deleted, spliced bytes)
    for ``seconds``, each input in-process (a hang is caught by the elapsed time of the one
    input). Crashing inputs are kept under ``keep_to`` (None: not kept)."""
    import random

    rng = random.Random(int(time.time()))
    pool = seeds(target) or [b""]
    t0, n, crashes, hangs, known = time.time(), 0, 0, 0, 0
    while time.time() - t0 < seconds:
        base = bytearray(rng.choice(pool))
        for _ in range(rng.randint(1, 8)):
            op = rng.randint(0, 3)
            if op == 0 and base:
                base[rng.randrange(len(base))] = rng.randrange(256)
            elif op == 1:
                junk = bytes(rng.randrange(256) for _ in range(rng.randint(0, 8)))
                base[rng.randint(0, len(base)):rng.randint(0, len(base))] = junk
            elif op == 2 and base:
                del base[rng.randrange(len(base)): rng.randrange(len(base) + 1)]
            else:
                at = rng.randint(0, len(base))
                base[at:at] = rng.choice(pool)[: rng.randint(0, 64)]
        data = bytes(base)
        start = time.time()
        try:
            check(target, data)
        except KnownIssue:
            known += 1
            if keep_to is not None and known == 1:
                keep(target, data, "known", keep_to)
        except Exception as exc:  # noqa: BLE001 -- a crash of the target
            crashes += 1
            if keep_to is not None:
                keep(target, data, f"crash-{type(exc).__name__}", keep_to)
        if time.time() - start > timeout:
            hangs += 1
            if keep_to is not None:
                keep(target, data, "timeout", keep_to)
        n += 1
    return {"target": target, "engine": "mutate", "seconds": round(time.time() - t0, 1),
            "executions": n, "crashes": crashes, "hangs": hangs, "known": known}


def keep(target: str, data: bytes, kind: str, where: Path = CORPUS) -> Path:
    d = where / target
    d.mkdir(parents=True, exist_ok=True)
    p = d / f"{kind}-{hashlib.sha1(data).hexdigest()}"
    p.write_bytes(data)
    return p


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, default=2.0, help="total time, split between the targets")
    ap.add_argument("--target", choices=TARGETS + ("all",), default="all")
    ap.add_argument("--engine", choices=("auto", "atheris", "mutate"), default="auto")
    ap.add_argument("--timeout", type=int, default=20, help="seconds one input may take before it is a hang")
    ap.add_argument("--json", help="write the per-target figures here")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    ap.add_argument("--seconds", type=int, help=argparse.SUPPRESS)
    ap.add_argument("--workdir", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        run_atheris_child(args.child, args.seconds, args.timeout, Path(args.workdir))
        return 0
    engine = args.engine
    if engine == "auto":
        try:
            import atheris  # noqa: F401
            engine = "atheris"
        except ImportError:
            engine = "mutate"
    targets = TARGETS if args.target == "all" else (args.target,)
    per = max(5, int(args.minutes * 60 / len(targets)))
    import lodkit
    print(f"fuzzing {lodkit.__file__} with {engine}, {per} s per target", flush=True)
    rows = []
    for t in targets:
        row = (run_atheris if engine == "atheris" else run_mutate)(t, per, args.timeout)
        rows.append(row)
        print(f"{t:9s} executions {row['executions']:>9d}  crashes {row['crashes']}  hangs {row['hangs']}"
              f"  ({row['seconds']} s)", flush=True)
        for f in row.get("new_files", []):
            print(f"          kept {f}")
    total = {k: sum(r[k] for r in rows) for k in ("executions", "crashes", "hangs")}
    print(f"total     executions {total['executions']:>9d}  crashes {total['crashes']}  hangs {total['hangs']}")
    if args.json:
        Path(args.json).write_text(json.dumps({"engine": engine, "targets": rows, "total": total}, indent=1))
    return 1 if total["crashes"] or total["hangs"] else 0


if __name__ == "__main__":
    sys.exit(main())
