#!/usr/bin/env bash
# Debian's chromium and chromedriver for the report's browser test (tests/test_report_browser.py);
# safe to run again: skipped when both are on PATH.
set -euo pipefail

if command -v chromium >/dev/null 2>&1 && command -v chromedriver >/dev/null 2>&1; then
  echo "[chromium] $(chromium --version 2>/dev/null | head -1) and chromedriver already installed"
  exit 0
fi
SUDO=""
if [ "$(id -u)" != "0" ]; then SUDO="sudo"; fi
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq chromium chromium-driver >/dev/null
echo "[chromium] installed $(chromium --version 2>/dev/null | head -1)"
