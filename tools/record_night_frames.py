"""Record one simulated pressure image per lying posture (supine, left, right, prone; a female body
on the BodiTrak BT-3510 bed, the physics producer) into ``tests/eval/data/night_frames.npz``, for
the monitor tests that build a night from them (``tests/eval/test_monitor.py``).

For each posture it takes the first sample of its partition (general_supine, general_lateral,
prone_hands_up; seed 11) whose settled body lies in that posture and that the shipped model reads
in it, so the tests check the timeline, not the model's posture accuracy (that is
``evaluate``'s). It records the pressure images, the postures, the partitions and the sample
indices::

    .venv/bin/python tools/record_night_frames.py
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import torch

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from pressurepose.data.physics import physics_producer  # noqa: E402
from pressurepose.data.producers import Rejected, attempt_rng  # noqa: E402
from pressurepose.data.schema import GenerationConfig  # noqa: E402
from pressurepose.eval.posture import posture_of  # noqa: E402
from pressurepose.files import save_npz_atomic  # noqa: E402
from pressurepose.net.infer import estimate  # noqa: E402

OUT = REPO / "tests" / "eval" / "data" / "night_frames.npz"
WANTED = (("supine", "general_supine"), ("left", "general_lateral"), ("right", "general_lateral"),
          ("prone", "prone_hands_up"))


def main() -> int:
    torch.set_num_threads(1)
    found: dict[str, tuple] = {}
    for posture, partition in WANTED:
        cfg = GenerationConfig(partition=partition, gender="f", count=1000, seed=11, producer="physics")
        for index in range(60):
            if posture in found:
                break
            sample = next((s for a in range(20) if not isinstance(s := physics_producer(cfg, attempt_rng(cfg, index, a)),
                                                                  Rejected)), None)
            if sample is None or posture_of(sample.pose[None])[0] != posture:
                continue
            read = posture_of(estimate(sample.pressure, "f").pose)[0]
            print(f"{partition} sample {index}: {posture}, read as {read}")
            if read == posture:
                found[posture] = (sample, partition, index)
    missing = [p for p, _ in WANTED if p not in found]
    if missing:
        print(f"no sample found for {missing}", file=sys.stderr)
        return 1
    names = [p for p, _ in WANTED]
    save_npz_atomic(OUT, pressure=np.stack([found[p][0].pressure for p in names]).astype(np.float32),
                    posture=np.array(names), partition=np.array([found[p][1] for p in names]),
                    index=np.array([found[p][2] for p in names]))
    print(f"wrote {OUT}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
