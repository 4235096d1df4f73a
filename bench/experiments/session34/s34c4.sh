#!/bin/bash
# Session 34, call 4 (nvidia-h200-x2): main dd224d0, the session's code after call 3 (test_carter_morphology names three files,
# StepEntry::set_by, --help, message and doc fixes; host code only). The same as call 3's script (s34c3.sh).
#   bash bench/experiments/session34/s34c4.sh gpu-carry/BUNDLE.tar.gz   carry: the bundle
bash "$(dirname "$0")/s34c3.sh" "$1" s34c4
