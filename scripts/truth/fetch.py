"""Download the truth corpus's recordings (``corpus.toml``) into a cache outside the repository.

    python scripts/truth/fetch.py [--cache DIR] [--shared DIR]

Each file comes from ``https://raw.githubusercontent.com/<repository>/<commit>/<path>`` (the pinned
commit: reproducible on a clean machine with network access to GitHub only) and is kept only if
its SHA-256 matches the corpus; it lands in ``<cache>/<owner+name>/<commit[:12]>/<path>``
(default cache ``~/.cache/bayes_emt_truth``, or ``$BAYES_EMT_TRUTH_CACHE``). A driver whose source
is unreachable, or whose bytes differ, is skipped with one line. ``--shared DIR`` first looks for
an unchanged copy (``shared_copy`` in the corpus: the file name there) in DIR and uses it
in place if its hash matches. Nothing is ever written inside the repository.
"""

from __future__ import annotations

import argparse
import hashlib
import os
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
    s = entry["source"]
    return cache / s["repository"].replace("/", "+") / s["commit"][:12] / s["path"]


def _sha(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def fetch(entry: dict, cache: Path, shared: Path | None = None, timeout: float = 30.0) -> Path | None:
    """The local path of ``entry``'s recording with its SHA-256 checked, or None (one line printed
    to stderr saying why)."""
    s = entry["source"]
    if shared is not None and s.get("shared_copy"):
        p = shared / s["shared_copy"]
        if p.is_file() and _sha(p.read_bytes()) == s["sha256"]:
            return p
    target = cached_path(entry, cache)
    if target.is_file():
        if _sha(target.read_bytes()) == s["sha256"]:
            return target
        print(f"skip {entry['id']}: cached {target} differs from the corpus SHA-256", file=sys.stderr)
        return None
    url = (f"https://raw.githubusercontent.com/{s['repository']}/{s['commit']}/"
           + urllib.parse.quote(s["path"]))
    try:
        with urllib.request.urlopen(url, timeout=timeout) as r:
            data = r.read()
    except Exception as exc:  # noqa: BLE001 - any network failure is one skip line
        print(f"skip {entry['id']}: {url} unreachable ({type(exc).__name__}: {exc})", file=sys.stderr)
        return None
    if _sha(data) != s["sha256"]:
        print(f"skip {entry['id']}: {url} has SHA-256 {_sha(data)}, the corpus says {s['sha256']}",
              file=sys.stderr)
        return None
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = target.with_name(target.name + ".part")
    tmp.write_bytes(data)
    tmp.replace(target)  # atomic: never half a file under the final name
    return target


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cache", type=Path, default=None,
                    help="cache directory (default ~/.cache/bayes_emt_truth)")
    ap.add_argument("--shared", type=Path, default=None, help="a directory holding unchanged copies")
    a = ap.parse_args(argv)
    cache = a.cache or default_cache()
    ok = 0
    entries = load_corpus()
    for e in entries:
        p = fetch(e, cache, a.shared)
        if p is not None:
            ok += 1
            print(f"{e['id']}: {p}")
    print(f"{ok} of {len(entries)} recordings available")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
