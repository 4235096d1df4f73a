#!/bin/bash
# Session 35, call 1 (one H200): main 397acd6, the four host-only commits after session 34's last
# GPU run (b4f7a4d, e730484, cf3254e, 397acd6). The whole CUDA suite, then every issue-20 row in one
# lease: HOOMD-blue's ABP + WCA beside flipflow's 2^14 and 2^20, 2^20 after 3 000 steps, Carter side
# by side, the sweep. Session 33's call 3 script under this call's name.
#   bash bench/experiments/session35/s35c1.sh gpu-carry/BUNDLE.tar.gz
#   carry: the bundle, gpu-carry/hoomd-kit.tgz, gpu-carry/peers-bundle.tar.gz
bash "$(dirname "$0")/../session33/s33c3.sh" "$1" s35c1
