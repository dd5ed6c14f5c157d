#!/usr/bin/env bash
# Set everything up, then run the whole test suite (slow tests included; CI runs this). Extra args
# go to pytest, e.g. `bash scripts/test.sh -m "not slow"` for the fast lane. It installs every extra,
# so a skipped test fails here (XICM_STRICT_SKIPS=1, tests/strict_skips.py) unless it names the platform.
# The tests run in XICM_TEST_WORKERS pytest-xdist workers (default 2: the suite alone keeps about one
# core busy; 0 runs them in this process).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
# llm=llamacpp's tests run a real llama-server, compiled once per machine and cached (~7-12 min on
# 2 cores): tests/prebuild.py starts that build, and the isolated environments', in the background
# when the tests are collected; the tests that wait for them run last (tests/file_order.py)
if ! command -v cmake >/dev/null || ! command -v g++ >/dev/null; then
  echo "[test] installing cmake and g++ (they build llama.cpp's llama-server)"
  SUDO=$([ "$(id -u)" -eq 0 ] && echo "" || echo sudo)
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends cmake g++ make >/dev/null
fi
export WANDB_MODE=disabled HF_HUB_OFFLINE=1 TRANSFORMERS_OFFLINE=1 XICM_STRICT_SKIPS="${XICM_STRICT_SKIPS:-1}"
exec .venv/bin/python -m pytest -q -n "${XICM_TEST_WORKERS:-2}" "$@"
