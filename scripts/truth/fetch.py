"""Download the truth corpus's recordings (``corpus.toml``) into a cache outside the repository.

    python scripts/truth/fetch.py [--cache DIR] [--shared DIR]

Each file comes from ``https://raw.githubusercontent.com/<repository>/<commit>/<path>`` (the pinned
commit: reproducible on a clean machine with network access to GitHub only) and is kept only if
its SHA-256 matches the corpus (``--git OWNER/NAME=GITDIR`` reads it from a local clone instead,
``git show COMMIT:PATH``, with the same check); it lands in ``<cache>/<owner+name>/<commit[:12]>/<path>``
(default cache ``~/.cache/bayes_emt_truth``, or ``$BAYES_EMT_TRUTH_CACHE``). A driver whose source
is unreachable, or whose bytes differ, is skipped with one line. ``--shared DIR`` first looks for
an unchanged copy (``shared_copy`` in the corpus: the file name there) in DIR and uses it
in place if its hash matches. An entry's added-mass recordings (``[[driver.loaded]]``, each with its
``delta_m_kg``) and the file holding its reference (``[driver.reference_file]``) are fetched the
same way. Nothing is ever written inside the repository.
"""

from __future__ import annotations

import argparse
import hashlib
import os
import subprocess
import sys
import tomllib
import urllib.parse
import urllib.request
from pathlib import Path

HERE = Path(__file__).resolve().parent
CORPUS = HERE / "corpus.toml"


def load_corpus(path: Path = CORPUS) -> list[dict]:
    with open(path, "rb") as fh:
        return tomllib.load(fh)["driver"]


def default_cache() -> Path:
    return Path(os.environ.get("BAYES_EMT_TRUTH_CACHE", Path.home() / ".cache" / "bayes_emt_truth"))


def cached_path(entry: dict, cache: Path) -> Path:
    return source_path(entry["source"], cache)


def source_path(s: dict, cache: Path) -> Path:
    """Where a source (repository, commit, path) lands in the cache."""
    return cache / s["repository"].replace("/", "+") / s["commit"][:12] / s["path"]


def _sha(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def _from_git(s: dict, gitdirs: dict[str, Path]) -> bytes | None:
    """The file's bytes at the pinned commit from a local clone of its repository, if one is given."""
    g = gitdirs.get(s["repository"])
    if g is None:
        return None
    r = subprocess.run(["git", "--git-dir", str(g), "show", f"{s['commit']}:{s['path']}"],
                       capture_output=True, timeout=60)
    return r.stdout if r.returncode == 0 else None


def fetch_source(s: dict, label: str, cache: Path, shared: Path | None = None, timeout: float = 30.0,
                 gitdirs: dict[str, Path] | None = None) -> Path | None:
    """The local path of one source file (repository, commit, path, sha256) with its SHA-256 checked,
    or None (one line printed to stderr saying why). ``label`` names it in that line."""
    if shared is not None and s.get("shared_copy"):
        p = shared / s["shared_copy"]
        if p.is_file() and _sha(p.read_bytes()) == s["sha256"]:
            return p
    target = source_path(s, cache)
    if target.is_file():
        if _sha(target.read_bytes()) == s["sha256"]:
            return target
        print(f"skip {label}: cached {target} differs from the corpus SHA-256", file=sys.stderr)
        return None
    data = _from_git(s, gitdirs or {})
    where = f"{s['repository']}@{s['commit'][:12]}:{s['path']} (local clone)"
    if data is None:
        where = (f"https://raw.githubusercontent.com/{s['repository']}/{s['commit']}/"
                 + urllib.parse.quote(s["path"]))
        try:
            with urllib.request.urlopen(where, timeout=timeout) as r:
                data = r.read()
        except Exception as exc:  # noqa: BLE001 - any network failure is one skip line
            print(f"skip {label}: {where} unreachable ({type(exc).__name__}: {exc})", file=sys.stderr)
            return None
    if _sha(data) != s["sha256"]:
        print(f"skip {label}: {where} has SHA-256 {_sha(data)}, the corpus says {s['sha256']}",
              file=sys.stderr)
        return None
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = target.with_name(target.name + ".part")
    tmp.write_bytes(data)
    tmp.replace(target)  # atomic: never half a file under the final name
    return target


def fetch(entry: dict, cache: Path, shared: Path | None = None, timeout: float = 30.0,
          gitdirs: dict[str, Path] | None = None) -> Path | None:
    """The local path of ``entry``'s recording with its SHA-256 checked, or None (one line printed
    to stderr saying why)."""
    return fetch_source(entry["source"], entry["id"], cache, shared, timeout, gitdirs)


def fetch_loaded(entry: dict, cache: Path, shared: Path | None = None, timeout: float = 30.0,
                 gitdirs: dict[str, Path] | None = None) -> list[tuple[Path, float]] | None:
    """``entry``'s added-mass recordings as ``[(path, delta_m_kg), ...]`` (empty when it has none),
    or None when one of them is unavailable (a line printed for it)."""
    out = []
    for i, s in enumerate(entry.get("loaded", [])):
        p = fetch_source(s, f"{entry['id']} loaded[{i}]", cache, shared, timeout, gitdirs)
        if p is None:
            return None
        out.append((p, float(s["delta_m_kg"])))
    return out


def parse_git_options(items: list[str]) -> dict[str, Path]:
    """``OWNER/NAME=GITDIR`` options as a mapping (a clear error for a malformed one)."""
    out = {}
    for it in items:
        repo, sep, path = it.partition("=")
        if not sep or repo.count("/") != 1 or not path:
            raise SystemExit(f"--git {it!r}: expected OWNER/NAME=PATH_TO_A_GIT_DIRECTORY")
        out[repo] = Path(path)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cache", type=Path, default=None,
                    help="cache directory (default ~/.cache/bayes_emt_truth)")
    ap.add_argument("--shared", type=Path, default=None, help="a directory holding unchanged copies")
    ap.add_argument("--git", action="append", default=[], metavar="OWNER/NAME=GITDIR",
                    help="read that repository's files from a local clone (git show COMMIT:PATH) instead "
                         "of the network; the SHA-256 is checked the same way")
    a = ap.parse_args(argv)
    cache = a.cache or default_cache()
    gitdirs = parse_git_options(a.git)
    ok = 0
    entries = load_corpus()
    for e in entries:
        p = fetch(e, cache, a.shared, gitdirs=gitdirs)
        loaded = fetch_loaded(e, cache, a.shared, gitdirs=gitdirs)
        ref = (fetch_source(e["reference_file"], f"{e['id']} reference_file", cache, a.shared,
                            gitdirs=gitdirs) if "reference_file" in e else None)
        if p is not None and loaded is not None:
            ok += 1
            extra = "".join(f" + {q} ({1e3 * dm:g} g added)" for q, dm in loaded)
            print(f"{e['id']}: {p}{extra}" + (f"; reference file {ref}" if ref else ""))
    print(f"{ok} of {len(entries)} recordings available")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
