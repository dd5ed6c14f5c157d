#!/usr/bin/env bash
# Set xicm up on a fresh Debian/Ubuntu machine; safe to run again (it skips what is done).
#   - the Vulkan CPU driver (Mesa >= 23 lavapipe) when no usable Vulkan device exists
#   - Debian's chromium and chromedriver (the report's browser test) when missing
#   - a virtual environment in .venv
#   - torch first (torch==2.13.0; XICM_TORCH_SPEC overrides), so no other package pulls a CUDA build
#   - xicm itself, editable, with every extra (LLM, serving, tests)
#   - FFmpeg's shared libraries: xicm-export's LeRobot datasets are read back (torchcodec) with them
set -euo pipefail
cd "$(dirname "$0")/.."

bash scripts/install_vulkan.sh
if ! ldconfig -p | grep -q libavcodec; then
  echo "[setup] installing ffmpeg (its libraries decode LeRobot dataset videos)"
  SUDO=$([ "$(id -u)" -eq 0 ] && echo "" || echo sudo)
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends ffmpeg >/dev/null
fi
bash scripts/install_chromium.sh

PYTHON="${PYTHON:-python3}"
if [ ! -x .venv/bin/python ]; then
  echo "[setup] creating .venv with $($PYTHON --version)"
  "$PYTHON" -m venv .venv
fi
PIP=(.venv/bin/python -m pip install --quiet --disable-pip-version-check)
pip_install() {  # pip, minus the warnings about this machine's extra local indexes
  "${PIP[@]}" "$@" 2> >(grep -v "^WARNING: Location 'file:" >&2)
}

if ! .venv/bin/python -c "import torch" 2>/dev/null; then
  echo "[setup] installing ${XICM_TORCH_SPEC:-torch==2.13.0}"
  # shellcheck disable=SC2086
  pip_install ${XICM_TORCH_SPEC:-torch==2.13.0}
fi
echo "[setup] installing xicm[all]"
pip_install -e ".[all]"
echo "[setup] done: $(.venv/bin/python -c 'import xicm, torch, sapien; print("xicm", xicm.__version__, "| torch", torch.__version__, "| sapien", sapien.__version__)')"
