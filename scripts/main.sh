#!/usr/bin/env bash
# The main job (`make run`): the paper's cartpole, half-cheetah and wiping results on
# the shipped controllers, the MPC runtime comparison, the transfer-gap reports against MuJoCo, PyBullet and DART, and
# the proof of our dynamics against them; everything goes to reports/.
set -euo pipefail
cd "$(dirname "$0")/.."
mkdir -p reports
bin=target/release/diffosi
py=.venv/bin/python
start=$SECONDS

# Tables 1, 2 and 4 and the window studies (paper Sections 4.2-4.3, Fig. 4):
# the cartpole and the half cheetah; Table 3 and the higher-dimension study
# (Section 4.4, Fig. 6): the wiping task.
$bin reproduce all
$py -m harness figures --task cartpole
$py -m harness figures --task half_cheetah
$py -m harness figures --task wiping-dims
# The paper's runtime comparison: iLQR MPC (horizon 200, replanning every 40
# control steps) against UC-DiffOSI over the same 40 steps, half cheetah.
$bin mpc --task half_cheetah
# The cartpole's MPC (horizon 60, replanning every 5): it balances every pole.
$bin mpc --task cartpole --episodes 10

# Transfer gaps (paper Section 4.6, Table 5): the targets as a user leaves them,
# then with effects our model lacks.
$py -m harness transfer --task cartpole --target all
$py -m harness transfer --task cartpole --target all --unmodelled friction
$py -m harness transfer --task cartpole --target all --unmodelled friction,delay
# The half cheetah's shipped controllers in MuJoCo running gymnasium's HalfCheetah-v5.
$py -m harness transfer --task half_cheetah --target mujoco

# Our dynamics and gradients against the reference engines.
for model in cartpole half_cheetah; do
    $py -m harness replay --model $model --engines mujoco,pybullet,dart --steps 500 --seed 0
done
for model in cartpole double_pendulum half_cheetah; do
    $py -m harness gradcheck --model $model
done
# Ball and free joints (the ant, the humanoid) and fluid: tangent-space Jacobians vs MuJoCo's.
$py -m harness gradcheck-free --states 5 --seed 0
# Contact: the half cheetah on its floor vs MuJoCo and PyBullet; the resting box in all engines.
$py -m harness contact --steps 500 --samples 200 --seed 0
# The wiping episode's torques replayed in MuJoCo, PyBullet and DART.
$py -m harness wiping-replay --mu 50,50 --steps 3000
# The wiping controllers and DiffOSI on the arm as MuJoCo, PyBullet and DART run it (transfer gap).
$py -m harness transfer --task wiping --target all --runs 5

# The transfer overview (every task x target x method) from the per-target reports, into
# reports/overview.* and the README; the half cheetah's PyBullet and DART reports come from
# the full study (`make study`).
$py -m harness overview --readme

# Example trajectories and a Jacobian from the command line.
$bin simulate reference_models/cartpole.xml --steps 500 --q0 0,0.3 -o reports/simulate-cartpole.csv
$bin jacobian reference_models/half_cheetah.xml --v 0.5,0,0,1,-1,0.5,0,0,0 --tau 0,0,0,10,0,0,-10,0,0 \
    --params body/torso/mass,joint/bthigh/damping --json > reports/jacobian-half_cheetah.json
echo "main job done in $((SECONDS - start)) s; reports in reports/"
