#!/usr/bin/env bash
# Build llama.cpp's llama-server once for this machine (the script ships inside the package, so a
# wheel install builds it too): see src/xicm/plugins/llms/build_llamacpp.sh.
exec bash "$(dirname "$0")/../src/xicm/plugins/llms/build_llamacpp.sh" "$@"
