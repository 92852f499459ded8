#!/usr/bin/env bash
# Fake cluster submit: run the job script (last argument) in the background, detached, with its
# output in logs/fake-cluster/, and print a job id as a scheduler would.
set -euo pipefail
jobscript="${@: -1}"
mkdir -p logs/fake-cluster
id="fake-$(date +%s%N)"
OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 nohup bash "$jobscript" > "logs/fake-cluster/$id.out" 2>&1 &
echo "$id"
