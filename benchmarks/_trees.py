"""Source trees that the A/B benchmarks compare (bn_ab, bn_cold_ir, sonar_filter).

A tree is given as a directory (a worktree or an exported copy) or as a commit of this
repository, which is exported (``git archive``, its ``src`` only) to a temporary directory
for the run. Either way the report names it by its commit, so that a table in
docs/benchmarks.md never points at a temporary path. A tree with the engine's C core (from
2026-12-05) has it compiled in place where it is not yet, as ``pip install`` would.
"""

from __future__ import annotations

import subprocess
import sysconfig
import tarfile
import tempfile
from contextlib import ExitStack
from io import BytesIO
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent


def _git(*args: str, cwd: Path = REPO) -> str | None:
    """Output of a git command, or ``None`` if it fails (not a checkout, unknown commit)."""
    try:
        done = subprocess.run(
            ["git", "-C", str(cwd), *args], capture_output=True, text=True, check=True
        )
    except (OSError, subprocess.CalledProcessError):
        return None
    return done.stdout.strip()


def source_tree(spec: str, stack: ExitStack) -> tuple[Path, str]:
    """The directory to run ``spec`` from and its label for the report.

    ``spec`` is a directory holding ``src/bayesmap`` (labelled by its checkout's commit, with
    ``+`` when its sources differ from it, or by its path if it is not a checkout), or else a
    commit of this repository (labelled by its short hash), exported for as long as
    ``stack`` is open.
    """
    path = Path(spec)
    if (path / "src" / "bayesmap").is_dir():
        path = path.resolve()
        _compile_extensions(path)
        head = _git("rev-parse", "--short", "HEAD", cwd=path)
        if head is None or _git("rev-parse", "--show-toplevel", cwd=path) != str(path):
            return path, f"`{path}`"
        dirty = _git("status", "--porcelain", "--", "src", cwd=path)
        return path, f"`{head}{'+' if dirty else ''}`"
    commit = _git("rev-parse", "--short", "--verify", f"{spec}^{{commit}}")
    if commit is None:
        raise SystemExit(f"{spec!r} is neither a source tree (no src/bayesmap) nor a commit")
    archive = subprocess.run(
        ["git", "-C", str(REPO), "archive", "--format=tar", commit, "src"],
        capture_output=True,
        check=True,
    ).stdout
    target = Path(stack.enter_context(tempfile.TemporaryDirectory(prefix=f"bayesmap-{commit}-")))
    with tarfile.open(fileobj=BytesIO(archive)) as tar:
        tar.extractall(target, filter="data")
    _compile_extensions(target)
    return target, f"`{commit}`"


def _compile_extensions(tree: Path) -> None:
    """Compile the engine's C core of ``tree`` into ``bayesmap/bn/_orders`` where it is
    missing or older than its sources (what setuptools does on install), with the compiler
    this Python was built with: the sources of ``bn/csrc`` (from 2026-12-05), or the one
    ``bn/_orders.c`` of the commits just before them."""
    package = tree / "src" / "bayesmap" / "bn"
    sources = sorted((package / "csrc").glob("*.c")) or sorted(package.glob("_orders.c"))
    if not sources:
        return
    module = package / ("_orders" + sysconfig.get_config_var("EXT_SUFFIX"))
    inputs = [*sources, *(package / "csrc").glob("*.h")]
    if module.exists() and module.stat().st_mtime >= max(p.stat().st_mtime for p in inputs):
        return
    compiler = (sysconfig.get_config_var("CC") or "cc").split()
    include = sysconfig.get_paths()["include"]
    flags = ["-O2", "-shared", "-fPIC", f"-I{include}"]
    subprocess.run([*compiler, *flags, *map(str, sources), "-o", str(module)], check=True)
