#!/bin/bash
# Two training sets judged by the models trained on them: the shipped recipe
# (tools/train_shipped_model.py) trained on each pack with seeds 1 and 2, all four runs side by side on
# one GPU (batch 64; about 3.5 minutes for two runs on an H200), each evaluated on PMD-I after training.
#
#   bash tools/train_pair.sh PACK_A PACK_B [DEADLINE_S] [OUT]
#
# PACK_A, PACK_B: `pressurepose pack` files made with the same recipe and seeds (e.g. the default settle
# and `--settle relaxed-limbs`), so the runs with one seed differ only in the data. Each run NAME
# (a1, a2, b1, b2) writes OUT/NAME.log and OUT/NAME/ (the shipped form of the model, its log.csv and the
# real-image evaluation). OUT: $OUT when set (the device machine's output folder), else runs/train_pair.
set -u
A=$1; B=$2; DL=${3:-540}; DEST=${4:-${OUT:-runs/train_pair}}
export PYTHONUNBUFFERED=1 PYTHONDONTWRITEBYTECODE=1 PYTHONPATH=$PWD MPLBACKEND=Agg OMP_NUM_THREADS=2
mkdir -p "$DEST"
date +%T
nvidia-smi -L 2>/dev/null
run() {
  n=$1; pack=$2; seed=$3
  timeout -k 10 "$DL" python3 tools/train_shipped_model.py --work "/tmp/train_pair/$n" --train-data "$pack" \
    --ship-to "$DEST/$n" --batch-size 64 --seed "$seed" > "$DEST/$n.log" 2>&1
  echo "$n rc=$? at $(date +%T)" >> "$DEST/$n.log"
  cp "/tmp/train_pair/$n/run/log.csv" "$DEST/$n/" 2>/dev/null
  cp -r "/tmp/train_pair/$n/real" "$DEST/$n/" 2>/dev/null
}
run a1 "$A" 1 &
run a2 "$A" 2 &
run b1 "$B" 1 &
run b2 "$B" 2 &
wait
date +%T
for n in a1 a2 b1 b2; do tail -n 2 "$DEST/$n.log"; done
