#!/usr/bin/env bash
# The main job: simulate the reference models with the release binary and
# write the trajectories to reports/. (Later issues add `diffosi reproduce all`.)
set -euo pipefail
cd "$(dirname "$0")/.."
mkdir -p reports
bin=target/release/diffosi
$bin simulate reference_models/cartpole.xml --steps 500 --q0 0,0.3 -o reports/simulate-cartpole.csv
$bin simulate reference_models/half_cheetah.xml --steps 1000 -o reports/simulate-half_cheetah.csv
$bin simulate reference_models/double_pendulum.urdf --steps 5000 --q0 1.0,-0.5 -o reports/simulate-double_pendulum.csv
$bin jacobian reference_models/half_cheetah.xml --v 0.5,0,0,1,-1,0.5,0,0,0 --tau 0,0,0,10,0,0,-10,0,0 \
    --params body/torso/mass,joint/bthigh/damping --json > reports/jacobian-half_cheetah.json
echo "wrote reports/jacobian-half_cheetah.json"
