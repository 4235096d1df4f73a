#!/bin/bash
# Session 35, call 4 (one H200): main e7c3e37 (the step's code as since session 33): CUPTI
# timelines of bench-abp at 2^10, 2^14, 2^16 and 2^20, issue 20's "GPU timeline of one ABP step",
# as of now; session 31's call-1 script under this call's name.
#   bash bench/experiments/session35/s35c4.sh gpu-carry/BUNDLE.tar.gz   carry: the bundle
bash "$(dirname "$0")/../session31/s31c1.sh" "$1" s35c4
