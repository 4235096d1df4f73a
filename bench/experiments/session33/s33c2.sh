#!/bin/bash
# Session 33, call 2: session 32's next-call1.sh on main 18ef429 (where Lawson's gated launch
# should switch to a grid round first: half a pass, v33h, and a quarter, v33q), its output in c2/.
#   bash bench/experiments/session33/s33c2.sh gpu-carry/b33a.tar.gz   carry: b33a, v33h, v33q
bash bench/experiments/session32/next-call1.sh "$1" c2
