#!/bin/bash
# Leave-one-generator-out on the gap_s15 records: fit each rotation on the other two
# generators' records (fit), score its own seen records (seen) or its fresh draw (fresh).
# bash benchmarks/records/gap_s15/logo.sh fit|seen|fresh
# fit rewrites cal_*.json beside the records (as committed, the files frozen before the seventh draw).
set -e
cd "$(dirname "$0")/../../.."  # the repository root
O=benchmarks/records/gap_s15
ET="$O/seen_etsid.jsonl"
PY="$O/none_py.jsonl $O/draw740_py.jsonl $O/seen_py.jsonl $O/accel_py.jsonl"
MR="$O/none_mr.jsonl $O/draw740_mr.jsonl $O/seen_mr.jsonl"
mode=${1:-seen}
for g in etsid pyflyt multirotor; do
  case $g in etsid) others=pyflyt,multirotor; cal_in="$PY $MR"; own="$ET"; fresh=$O/fresh870_etsid.jsonl;;
             pyflyt) others=etsid,multirotor; cal_in="$ET $MR"; own="$PY"; fresh=$O/fresh770_py.jsonl;;
             multirotor) others=etsid,pyflyt; cal_in="$ET $PY"; own="$MR"; fresh=$O/fresh770_mr.jsonl;; esac
  if [ "$mode" = fit ]; then
    python benchmarks/gap_calibrate.py fit $cal_in --generators $others --out $O/cal_$g.json | tail -n 1
  elif [ "$mode" = seen ]; then
    python benchmarks/gap_calibrate.py score $own --generator $g --calibration $O/cal_$g.json | tail -n 1
  else
    python benchmarks/gap_calibrate.py score $fresh --generator $g --calibration $O/cal_$g.json | tail -n 1
  fi
done
