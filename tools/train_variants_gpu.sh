#!/bin/bash
# Train variants of the shipped recipe side by side on one GPU from a training pack (`pressurepose pack`),
# each with tools/train_shipped_model.py --train-data PACK --ship-to.
#
#   bash tools/train_variants_gpu.sh PACK DEADLINE_S [NAME:"TOOL ARGS" ...]
#   bash tools/train_variants_gpu.sh train.npz 540 A:"--seed 0" A2:"--seed 1" B:"--seed 0 --epochs-mod1 72 --epochs-mod2 24"
#
# A variant may name its own training pack ("--train-data OTHER" in its arguments wins over PACK), so two
# packs made with one recipe and seeds (e.g. the default settle and `--settle paper`) are compared
# by the models trained on them: a1:"--seed 1" b1:"--seed 1 --train-data other.npz" ...
#
# Writes NAME.log and NAME.tar (the float16 shipped form and log.csv) into $OUT (default runs/gpu_variants).
# Each run is stopped DEADLINE_S seconds after it starts; a stopped run leaves only its log.csv.
# Measured (one H200, the command saw 4 CPU cores): with three runs sharing the GPU each Mod1
# epoch took 7-10 s, and a Mod2 epoch 11-12 s alone, so 48 + 16 epochs need about 10 minutes of the GPU;
# three such runs side by side did not finish 48 Mod1 epochs in 450 s. With 16 CPU cores (one H200,
# OMP_NUM_THREADS=2 a run): two runs side by side with "--batch-size 64" each took about 3.5 minutes
# (Mod1 2.4-3.1 s an epoch, Mod2 4.3-5.6 s), the GPU 91-99 % busy, and read real and simulated images
# as well as the batch-32 seeds (docs/training.md, "Training speed"). A warm machine keeps WORK: a
# NAME trained again with other arguments is refused ("differs in"); give it a new NAME.
set -u
PACK=$1; DL=$2; shift 2
OUT=${OUT:-runs/gpu_variants}; WORK=${WORK:-/tmp/gpu_variants}
mkdir -p "$OUT" "$WORK"
export PYTHONUNBUFFERED=1 PYTHONDONTWRITEBYTECODE=1 PYTHONPATH=$PWD OMP_NUM_THREADS=${OMP_NUM_THREADS:-4}
nvidia-smi -L 2>/dev/null; echo "cpus: $(nproc)"
python3 -c "import torch; print('torch', torch.__version__, torch.cuda.is_available() and torch.cuda.get_device_name())"
(nvidia-smi --query-gpu=timestamp,utilization.gpu,memory.used --format=csv -l 20 > "$OUT/gpu.csv" 2>&1 &)
# Preflight (about half a minute; PREFLIGHT=0 skips it): a training step's speed and how often it makes the
# host wait for the GPU (0 or 1 per step is expected, the 1 being
# the synchronisation the benchmark adds to time a step), for the half and the paper CNN at batch 32.
if [ "${PREFLIGHT:-1}" = 1 ]; then
  python3 - <<'PY' 2>&1 | tee "$OUT/preflight.log"
from benchmarks.bench_net import bench_training, bodies, make_net
female, male, _ = bodies()
for cnn in ("half", "paper"):
    for k, (_, per_s, waits) in bench_training(make_net(female, male, "cuda", cnn=cnn), 32, 20, device="cuda",
                                               amp=True).items():
        print(f"preflight {cnn} CNN {k}: {per_s:.0f} images/s, {32000 / per_s:.1f} ms a step, host waits {waits}")
PY
fi
run() {
  local n=$1; shift
  # shellcheck disable=SC2086  # the variant's arguments are meant to split
  timeout -k 10 "$DL" python3 tools/train_shipped_model.py --work "$WORK/$n" --train-data "$PACK" \
    --ship-to "$WORK/ship/$n" $* > "$OUT/$n.log" 2>&1
  echo "$n rc=$? at $(date +%T)" >> "$OUT/$n.log"
  mkdir -p "$WORK/ship/$n"; cp "$WORK/$n/run/log.csv" "$WORK/ship/$n/" 2>/dev/null
  tar -C "$WORK/ship" -cf "$OUT/$n.tar" "$n"
}
for v in "$@"; do run "${v%%:*}" "${v#*:}" & done
wait
ls -la "$OUT"
