#!/bin/bash
# Leave-one-generator-out on a folder of `gap_calibrate.py record` files: fit each rotation
# on the other two generators' records (fit: rewrites DIR/cal_*.json, as committed the files
# frozen before that folder's fresh draw), score each generator's seen records under its
# rotation (seen), or its fresh draw: the folder's highest-numbered fresh*_etsid, fresh*_py
# and fresh*_mr files (fresh).
#   bash benchmarks/gap_logo.sh benchmarks/records/gap_s15 fit|seen|fresh
set -e
O=${1:?records folder}
mode=${2:-seen}
cd "$(dirname "$0")/.."  # the repository root
newest() { ls "$O"/fresh*_"$1".jsonl | sort | tail -n 1; }
ET="$O/seen_etsid.jsonl"
PY="$O/none_py.jsonl $O/draw740_py.jsonl $O/seen_py.jsonl $O/accel_py.jsonl"
MR="$O/none_mr.jsonl $O/draw740_mr.jsonl $O/seen_mr.jsonl"
for g in etsid pyflyt multirotor; do
  case $g in etsid) others=pyflyt,multirotor; cal_in="$PY $MR"; own="$ET"; fresh=$(newest etsid);;
             pyflyt) others=etsid,multirotor; cal_in="$ET $MR"; own="$PY"; fresh=$(newest py);;
             multirotor) others=etsid,pyflyt; cal_in="$ET $PY"; own="$MR"; fresh=$(newest mr);; esac
  if [ "$mode" = fit ]; then
    python benchmarks/gap_calibrate.py fit $cal_in --generators $others --out $O/cal_$g.json | tail -n 1
  elif [ "$mode" = seen ]; then
    python benchmarks/gap_calibrate.py score $own --generator $g --calibration $O/cal_$g.json | tail -n 1
  else
    python benchmarks/gap_calibrate.py score $fresh --generator $g --calibration $O/cal_$g.json | tail -n 1
  fi
done
