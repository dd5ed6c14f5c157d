#!/usr/bin/env bash
# Set everything up, then run the whole test suite (slow tests included; CI runs this). Extra args
# go to pytest, e.g. `bash scripts/test.sh -m "not slow"` for the fast lane. It installs every extra,
# so a skipped test fails here (XICM_STRICT_SKIPS=1, tests/strict_skips.py) unless it names the platform.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
# llm=llamacpp's tests run a real llama-server: built once per machine and cached (~7 min on 2 cores)
if ! command -v cmake >/dev/null || ! command -v g++ >/dev/null; then
  echo "[test] installing cmake and g++ (they build llama.cpp's llama-server)"
  SUDO=$([ "$(id -u)" -eq 0 ] && echo "" || echo sudo)
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends cmake g++ make >/dev/null
fi
PYTHON=.venv/bin/python bash scripts/build_llamacpp.sh >/dev/null
export WANDB_MODE=disabled HF_HUB_OFFLINE=1 TRANSFORMERS_OFFLINE=1 XICM_STRICT_SKIPS="${XICM_STRICT_SKIPS:-1}"
exec .venv/bin/python -m pytest -q "$@"
