#!/usr/bin/env bash
# Set everything up, then run the whole test suite (slow tests included; CI runs this). Extra args
# go to pytest, e.g. `bash scripts/test.sh -m "not slow"` for the fast lane. It installs every extra,
# so a skipped test fails here (XICM_STRICT_SKIPS=1, tests/strict_skips.py) unless it names the platform.
# The tests run in XICM_TEST_WORKERS pytest-xdist workers (default 2: the suite alone keeps about one
# core busy; 0 runs them in this process).
set -euo pipefail
cd "$(dirname "$0")/.."
# llm=llamacpp's tests run a real llama-server, compiled once per machine and cached (~7-12 min on
# 2 cores). Its build starts here, in the background under the lock those tests wait on, so it uses
# the cores that set-up (mostly downloads) leaves idle; tests/prebuild.py starts it, and the isolated
# environments' builds, when only pytest is run. The tests that wait for them run last.
if ! command -v cmake >/dev/null || ! command -v g++ >/dev/null; then
  echo "[test] installing cmake and g++ (they build llama.cpp's llama-server)"
  SUDO=$([ "$(id -u)" -eq 0 ] && echo "" || echo sudo)
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends cmake g++ make >/dev/null
fi
BUILD_LOG="${XICM_CACHE:-$HOME/.cache/xicm}/prebuild-llama_server-test_sh.log"
mkdir -p "$(dirname "$BUILD_LOG")"
nohup bash scripts/build_llamacpp.sh >"$BUILD_LOG" 2>&1 &
bash scripts/setup.sh
export WANDB_MODE=disabled HF_HUB_OFFLINE=1 TRANSFORMERS_OFFLINE=1 XICM_STRICT_SKIPS="${XICM_STRICT_SKIPS:-1}"
exec .venv/bin/python -m pytest -q -n "${XICM_TEST_WORKERS:-2}" "$@"
