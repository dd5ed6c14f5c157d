#!/usr/bin/env bash
# Set everything up, collect a small demonstration pool (resumable), evaluate X-ICM on the
# smoke benchmark and print the success table. Extra args are Hydra overrides for xicm-eval,
# e.g. `bash scripts/main.sh llm=gemma3_270m policy.k=2`.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
export HF_HUB_OFFLINE=1 TRANSFORMERS_OFFLINE=1
.venv/bin/xicm-collect benchmark=smoke collect.demos_per_task=5
# One run folder per code version: a re-run resumes (and prints the table at once); a checkout
# with other code starts a new folder instead of refusing the old one's different config.
version=$(git rev-parse --short HEAD 2>/dev/null || echo unversioned)
.venv/bin/xicm-eval benchmark=smoke seeds=[0,1] episodes=5 "hydra.run.dir=outputs/\${run_name}/$version" "$@"
